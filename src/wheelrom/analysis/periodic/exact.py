"""A harmonic-balance cycle made exact: polished by shooting into the periodic orbit of the
transient's own equations and steps (:mod:`.shooting`), its stability from the whole wheel's
monodromy (:mod:`.monodromy`), with the dominant multiplier inside the cycle's own symmetry
recomputed at finer steps (docs/theory.md, "Limit cycles")."""

from __future__ import annotations

import math

import numpy as np

from wheelrom.analysis.floquet import TRUSTED, FloquetResult
from wheelrom.analysis.periodic.cycle import Cycle
from wheelrom.analysis.periodic.monodromy import floquet_multipliers
from wheelrom.analysis.periodic.report import orbit_quantities
from wheelrom.analysis.periodic.shooting import Orbit, Shooting
from wheelrom.runtime.environment import petsc


def exact_cycle(model, cfg, angles, branch, balance, X: np.ndarray, omega: float,
                cycle: Cycle, harmonics: int, comm=None) -> Cycle:  # fmt: skip
    """The HB cycle ``X`` ``(2H + 1, m)``, ``omega`` [rad/s] (described as ``cycle``) of
    ``branch``'s wave polished into the exact orbit by shooting at ``cycle.lam``; ``cycle``
    itself, its shooting residual set and the failure said in ``branch.end``, when Newton
    does not converge."""
    shooting = Shooting(model, cfg, branch.wave, angles, cycle.lam, comm)
    try:
        q, v = balance.wheel_state(X, omega)
        start = np.stack([q, v])[:, : shooting.N]
        try:
            orbit = shooting.solve(start, 2 * math.pi / omega)
        except (ValueError, RuntimeError, petsc().Error) as exc:  # the flow failed on a step
            orbit = Orbit(branch.wave, math.nan, start, 0, 0.0, math.inf, 0, False,
                          reason=f"{type(exc).__name__}: {exc}")  # fmt: skip
        moving = orbit.converged and np.abs(orbit.state[1]).max() > 1e-3 * np.abs(start[1]).max()
        plausible = moving and abs(math.log(orbit.period * omega / (2 * math.pi))) < math.log(2)
        if not plausible:
            cycle.shooting_residual = orbit.residual
            branch.end += (f"{'; ' if branch.end else ''}shooting did not converge from the "
                           f"{cycle.tip_amplitude * 1e6:.3g} um cycle (residual "
                           f"{orbit.residual:.2g})")  # fmt: skip
            return cycle
        exact = Cycle(**orbit_quantities(shooting, orbit, harmonics, cycle.lam))
    finally:
        shooting.destroy()
    exact.hb_tip_amplitude, exact.hb_frequency_hz = cycle.tip_amplitude, cycle.frequency_hz
    return exact


def monodromy_stability(model, cfg, angles, cycle: Cycle, count: int, refine: int,
                        comm=None) -> None:  # fmt: skip
    """Floquet multipliers of the exact orbit ``cycle.orbit``: the ``count`` largest of the
    whole wheel's monodromy at the configured step (``cycle.multipliers``, and
    ``cycle.stability`` from them), and the dominant one inside the cycle's symmetry at the
    step and ``refine`` halvings of it (``cycle.refined``: ``(step [s], |mu|, ND)``; on the
    pattern wheel, cheap): the scheme steps over the contacts' lift-off kinks, so the
    multipliers of a cycle whose contacts open converge at first order in the step."""
    orbit = cycle.orbit
    steps = orbit.steps_per_period
    mu = floquet_multipliers(model, cfg, orbit, steps, angles, cycle.lam, count, comm)
    cycle.multipliers = mu
    rest = mu.nontrivial()
    # the error of the one multiplier known exactly (the phase shift's, 1) measures the
    # finite-difference monodromy's: the verdict holds while the largest is farther from 1
    # than twice that
    cycle.stability = FloquetResult(
        mu.nd[rest], np.log(np.maximum(np.abs(mu.values[rest]), 1e-300)) / orbit.period,
        mu.largest, mu.trivial_error, mu.stable, by="monodromy: ND",
        trust=max(TRUSTED, 0.5 * abs(mu.largest - 1.0)))  # fmt: skip
    if orbit.symmetric_multipliers.size:
        cycle.refined.append((orbit.period / steps, float(abs(orbit.symmetric_multipliers[0])),
                              int(orbit.symmetric_nd[0])))  # fmt: skip
    state, step = orbit.state, float(cfg.time.step)
    for r in range(1, refine + 1):
        finer = cfg.replace(**{"time.step": step / 2**r})
        shooting = Shooting(model, finer, orbit.wave, angles, cycle.lam, comm)
        try:
            again = shooting.solve(state, orbit.period)
        finally:
            shooting.destroy()
        if not again.converged or not again.symmetric_multipliers.size:
            break
        state = again.state
        cycle.refined.append((again.period / again.steps_per_period,
                              float(abs(again.symmetric_multipliers[0])),
                              int(again.symmetric_nd[0])))  # fmt: skip
