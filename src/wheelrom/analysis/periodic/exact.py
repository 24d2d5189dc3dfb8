"""A harmonic-balance cycle made exact: polished by shooting into the periodic orbit of the
transient's own equations and steps (:mod:`.shooting`), its stability from the whole wheel's
monodromy (:mod:`.monodromy`), with the dominant multiplier inside the cycle's own symmetry
recomputed at finer steps (docs/theory.md, "Limit cycles"); under the elastic law the orbit
marched and shot with the sliders in the state (:func:`marched_cycle`)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from wheelrom.analysis.periodic.bloch import bloch_multipliers
from wheelrom.analysis.periodic.continuation import Corrector
from wheelrom.analysis.periodic.cycle import Cycle
from wheelrom.analysis.periodic.events import orbit_switches
from wheelrom.analysis.periodic.family import friction_band
from wheelrom.analysis.periodic.floquet import TRUSTED, FloquetResult
from wheelrom.analysis.periodic.harmonic_balance import WaveBalance
from wheelrom.analysis.periodic.hopf import wave_mode
from wheelrom.analysis.periodic.monodromy import floquet_multipliers
from wheelrom.analysis.periodic.report import orbit_quantities
from wheelrom.analysis.periodic.shooting import Orbit, Shooting, vibration_units
from wheelrom.analysis.periodic.slider_shooting import SEED, SEED_FRACTION, SliderShooting
from wheelrom.runtime.environment import petsc

#: halvings of time.step tried when the shot does not converge at the configured step: a
#: fixed step that straddles a contact's lift-off makes the discrete map's derivative jump
#: where the lift-off crosses a step (measured: the paper's 65 deg ND 33 orbit stalls at a
#: residual of 8e-3 at 10 us and converges at 5 us)
STEP_HALVINGS = 2
#: the harmonics of the balance a missed shot is started from again (the paper's H = 11 cycles
#: at 65-90 deg are 3-8 % off their orbits where the shroud opens; 21 halves that)
FINER_HARMONICS = 21
FINER_PREFIX = "limitcycle_finer_"  # the options prefix of that balance's SNES
#: its Newton iterations at most (the paper's 75 deg converged in 4; a failing one at 70 deg
#: ran 53 s to the continuation's cap)
FINER_ITERATIONS = 10
#: the halvings of the multipliers' step stop where the largest in-symmetry modulus changed by
#: at most this over the last one, on an event schedule (converging at the scheme's order, the
#: finer value is then within a fifteenth of it: the paper's 90 deg orbit changed 2.9e-2,
#: 4.7e-3, 3.3e-4, 2.7e-5 over its halvings from 10 us; docs/theory.md "Events in the step").
#: Without events the first-order scatter can agree by chance: every halving is taken.
SETTLED_CHANGE = 1e-4


def exact_cycle(model, cfg, angles, branch, balance, X: np.ndarray, omega: float,
                cycle: Cycle, harmonics: int, comm=None) -> Cycle:
    """The HB cycle ``X`` ``(2H + 1, m)``, ``omega`` [rad/s] (described as ``cycle``) of
    ``branch``'s wave polished into the exact orbit by shooting at ``cycle.lam``, at
    ``time.step`` or, when that does not converge, at up to :data:`STEP_HALVINGS` halvings of
    it; when none converges, again from the same cycle balanced with
    :data:`FINER_HARMONICS` (:func:`finer_balance`: the low ``H`` leaves the start too far
    off where contacts open); ``cycle`` itself, its shooting residual set and the failure
    said in ``branch.end``, when none converges."""
    exact, residual = _shoot(model, cfg, angles, branch, balance, X, omega, cycle, harmonics,
                             comm)
    if exact is not None:
        return exact
    finer = finer_balance(balance, X, omega, cycle.lam, comm)
    if finer is not None:
        fine, X2, omega2 = finer
        exact, again = _shoot(model, cfg, angles, branch, fine, X2, omega2, cycle, harmonics,
                              comm)
        if exact is not None:
            branch.end += (f"{'; ' if branch.end else ''}the shot from the H = {balance.H} "
                           f"cycle missed (residual {residual:.2g}); from the same cycle "
                           f"balanced with H = {fine.H} it converged")
            return exact
        residual = min(residual, again)
    cycle.shooting_residual = residual
    branch.end += (f"{'; ' if branch.end else ''}shooting did not converge from the "
                   f"{cycle.tip_amplitude * 1e6:.3g} um cycle (residual {residual:.2g} down "
                   f"to a {cfg.time.step / 2**STEP_HALVINGS * 1e6:.3g} us step"
                   + (f", also from it balanced with H = {finer[0].H})" if finer else ")"))
    return cycle


def _shoot(model, cfg, angles, branch, balance, X, omega, cycle: Cycle, harmonics: int,
           comm=None) -> tuple[Cycle | None, float]:
    """``(exact cycle or None, the smallest residual)``: the shots of :func:`exact_cycle`
    from the balance's ``X``, ``omega`` at the step and its halvings."""
    q, v = balance.wheel_state(X, omega)
    residual, start, period = math.inf, None, 2 * math.pi / omega
    for r in range(STEP_HALVINGS + 1):
        step_cfg = cfg if r == 0 else cfg.replace(**{"time.step": cfg.time.step / 2**r})
        shooting = Shooting(model, step_cfg, branch.wave, angles, cycle.lam, comm)
        try:
            if start is None:
                start = np.stack([q, v])[:, : shooting.N]
            try:
                orbit = shooting.solve(start, period)
            except (ValueError, RuntimeError, petsc().Error) as exc:  # a step of the flow failed
                orbit = Orbit(branch.wave, math.nan, start, 0, 0.0, math.inf, 0, False,
                              reason=f"{type(exc).__name__}: {exc}")
            moving = orbit.converged and \
                np.abs(orbit.state[1]).max() > 1e-3 * np.abs(start[1]).max()
            if moving and abs(math.log(orbit.period * omega / (2 * math.pi))) < math.log(2):
                exact = Cycle(**orbit_quantities(shooting, orbit, harmonics, cycle.lam))
                exact.hb_tip_amplitude = cycle.tip_amplitude
                exact.hb_frequency_hz = cycle.frequency_hz
                return exact, orbit.residual
            if orbit.residual < min(residual, 0.1) and math.isfinite(orbit.period):
                # a near miss at this step: the finer step starts from where it stalled
                start, period = orbit.state, orbit.period
            residual = min(residual, orbit.residual)
        finally:
            shooting.destroy()
    return None, residual


def finer_balance(balance, X: np.ndarray, omega: float, lam: float, comm=None):
    """``(balance', X', omega')``: the cycle ``X`` ``(2H + 1, m)``, ``omega`` [rad/s] of
    ``balance`` solved again at the same ``lam`` with :data:`FINER_HARMONICS` harmonics
    (Newton from ``X`` with the higher harmonics zero, the samples scaled alike; SNES prefix
    :data:`FINER_PREFIX`, backtracking by default); None when ``balance`` has as many or
    Newton fails. Measured on the paper wheel at 75 deg: the
    shot from the H = 11 cycle (23.4 um) did not converge; from H = 21 (21.2 um) it did
    (20.0 um)."""
    H, H2 = balance.H, FINER_HARMONICS
    if H >= H2:
        return None
    m = balance.modes
    # the samples per harmonic kept (the default 8 (H + 1) stays 8 (H' + 1))
    samples = max(2 * H2 + 1, math.ceil(balance.nt * (H2 + 1) / (H + 1)))
    fine = WaveBalance(balance.model, balance.params, balance.beta, balance.wave, H2, samples)
    X2 = np.zeros((2 * H2 + 1, m))
    X2[: 2 * H + 1] = X
    j = int(np.argmax(np.hypot(X2[1], X2[2])))  # the phase: Im c_1 of mode j zero
    shift = -math.atan2(X2[2, j], X2[1, j])
    for h in range(1, H2 + 1):  # c_h = a_h + i b_h turned by e^{i h shift}
        c = (X2[2 * h - 1] + 1j * X2[2 * h]) * np.exp(1j * h * shift)
        X2[2 * h - 1], X2[2 * h] = c.real, c.imag
    x_scale = np.full(2 * H2 + 1, max(float(np.abs(X2[1:]).max()), 1e-30))
    x_scale[0] = max(float(np.abs(X2[0]).max()), x_scale[1])
    # a backtracking line search: from the low H's cycle plain Newton steps overshoot (the
    # paper wheel at 75 deg: diverged in 30 iterations; with backtracking 4)
    options = petsc().Options(FINER_PREFIX)
    if not options.hasName("snes_linesearch_type"):
        options.setValue("snes_linesearch_type", "bt")
    corrector = Corrector(fine, x_scale, omega, 2 * m + j, comm, prefix=FINER_PREFIX)
    try:
        z0 = corrector.pack(X2, omega, lam)
        fixed = np.zeros(corrector.n)
        fixed[-1] = 1.0  # lam . z = lam: the intensity held
        point = corrector.solve(z0, fixed, lam, iterations=FINER_ITERATIONS)
    except petsc().Error:  # a failure inside the solve: no retry, as a diverged Newton
        point = None
    finally:
        corrector.destroy()
    # the same cycle, not the trivial X = 0 nor another frequency: within a factor 2 of its
    # vibration and 10 % of its frequency
    vibration = float(np.abs(X[1:]).max())
    if point is None or not 0.5 * vibration <= float(np.abs(point.X[1:]).max()) <= \
            2 * vibration or abs(point.omega / omega - 1.0) > 0.1:
        return None
    return fine, point.X, point.omega


def monodromy_stability(model, cfg, angles, cycle: Cycle, count: int, refine: int,
                        comm=None, whole_wheel: str = "always") -> None:
    """Floquet multipliers of the exact orbit ``cycle.orbit``: the dominant one inside the
    cycle's symmetry at the step and up to ``refine`` halvings of it (``cycle.refined``:
    ``(step [s], |mu|, ND)``; on the pattern wheel, cheap; on the orbit's event schedule when
    its switches were located, :mod:`.events`, the halvings stopping where it settles,
    :func:`_settled`: in uniform steps across the contacts' lift-off kinks they converge at
    first order), and the ``count`` largest of the whole wheel's at the configured step
    (``cycle.multipliers``, and ``cycle.stability`` from them: every ND's by Bloch waves,
    :func:`~.bloch.bloch_multipliers`, when the orbit's pattern is smaller than the wheel,
    else SLEPc's on the monodromy, in uniform steps) unless ``whole_wheel = 'undecided'`` and
    the first already proves the cycle unstable."""
    orbit = cycle.orbit
    if orbit.symmetric_multipliers.size:
        cycle.refined.append((orbit.period / orbit.steps_per_period,
                              float(abs(orbit.symmetric_multipliers[0])),
                              int(orbit.symmetric_nd[0])))
    _refine(model, cfg, angles, cycle, refine, comm)
    proof = _instability_proof(cycle)
    if proof is not None and whole_wheel == "undecided":
        cycle.stability = proof
        return
    # at the configured step, also for an orbit that needed a finer one (there a point within
    # the integration error of the coarser map's orbit): 4x the cost at a quarter step
    steps = max(orbit.steps_per_period, 1)
    coarse = max(1, math.ceil(orbit.period / float(cfg.time.step) * (1 - 1e-12)))
    if orbit.pattern < model.blades:  # every ND's, by Bloch waves over the pattern's copies
        keep = np.arange(orbit.state.size)
        units = vibration_units(orbit.state, orbit.period).ravel()
        mu = bloch_multipliers(model, cfg, orbit, units, keep, angles, cycle.lam,
                               coarse=coarse < steps)
    else:  # the pattern is the wheel: the outermost by SLEPc (2 N m differences otherwise)
        mu = floquet_multipliers(model, cfg, orbit, min(steps, coarse), angles, cycle.lam,
                                 count, comm)
    cycle.multipliers = mu.top(count)  # the verdict from all of them
    rest = mu.nontrivial()
    # the error of the one multiplier known exactly (the phase shift's, 1) measures the
    # finite-difference monodromy's: the verdict holds while the largest is farther from 1
    # than twice that
    # nothing converged says nothing: not trusted (reported uncertain), never "stable"
    trust = max(TRUSTED, 0.5 * abs(mu.largest - 1.0)) if rest.size else -math.inf
    cycle.stability = FloquetResult(
        mu.nd[rest], np.log(np.maximum(np.abs(mu.values[rest]), 1e-300)) / orbit.period,
        mu.largest, mu.trivial_error, mu.stable, by="monodromy: ND", trust=trust)
    if proof is not None:
        cycle.stability = dataclasses.replace(proof, trivial=mu.trivial_error)


def _instability_proof(cycle: Cycle) -> FloquetResult | None:
    """One multiplier above 1 proves instability, whatever the whole wheel's partial spectrum
    at ``time.step`` could say: the in-symmetry one, where it stands above 1 by more than
    twice its change over the last halving of the step (``cycle.refined``'s last two)."""
    finest = cycle.refined[-2:]
    if len(finest) < 2:
        return None
    (_, a, nd), (_, b, _) = finest
    if min(a, b) - 1.0 <= 2 * abs(a - b):
        return None
    return FloquetResult(
        np.array([nd]), np.array([math.log(b) / cycle.orbit.period]), b, math.nan, False,
        by="monodromy inside the cycle's symmetry at the finest step: ND",
        trust=math.inf)


def finer_steps(cfg, orbit: Orbit, refine: int):
    """``cfg`` at each of the ``refine`` halvings of ``time.step`` that is finer than the
    step ``orbit`` was shot at (a halving already, when its shot needed one)."""
    own = orbit.period / orbit.steps_per_period
    for r in range(1, refine + 1):
        step = float(cfg.time.step) / 2**r
        if step < 0.99 * own:
            yield cfg.replace(**{"time.step": step})


def _refine(model, cfg, angles, cycle: Cycle, refine: int, comm=None) -> None:
    """The dominant in-symmetry multiplier at ``refine`` halvings of the step
    (``cycle.refined``), each from the pattern map's Jacobian at the orbit (no Newton solve:
    :meth:`~wheelrom.analysis.periodic.shooting.Shooting.multipliers_at`; on the orbit's
    switches when they were located, :mod:`.events`)."""
    orbit = cycle.orbit
    for finer in finer_steps(cfg, orbit, refine):
        if _settled(cycle.refined, orbit):
            break
        shooting = Shooting(model, finer, orbit.wave, angles, cycle.lam, comm)
        try:
            mu, nd = shooting.multipliers_at(orbit.state, orbit.period, orbit.switches)
            steps = shooting.flow.steps_for(orbit.fraction * orbit.period)[0]
        finally:
            shooting.destroy()
        cycle.refined.append((orbit.period * orbit.fraction / steps, float(abs(mu[0])),
                              int(nd[0])))


def _settled(refined: list, orbit: Orbit) -> bool:
    """Whether the in-symmetry multiplier ``refined`` (``(step, |mu|, ND)`` per level) has
    settled on the orbit's event schedule (:data:`SETTLED_CHANGE`) and stands off 1 by at
    least twice that change (the verdict's own rule, :func:`_elastic_verdict`)."""
    if orbit.switches is None or len(refined) < 2:
        return False
    change = abs(refined[-1][1] - refined[-2][1])
    return change <= SETTLED_CHANGE and abs(refined[-1][1] - 1.0) >= 2 * change


def marched_cycle(model, cfg, angles, branch, q_eq: np.ndarray, blocks, harmonics: int,
                  progress=None, refine: int | None = None, whole_wheel: str = "always",
                  count: int = 10) -> None:
    """The elastic law's exact orbit of ``branch``'s wave at the configured intensity
    (:mod:`.slider_shooting`): its growing mode at ``lam = 1`` (``blocks``: the wave's ND
    blocks ``(B0, B1)``) seeded at half its slip onset on the wave's pattern wheel with the
    sliders at rest at the equilibrium ``q_eq`` ``(N, m)``, marched until its energy settles,
    then shot (``progress(tip_amplitude)`` [m] after every chunk of the march); appended to
    ``branch.cycles`` when Newton converges, said in ``branch.end`` either way; its stability
    inside its own symmetry at ``refine`` halvings of the step and the whole wheel's
    (:func:`elastic_stability`, ``whole_wheel``, ``count``; ``refine`` None: not computed)."""
    lam_c = branch.critical_lam
    branch.hopf_hz = float(wave_mode(blocks[0], blocks[1], lam_c if lam_c > 0 else 1.0)[1].imag
                           / (2 * math.pi))
    _, value, vector = wave_mode(blocks[0], blocks[1], 1.0)
    period = 2 * math.pi / float(value.imag)
    shooting = SliderShooting(model, cfg, branch.wave, angles, 1.0)
    try:
        onset = shooting.slip_onset(q_eq, vector)
        seed = SEED_FRACTION * onset if 0 < onset < math.inf else SEED
        x = shooting.start(q_eq, vector, seed)
        say = None if progress is None else (lambda periods, tip: progress(tip))
        x, period, periods = shooting.march(x, period, progress=say)
        orbit = shooting.solve(x, period, max(shooting.tip_estimate(x, period), 1e-300))
        how = (f"the elastic law: marched {periods} periods on the {shooting.N}-blade pattern "
               f"from the growing mode at {seed * 1e6:.3g} um")
        if not orbit.converged:
            branch.end = f"{how}; the shot from there did not converge ({orbit.reason}, " \
                f"residual {orbit.residual:.2g})"
            return
        cycle = Cycle(**orbit_quantities(shooting, orbit, harmonics, 1.0))
        if refine is None:
            cycle.floquet_skipped = "limit_cycle.floquet = 'off'"
        else:
            try:
                elastic_stability(model, cfg, angles, cycle, shooting, refine, whole_wheel,
                                  count)
            except (ValueError, RuntimeError, petsc().Error) as exc:  # the orbit stands
                cycle.stability, cycle.refined = None, []
                cycle.floquet_skipped = f"its multipliers failed: {type(exc).__name__}: {exc}"
        if cfg.limit_cycle.band:
            try:
                cycle.band = orbit_band(shooting, cycle)
            except (ValueError, RuntimeError, petsc().Error) as exc:  # the orbit stands
                how += f"; its family's band failed ({type(exc).__name__}: {exc})"
        branch.end = f"{how}, then shot ({orbit.iterations} Newton iterations)"
        branch.cycles.append(cycle)
    except (ValueError, RuntimeError, petsc().Error) as exc:  # a step of the flow failed
        branch.end = f"the elastic law's march and shot failed: {type(exc).__name__}: {exc}"
    finally:
        shooting.destroy()


def orbit_band(shooting: SliderShooting, cycle: Cycle):
    """The :func:`~.family.friction_band` of ``cycle``'s exact orbit on ``shooting``'s
    pattern wheel, the ends' largest in-symmetry multiplier but the phase shift's (at the
    orbit's own step)."""

    def largest(orbit) -> float:
        found = shooting.multipliers(orbit, cycle.tip_amplitude)
        values = np.delete(np.abs(found["values"]), found["trivial"])
        return float(values.max()) if values.size else math.nan

    return friction_band(shooting, cycle.orbit, cycle.tip_amplitude, largest)


def elastic_stability(model, cfg, angles, cycle: Cycle, shooting: SliderShooting,
                      refine: int, whole_wheel: str = "always", count: int = 10) -> None:
    """The elastic orbit's multipliers inside its own symmetry (the pattern map's,
    :meth:`~.slider_shooting.SliderShooting.multipliers`: the sliders of contacts stuck all
    period left out, each a multiplier exactly 1) at its own step (``shooting``'s) and at the
    halvings of ``time.step`` up to ``refine`` finer than it, the orbit shot again at each
    (a fixed point of that step's map, so that the phase shift's multiplier measures the
    differences' error), on the orbit's event schedule (:mod:`.events`; uniform steps meet
    the stick-slip kinks anywhere and converge at first order, not monotonically: the paper
    wheel at 70 deg read 1.0101 at a 5.9 us step, 1.0001-1.0005 from 5 us down to 0.16 us),
    the halvings stopping where the largest settled (:func:`_settled`). ``cycle.refined``:
    ``(step [s], |mu|, ND)`` of the largest non-trivial one per step; ``cycle.stability``
    from the finest (:func:`_elastic_verdict`). Then every multiplier of the whole wheel by
    Bloch waves (:func:`~.bloch.bloch_multipliers`) at the two finest steps, and at a further
    halving while their verdict is uncertain and ``refine`` allows one (``cycle.multipliers``:
    the ``count`` largest of the finest), and the verdict from them by the same rule, unless
    the pattern is the whole wheel or ``whole_wheel = 'undecided'`` and the symmetry's
    already proves the orbit unstable."""
    orbit, tip = cycle.orbit, cycle.tip_amplitude
    levels = [_level(shooting, orbit, tip, cfg)]
    orbit.symmetric_multipliers, orbit.symmetric_nd = levels[0]["values"], levels[0]["nd"]
    pending = list(finer_steps(cfg, orbit, refine))
    while pending and not _settled(_refined(levels), orbit):
        level = _finer_level(model, angles, orbit, tip, pending.pop(0))
        if level is None:
            pending = []
            break
        levels.append(level)
    whole = orbit.pattern == model.blades
    cycle.refined = _refined(levels)
    cycle.stability = _elastic_verdict(levels, orbit.period, whole)
    proved = cycle.stability.trusted and not cycle.stability.stable
    if whole or (proved and whole_wheel == "undecided"):
        return
    inside = cycle.stability
    try:
        wheel = [_wheel_level(model, angles, lv) for lv in levels[-2:]]
        verdict = _elastic_verdict(wheel, orbit.period, True, wheel=True)
        while not verdict.trusted and pending:  # a further halving, for the wheel's sake
            level = _finer_level(model, angles, orbit, tip, pending.pop(0))
            if level is None:
                break
            levels.append(level)
            wheel.append(_wheel_level(model, angles, level))
            verdict = _elastic_verdict(wheel[-2:], orbit.period, True, wheel=True)
    except (ValueError, RuntimeError, np.linalg.LinAlgError, petsc().Error) as exc:
        # the symmetry's verdict stands, with why the wheel's is missing
        cycle.stability = dataclasses.replace(inside, by=f"{inside.by}; the whole wheel's "
                                              f"failed ({type(exc).__name__}: {exc}): settle "
                                              "decides")
        return
    cycle.refined = _refined(levels)
    inside = _elastic_verdict(levels, orbit.period, whole)  # with any further halving
    mu = wheel[-1]["multipliers"]
    cycle.multipliers = dataclasses.replace(mu.top(count), wall_s=sum(
        w["multipliers"].wall_s for w in wheel))  # every step's time
    if not proved or verdict.trusted and not verdict.stable:  # the wheel's adds its ND
        if not verdict.trusted and inside.by.startswith("stable inside"):  # say it too
            verdict = dataclasses.replace(verdict, by=f"{verdict.by}; {inside.by}")
        cycle.stability = verdict


def _refined(levels: list[dict]) -> list[tuple]:
    """``cycle.refined``'s rows ``(step [s], |mu|, ND)`` of :func:`_level`'s ``levels``."""
    return [(lv["step"], lv["largest"], lv["worst_nd"]) for lv in levels]


def _finer_level(model, angles, orbit: Orbit, tip: float, step_cfg) -> dict | None:
    """:func:`_level` of ``orbit`` shot again at ``step_cfg``'s step (None: Newton failed),
    on that orbit's own switches, located on its flow at ``orbit``'s step (the sampling's
    resolution; the bisection sets their accuracy)."""
    finer = SliderShooting(model, step_cfg, orbit.wave, angles, 1.0)
    try:
        again = finer.solve(orbit.flat(), orbit.period, tip)
        if not again.converged:
            return None
        if orbit.switches is not None:
            again.switches = orbit_switches(finer.flow, again,
                                            orbit.period / orbit.steps_per_period)
        return _level(finer, again, tip, step_cfg)
    finally:
        finer.destroy()


def _wheel_level(model, angles, level: dict) -> dict:
    """The whole wheel's multipliers by Bloch waves at ``level`` (:func:`_level`'s): its
    step, largest modulus, the phase shift's error, the largest's ND and the multipliers."""
    mu = bloch_multipliers(model, level["cfg"], level["orbit"], level["scale"], level["keep"],
                           angles)
    worst = mu.worst
    return {"step": level["step"], "largest": mu.largest, "error": mu.trivial_error,
            "worst_nd": int(mu.nd[worst]) if worst >= 0 else -1, "multipliers": mu}


def _level(shooting: SliderShooting, orbit: Orbit, tip: float, cfg) -> dict:
    """The pattern map's multipliers at ``orbit``'s step, with the largest non-trivial one's
    modulus (``largest``, 0 when none), its ND and the phase shift's error ``|mu_0 - 1|``;
    the orbit and its configuration (with the multipliers' ``scale`` and ``keep``: the whole
    wheel's are taken from them)."""
    mu = shooting.multipliers(orbit, tip)
    values, trivial = mu["values"], mu["trivial"]
    rest = np.delete(np.arange(values.size), trivial)
    worst = int(rest[np.argmax(np.abs(values[rest]))]) if rest.size else -1
    return {**mu, "step": orbit.period / orbit.steps_per_period,
            "largest": float(abs(values[worst])) if worst >= 0 else 0.0,
            "worst_nd": int(mu["nd"][worst]) if worst >= 0 else -1,
            "error": float(abs(values[trivial] - 1.0)), "orbit": orbit, "cfg": cfg}


def _elastic_verdict(levels: list[dict], period: float, whole: bool,
                     wheel: bool = False) -> FloquetResult:
    """The verdict of the finest level, trusted when the largest non-trivial modulus stands
    off 1 by at least twice its change over the last halving of the step, and the phase
    shift's multiplier is 1 to :data:`~.floquet.TRUSTED` or to half that distance (the whole
    wheel's rule, :func:`monodromy_stability`; the phase shift's error is the larger: the
    phase moves every stick-slip switch against the fixed steps at once, measured 4e-5 to
    1.3e-3 over the paper wheel's halvings where the largest non-trivial one changed by 1e-5
    to 4e-4): above 1, unstable (inside the symmetry proves it for the wheel); at or below
    1, stable when the pattern is the whole wheel (``whole``) or the levels are the whole
    wheel's (``wheel``: every ND, by Bloch waves), else stable inside its symmetry only
    (``Cycle.stable`` None until the whole wheel's decide); untrusted: uncertain, with the
    reason."""
    last = levels[-1]
    largest, error, nd = last["largest"], last["error"], last["worst_nd"]
    change = abs(largest - levels[-2]["largest"]) if len(levels) > 1 else math.inf
    margin = 0.5 * abs(largest - 1.0)
    trusted = change <= margin and error <= max(TRUSTED, margin)
    growth = np.array([math.log(max(largest, 1e-300)) / period])
    at = f"largest {largest:.5g} per period, ND {nd}, at a {last['step'] * 1e6:.2g} us step"
    where = "of the whole wheel by Bloch waves" if wheel else \
        "of the whole wheel (the orbit's pattern)" if whole else "inside the cycle's symmetry"
    if trusted and (largest > 1.0 or whole):
        by = f"monodromy {where} at the finest step (elastic law): ND"
        return FloquetResult(np.array([nd]), growth, largest, error, largest <= 1.0, by=by,
                             trust=math.inf)
    if trusted:  # the whole wheel's decide (elastic_stability)
        by = f"stable inside its own symmetry ({at})"
    else:
        why = f"changing by {change:.1e} over the last halving" if change > margin else \
            f"the phase-shift multiplier off 1 by {error:.1e}"
        where = "for the whole wheel (Bloch waves)" if wheel else "inside its own symmetry"
        by = f"stability uncertain {where} ({at}; {why})"
    return FloquetResult(np.array([nd]), growth, largest, error, largest <= 1.0, by=by,
                         trust=-1.0)
