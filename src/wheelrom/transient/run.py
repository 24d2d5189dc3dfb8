"""Integrate cases window by window on PETSc TS and harvest their statistics.

:func:`run_cases` integrates a batch of cases (one per entry of ``angles``) in one TS: the
initial states, then every window (the TS steps to the window end, the compiled monitor has
recorded the samples, :class:`Samples` turns them into :class:`WindowStats`), then the
results. With fixed steps each case's result is bitwise the one it has alone.
"""

from __future__ import annotations

import math
import time

import numba
import numpy as np

from wheelrom.config import Config
from wheelrom.forces.parameters import ForceParameters, force_parameters
from wheelrom.forces.reference import ReferenceForces
from wheelrom.rom.bases import basis_size
from wheelrom.rom.model import ReducedModel
from wheelrom.runtime.environment import petsc
from wheelrom.runtime.errors import InputError
from wheelrom.runtime.outputs import check_memory
from wheelrom.transient import bridge, exponential
from wheelrom.transient.contact_kernel import slide_core
from wheelrom.transient.exponential_kernel import etd4_step
from wheelrom.transient.kernel import sample_core
from wheelrom.transient.layout import (
    H_OVERFLOW,
    H_RHS_CALLS,
    STOP_AMPLITUDE,
    STOP_NONFINITE,
    context_bytes,
)
from wheelrom.transient.preload import initial_state
from wheelrom.transient.problem import (
    N_WORK,
    CaseResult,
    WheelProblem,
    WindowStats,
    nd_amplitudes,
)
from wheelrom.transient.ts import (
    PREFIX,
    check_step,
    make_ts,
    reason_words,
    scoped_options,
    time_grid,
)


class Samples:
    """Output samples of one case of a batch, collected window by window from the context.

    Window statistics are taken over the samples (rate ``output.sample_rate_hz``), which the
    compiled monitor records at the first step at or after each sample time.
    """

    def __init__(self, problem: WheelProblem, case: int = 0, history_every: int = 1):
        self.p, self.case = problem, case
        self.kinds = problem.kinds
        self.history_every = history_every  # keep every k-th sample's tips (0: none)
        self.total = 0  # samples since t = 0
        self.times: list[np.ndarray] = []
        self.tips: list[np.ndarray] = []
        self.state_times: list[np.ndarray] = []
        self.states: list[np.ndarray] = []

    def _keep_history(self, t: np.ndarray, tip: np.ndarray) -> None:
        """The window's tip history: every ``history_every``-th sample since ``t = 0``."""
        count = t.size
        if self.history_every:
            keep = (self.total + np.arange(count)) % self.history_every == 0
            self.times.append(t[keep])
            self.tips.append(tip[keep])
        self.total += count

    def _take_states(self) -> None:
        """Move the window's modal state samples out of the context (blade-major)."""
        ctx, b = self.p.context, self.case
        count = int(ctx.view("state_count")[b])
        if count:
            self.state_times.append(ctx.view("state_time")[b, :count].copy())
            self.states.append(ctx.unpack_states(ctx.view("state")[b, :count]))
        ctx.view("state_count")[b] = 0

    def take_window(self) -> WindowStats:
        """Move the window's samples out of the context; return its statistics."""
        ctx, b = self.p.context, self.case
        count = int(ctx.view("count")[b])
        if ctx.header(H_OVERFLOW):
            raise RuntimeError("output sample buffer overflow (report this as a bug)")
        N = self.p.N
        t = ctx.view("sample_time")[b, :count].copy()
        tip = ctx.view("sample_tip")[b, :count].copy()
        low = ctx.view("sample_min_normal")[b, :count]
        opened = ctx.view("sample_open")[b, :count]
        slipping = ctx.view("sample_slip")[b, :count]
        ctx.view("count")[b] = 0
        self._keep_history(t, tip)
        self._take_states()
        if count == 0:
            nan = {k: math.nan for k in self.kinds}
            return WindowStats(math.nan, np.full(N // 2 + 1, math.nan), nan, nan, nan)
        return WindowStats(
            max_tip_amplitude=float(np.sqrt((tip * tip).sum(axis=2)).max()),
            nd_spectrum=nd_amplitudes(tip[:, :, 1]).max(axis=0),
            min_normal_force={k: float(low[:, i].min()) for i, k in enumerate(self.kinds)},
            open_fraction={k: float(opened[:, i].sum() / (count * N))
                           for i, k in enumerate(self.kinds)},
            slip_fraction={k: float(slipping[:, i].sum() / (count * N))
                           for i, k in enumerate(self.kinds)},
        )

    def stop(self) -> tuple[float | None, str | None]:
        """``(time [s], reason)`` when the monitor froze this case, else ``(None, None)``."""
        ctx, b = self.p.context, self.case
        flag = int(ctx.view("stop")[b])
        t = float(ctx.view("stop_t")[b])
        if flag == STOP_NONFINITE:
            return t, f"non-finite state at t = {t:.6g} s"
        if flag == STOP_AMPLITUDE:
            return t, f"tip amplitude exceeds time.divergence_amplitude at t = {t:.6g} s"
        return None, None


class _CaseRecord:
    """The rows of one case while its batch runs."""

    def __init__(self, problem: WheelProblem, case: int, history_every: int):
        self.result = CaseResult()
        self.samples = Samples(problem, case, history_every)
        self.running = True
        self.steps = 0
        self.ends: list[float] = []
        self.stats: list[WindowStats] = []
        self.energy: list[float] = []
        self.work: list[np.ndarray] = []

    def fail(self, reason: str) -> None:
        self.result.status = f"failed: {reason}"
        self.running = False


def run_case(model: ReducedModel, cfg: Config, angles_deg: dict | None = None,
             options: dict | None = None, progress=None, prefix: str = PREFIX,
             u0: np.ndarray | None = None, rhs_kind: str = "compiled") -> CaseResult:
    """Integrate one case window by window; a divergence stops it and keeps what was done.

    ``u0``: optional initial modal state ``(q, q')`` of length ``2 N m`` (else ``time.start``).
    ``options``: PETSc options for this TS (keys without prefix, e.g. ``{"ts_rk_type": "5dp"}``).
    ``progress(window, windows, t, amplitude)`` is called after every window.
    """
    return run_cases(model, cfg, [angles_deg], options, progress, prefix,
                     None if u0 is None else [u0], rhs_kind)[0]


def adaptive(options: dict | None, prefix: str = PREFIX) -> bool:
    """Whether the TS of these options adapts its step (then cases are not batched: a shared
    step would make a case's result depend on the others)."""
    with scoped_options(prefix, options):
        value = petsc().Options().getString(prefix + "ts_adapt_type", "none")
    return str(value) != "none"


def _step_groups(model: ReducedModel, cfg: Config, angles: list[dict | None],
                 options: dict | None, prefix: str) -> list[list[int]]:
    """The cases grouped by the step the exponential scheme takes for each alone
    (:func:`~wheelrom.transient.exponential.stable_step` depends on the contact angles under
    the elastic law) and by the springs the kernel propagates (:mod:`.stuck_shift`: one basis
    a batch): a batch takes one step, and a case's result must not depend on the cases it
    shares a batch with."""
    from wheelrom.forces.parameters import force_parameters
    from wheelrom.transient.exponential import stable_step
    from wheelrom.transient.stuck_shift import shift_stiffness
    from wheelrom.transient.ts import time_step

    exponential = cfg.time.scheme == "exponential"
    step = time_step(cfg, prefix, options) if exponential else None
    groups: dict[tuple, list[int]] = {}
    for i, a in enumerate(angles):
        params = force_parameters(model, cfg, a)
        taken = stable_step(model, params, cfg.wheel.damping_beta, step)[0] if exponential else None
        groups.setdefault((taken, tuple(shift_stiffness(model, params))), []).append(i)
    return list(groups.values())


def run_cases(model: ReducedModel, cfg: Config, angles: list[dict | None],
              options: dict | None = None, progress=None, prefix: str = PREFIX,
              u0: list[np.ndarray] | None = None,
              rhs_kind: str = "compiled") -> list[CaseResult]:
    """Integrate a batch of cases (one per entry of ``angles``) in one TS, window by window.

    The cases share the model and every setting but their contact angles; with fixed steps
    each case's result is bitwise the one it has alone (a batch only runs faster: the kernel
    vectorises across cases and PETSc's per-step work is shared). A diverging case is frozen
    and reported failed while the others go on. Adaptive steps run the cases one by one.
    ``u0``: optional initial modal states ``(q, q')``, one per case. ``progress(window,
    windows, t, amplitude)`` after every window (largest amplitude over running cases).
    """
    if len(angles) > 1 and adaptive(options, prefix):
        return [run_cases(model, cfg, [a], options, progress, prefix,
                          None if u0 is None else [u0[i]], rhs_kind)[0]
                for i, a in enumerate(angles)]
    if len(angles) > 1:  # a batch shares its step: cases whose own differ run apart
        groups = _step_groups(model, cfg, angles, options, prefix)
        if len(groups) > 1:
            out: list = [None] * len(angles)
            for group in groups:
                done = run_cases(model, cfg, [angles[i] for i in group], options, progress,
                                 prefix, None if u0 is None else [u0[i] for i in group],
                                 rhs_kind)
                for i, res in zip(group, done, strict=True):
                    out[i] = res
            return out
    check_run_memory(cfg, len(angles))  # every caller checked up front; this is the floor
    params = [force_parameters(model, cfg, a) for a in angles]
    compile_s = load_kernels(params[0], rhs_kind)
    t_wall = time.perf_counter()
    grid = time_grid(cfg)
    problem = WheelProblem(model, cfg, params, petsc().COMM_SELF, grid.sample_capacity,
                           grid.state_capacity)
    records = [_CaseRecord(problem, b, grid.history_every) for b in range(problem.B)]
    states = _initial_states(problem, records, u0)
    ts, fvec, used = make_ts(problem, cfg, prefix, options, rhs_kind)
    try:
        check_step(model, used)
    except InputError:
        for obj in (ts, fvec):
            obj.destroy()
        problem.destroy()
        raise
    compiled = rhs_kind == "compiled"
    u = fvec.duplicate()
    u.setArray(problem.context.pack(states) if compiled else states[0])
    try:
        _integrate(ts, u, problem, records, grid.window_end, used, compiled, progress)
    except petsc().Error as exc:
        for rec in records:
            if rec.running:
                rec.fail(f"PETSc error {exc}")
                rec.steps = ts.getStepNumber()
    ua = u.getArray(readonly=True)
    finals = problem.context.unpack(ua) if compiled else ua[None, :].copy()
    wall = time.perf_counter() - t_wall
    results = [_finish(rec, problem, used, finals[b], wall, compile_s)
               for b, rec in enumerate(records)]
    for obj in (ts, fvec, u):
        obj.destroy()
    problem.destroy()
    return results


def run_memory(cfg: Config, batch: int = 1) -> dict[str, int]:
    """About the memory [bytes] a run of ``cfg`` (``batch`` cases) holds at its peak, by what
    sizes it, known before anything is allocated: ``"window"`` the context with one window's
    sample buffers (:func:`~wheelrom.transient.layout.context_bytes`) and the window's
    samples taken out of it with their squares (``time.window`` x ``output.sample_rate_hz``);
    ``"histories"`` the tip and state histories kept and joined at the end (``time.end`` x
    ``output.history_rate_hz`` / ``state_rate_hz``); ``"matrices"`` the dense ``K_R`` of the
    energies and its copies (``wheel.blades`` x basis vectors, squared)."""
    grid = time_grid(cfg)
    N, m = cfg.wheel.blades, basis_size(cfg)
    K = len(cfg.contacts.enabled_kinds())
    tip, state = 1 + 3 * N, 1 + 2 * N * m  # doubles per sample: its time and the values
    return {
        "window": context_bytes(N, m, K, batch, grid.sample_capacity, grid.state_capacity)
        + 8 * batch * 2 * grid.sample_capacity * tip,
        "histories": 8 * batch * (2 * grid.history_max * tip + 2 * grid.state_max * state),
        "matrices": 8 * DENSE_COPIES * (N * m) ** 2,
    }


#: dense ``(N m, N m)`` arrays a run holds at once: ``K_R`` for the energies (built as
#: ``(N, m, N, m)``), the results file's copy of it, a preload Jacobian without a sparse
#: tangent
DENSE_COPIES = 3


def run_bytes(cfg: Config, batch: int = 1) -> int:
    """:func:`run_memory` in all [bytes]."""
    return sum(run_memory(cfg, batch).values())


def check_run_memory(cfg: Config, batch: int = 1, given: str | None = None,
                     advice: str | None = None) -> None:
    """Refuse, before anything is built, a run of ``cfg`` (``batch`` cases at once) that does
    not fit in the memory available, naming what sizes its largest part by the keys that
    set it (``given``, ``advice``: the option that set them instead, e.g. ``compare
    --steps``, and what to do)."""
    parts = run_memory(cfg, batch)
    t, out = cfg.time, cfg.output
    largest = max(parts, key=parts.get)
    batch_text = f" for {batch} cases at once" if batch > 1 else ""
    what, fix = {
        "window": (f"time.window {t.window:g} s at output.sample_rate_hz "
                   f"{out.sample_rate_hz:g} Hz ({time_grid(cfg).sample_capacity} samples of "
                   f"{cfg.wheel.blades} tips a window{batch_text})",
                   "shorten time.window or lower output.sample_rate_hz"),
        "histories": (f"time.end {t.end:g} s at output.history_rate_hz "
                      f"{out.history_rate_hz:g} Hz and state_rate_hz {out.state_rate_hz:g} Hz "
                      f"(the stored histories{batch_text})",
                      "shorten time.end or lower the history rates"),
        "matrices": (f"wheel.blades {cfg.wheel.blades} with {basis_size(cfg)} basis vectors "
                     "each (the dense reduced stiffness)",
                     "fewer blades or wheel.modes_per_segment"),
    }[largest]
    check_memory(sum(parts.values()), given or what, advice or fix)


_LOADED: set[str] = set()  # right-hand side kinds whose kernels this process has


def load_kernels(case: ForceParameters, rhs_kind: str = "compiled") -> float:
    """Make the compiled code a run of ``rhs_kind`` needs ready in this process (loaded from
    the kernel cache, else compiled: :mod:`wheelrom.runtime.kernel_cache`); returns the seconds it
    took, 0 when this process had it already. ``case``: any case (the reference force model,
    used for the preload and the energies, is compiled for its argument types).

    :func:`run_cases` calls it before its clock starts: ``wall_s`` is integration only.
    """
    if rhs_kind in _LOADED:
        return 0.0
    t0 = time.perf_counter()
    if rhs_kind == "compiled":
        bridge.callbacks()
        vector = numba.float64[::1]
        etd4_step.compile((numba.float64, numba.float64, vector, vector,
                           numba.float64[:, ::1], numba.float64[:, ::1]))
        slide_core.compile((vector, vector))  # a solve's end state (exponential.end_sliders)
    elif rhs_kind == "python":
        vector = numba.float64[::1]
        sample_core.compile((numba.float64, vector, vector))
    zeros = np.zeros((case.blades, case.modes))
    ReferenceForces(case).evaluate(0.0, zeros, zeros)
    _LOADED.add(rhs_kind)
    return time.perf_counter() - t0


def _initial_states(problem: WheelProblem, records, u0) -> np.ndarray:
    """``(B, state size)`` blade-major states at ``t = 0``; records ``energy0`` and the
    preload residual. ``u0[b]``: ``(q, q')`` (the elastic law's sliders then start at rest
    there, no tangential force) or a whole state (its sliders kept)."""
    states = np.zeros((problem.B, problem.size()))
    for b, rec in enumerate(records):
        if u0 is None:
            states[b], rec.result.preload_residual = initial_state(problem, case=b)
        else:
            states[b] = problem.start_state(u0[b], b)
        rec.result.energy0 = problem.energy(states[b], case=b)
    return states


def _integrate(ts, u, problem, records, window_end, used, compiled, progress) -> None:
    """Step the TS through the windows, harvesting every running case after each."""
    PETSc = petsc()
    dt0 = ts.getTimeStep()
    fixed = used.get("ts_adapt_type", "none") == "none"
    windows = len(window_end)
    for w, t_end in enumerate(window_end):
        if fixed:  # step over, never clip: the step count ends the window
            # (TS "matchstep" would shorten or split the last step of a window and keep it)
            ts.setExactFinalTime(PETSc.TS.ExactFinalTime.STEPOVER)
            ts.setTimeStep(dt0)
            ts.setMaxSteps(int(round(t_end / dt0)))
            ts.setMaxTime(t_end + 0.5 * dt0)
        else:
            ts.setMaxTime(t_end)
        ts.solve(u)
        exponential.end_sliders(u, problem.context)
        t_now = ts.getTime()
        ua = u.getArray(readonly=True)
        states = problem.context.unpack(ua) if compiled else ua[None, :].copy()
        early = t_now < t_end - (0.5 * dt0 if fixed else 1e-9 * max(1.0, t_end))
        for b, rec in enumerate(records):
            if rec.running:
                _harvest(rec, problem, b, states[b], ts, t_now, dt0 if fixed else None, early)
        running = [rec for rec in records if rec.running]
        if progress and running:
            progress(w + 1, windows, t_now, max(rec.stats[-1].max_tip_amplitude
                                                for rec in running))
        if not running:
            break


def _harvest(rec: _CaseRecord, problem, b: int, state, ts, t_now, fixed_dt, early) -> None:
    """One window of one case: its statistics, energy and work, or its stop."""
    stats = rec.samples.take_window()
    stopped, reason = rec.samples.stop()
    rec.steps = ts.getStepNumber()
    if reason:
        rec.fail(reason)
        if fixed_dt is not None and stopped is not None:  # frozen: the steps up to then
            rec.steps = int(round(stopped / fixed_dt))
        return
    rec.ends.append(t_now)
    rec.stats.append(stats)
    rec.energy.append(problem.energy(state, case=b))
    rec.work.append(state[2 * problem.n : 2 * problem.n + N_WORK].copy())
    if early:
        rec.fail(f"TS stopped early at t = {t_now:.6g} s: {reason_words(ts.getConvergedReason())}")


def _finish(rec: _CaseRecord, problem, used, final_state, wall, compile_s) -> CaseResult:
    """The :class:`CaseResult` of one case from its rows (``wall``, ``compile_s`` [s]: of the
    batch)."""
    res, kinds = rec.result, problem.kinds
    res.options = used
    res.window_end = np.array(rec.ends)
    res.max_tip_amplitude = np.array([s.max_tip_amplitude for s in rec.stats])
    res.nd_spectrum = np.array([s.nd_spectrum for s in rec.stats]).reshape(-1, problem.N // 2 + 1)
    res.energy = np.array(rec.energy)
    res.work = np.array(rec.work).reshape(-1, N_WORK)
    res.min_normal_force = {k: np.array([s.min_normal_force[k] for s in rec.stats]) for k in kinds}
    res.open_fraction = {k: np.array([s.open_fraction[k] for s in rec.stats]) for k in kinds}
    res.slip_fraction = {k: np.array([s.slip_fraction[k] for s in rec.stats]) for k in kinds}
    times, tips = rec.samples.times, rec.samples.tips
    res.sample_time = np.concatenate(times) if times else np.zeros(0)
    res.tip_history = (np.concatenate(tips) if tips else np.zeros(0)).reshape(-1, problem.N, 3)
    states = rec.samples.states
    res.state_time = np.concatenate(rec.samples.state_times) if states else np.zeros(0)
    res.state_history = (np.concatenate(states) if states else
                         np.zeros(0)).reshape(-1, 2, problem.N, problem.m)
    res.steps = rec.steps
    res.rhs_evaluations = int(problem.context.header(H_RHS_CALLS))
    res.final_state = final_state.copy()
    res.batch = problem.B
    res.wall_s = wall / problem.B
    res.compile_s = compile_s / problem.B
    return res
