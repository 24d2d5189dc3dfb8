"""Benchmark of the transient hot path (``wheelrom bench``): a fixed workload, one process.

Figures (all on the configuration's reduced model, single core):

- ``startup_s`` (``{"cold", "warm"}``): a fresh process from its spawn to the end of its first
  TS step on the configuration's model (given: ``model_build_s`` is what building it took),
  with an empty kernel cache (it compiles the kernels) and then with that cache (it loads
  them); ``startup_compile_s`` the part of each spent compiling or loading the kernels
  (:mod:`wheelrom.transient.startup`, :mod:`wheelrom.runtime.kernel_cache`);

- ``us_per_rhs``: one compiled right-hand side evaluation (``K_R`` product + all forces),
  timed in a compiled loop (no call overhead) at the state the timed run reached;
  ``us_per_force_evaluation`` the same without the ``K_R`` product;
- ``steps_per_s``: PETSc TS steps per second of a measured run of ``steps`` (>= 20,000)
  steps with the configuration's TS settings, output sampling included;
- ``ts_overhead_us_per_step``: wall per step minus the right-hand sides it evaluated;
- ``paper_case_s``: ``time.end / time.step`` steps at that rate (the paper case with the
  default configuration);
- ``batch``, ``us_per_rhs_in_batch``, ``steps_per_s_in_batch``, ``paper_case_s_in_batch``:
  the same for ``batch`` angle cases integrated together in one TS (as ``wheelrom sweep``
  does; the sweep's shroud angles that share the first one's propagated springs,
  :mod:`wheelrom.transient.stuck_shift`), per case: the throughput of a sweep on one core;
- floors (what bounds ``paper_case_s`` on this machine): ``ts_null_us_per_step`` (and
  ``ts_null_us_per_case_step_in_batch``), the configured TS with a no-op right-hand side;
  ``multiply_adds_per_rhs`` (:func:`wheelrom.transient.kernel.multiply_adds`, contact laws
  not counted);
  ``machine_gmadd_per_s``, a one-thread 1024^3 BLAS ``dgemm`` (this core's attainable
  multiply-add rate), and ``shape_gmadd_per_s``, ``dgemm`` on the kernel's product shape
  ``(m x 3m)(3m x N batch)``; ``kernel_gmadd_per_s`` (``_in_batch``), our kernel's rate
  counted the same way; ``paper_case_bound_s``: ``time.end / time.step`` steps of the no-op
  TS plus ``rhs_per_step`` evaluations of the multiply-adds at ``machine_gmadd_per_s`` (a
  lower bound: contact laws free, every operand in a register), and
  ``paper_case_bound_at_shape_rate_s`` the same at ``shape_gmadd_per_s``;
- ``ratio_vs_numpy_reference``: wall of the plain-numpy serial reference (same steps, same
  force model) over ours;
- ``ratio_vs_scipy``: wall of ``scipy.integrate.solve_ivp`` (RK23, adaptive, on the same
  compiled right-hand side) over ours for the same simulated time, its ``rtol`` chosen as the
  loosest of 1e-2..1e-9 (steps of 1, 3 per decade: a decade grid made the ratio jump by 3x
  with round-off-level changes of the state's coordinates) whose tip-history error against
  a fine-step reference (all from the preloaded equilibrium) is not larger than ours; a run
  over ``SCIPY_BUDGET`` times ours ends the search (``ratio_vs_scipy_is_lower_bound``).
- ``limit_cycle_*`` (#30): :mod:`wheelrom.bench.limit_cycle`; ``*law*`` (#44) and ``settle_*``
  (#70): :mod:`.laws`.
- ``rk_*`` and ``configured_*`` (issue #31): RK 3bs at ``RK_STEP`` (the paper's scheme) and
  the configured scheme and step (default: the exponential scheme), both from the preloaded
  equilibrium with a 1 nm seed: ``*_tip_error`` after 20.16 ms against RK 5dp at 0.75 us
  (relative to the largest tip displacement), ``*_s_per_simulated_s``, ``*_energy_balance``;
  ``speedup_vs_rk`` (RK's seconds per simulated second over the configured scheme's).
"""

from __future__ import annotations

import math
import time

import numpy as np

from wheelrom.config import Config
from wheelrom.forces.parameters import force_parameters
from wheelrom.rom.model import ReducedModel
from wheelrom.runtime import kernel_cache as _kernel_cache
from wheelrom.runtime.environment import petsc
from wheelrom.transient import bridge, layout, startup
from wheelrom.transient.exponential import taken_step
from wheelrom.transient.kernel import multiply_adds, rhs_core
from wheelrom.transient.preload import initial_state
from wheelrom.transient.problem import WheelProblem
from wheelrom.transient.reference import reference_solution
from wheelrom.transient.run import run_case, run_cases
from wheelrom.transient.stuck_shift import shift_stiffness
from wheelrom.transient.ts import make_ts, time_step


def _tip(model: ReducedModel, states: np.ndarray) -> np.ndarray:
    """Tip displacements ``(..., N, 3)`` of states ``(..., 2 N m + 4)``."""
    n = model.size
    q = states[..., :n].reshape(*states.shape[:-1], model.blades, model.modes)
    return q @ model.tip.T


@_kernel_cache.njit()
def _rhs_loop(count, u, f, ctx):
    """``count`` right-hand sides in a compiled loop (cached like the kernel)."""
    for i in range(count):
        rhs_core(1e-3 * (i % 7), u, f, ctx)


def rhs_microseconds(problem: WheelProblem, calls: int = 20000, linear: bool = True,
                     state: np.ndarray | None = None) -> float:
    """Best-of-3 mean wall time of one compiled RHS evaluation [us] (compiled loop, warm);
    ``linear=False`` leaves out the ``K_R`` product (the force model alone)."""
    loop = _rhs_loop
    if state is None:
        state = np.random.default_rng(0).normal(size=(problem.B, problem.size())) * 1e-4
    u = problem.context.pack(state)
    f = np.empty_like(u)
    ctx = layout.aligned_zeros(problem.context.array.size)  # leave the case's context untouched
    ctx[:] = problem.context.array
    ctx[layout.H_SKIP_LINEAR] = 0.0 if linear else 1.0
    loop(10, u, f, ctx)
    best = math.inf
    for _ in range(3):
        t0 = time.perf_counter()
        loop(calls, u, f, ctx)
        best = min(best, (time.perf_counter() - t0) / calls * 1e6)
    return best


class _NullStepper:
    """A ``python`` TS step that only advances the time: the python TS's own cost."""

    def step(self, ts) -> None:
        ts.setTime(ts.getTime() + ts.getTimeStep())


def integrator_microseconds(problem: WheelProblem, cfg: Config, steps: int = 20000) -> float:
    """Best-of-3 wall per step [us] of the configured TS (``make_ts``: the same type, tableau
    and ``-wheel_`` options) on ``problem``'s state size with a right-hand side that does
    nothing and no monitor: what PETSc's integrator costs by itself (stage copies and
    ``VecMAXPY`` updates over ``B (2 N m + 4)`` doubles, call chain), a floor under any
    right-hand side."""
    ts, f, used = make_ts(problem, cfg)
    bridge.attach_null(ts, f)
    if used.get("ts_scheme"):  # the exponential scheme steps itself: a stepper doing nothing
        ts.setPythonContext(_NullStepper())
    u = f.duplicate()
    best = math.inf
    for _ in range(3):
        u.set(1e-6)
        ts.setTime(0.0)
        ts.setStepNumber(0)
        ts.setMaxSteps(steps)
        ts.setMaxTime(2 * steps * ts.getTimeStep())
        t0 = time.perf_counter()
        ts.solve(u)
        best = min(best, time.perf_counter() - t0)
        if ts.getStepNumber() != steps:
            raise RuntimeError(f"no-op TS run stopped after {ts.getStepNumber()} of {steps}")
    for obj in (ts, f, u):
        obj.destroy()
    return best / steps * 1e6


def dgemm_gmadd_per_s(rows: int, inner: int, cols: int, calls: int) -> float:
    """Best-of-3 rate [1e9 multiply-adds/s] of the BLAS product ``(rows x inner)(inner x cols)``
    (one BLAS thread, as set for every wheelrom process): a large square one measures what
    this core can do, the kernel's own shape what an optimised library reaches on it."""
    rng = np.random.default_rng(0)
    a, b = rng.random((rows, inner)), rng.random((inner, cols))
    c = np.empty((rows, cols))
    np.dot(a, b, out=c)
    best = math.inf
    for _ in range(3):
        t0 = time.perf_counter()
        for _ in range(calls):
            np.dot(a, b, out=c)
        best = min(best, (time.perf_counter() - t0) / calls)
    return rows * inner * cols / best / 1e9


def _problem(model: ReducedModel, cfg: Config, angles: list) -> WheelProblem:
    return WheelProblem(model, cfg, [force_parameters(model, cfg, a) for a in angles],
                        petsc().COMM_SELF)


class _OverBudget(Exception):  # a solve_ivp run of the scipy comparison passed its budget
    pass


def _scipy_run(problem: WheelProblem, t_end: float, rtol: float, t_eval: np.ndarray,
               budget: float, u0: np.ndarray):
    """``(solution, wall)`` from the kernel-layout state ``u0``; the solution is ``None`` when
    the run passed ``budget`` [s]."""
    from scipy.integrate import solve_ivp

    ctx = problem.context.array
    f = np.empty(problem.size())
    t0 = time.perf_counter()

    def fun(t, u):  # kernel layout (one case): unpacked for the tips afterwards
        if time.perf_counter() - t0 > budget:
            raise _OverBudget
        rhs_core(t, u, f, ctx)
        return f.copy()

    t_end = max(t_end, float(t_eval[-1]))  # the last sample may sit a round-off past t_end
    try:
        sol = solve_ivp(fun, (0.0, t_end), u0, method="RK23", rtol=rtol, atol=rtol * 1e-9,
                        t_eval=t_eval)
    except _OverBudget:
        sol = None
    return sol, time.perf_counter() - t0


def _timed_single(model: ReducedModel, cfg: Config, problem: WheelProblem, steps: int,
                  h: float, say):
    """One case: a TS run of ``steps`` steps of ``h`` [s] and the compiled right-hand side
    timed at the state it reached; returns ``(figures, res)`` (``res`` the timed run)."""
    # TS run of `steps` steps (warm-up first: caches and branch predictors warm)
    short = cfg.replace(**{"time.end": 20 * h, "time.window": 20 * h})
    run_case(model, short)
    t_end = steps * h
    timed = cfg.replace(**{"time.end": t_end, "time.window": t_end})
    res = run_case(model, timed)
    # the RHS timed at the state the run reached (a physical mix of open/stuck/slipping
    # contacts; the force model's cost depends on it)
    us_rhs = rhs_microseconds(problem, state=res.final_state)
    us_forces = rhs_microseconds(problem, linear=False, state=res.final_state)
    say(f"compiled right-hand side: {us_rhs:.2f} us per evaluation ({us_forces:.2f} us forces)")
    steps_per_s = res.steps / res.wall_s
    per_step_us = 1e6 / steps_per_s
    rhs_per_step = res.rhs_evaluations / max(res.steps, 1)
    say(f"PETSc TS: {res.steps} steps in {res.wall_s:.2f} s = {steps_per_s:.0f} steps/s")
    paper_steps = cfg.time.end / h
    figures = {
        "us_per_rhs": us_rhs,
        "us_per_force_evaluation": us_forces,
        "us_per_linear_product": us_rhs - us_forces,
        "rhs_per_step": rhs_per_step,
        "steps": res.steps,
        "steps_per_s": steps_per_s,
        "us_per_step": per_step_us,
        "ts_overhead_us_per_step": per_step_us - rhs_per_step * us_rhs,
        "paper_case_steps": paper_steps,
        "paper_case_s": paper_steps / steps_per_s,
    }
    return figures, res


def _batch_figures(model: ReducedModel, cfg: Config, steps: int, h: float, batch: int,
                   paper_steps: float, say):
    """The timed run for ``batch`` angle cases in one TS (sweep throughput per case);
    returns ``(figures, batch_problem)``."""
    t_end = steps * h
    timed = cfg.replace(**{"time.end": t_end, "time.window": t_end})
    shroud = list(cfg.sweep.shroud_angles_deg) or [cfg.contacts.shroud.angle_deg]
    shifts = [shift_stiffness(model, force_parameters(model, cfg, {"shroud": a})) for a in shroud]
    shroud = [a for a, k in zip(shroud, shifts, strict=True) if np.array_equal(k, shifts[0])]
    angles = [{"shroud": shroud[i % len(shroud)]} for i in range(batch)]
    t0 = time.perf_counter()
    batch_res = run_cases(model, timed, angles)
    batch_wall = time.perf_counter() - t0
    batch_problem = _problem(model, cfg, angles)
    batch_states = np.array([r.final_state for r in batch_res])
    us_rhs_batch = rhs_microseconds(batch_problem, calls=max(2000, 20000 // batch),
                                    state=batch_states) / batch
    batch_steps_per_s = batch * batch_res[0].steps / batch_wall
    say(f"batch of {batch} cases: {batch_wall:.2f} s, {us_rhs_batch:.2f} us per RHS and case, "
        f"{batch_steps_per_s:.0f} case-steps/s")
    figures = {
        "batch": batch,
        "us_per_rhs_in_batch": us_rhs_batch,
        "steps_per_s_in_batch": batch_steps_per_s,
        "paper_case_s_in_batch": paper_steps / batch_steps_per_s,
    }
    return figures, batch_problem


def _floors(model: ReducedModel, cfg: Config, problem: WheelProblem,
            batch_problem: WheelProblem, steps: int, batch: int, single: dict,
            in_batch: dict, say) -> dict:
    """Floors: PETSc's integrator alone [us/step], and the multiply-adds at this core's
    ``dgemm`` rate [1e9/s]; ``single``/``in_batch`` the figures of the timed runs."""
    us_rhs, rhs_per_step = single["us_per_rhs"], single["rhs_per_step"]
    paper_steps = single["paper_case_steps"]
    ts_null = integrator_microseconds(problem, cfg)
    ts_null_batch = integrator_microseconds(batch_problem, cfg, max(2000, steps // batch)) / batch
    m, kinds = model.modes, len(problem.kinds)
    madds = multiply_adds(model.blades, m, kinds)
    peak = dgemm_gmadd_per_s(1024, 1024, 1024, 1)
    shape = dgemm_gmadd_per_s(m, 3 * m, model.blades * batch, max(100, 20000 // batch))
    bound_us = ts_null + rhs_per_step * madds / peak / 1e3
    bound_shape_us = ts_null + rhs_per_step * madds / shape / 1e3
    say(f"floors: no-op TS {ts_null:.2f} us per step ({ts_null_batch:.2f} per case in the "
        f"batch); {madds} multiply-adds per RHS; dgemm {peak:.1f} G/s (1024^3), {shape:.1f} "
        f"G/s ({m}x{3 * m})({3 * m}x{model.blades * batch}); paper case >= "
        f"{paper_steps * bound_us / 1e6:.1f} s")
    return {
        "ts_null_us_per_step": ts_null,
        "ts_null_us_per_case_step_in_batch": ts_null_batch,
        "multiply_adds_per_rhs": madds,
        "machine_gmadd_per_s": peak,
        "shape_gmadd_per_s": shape,
        "kernel_gmadd_per_s": madds / us_rhs / 1e3,
        "kernel_gmadd_per_s_in_batch": madds / in_batch["us_per_rhs_in_batch"] / 1e3,
        "paper_case_bound_s": paper_steps * bound_us / 1e6,
        "paper_case_bound_at_shape_rate_s": paper_steps * bound_shape_us / 1e6,
    }


def _numpy_comparison(model: ReducedModel, cfg: Config, compare_steps: int, h: float, res,
                      say) -> dict:
    """Plain-numpy serial reference over ``compare_steps``: its wall per step over ours."""
    _, ref_states, ref_wall = reference_solution(model, cfg, compare_steps, h,
                                                 sample_every=compare_steps)
    ratio_numpy = (ref_wall / compare_steps) / (res.wall_s / res.steps)
    say(f"numpy reference: {compare_steps} steps in {ref_wall:.2f} s")
    return {"reference_steps": compare_steps, "ratio_vs_numpy_reference": ratio_numpy}


def _scipy_comparison(model: ReducedModel, cfg: Config, problem: WheelProblem,
                      compare_steps: int, h: float, res, t_end: float, say) -> dict:
    """Accuracy of our fixed step on the tip history over ``compare_steps`` against a 4x finer
    step, and ``solve_ivp`` RK23 at the loosest ``rtol`` as accurate: its wall per simulated
    second over ours (``res`` our timed run of ``t_end`` [s]). Every run starts from the
    preloaded equilibrium with the 1 nm seed: from rest the contacts chatter chaotically for
    ~100 ms and the comparison would measure that chaos, not the schemes (issue #31)."""
    t_cmp = compare_steps * h
    # the tip history at every statistics sample, as compared before history_rate_hz
    cmp_cfg = cfg.replace(**{"time.end": t_cmp, "time.window": t_cmp,
                             "output.history_rate_hz": cfg.output.sample_rate_hz,
                             "time.start": "preload", "time.perturbation": 1e-9})
    u0 = initial_state(_problem(model, cmp_cfg, [None]))[0]
    ours = run_case(model, cmp_cfg, u0=u0[: 2 * model.size])
    fine = run_case(model, cmp_cfg, options={"ts_dt": h / 4}, u0=u0[: 2 * model.size])
    scale = np.abs(fine.tip_history).max()
    our_error = float(np.abs(ours.tip_history - fine.tip_history).max() / scale)
    chosen, sp_wall, sp_error, bound = None, math.nan, math.nan, None
    budget = SCIPY_BUDGET * max(ours.wall_s, 1e-3)
    for rtol in [f * 10.0**-e for e in range(2, 10) for f in (1.0, 0.3)][:-1]:
        sol, wall = _scipy_run(problem, t_cmp, rtol, fine.sample_time, budget,
                               problem.context.pack(u0[None, :]))
        if sol is None:  # a tighter rtol only costs more: ours is at least this much faster
            bound, sp_wall = rtol, wall
            break
        if not sol.success:
            continue
        states = np.array([problem.context.unpack(y)[0] for y in sol.y.T])
        err = float(np.abs(_tip(model, states) - fine.tip_history).max() / scale)
        if err <= our_error:
            chosen, sp_wall, sp_error = rtol, wall, err
            break
    ratio_scipy = (sp_wall / t_cmp) / (res.wall_s / t_end) if chosen or bound else math.nan
    say(f"scipy RK23: rtol {chosen or bound}, error {sp_error:.2e} (ours {our_error:.2e}), "
        f"{sp_wall:.2f} s for {t_cmp * 1e3:.0f} ms"
        + (" (search stopped: over its time budget, so the ratio is a lower bound)"
           if bound else ""))
    return {
        "tip_error_fixed_step": our_error,
        "scipy_rtol": chosen,
        "scipy_tip_error": sp_error,
        "ratio_vs_scipy": ratio_scipy,
        "ratio_vs_scipy_is_lower_bound": bound is not None,
    }


def _startup_figures(model: ReducedModel, cfg: Config, say) -> dict:
    """``startup_s``: a fresh process from its spawn to the end of its first TS step on this
    model (given, not built), cold (empty kernel cache: compiles) and warm (loads);
    ``startup_compile_s``: the part of it spent compiling or loading the kernels;
    ``model_build_s``: what building this model took (not in ``startup_s``)."""
    probe = startup.measure(model, cfg)
    cold, warm = probe["cold"], probe["warm"]
    say(f"start-up to the first step: cold {cold['startup_s']:.2f} s (compiling "
        f"{cold['compile_s']:.2f} s), warm {warm['startup_s']:.2f} s (loading the kernels "
        f"{warm['compile_s']:.2f} s)")
    return {
        "startup_s": {"cold": cold["startup_s"], "warm": warm["startup_s"]},
        "startup_compile_s": {"cold": cold["compile_s"], "warm": warm["compile_s"]},
        "model_build_s": model.info.get("build_s"),
    }


class _Progress:
    """Progress of the bench's groups on ``say`` with an estimate of the time left: the work
    of each group in single-case TS step equivalents (:func:`_work`), at the rate the timed
    groups done so far ran (the start-up group, compile-bound, is not counted in the rate)."""

    def __init__(self, say, work: dict):
        self.say, self.work = say, work
        self.names = list(work)
        self.t0 = self.t_group = time.perf_counter()
        self.timed_s = self.timed_work = 0.0

    def start(self, name: str) -> None:
        self.t_group = time.perf_counter()
        self.say(f"bench [{self.names.index(name) + 1}/{len(self.names)}] {name} ...")

    def done(self, name: str) -> None:
        now = time.perf_counter()
        if self.work[name]:
            self.timed_s += now - self.t_group
            self.timed_work += self.work[name]
        left = sum(self.work[n] for n in self.names[self.names.index(name) + 1 :])
        eta = f", about {left * self.timed_s / self.timed_work:.0f} s left" if (
            self.timed_work and left) else ""
        self.say(f"bench [{self.names.index(name) + 1}/{len(self.names)}] {name}: "
                 f"{now - self.t_group:.1f} s ({now - self.t0:.0f} s in all{eta})")


def _work(steps: int, compare_steps: int, batch: int) -> dict:
    """Each group's work in single-case TS step equivalents (measured proportions: a case-step
    in a batch ~0.7 of a single step, a no-op TS step ~0.1, three right-hand sides ~0.6, a
    numpy reference step ~10, the scipy search ~15 steps per compared step); ``0``: not
    counted (the start-up group, whose time is compiling)."""
    rhs_timed = 2 * 3 * 20000 * 0.2
    batch_rhs = 3 * max(2000, 20000 // batch) * batch * 0.2
    null_ts = 3 * (steps + max(2000, steps // batch) * batch) * 0.1
    return {
        "start-up of fresh processes (cold: compiles the kernels)": 0,
        "one case": 20 + steps + rhs_timed,
        f"batch of {batch} cases": 0.7 * batch * steps + batch_rhs,
        "floors (no-op TS, dgemm)": null_ts + 5000,
        "numpy reference": 10 * compare_steps,
        "scipy solve_ivp": 20 * compare_steps,
        "linear stability of the configured angles": 30000,
        "RK and the exponential scheme from the preloaded equilibrium": 40000,
        "the elastic law against the paper law (alternated runs)": 30000,
        "the settle's step against time.step (alternated runs)": 20000,
        "limit cycles (harmonic balance)": 30000,
        "nonlinear forced response (200 frequencies, traced)": 30000,
    }


def run(model: ReducedModel, cfg: Config, steps: int = 20000, compare_steps: int = 2000,
        log=None, batch: int = 10) -> dict:
    """Run the workload; returns the figures (see the module docstring). Progress lines with
    the time left go to ``log``."""
    say = log or (lambda m: None)
    progress = _Progress(say, _work(steps, compare_steps, batch))
    groups = iter(progress.names)

    def group(name, figures, *args):
        progress.start(name)
        out = figures(*args)
        progress.done(name)
        return out

    h = time_step(cfg)  # the TS's step (-wheel_ts_dt overrides time.step)
    if cfg.time.scheme == "exponential":  # as the TS moves it (resonances, stability)
        h = taken_step(model, cfg, h)
    problem = _problem(model, cfg, [None])
    start = group(next(groups), _startup_figures, model, cfg, say)
    single, res = group(next(groups), _timed_single, model, cfg, problem, steps, h, say)
    in_batch, batch_problem = group(next(groups), _batch_figures, model, cfg, steps, h, batch,
                                    single["paper_case_steps"], say)
    floors = group(next(groups), _floors, model, cfg, problem, batch_problem, steps, batch,
                   single, in_batch, say)
    numpy_cmp = group(next(groups), _numpy_comparison, model, cfg, compare_steps, h, res, say)
    scipy_cmp = group(next(groups), _scipy_comparison, model, cfg, problem, compare_steps, h,
                      res, steps * h, say)
    stability = group(next(groups), _stability_figures, model, cfg)
    schemes = group(next(groups), _scheme_figures, model, cfg, h, say)
    from wheelrom.bench import forced, laws, limit_cycle

    law_cost = group(next(groups), laws.law_figures, model, cfg, say)
    settle_cost = group(next(groups), laws.settle_figures, model, cfg, say)
    cycles = group(next(groups), limit_cycle.limit_cycle_figures, model, cfg, say)
    nonlinear = group(next(groups), forced.forced_figures, model, cfg, say)
    return {"blades": model.blades, "modes": model.modes, "contact_kinds": list(problem.kinds),
            **start, **single, **in_batch, **floors, **numpy_cmp, **scipy_cmp, **stability,
            **schemes, **law_cost, **settle_cost, **cycles, **nonlinear}


SCIPY_BUDGET = 200.0  # x our run: a longer solve_ivp run ends the rtol search (a lower bound)
RK_STEP = 3e-6  # [s] the paper's RK 3bs step on the default wheel (its limit: 4.2 us)


def _scheme_figures(model: ReducedModel, cfg: Config, h: float, say) -> dict:
    """RK 3bs at ``RK_STEP`` against the configured scheme and step ``h`` (the default: the
    exponential scheme), both from the preloaded equilibrium with a 1 nm physical seed (the
    start of ./run/paper's transients, where the solution is a smooth function of the step):
    the tip error of every blade after 20.16 ms (a multiple of both steps) against RK 5dp at
    0.75 us, relative to the largest tip displacement, and the seconds of integration per
    simulated second (the preload solved once, outside the timed runs)."""
    end = 0.02016
    start = cfg.replace(**{"time.start": "preload", "time.perturbation": 1e-9,
                           "time.end": end, "time.window": end})
    u0 = initial_state(_problem(model, start, [None]))[0][: 2 * model.size]
    rk = {"ts_type": "rk", "ts_rk_type": "3bs"}
    reference = run_case(model, start, u0=u0, options={**rk, "ts_rk_type": "5dp",
                                                       "ts_dt": 7.5e-7})
    tip_ref = _tip(model, reference.final_state[None, :])
    scale = float(np.abs(tip_ref).max())
    figures = {}
    for name, options in (("rk", {**rk, "ts_dt": RK_STEP}), ("configured", None)):
        res = run_case(model, start, u0=u0, options=options)
        error = float(np.abs(_tip(model, res.final_state[None, :]) - tip_ref).max() / scale)
        figures[f"{name}_scheme"] = res.options.get("ts_scheme", res.options.get("ts_rk_type"))
        figures[f"{name}_step_s"] = float(res.options["ts_dt"])
        figures[f"{name}_tip_error"] = error
        figures[f"{name}_s_per_simulated_s"] = res.wall_s / end
        figures[f"{name}_energy_balance"] = res.energy_balance_error()
        say(f"{name} ({figures[f'{name}_scheme']}): step {figures[f'{name}_step_s']:.3g} s, tip "
            f"error {error:.2e}, {res.wall_s / end:.2f} s per simulated s")
    figures["speedup_vs_rk"] = (figures["rk_s_per_simulated_s"]
                                / figures["configured_s_per_simulated_s"])
    return figures


def _stability_figures(model: ReducedModel, cfg: Config) -> dict:
    """``stability_s_per_case``: equilibrium, analytic Jacobian and per-ND eigenvalues of one
    case, over the configured shroud angles (after one untimed case)."""
    from wheelrom.analysis.stability import analyse

    angles = list(cfg.sweep.shroud_angles_deg)
    analyse(model, cfg, {"shroud": angles[0]})
    t0 = time.perf_counter()
    for angle in angles:
        analyse(model, cfg, {"shroud": angle})
    per_case = (time.perf_counter() - t0) / len(angles)
    return {"stability_cases": len(angles), "stability_s_per_case": per_case}
