"""``bench``'s limit-cycle figures (issue #30): at the configured sweep's fastest-growing case,
one limit cycle of its fastest wave (equilibrium, Hopf point and Newton at the configured
intensity from the linear mode), the whole default branch analysis of that wave, and the
Floquet analysis of every Bloch family at the cycle.

- ``limit_cycle_s_per_case``: one cycle, including the preloaded equilibrium [s];
- ``limit_cycle_branch_s``: ``wheelrom limit-cycle --nd fastest`` of that case without
  Floquet (the branch from the Hopf point and from the seeds) [s];
- ``limit_cycle_floquet_s``: every Bloch family at the cycle [s];
- ``limit_cycle_case``: the shroud angle, wave, harmonics, samples, tip amplitude and
  Newton iterations of that cycle;
- ``shooting_s``: the exact orbit by shooting from that cycle (issue #38: <= 20 s on the
  paper wheel), ``shooting``: its Newton iterations, residual, HB-vs-orbit amplitude and
  frequency difference;
- ``monodromy_s``: the ``limit_cycle.multipliers`` largest Floquet multipliers of the whole
  wheel's monodromy (SLEPc; issue #38: 10 in <= 15 s), ``monodromy``: their count converged,
  linearised periods, the largest and its ND; ``bloch_s``: every ND's by Bloch waves, the
  default for an orbit whose pattern is smaller than the wheel (``bloch``: their count, the
  wheel's shots, the largest and its ND);
- under the elastic law instead: ``elastic_orbit_s``, the exact orbit of the fastest wave
  marched and shot with the sliders in the state, equilibrium included (issue #44: <= 20 s
  on one core), ``elastic_orbit``: its wave, pattern, Newton iterations, residual, tip
  amplitude and frequency; ``elastic_multipliers_s``: its multipliers inside its symmetry
  at ``limit_cycle.refine`` halvings of the step, the orbit shot again at each,
  ``elastic_multipliers``: the steps, the largest non-trivial modulus at each, the verdict;
  ``elastic_wheel_multipliers_s``: the whole wheel's, every ND by Bloch waves at the two
  finest steps (``wheel_largest``, ``wheel_nd``).
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from wheelrom.analysis.periodic.bloch import bloch_multipliers
from wheelrom.analysis.periodic.cycle import describe
from wheelrom.analysis.periodic.exact import elastic_stability
from wheelrom.analysis.periodic.floquet import floquet
from wheelrom.analysis.periodic.harmonic_balance import WaveBalance
from wheelrom.analysis.periodic.hopf import hopf_point, wave_blocks, wave_mode
from wheelrom.analysis.periodic.limit_cycle import (
    FASTEST,
    case_limit_cycles,
    periodic_solution,
    settings_of,
)
from wheelrom.analysis.periodic.shooting import vibration_units
from wheelrom.analysis.periodic.slider_shooting import SliderShooting
from wheelrom.analysis.stability import linearise
from wheelrom.config import Config
from wheelrom.results.layout import angles_of, case_angles
from wheelrom.rom.model import ReducedModel

SEED = 1e-5  # [m] tip amplitude of the first Newton start (then limit_cycle.seeds outwards)


def limit_cycle_figures(model: ReducedModel, cfg: Config, say) -> dict:
    if not model.tuned or cfg.flutter.model == "off":
        return {"limit_cycle_s_per_case": None}
    angles = case_angles(cfg)
    growth = []
    for row in angles:
        params, q, _, J, _ = linearise(model, cfg, angles_of(row))
        B0, B1 = wave_blocks(model, params, q, J)
        growth.append(max(wave_mode(B0[k], B1[k], 1.0)[0] for k in range(model.blades)))
    if max(growth) <= 0:
        return {"limit_cycle_s_per_case": None}
    case = angles_of(angles[int(np.argmax(growth))])
    settings = settings_of(cfg)
    if cfg.contacts.elastic:  # no balance branch: the marched and shot orbit
        return _elastic_orbit(model, cfg, case, settings, say)
    t0 = time.perf_counter()
    point, balance, wave = _one_cycle(model, cfg, case, settings)
    one = time.perf_counter() - t0
    if point is None:
        return {"limit_cycle_s_per_case": None}
    t0 = time.perf_counter()
    floquet(balance, point.linearisation, point.omega, 1.0, range(model.blades))
    floquet_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    quiet = dataclasses.replace(settings, waves=(FASTEST,), floquet="off")
    case_limit_cycles(model, cfg, quiet, case)
    branch_s = time.perf_counter() - t0
    c1 = point.X[1] + 1j * point.X[2]
    tip = float(np.linalg.norm(np.abs(model.tip @ c1)))
    hb_tip = describe(balance, balance, point.X, point.omega, 1.0, 0.0).tip_amplitude  # 0-peak
    exact = _exact(model, cfg, case, wave, balance, point, settings, hb_tip, say)
    say(f"limit cycle: shroud {case.get('shroud', math.nan):g} deg, wave {wave}: one cycle "
        f"{one:.2f} s ({point.iterations} Newton iterations, {tip * 1e6:.3g} um), branch "
        f"{branch_s:.1f} s, Floquet {floquet_s:.1f} s")
    return {
        "limit_cycle_s_per_case": one,
        "limit_cycle_branch_s": branch_s,
        "limit_cycle_floquet_s": floquet_s,
        "limit_cycle_case": {"angles_deg": case, "wave": wave, "harmonics": settings.harmonics,
                             "samples": settings.time_samples, "tip_amplitude_m": tip,
                             "newton_iterations": point.iterations},
        **exact,
    }


def _exact(model, cfg, case, wave, balance, point, settings, hb_tip, say) -> dict:
    """The shooting from the HB cycle and the monodromy's multipliers, timed."""
    from wheelrom.analysis.periodic.monodromy import floquet_multipliers
    from wheelrom.analysis.periodic.report import orbit_quantities
    from wheelrom.analysis.periodic.shooting import Shooting

    t0 = time.perf_counter()
    shooting = Shooting(model, cfg, wave, case)
    try:
        q, v = balance.wheel_state(point.X, point.omega)
        orbit = shooting.solve(np.stack([q, v])[:, : shooting.N], 2 * math.pi / point.omega)
        shooting_s = time.perf_counter() - t0
        if not orbit.converged:
            return {"shooting_s": shooting_s, "shooting": {"converged": False}}
        exact = orbit_quantities(shooting, orbit, settings.harmonics, 1.0)
    finally:
        shooting.destroy()
    hb_hz = point.omega / (2 * math.pi)
    t0 = time.perf_counter()
    mu = floquet_multipliers(model, cfg, orbit, orbit.steps_per_period, case, 1.0,
                             settings.multipliers)
    monodromy_s = time.perf_counter() - t0
    say(f"exact orbit: shooting {shooting_s:.2f} s ({orbit.iterations} iterations, residual "
        f"{orbit.residual:.1e}), {exact['tip_amplitude'] * 1e6:.4g} um, "
        f"{exact['frequency_hz']:.5g} Hz; {len(mu.values)} multipliers in {monodromy_s:.1f} s "
        f"({mu.matvecs} linearised periods), largest {mu.largest:.4g}")
    units = vibration_units(orbit.state, orbit.period).ravel()
    bloch = bloch_multipliers(model, cfg, orbit, units, np.arange(orbit.state.size), case) \
        if orbit.pattern < model.blades else None
    if bloch is not None:
        say(f"every ND's by Bloch waves (the default for this orbit): {bloch.wall_s:.1f} s "
            f"({bloch.matvecs} shots of the wheel), largest {bloch.largest:.4g} "
            f"(ND {bloch.nd[bloch.worst]})")
    return {
        "shooting_s": shooting_s,
        "shooting": {"converged": True, "iterations": orbit.iterations,
                     "residual": orbit.residual, "tip_amplitude_m": exact["tip_amplitude"],
                     "frequency_hz": exact["frequency_hz"],
                     "hb_amplitude_difference": hb_tip / exact["tip_amplitude"] - 1,
                     "hb_frequency_difference": hb_hz / exact["frequency_hz"] - 1},
        "monodromy_s": monodromy_s,
        "monodromy": {"requested": settings.multipliers, "converged": int(len(mu.values)),
                      "linearised_periods": mu.matvecs, "largest": mu.largest,
                      "largest_nd": int(mu.nd[mu.worst]) if mu.worst >= 0 else None},
        "bloch_s": bloch.wall_s if bloch is not None else None,
        "bloch": None if bloch is None else {"multipliers": int(bloch.values.size),
                                             "shots": bloch.matvecs,
                                             "largest": bloch.largest,
                                             "largest_nd": int(bloch.nd[bloch.worst])},
    }


def _elastic_orbit(model, cfg, case, settings, say) -> dict:
    """The elastic law's exact orbit of the fastest wave (``wheelrom limit-cycle --nd
    fastest`` of that case: the march and the shot), timed (issue #44: <= 20 s), then its
    multipliers inside its symmetry at ``limit_cycle.refine`` halvings of the step, timed
    apart (``elastic_multipliers_s``)."""
    t0 = time.perf_counter()
    orbit_only = dataclasses.replace(settings, waves=(FASTEST,), floquet="off")
    res = case_limit_cycles(model, cfg, orbit_only, case)
    wall = time.perf_counter() - t0
    cycles = [c for b in res.branches for c in b.cycles]
    if not cycles:
        return {"limit_cycle_s_per_case": None, "elastic_orbit_s": wall,
                "elastic_orbit": {"converged": False}}
    c, branch = cycles[0], res.branches[0]
    say(f"elastic exact orbit: shroud {case.get('shroud', math.nan):g} deg, wave "
        f"{branch.wave}: {wall:.2f} s ({c.orbit.iterations} Newton iterations, residual "
        f"{c.orbit.residual:.1e}), {c.tip_amplitude * 1e6:.4g} um, {c.frequency_hz:.5g} Hz")
    t0 = time.perf_counter()
    shooting = SliderShooting(model, cfg, branch.wave, case, 1.0)
    try:
        elastic_stability(model, cfg, case, c, shooting, settings.refine)
    finally:
        shooting.destroy()
    mu = c.multipliers  # the whole wheel's, every ND by Bloch waves (None: not computed)
    whole = mu.wall_s if mu is not None else 0.0
    stability = time.perf_counter() - t0 - whole
    say(f"its multipliers inside its symmetry at {len(c.refined)} steps: {stability:.2f} s, "
        f"largest {c.refined[-1][1]:.5g} at {c.refined[-1][0] * 1e6:.2g} us")
    if mu is not None:
        say(f"the whole wheel's, every ND by Bloch waves at the two finest steps: {whole:.2f} "
            f"s, largest {mu.largest:.5g} (ND {mu.nd[mu.worst]}) at {mu.step * 1e6:.2g} us "
            f"({c.stability.by if c.stable is None else 'stable' if c.stable else 'unstable'})")
    return {"limit_cycle_s_per_case": None, "elastic_orbit_s": wall,
            "elastic_multipliers_s": stability,
            "elastic_wheel_multipliers_s": whole if mu is not None else None,
            "elastic_multipliers": {"steps_s": [r[0] for r in c.refined],
                                    "largest": [r[1] for r in c.refined],
                                    "stable": c.stable,
                                    "stable_inside_symmetry": bool(c.refined[-1][1] <= 1.0),
                                    "wheel_largest": mu.largest if mu is not None else None,
                                    "wheel_nd": int(mu.nd[mu.worst]) if mu is not None
                                    else None},
            "elastic_orbit": {"converged": True, "angles_deg": case, "wave": branch.wave,
                              "pattern_blades": c.orbit.pattern,
                              "iterations": c.orbit.iterations,
                              "residual": c.orbit.residual,
                              "tip_amplitude_m": c.tip_amplitude,
                              "frequency_hz": c.frequency_hz}}


def _one_cycle(model, cfg, case, settings):
    """The equilibrium, the fastest wave's Hopf point and its cycle at the configured intensity
    by Newton from the linear mode at the seeds nearest :data:`SEED` first (what one limit
    cycle costs, failed starts included)."""
    params, q, _, J, _ = linearise(model, cfg, case)
    params = dataclasses.replace(params, nozzle_force=0.0)
    B0, B1 = wave_blocks(model, params, q, J)
    wave = int(np.argmax([wave_mode(B0[k], B1[k], 1.0)[0] for k in range(model.blades)]))
    lam_c = hopf_point(B0[wave], B1[wave], settings.branch.lam_max)
    _, value, vector = wave_mode(B0[wave], B1[wave], lam_c if lam_c > 0 else 1.0)
    v = vector[: model.modes]
    v = v / np.linalg.norm(v @ model.tip.T)
    balance = WaveBalance(model, params, cfg.wheel.damping_beta, wave, settings.harmonics,
                          settings.time_samples)
    X = np.zeros((2 * settings.harmonics + 1, model.modes))
    X[0] = q[0]
    for seed in sorted(settings.seeds, key=lambda a: abs(math.log(a / SEED))):
        X[1], X[2] = seed * v.real, seed * v.imag
        point = periodic_solution(balance, X, float(value.imag), 1.0)
        if point is not None and np.abs(point.X[1:3]).max() > 1e-3 * np.abs(X[1:3]).max():
            return point, balance, wave  # converged, and not onto the trivial solution
    return None, balance, wave
