"""``bench``'s nonlinear forced-response figures (issue #45): the nozzle's resonance of the
configured wheel with its contacts (Van der Pol off, the nozzle force ``excitation.force``,
10 N where it is 0), over the automatic band (the excited ND's ``forced.family`` from the
slipping to the stuck resonance, :func:`~wheelrom.studies.forced_nonlinear.nonlinear_band`),
``forced.harmonics`` harmonics, one core:

- ``forced_grid_s``: the curve at ``forced.points`` frequencies (41: ``forced-response
  --nonlinear``'s grid) over the band, ``forced_grid_solved`` of them (issue #69: the small
  wheel's friction plateau at most 30 s, the paper wheel's elastic ND 2 resonance at most
  60 s, every frequency solved);
- ``forced_grid_200_s``: the curve at 200 frequencies over the band by natural continuation
  (issue #45: <= 20 s on the paper wheel), ``forced_grid_200_solved`` of them;
- ``forced_traced_s``: the curve traced by arclength over the band (grid spacing 1/40 of
  the band for the stalls' jumps, no stability), ``forced_traced_points``, its folds
  [Hz] and how the trace ended;
- ``forced_peak_amplitude_m``, ``forced_peak_frequency_hz``: the traced curve's refined
  peak; ``forced_case``: the law, harmonics, band [Hz] and ND;
- with ``forced.exact`` (the default): ``forced_exact_s``, the exact state at that peak by
  shooting with its multipliers in every ND (``forced-response --nonlinear``'s default
  answer; issue #74's goal 20 s on the paper wheel's elastic 1 N peak),
  ``forced_exact_tip_m`` [m] (None: not converged) and ``forced_exact_largest``, the
  largest ``|mu|`` in every ND.
"""

from __future__ import annotations

import math
import time

import numpy as np

from wheelrom.analysis.periodic.forced_branch import traced_curve
from wheelrom.analysis.periodic.forced_wave import forced_curve
from wheelrom.config import Config
from wheelrom.rom.model import ReducedModel
from wheelrom.studies.forced_nonlinear import exact_peak, forced_inputs, nonlinear_band

GRID_POINTS = 200
JUMPS = 40  # the traced curve's jump: this share of the band


def forced_figures(model: ReducedModel, cfg: Config, say) -> dict:
    if not model.tuned:
        return {"forced_traced_s": None}
    cfg = cfg.replace(**{"flutter.model": "off",
                         "excitation.force": cfg.excitation.force or 10.0})
    band, _ = nonlinear_band(model, cfg)
    params, q = forced_inputs(model, cfg)
    H, beta = cfg.forced.harmonics, cfg.wheel.damping_beta
    t0 = time.perf_counter()
    points = forced_curve(model, params, beta, np.linspace(*band, cfg.forced.points or 41), q,
                          harmonics=H)
    points_s = time.perf_counter() - t0
    say(f"  {points.frequency.size} frequencies in {points_s:.1f} s "
        f"({int(points.converged.sum())} solved)")
    t0 = time.perf_counter()
    grid = forced_curve(model, params, beta, np.linspace(*band, GRID_POINTS), q, harmonics=H)
    t1 = time.perf_counter()
    say(f"  {GRID_POINTS} frequencies in {t1 - t0:.1f} s ({int(grid.converged.sum())} solved)")
    traced = traced_curve(model, params, beta, band, q, harmonics=H, refine=True,
                          jump=(band[1] - band[0]) / JUMPS)
    t2 = time.perf_counter()
    peak = traced.refined
    exact = {}
    if cfg.forced.exact and peak is not None:
        say("  the exact state at the peak")
        orbit = exact_peak(model, cfg, peak.harmonics, peak.frequency, H, (params, q),
                           whole_wheel=True)
        exact = {"forced_exact_s": time.perf_counter() - t2,
                 "forced_exact_tip_m": orbit.tip_amplitude if orbit.converged else None,
                 "forced_exact_largest": (float(abs(orbit.wheel_multipliers[0]))
                                          if orbit.wheel_multipliers.size else
                                          orbit.largest if orbit.multipliers.size else None)}
    return exact | {
        "forced_grid_s": points_s,
        "forced_grid_solved": int(points.converged.sum()),
        "forced_grid_200_s": t1 - t0,
        "forced_grid_200_solved": int(grid.converged.sum()),
        "forced_traced_s": t2 - t1,
        "forced_traced_points": int(traced.converged.sum()),
        "forced_traced_folds_hz": (traced.folds / (2 * math.pi)).tolist(),
        "forced_traced_end": traced.trace,
        "forced_peak_amplitude_m": peak.tip_amplitude if peak else None,
        "forced_peak_frequency_hz": peak.frequency / (2 * math.pi) if peak else None,
        "forced_case": {"law": cfg.contacts.law, "harmonics": H,
                        "band_hz": [b / (2 * math.pi) for b in band],
                        "nodal_diameter": traced.nodal_diameter},
    }
