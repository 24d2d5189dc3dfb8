"""Transient response of the reduced wheel on PETSc TS (paper eq. 15), and a serial reference.

State ``u = (q, q', W)`` with ``q, q'`` of length ``N m`` and four work accumulators
``W = (W_nozzle, W_vdp, W_friction, W_damping)`` [J] integrated with the same stages as the
motion, so the energy balance ``E(t) - E(0) = sum W`` is a check of the integration itself:

    q''  = -K_R (q + beta_D q') + f(q, q', t)
    W'   = (P_nozzle, P_vdp, P_friction, -beta_D q'^T K_R q')

Default TS: ``rk`` / ``3bs`` (Bogacki-Shampine = Simulink ode3), fixed step ``time.step``, no
adaptivity. Options prefix ``wheel_``: ``-wheel_ts_type``, ``-wheel_ts_rk_type``,
``-wheel_ts_adapt_type``, ``-wheel_ts_dt`` ... are applied last (``setFromOptions``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from wheelrom import rhs
from wheelrom._environment import petsc
from wheelrom.config import Config
from wheelrom.cyclic import ReducedModel
from wheelrom.forces import ForceModel

N_WORK = 4
WORK_NAMES = ("nozzle", "van_der_pol", "friction", "damping")


@dataclass
class CaseResult:
    """Monitor output of one case (arrays per window ``w`` unless noted).

    Attributes:
        status: ``"done"`` or ``"failed: <reason>"``.
        window_end: ``(W,)`` end time of each window [s].
        max_tip_amplitude: ``(W,)`` largest tip displacement magnitude over blades [m].
        min_normal_force: kind -> ``(W,)`` smallest normal force over blades and time [N].
        open_fraction: kind -> ``(W,)`` fraction of (blade, step) samples with the contact open.
        nd_spectrum: ``(W, N//2+1)`` largest DFT amplitude over the window of the tip ``y``
            displacement per nodal diameter [m].
        energy: ``(W,)`` kinetic + potential energy at window end [J].
        work: ``(W, 4)`` cumulative work of nozzle, Van der Pol, friction, damping [J].
        sample_time: ``(S,)`` [s]; tip_history: ``(S, N, 3)`` tip displacement [m].
        steps, wall_s, options: TS steps taken, wall time [s] (of a batch: its wall time
            over its number of cases), PETSc options used.
        batch: number of cases integrated together in the TS of this case.
    """

    status: str = "done"
    window_end: np.ndarray = field(default_factory=lambda: np.zeros(0))
    max_tip_amplitude: np.ndarray = field(default_factory=lambda: np.zeros(0))
    min_normal_force: dict = field(default_factory=dict)
    open_fraction: dict = field(default_factory=dict)
    nd_spectrum: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    energy: np.ndarray = field(default_factory=lambda: np.zeros(0))
    energy0: float = 0.0
    work: np.ndarray = field(default_factory=lambda: np.zeros((0, N_WORK)))
    sample_time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    tip_history: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 3)))
    steps: int = 0
    rhs_evaluations: int = 0
    wall_s: float = 0.0
    options: dict = field(default_factory=dict)
    preload_residual: float | None = None
    final_state: np.ndarray | None = None
    batch: int = 1

    def energy_balance_error(self) -> float:
        """``|E - E0 - sum W| / sum |W|`` at the last window (0 when nothing happened)."""
        if self.energy.size == 0:
            return 0.0
        total = self.work[-1].sum()
        scale = np.abs(self.work[-1]).sum()
        return float(abs(self.energy[-1] - self.energy0 - total) / scale) if scale else 0.0

    def summary(self) -> dict:
        last = -1 if self.window_end.size else None
        return {
            "status": self.status,
            "steps": self.steps,
            "wall_s": self.wall_s,
            "simulated_s": float(self.window_end[-1]) if last is not None else 0.0,
            "max_tip_amplitude": float(self.max_tip_amplitude[-1]) if last is not None else None,
            "min_normal_force": {
                k: float(v[-1]) for k, v in self.min_normal_force.items() if v.size
            },
            "open_fraction": {k: float(v[-1]) for k, v in self.open_fraction.items() if v.size},
            "energy_balance_error": self.energy_balance_error(),
            "preload_residual": self.preload_residual,
            "options": self.options,
        }


class WheelProblem:
    """The ODE of one case or of a batch of cases: sizes, the compiled context and the TS
    callbacks (``COMM_SELF``).

    ``forces``: one :class:`ForceModel` or a list of them, one per case of a batch (cases
    differing only in contact angles, integrated together in one TS: see :mod:`wheelrom.rhs`).
    Two right-hand sides: the compiled one (:mod:`wheelrom.rhs`, registered as C callbacks,
    the default) and a petsc4py Python callback using the PETSc BAIJ ``K_R`` and the
    :class:`ForceModel` kernel (``rhs="python"``, one case: slower, a second implementation).
    ``n``, :meth:`size`, :meth:`rhs_numpy`, :meth:`energy` refer to one case.
    """

    def __init__(self, model: ReducedModel, cfg: Config, forces, comm=None):
        PETSc = petsc()
        self.comm = comm or PETSc.COMM_SELF
        self.cases = list(forces) if isinstance(forces, list | tuple) else [forces]
        self.model, self.cfg, self.forces = model, cfg, self.cases[0]
        self.B = len(self.cases)
        self.N, self.m = model.blades, model.modes
        self.n = self.N * self.m
        self.beta = cfg.wheel.damping_beta
        self.Kd = model.dense_stiffness()  # for energies and the reference (small)
        self.context = rhs.Context(
            self.cases,
            model,
            self.beta,
            sample_dt=1.0 / cfg.output.sample_rate_hz,
            limit=cfg.time.divergence_amplitude,
            capacity=_sample_capacity(cfg),
        )
        self._petsc: list = []  # BAIJ K_R and work Vecs of the Python path, made on demand

    def size(self) -> int:
        return 2 * self.n + N_WORK

    def rhs(self, ts, t, u, f):
        """Python TS callback (``rhs="python"``): ``f = (q', q'', W')`` with BAIJ products."""
        PETSc = petsc()
        if not self._petsc:
            K = self.model.petsc_stiffness(self.comm)
            self._petsc = [K] + [PETSc.Vec().createSeq(self.n, comm=self.comm) for _ in "xqv"]
        K, x, Kq, Kv = self._petsc
        self.context.array[rhs.H_RHS_CALLS] += 1
        n = self.n
        ua = u.getArray(readonly=True)
        fa = f.getArray()
        q = ua[:n]
        v = ua[n : 2 * n]
        x.setArray(q)
        K.mult(x, Kq)
        x.setArray(v)
        K.mult(x, Kv)
        force = self.forces.evaluate(t, q.reshape(self.N, self.m), v.reshape(self.N, self.m))
        Kqa = Kq.getArray(readonly=True)
        Kva = Kv.getArray(readonly=True)
        fa[:n] = v
        fa[n : 2 * n] = force.ravel() - Kqa - self.beta * Kva
        fa[2 * n : 2 * n + 3] = self.forces.power
        fa[2 * n + 3] = -self.beta * float(v @ Kva)

    def rhs_numpy(self, t: float, u: np.ndarray, case: int = 0) -> np.ndarray:
        """The same right-hand side with numpy only (serial reference), one case."""
        n = self.n
        q, v = u[:n], u[n : 2 * n]
        forces = self.cases[case]
        force = forces.evaluate(t, q.reshape(self.N, self.m), v.reshape(self.N, self.m))
        Kv = self.Kd @ v
        out = np.empty_like(u)
        out[:n] = v
        out[n : 2 * n] = force.ravel() - self.Kd @ q - self.beta * Kv
        out[2 * n : 2 * n + 3] = forces.power
        out[2 * n + 3] = -self.beta * float(v @ Kv)
        return out

    def energy(self, u: np.ndarray, case: int = 0) -> float:
        """Kinetic + modal strain + contact spring energy [J] of one case's blade-major state
        (evaluates the contacts)."""
        n = self.n
        q, v = u[:n], u[n : 2 * n]
        forces = self.cases[case]
        forces.evaluate(0.0, q.reshape(self.N, self.m), v.reshape(self.N, self.m))
        return 0.5 * float(v @ v) + 0.5 * float(q @ (self.Kd @ q)) + forces.contact_energy()

    def destroy(self) -> None:
        for obj in self._petsc:
            obj.destroy()
        self._petsc = []


def _sample_capacity(cfg: Config) -> int:
    """Output samples one window can hold (the last window may be up to 1.5 windows long)."""
    windows = max(1, int(round(cfg.time.end / cfg.time.window)))
    longest = max(cfg.time.window, cfg.time.end - (windows - 1) * cfg.time.window)
    return int(math.ceil(longest * cfg.output.sample_rate_hz)) + 4


class Samples:
    """Output samples of one case of a batch, collected window by window from the context.

    Window statistics are taken over the samples (rate ``output.sample_rate_hz``), which the
    compiled monitor records at the first step at or after each sample time.
    """

    def __init__(self, problem: WheelProblem, case: int = 0):
        self.p, self.case = problem, case
        self.kinds = problem.forces.contacts.kinds
        self.times: list[np.ndarray] = []
        self.tips: list[np.ndarray] = []

    def take_window(self) -> dict:
        """Move the window's samples out of the context; return its statistics."""
        ctx, b = self.p.context, self.case
        count = int(ctx.view("count")[b])
        if ctx.header(rhs.H_OVERFLOW):
            raise RuntimeError("output sample buffer overflow (report this as a bug)")
        N = self.p.N
        t = ctx.view("sample_time")[b, :count].copy()
        tip = ctx.view("sample_tip")[b, :count].copy()
        low = ctx.view("sample_min_normal")[b, :count]
        opened = ctx.view("sample_open")[b, :count]
        ctx.view("count")[b] = 0
        self.times.append(t)
        self.tips.append(tip)
        if count == 0:
            return {
                "amp": math.nan,
                "spec": np.full(N // 2 + 1, math.nan),
                "min_fn": {k: math.nan for k in self.kinds},
                "open": {k: math.nan for k in self.kinds},
            }
        return {
            "amp": float(np.sqrt((tip * tip).sum(axis=2)).max()),
            "spec": (np.abs(np.fft.rfft(tip[:, :, 1], axis=1)) / N).max(axis=0),
            "min_fn": {k: float(low[:, i].min()) for i, k in enumerate(self.kinds)},
            "open": {k: float(opened[:, i].sum() / (count * N)) for i, k in enumerate(self.kinds)},
        }

    def stop_time(self) -> float | None:
        ctx, b = self.p.context, self.case
        return float(ctx.view("stop_t")[b]) if ctx.view("stop")[b] else None

    def stop_reason(self) -> str | None:
        ctx, b = self.p.context, self.case
        flag = int(ctx.view("stop")[b])
        t = float(ctx.view("stop_t")[b])
        if flag == rhs.STOP_NONFINITE:
            return f"non-finite state at t = {t:.6g} s"
        if flag == rhs.STOP_AMPLITUDE:
            return f"tip amplitude exceeds time.divergence_amplitude at t = {t:.6g} s"
        return None


def _options_used(prefix: str) -> dict:
    PETSc = petsc()
    opts = PETSc.Options().getAll()
    return {k: v for k, v in opts.items() if k.startswith(prefix)}


def make_ts(
    problem: WheelProblem,
    cfg: Config,
    prefix: str = "wheel_",
    options: dict | None = None,
    rhs_kind: str = "compiled",
):
    """A configured TS (defaults in code, ``setFromOptions`` last).

    ``options``: extra PETSc options (without prefix) set under ``prefix`` for this TS only.
    ``rhs_kind``: ``"compiled"`` (C callbacks, default) or ``"python"`` (petsc4py callbacks).
    """
    PETSc = petsc()
    opts = PETSc.Options()
    inserted = []
    # petsc4py 3.18 has no TSAdapt object: fixed steps are a default in the options database
    # (a user's -wheel_ts_adapt_type wins because it is already set)
    defaults = {"ts_adapt_type": "none"}
    for key, value in {**defaults, **(options or {})}.items():
        name = prefix + key.lstrip("-")
        if key in defaults and opts.hasName(name):
            continue
        if not opts.hasName(name) or key not in defaults:
            inserted.append(name)
        opts.setValue(name, "" if value is None else str(value))
    ts = PETSc.TS().create(comm=problem.comm)
    ts.setOptionsPrefix(prefix)
    ts.setProblemType(PETSc.TS.ProblemType.NONLINEAR)
    ts.setType(PETSc.TS.Type.RK)
    ts.setRKType("3bs")
    ts.setTimeStep(cfg.time.step)
    ts.setMaxTime(cfg.time.end)
    ts.setMaxSteps(10**9)
    ts.setExactFinalTime(PETSc.TS.ExactFinalTime.MATCHSTEP)
    if rhs_kind == "compiled":
        f = PETSc.Vec().createSeq(problem.B * problem.size(), comm=problem.comm)
        rhs.attach(ts, f, problem.context)
    elif rhs_kind == "python":
        if problem.B != 1:
            raise ValueError("rhs_kind='python' integrates one case, not a batch")
        f = PETSc.Vec().createSeq(problem.size(), comm=problem.comm)
        context = problem.context

        def monitor(ts, step, t, x):  # the TS state is blade-major here
            if rhs.sample_core(t, context.pack(x.getArray(readonly=True)), context.array):
                ts.setConvergedReason(PETSc.TS.ConvergedReason.CONVERGED_USER)

        ts.setRHSFunction(problem.rhs, f)
        ts.setMonitor(monitor)
    else:
        raise ValueError(f"rhs_kind must be 'compiled' or 'python', not {rhs_kind!r}")
    ts.setFromOptions()
    used = {
        "ts_type": ts.getType(),
        "ts_rk_type": ts.getRKType() if ts.getType() == "rk" else None,
        "ts_dt": ts.getTimeStep(),
    }
    used.update({k[len(prefix) :]: v for k, v in _options_used(prefix).items()})
    for name in inserted:
        opts.delValue(name)
    return ts, f, {k: v for k, v in used.items() if v is not None}


def initial_state(
    problem: WheelProblem, cfg: Config, result: CaseResult, case: int = 0
) -> np.ndarray:
    """Zero state, or the static equilibrium under preloads (and the t = 0 nozzle force)."""
    u0 = np.zeros(problem.size())
    if cfg.time.start == "preload":
        q, residual = static_preload(problem, case=case)
        u0[: problem.n] = q
        result.preload_residual = residual
    return u0


def static_preload(
    problem: WheelProblem, prefix: str = "preload_", case: int = 0
) -> tuple[np.ndarray, float]:
    """Solve ``K_R q = f(q, 0, t=0)`` with PETSc SNES; returns ``q`` and ``|residual|``.

    Jacobian by finite differences of the residual with ``K_R`` structure (dense, N m
    unknowns). Options prefix ``preload_`` (``-preload_snes_rtol`` ...).
    """
    PETSc = petsc()
    n = problem.n
    zeros_v = np.zeros((problem.N, problem.m))

    forces = problem.cases[case]

    def residual_np(q):
        force = forces.evaluate(0.0, q.reshape(problem.N, problem.m), zeros_v)
        return problem.Kd @ q - force.ravel()

    def residual(snes, x, r):
        r.setArray(residual_np(x.getArray(readonly=True)))

    def jacobian(snes, x, J, P):
        q = x.getArray(readonly=True).copy()
        base = residual_np(q)
        h = 1e-9 * max(1.0, np.abs(q).max())
        Jd = np.empty((n, n))
        for j in range(n):
            qj = q.copy()
            qj[j] += h
            Jd[:, j] = (residual_np(qj) - base) / h
        P.setValues(range(n), range(n), Jd)
        P.assemble()

    snes = PETSc.SNES().create(comm=problem.comm)
    snes.setOptionsPrefix(prefix)
    J = PETSc.Mat().createDense((n, n), comm=problem.comm)
    J.setUp()
    r = PETSc.Vec().createSeq(n, comm=problem.comm)
    x = PETSc.Vec().createSeq(n, comm=problem.comm)
    snes.setFunction(residual, r)
    snes.setJacobian(jacobian, J, J)
    snes.setTolerances(rtol=1e-12, atol=1e-12 * max(1.0, forces.nozzle_force), max_it=50)
    snes.getKSP().setType("preonly")
    snes.getKSP().getPC().setType("lu")
    snes.setFromOptions()
    x.set(0.0)
    snes.solve(None, x)
    q = x.getArray().copy()
    res = float(np.linalg.norm(residual_np(q)))
    reason = snes.getConvergedReason()
    for obj in (snes, J, r, x):
        obj.destroy()
    if reason <= 0:
        raise RuntimeError(f"preload SNES did not converge (reason {reason}, |F| = {res:.3g})")
    return q, res


def run_case(
    model: ReducedModel,
    cfg: Config,
    angles_deg: dict | None = None,
    options: dict | None = None,
    progress=None,
    prefix: str = "wheel_",
    u0: np.ndarray | None = None,
    rhs_kind: str = "compiled",
) -> CaseResult:
    """Integrate one case window by window; a divergence stops it and keeps what was done.

    ``u0``: optional initial modal state ``(q, q')`` of length ``2 N m`` (else ``time.start``).
    ``options``: PETSc options for this TS (keys without prefix, e.g. ``{"ts_rk_type": "5dp"}``).
    ``progress(window, windows, t, amplitude)`` is called after every window.
    """
    return run_cases(model, cfg, [angles_deg], options, progress, prefix,
                     None if u0 is None else [u0], rhs_kind)[0]  # fmt: skip


def _adaptive(options: dict | None, prefix: str) -> bool:
    """Whether the TS of these options adapts its step (then cases are not batched: a shared
    step would make a case's result depend on the others)."""
    PETSc = petsc()
    value = (options or {}).get("ts_adapt_type")
    if value is None:
        opts = PETSc.Options()
        value = opts.getString(prefix + "ts_adapt_type", "none")
    return str(value) != "none"


def run_cases(
    model: ReducedModel,
    cfg: Config,
    angles: list[dict | None],
    options: dict | None = None,
    progress=None,
    prefix: str = "wheel_",
    u0: list[np.ndarray] | None = None,
    rhs_kind: str = "compiled",
) -> list[CaseResult]:
    """Integrate a batch of cases (one per entry of ``angles``) in one TS, window by window.

    The cases share the model and every setting but their contact angles; with fixed steps
    each case's result is bitwise the one it has alone (a batch only runs faster: the kernel
    vectorises across cases and PETSc's per-step work is shared). A diverging case is frozen
    and reported failed while the others go on. Adaptive steps run the cases one by one.
    ``u0``: optional initial modal states ``(q, q')``, one per case. ``progress(window,
    windows, t, amplitude)`` after every window (largest amplitude over running cases).
    """
    PETSc = petsc()
    if len(angles) > 1 and _adaptive(options, prefix):
        return [
            run_cases(
                model,
                cfg,
                [a],
                options,
                progress,
                prefix,
                None if u0 is None else [u0[i]],
                rhs_kind,
            )[0]  # fmt: skip
            for i, a in enumerate(angles)
        ]
    t_wall = time.perf_counter()
    problem = WheelProblem(model, cfg, [ForceModel(model, cfg, a) for a in angles])
    B, n, context = problem.B, problem.n, problem.context
    results = [CaseResult() for _ in range(B)]
    states = np.zeros((B, problem.size()))
    for b in range(B):
        if u0 is None:
            states[b] = initial_state(problem, cfg, results[b], case=b)
        else:
            states[b, : 2 * n] = u0[b]
        results[b].energy0 = problem.energy(states[b], case=b)
    # the TS state: kernel layout for the compiled callbacks, blade-major for the Python one
    compiled = rhs_kind == "compiled"
    ts, fvec, used = make_ts(problem, cfg, prefix, options, rhs_kind)
    u = PETSc.Vec().createSeq(fvec.getSize(), comm=problem.comm)
    u.setArray(context.pack(states) if compiled else states[0])
    samples = [Samples(problem, b) for b in range(B)]
    running = [True] * B
    windows = max(1, int(round(cfg.time.end / cfg.time.window)))
    rows = [{key: [] for key in ("end", "amp", "energy", "work", "spec")} for _ in range(B)]
    kinds = problem.forces.contacts.kinds
    fn_rows = [{k: [] for k in kinds} for _ in range(B)]
    open_rows = [{k: [] for k in kinds} for _ in range(B)]
    steps = [0] * B
    # Fixed steps: a window ends after a step count, not at a time, because TS "matchstep"
    # shortens (or splits in two) the steps before a window end and keeps the short step.
    dt0 = ts.getTimeStep()
    fixed = used.get("ts_adapt_type", "none") == "none"
    try:
        for w in range(windows):
            t_end = cfg.time.end if w == windows - 1 else (w + 1) * cfg.time.window
            if fixed:  # step over, never clip: the step count ends the window
                ts.setExactFinalTime(PETSc.TS.ExactFinalTime.STEPOVER)
                ts.setTimeStep(dt0)
                ts.setMaxSteps(int(round(t_end / dt0)))
                ts.setMaxTime(t_end + 0.5 * dt0)
            else:
                ts.setMaxTime(t_end)
            ts.solve(u)
            t_now = ts.getTime()
            ua = u.getArray(readonly=True)
            states = context.unpack(ua) if compiled else ua[None, :].copy()
            early = t_now < t_end - (0.5 * dt0 if fixed else 1e-9 * max(1.0, t_end))
            for b in range(B):
                if not running[b]:
                    continue
                res, row = results[b], rows[b]
                stats = samples[b].take_window()
                reason = samples[b].stop_reason()
                steps[b] = ts.getStepNumber()
                if reason:
                    res.status = f"failed: {reason}"
                    running[b] = False
                    stopped = samples[b].stop_time()
                    if fixed and stopped is not None:  # frozen: the steps up to then
                        steps[b] = int(round(stopped / dt0))
                    continue
                row["end"].append(t_now)
                row["amp"].append(stats["amp"])
                row["spec"].append(stats["spec"])
                row["energy"].append(problem.energy(states[b], case=b))
                row["work"].append(states[b, 2 * n :].copy())
                for k in kinds:
                    fn_rows[b][k].append(stats["min_fn"][k])
                    open_rows[b][k].append(stats["open"][k])
                if early:
                    res.status = (
                        f"failed: TS stopped at t = {t_now:.6g} s ({ts.getConvergedReason()})"
                    )
                    running[b] = False
            if progress and any(running):
                amps = [rows[b]["amp"][-1] for b in range(B) if running[b]]
                progress(w + 1, windows, t_now, max(amps))
            if not any(running):
                break
    except PETSc.Error as exc:
        for b in range(B):
            if running[b]:
                results[b].status = f"failed: PETSc error {exc}"
                steps[b] = ts.getStepNumber()
    ua = u.getArray(readonly=True)
    finals = context.unpack(ua) if compiled else ua[None, :].copy()
    wall = time.perf_counter() - t_wall
    for b, res in enumerate(results):
        row = rows[b]
        res.options = used
        res.window_end = np.array(row["end"])
        res.max_tip_amplitude = np.array(row["amp"])
        res.nd_spectrum = np.array(row["spec"]).reshape(-1, problem.N // 2 + 1)
        res.energy = np.array(row["energy"])
        res.work = np.array(row["work"]).reshape(-1, N_WORK)
        res.min_normal_force = {k: np.array(v) for k, v in fn_rows[b].items()}
        res.open_fraction = {k: np.array(v) for k, v in open_rows[b].items()}
        res.sample_time = np.concatenate(samples[b].times)
        res.tip_history = np.concatenate(samples[b].tips).reshape(-1, problem.N, 3)
        res.steps = steps[b]
        res.rhs_evaluations = int(context.header(rhs.H_RHS_CALLS))
        res.final_state = finals[b].copy()
        res.batch = B
        res.wall_s = wall / B
    for obj in (ts, fvec, u):
        obj.destroy()
    problem.destroy()
    return results


# Bogacki-Shampine tableau (explicit RK3, FSAL; the 3rd-order solution is used)
_BS_A = ((0.5,), (0.0, 0.75))
_BS_B = (2.0 / 9.0, 1.0 / 3.0, 4.0 / 9.0)
_BS_C = (0.0, 0.5, 0.75)


def reference_solution(
    model: ReducedModel,
    cfg: Config,
    steps: int,
    angles_deg: dict | None = None,
    sample_every: int = 1,
):
    """Plain-numpy fixed-step Bogacki-Shampine loop (no PETSc) over the same force model.

    Returns ``(times, states)`` with the state every ``sample_every`` steps and ``wall_s``.
    """
    t_wall = time.perf_counter()
    forces = ForceModel(model, cfg, angles_deg)
    problem = WheelProblem(model, cfg, forces)
    res = CaseResult()
    u = initial_state(problem, cfg, res)
    h = cfg.time.step
    times, states = [0.0], [u.copy()]
    t = 0.0
    for i in range(steps):
        k1 = problem.rhs_numpy(t, u)
        k2 = problem.rhs_numpy(t + _BS_C[1] * h, u + h * _BS_A[0][0] * k1)
        k3 = problem.rhs_numpy(t + _BS_C[2] * h, u + h * _BS_A[1][1] * k2)
        u = u + h * (_BS_B[0] * k1 + _BS_B[1] * k2 + _BS_B[2] * k3)
        t = (i + 1) * h
        if (i + 1) % sample_every == 0:
            times.append(t)
            states.append(u.copy())
    problem.destroy()
    return np.array(times), np.array(states), time.perf_counter() - t_wall
