"""The PETSc TS of a case and its time grid.

Default TS (``time.scheme = "exponential"``): type ``python``, ETDRK4 with the segment block
``A0`` exact (:mod:`wheelrom.transient.exponential`), fixed step ``time.step`` (moved off the
scheme's resonances); ``time.scheme = "rk"``: ``rk`` / ``3bs`` (Bogacki-Shampine = Simulink
ode3), fixed step, no adaptivity, set in code; options under the prefix (default ``wheel_``:
``-wheel_ts_type``, ``-wheel_ts_rk_type``, ``-wheel_ts_adapt_type``, ``-wheel_ts_dt`` ...) are
applied last (``setFromOptions``). Options a caller passes as a dict are inserted under the
prefix only while the TS reads them (:func:`scoped_options`); the global database is left as
it was.
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass

from wheelrom.config import Config, sample_every
from wheelrom.runtime.environment import petsc
from wheelrom.runtime.errors import InputError
from wheelrom.transient import bridge, exponential
from wheelrom.transient.layout import H_EXPONENTIAL
from wheelrom.transient.problem import WheelProblem

PREFIX = "wheel_"


@contextlib.contextmanager
def scoped_options(prefix: str, options: dict | None):
    """Insert ``options`` (keys without prefix, ``None`` for a flag) under ``prefix`` into
    the PETSc options database for the duration of the block, then restore what was there."""
    db = petsc().Options()
    saved = {}
    for key, value in (options or {}).items():
        name = prefix + key.lstrip("-")
        if name not in saved:
            saved[name] = db.getString(name) if db.hasName(name) else None
        db.setValue(name, "" if value is None else str(value))
    try:
        yield
    finally:
        for name, old in saved.items():
            if old is None:
                db.delValue(name)
            else:
                db.setValue(name, old)


# TSConvergedReason in words (petsc/include/petscts.h)
_REASONS = {
    0: "still iterating",
    1: "reached its final time",
    2: "reached its step limit",
    3: "stopped by the sampling monitor",
    4: "stopped at an event",
    -1: "a nonlinear solve diverged",
    -2: "a step was rejected too often",
}


def reason_words(reason: int) -> str:
    """A TS converged reason for people: ``-2`` -> ``"a step was rejected too often (PETSc
    TS reason -2)"``."""
    return f"{_REASONS.get(int(reason), 'unknown reason')} (PETSc TS reason {int(reason)})"


def ts_options_used(ts, prefix: str) -> dict:
    """The TS settings in effect (type, RK scheme, step) and the ``<prefix>ts_`` options of
    the database that took effect, prefix stripped: what a result records about its
    integrator. An option took effect when PETSc read it (``PetscOptionsUsed``: not
    ``-wheel_ts_rk_type`` for a TS of another type) and, with the exponential scheme, when
    it is none of the RK (``ts_rk_*``) or step adaptor (``ts_adapt_*``) options: PETSc
    reads the latter for any TS type, but the scheme's own fixed step never consults them."""
    from wheelrom.transient.options import was_read

    exp = _exponential(ts)
    used = {
        "ts_type": ts.getType(),
        "ts_rk_type": ts.getRKType() if ts.getType() == "rk" else None,
        "ts_scheme": exponential.SCHEME if exp else None,
        "ts_dt": ts.getTimeStep(),
    }
    ours = prefix + "ts_"
    everything = petsc().Options().getAll()
    for key, value in everything.items():
        name = key[len(prefix) :]
        if not key.startswith(ours) or (exp and name.startswith(_NOT_EXPONENTIAL)):
            continue
        if was_read(key):
            used[name] = value
    return {k: v for k, v in used.items() if v is not None}


# option families the exponential scheme does not act on (its step is its own, fixed)
_NOT_EXPONENTIAL = ("ts_rk_", "ts_adapt_")


def _ignore_for_exponential(ts, prefix: str) -> None:
    """After ``setFromOptions`` of an exponential TS: its step adaptor back to ``none`` (an
    adaptor another ``-<prefix>ts_adapt_type`` chose would not act, but would make the run
    stop at windows like an adaptive one), and the RK and adaptor options of the database
    left unread, so that the end of the command reports them unused."""
    from wheelrom.transient.options import forget_reads

    bridge.set_adapt_type(ts, "none")
    names = [k for k in petsc().Options().getAll()
             if k.startswith(prefix) and k[len(prefix) :].startswith(_NOT_EXPONENTIAL)]
    forget_reads(names)


def _exponential(ts) -> bool:
    """Whether ``ts`` integrates with wheelrom's exponential scheme."""
    return ts.getType() == "python" and isinstance(ts.getPythonContext(),
                                                   exponential.ExponentialStepper)


def _defaults(ts, cfg: Config, context=None) -> None:
    """The TS settings in code, before ``setFromOptions``: RK 3bs, or the exponential scheme
    (``time.scheme``; ``context``: the batch's kernel context), fixed step ``time.step``."""
    PETSc = petsc()
    ts.setProblemType(PETSc.TS.ProblemType.NONLINEAR)
    ts.setType(PETSc.TS.Type.RK)
    ts.setRKType("3bs")
    if cfg.time.scheme == "exponential":
        ts.setType(PETSc.TS.Type.PYTHON)
        ts.setPythonContext(exponential.ExponentialStepper(context))
    bridge.set_adapt_type(ts, "none")  # fixed steps unless -<prefix>ts_adapt_type says else
    ts.setTimeStep(cfg.time.step)
    ts.setMaxTime(cfg.time.end)
    ts.setMaxSteps(10**9)
    ts.setExactFinalTime(PETSc.TS.ExactFinalTime.MATCHSTEP)


def ts_settings(cfg: Config, prefix: str = PREFIX, options: dict | None = None) -> dict:
    """The ``options`` record (:func:`ts_options_used`) a case TS of ``cfg`` would have with
    the current database and ``options``, without a problem: what a sweep compares with the
    cases already in a file before it resumes."""
    PETSc = petsc()
    ts = PETSc.TS().create(comm=PETSc.COMM_SELF)
    try:
        ts.setOptionsPrefix(prefix)
        _defaults(ts, cfg)
        with scoped_options(prefix, options):
            ts.setFromOptions()
            used = ts_options_used(ts, prefix)
            if _exponential(ts):
                _ignore_for_exponential(ts, prefix)
        used.setdefault("ts_adapt_type", bridge.adapt_type(ts))
        return used
    finally:
        ts.destroy()


def make_ts(problem: WheelProblem, cfg: Config, prefix: str = PREFIX,
            options: dict | None = None, rhs_kind: str = "compiled"):
    """A configured TS (defaults in code, ``setFromOptions`` last): ``(ts, f, used)``.

    ``options``: PETSc options (keys without prefix) for this TS only. ``rhs_kind``:
    ``"compiled"`` (C callbacks, default) or ``"python"`` (petsc4py callbacks, one case).
    ``used``: :func:`ts_options_used`.
    """
    PETSc = petsc()
    ts = PETSc.TS().create(comm=problem.comm)
    ts.setOptionsPrefix(prefix)
    _defaults(ts, cfg, problem.context)
    if rhs_kind == "compiled":
        f = PETSc.Vec().createSeq(problem.B * problem.size(), comm=problem.comm)
        bridge.attach(ts, f, problem.context)
    elif rhs_kind == "python":
        if problem.B != 1:
            raise ValueError("rhs_kind='python' integrates one case, not a batch")
        f = PETSc.Vec().createSeq(problem.size(), comm=problem.comm)
        _attach_python(ts, f, problem)
    else:
        raise ValueError(f"rhs_kind must be 'compiled' or 'python', not {rhs_kind!r}")
    with scoped_options(prefix, options):
        ts.setFromOptions()
        used = ts_options_used(ts, prefix)
        if _exponential(ts):
            _ignore_for_exponential(ts, prefix)
    if ts.getType() == "python" and not _exponential(ts):
        raise InputError("-wheel_ts_type python: wheelrom's python TS is the exponential "
                         "scheme, chosen by time.scheme = 'exponential'")
    if _exponential(ts):
        if rhs_kind != "compiled":
            raise InputError("time.scheme = 'exponential' integrates the compiled right-hand "
                             "side only (use time.scheme = 'rk' for the Python one)")
        ts.getPythonContext().attach(True)
        # off the resonances and within the explicit contact coupling's stability (run_cases
        # batches only cases that take one step; a flow's batch is one case repeated: each
        # distinct case checked once, not 2 n times for a shot's Jacobian)
        distinct = {id(params): params for params in problem.cases}.values()
        step, why = min((exponential.stable_step(problem.model, params, problem.beta,
                                                 ts.getTimeStep())
                         for params in distinct), key=lambda found: found[0])
        if why:
            ts.setTimeStep(step)
            used["ts_dt"] = step
            used["ts_dt_lowered"] = why
    else:
        problem.context.array[H_EXPONENTIAL] = 0.0
    used.setdefault("ts_adapt_type", bridge.adapt_type(ts))
    return ts, f, used


def _attach_python(ts, f, problem: WheelProblem) -> None:
    """The petsc4py right-hand side and a Python sampling monitor (blade-major state)."""
    PETSc = petsc()
    context = problem.context

    def monitor(ts, step, t, x):
        # sampled before the sliders' return, as the compiled monitor (bridge)
        stop = bridge.sample(t, context.pack(x.getArray(readonly=True)), context)
        if problem.sliders:  # the step's end: the elastic law's sliders returned
            with x as u:
                if problem.slide(u):
                    ts.restartStep()
        if stop:
            ts.setConvergedReason(PETSc.TS.ConvergedReason.CONVERGED_USER)

    ts.setRHSFunction(problem.rhs, f)
    ts.setMonitor(monitor)


def time_step(cfg: Config, prefix: str = PREFIX, options: dict | None = None) -> float:
    """The step [s] a case's TS takes: ``time.step``, or ``-<prefix>ts_dt`` when given."""
    PETSc = petsc()
    ts = PETSc.TS().create(comm=PETSc.COMM_SELF)
    ts.setOptionsPrefix(prefix)
    ts.setTimeStep(cfg.time.step)
    with scoped_options(prefix, options):
        ts.setFromOptions()
    step = ts.getTimeStep()
    ts.destroy()
    return step


@dataclass(frozen=True)
class TimeGrid:
    """Windows and samples of a run, computed once (every writer and reader uses these).

    ``window_end``: ``(W,)`` end time [s] of every window: multiples of ``time.window``, the
    last window ending at ``time.end`` (it may be up to 1.5 windows long);
    ``sample_capacity``: output samples one window can hold; ``samples_max``: samples of the
    whole run at most. The stored histories keep every ``history_every``-th (tip) and
    ``state_every``-th (modal state) sample, counted from the first one at ``t = 0`` (0:
    none): at most ``history_max`` and ``state_max`` of them; ``state_capacity``: state
    samples one window can hold.
    """

    window_end: tuple[float, ...]
    sample_capacity: int
    samples_max: int
    history_every: int = 1
    history_max: int = 0
    state_every: int = 0
    state_capacity: int = 0
    state_max: int = 0

    @property
    def windows(self) -> int:
        return len(self.window_end)


def time_grid(cfg: Config) -> TimeGrid:
    """The :class:`TimeGrid` of ``cfg``."""
    t = cfg.time
    windows = max(1, int(round(t.end / t.window)))
    ends = tuple((w + 1) * t.window for w in range(windows - 1)) + (t.end,)
    longest = max(t.window, t.end - (windows - 1) * t.window)
    rate = cfg.output.sample_rate_hz
    capacity = int(math.ceil(longest * rate)) + 4
    samples = int(math.ceil(t.end * rate)) + 2
    history = sample_every(cfg.output.history_rate_hz, rate)
    state = sample_every(cfg.output.state_rate_hz, rate)
    return TimeGrid(
        window_end=ends,
        sample_capacity=capacity,
        samples_max=samples,
        history_every=history,
        history_max=-(-samples // history) if history else 0,
        state_every=state,
        state_capacity=capacity // state + 2 if state else 0,
        state_max=-(-samples // state) if state else 0,
    )


# reach of fixed-step explicit RK schemes on the imaginary axis: |lambda dt| for an undamped
# mode (3-stage 3rd order: sqrt 3; classical RK4: 2 sqrt 2); other schemes are not checked
RK_IMAGINARY_REACH = {"3": 3.0**0.5, "3bs": 3.0**0.5, "4": 8.0**0.5}


def check_step(model, used: dict) -> None:
    """Refuse a fixed RK step the model's stiffest wheel mode makes unstable: ``2 pi f_max
    dt`` beyond the scheme's reach on the imaginary axis (``used``: :func:`ts_options_used`).
    ``f_max`` is that of ``K_R`` alone, so passing is necessary, not sufficient (the contact
    springs stiffen the wheel further)."""
    if used.get("ts_scheme") == exponential.SCHEME:
        return  # unconditionally stable; make_ts moved the step off the resonances
    reach = RK_IMAGINARY_REACH.get(str(used.get("ts_rk_type")))
    if used.get("ts_type") != "rk" or used.get("ts_adapt_type") != "none" or reach is None:
        return
    dt = float(used["ts_dt"])
    f_max = model.highest_frequency_hz()
    if 2 * math.pi * f_max * dt > reach:
        largest = reach / (2 * math.pi * f_max)
        raise InputError(
            f"time.step {dt:g} s is beyond the stability of RK {used['ts_rk_type']} for this "
            f"model's stiffest wheel mode ({f_max / 1e3:.4g} kHz): use a step of at most "
            f"{largest:.3g} s (the contact springs may need less), or a basis without its "
            "highest vectors"
        )
