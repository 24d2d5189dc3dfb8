#!/usr/bin/env python
"""Validation (not a test): the paper wheel's exact forced state under the elastic law at 130 Hz
and its Floquet multipliers against the whole wheel's transient (issue #74; about 15 minutes
on one core, most of it the exact state).

    .venv/bin/python run/validate_forced_multipliers.py [--out results.json]

The state is the one of

    wheelrom forced-response run/paper.toml --set 'contacts.law="elastic"' \\
      --set excitation.force=1.0 --set 'flutter.model="off"' --nonlinear --harmonics 3 \\
      --frequencies 130:130:1 --exact all

computed by the functions that command calls (the balance at H = 3, continued from 128 Hz as
in the issue's band, the shot refined at half the step, the multipliers in every ND). Then:

1. a wave seeded at 1e-8 of the vibration in the ND of the largest multiplier of each Bloch
   family (the even and the odd NDs of the ND-2 wave's 33-blade pattern), its growth per
   period fitted over periods 30..(1e-4 of the vibration), against that family's largest
   ``|mu|``;
2. the issue's check, a seed at 1e-3 of the vibration: its distance from the state over 80
   periods (it starts near the level where the instability saturates);
3. where the wheel goes from the state perturbed in its unstable NDs
   (:func:`~wheelrom.analysis.periodic.forced_perturbed.settle_forced`): bounded or not,
   the largest blade and the spread against the travelling wave, the ND content beside it.
"""

from __future__ import annotations

import argparse
import json
import math
import time

from wheelrom.runtime.environment import bootstrap

bootstrap()

import numpy as np  # noqa: E402

from wheelrom import config  # noqa: E402
from wheelrom.analysis.periodic.forced_perturbed import (  # noqa: E402
    seeded_growth,
    settle_forced,
)
from wheelrom.analysis.periodic.forced_shooting import exact_forced  # noqa: E402
from wheelrom.analysis.periodic.forced_wave import ForcedWave, forced_curve  # noqa: E402
from wheelrom.rom.build import build_model  # noqa: E402
from wheelrom.runtime.environment import petsc  # noqa: E402
from wheelrom.studies.forced_nonlinear import forced_inputs  # noqa: E402

PAPER = "run/paper.toml"
SETS = ['contacts.law="elastic"', "excitation.force=1.0", 'flutter.model="off"']
FREQUENCY_HZ, HARMONICS = 130.0, 3


def families(mu: np.ndarray, nd: np.ndarray) -> dict:
    """``{parity: (|mu|, ND)}``: the largest multiplier but the neutral sliders' (exactly 1)
    among the even and the odd NDs."""
    out = {}
    for parity in (0, 1):
        chosen = np.flatnonzero((mu != 1.0) & (nd % 2 == parity))
        if chosen.size:
            i = chosen[np.argmax(np.abs(mu[chosen]))]
            out[parity] = (float(abs(mu[i])), int(nd[i]))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="", help="write the numbers to this JSON file")
    args = parser.parse_args()
    cfg = config.load(PAPER, SETS)
    model = build_model(cfg, petsc().COMM_SELF)
    params, q = forced_inputs(model, cfg)
    omega = 2 * math.pi * FREQUENCY_HZ
    band = 2 * math.pi * np.array([128.0, 129.0, FREQUENCY_HZ])
    curve = forced_curve(model, params, cfg.wheel.damping_beta, band, q, harmonics=HARMONICS)
    assert curve.converged[-1], "the balance has no solution at 130 Hz"
    problem = ForcedWave(model, params, cfg.wheel.damping_beta, HARMONICS)
    t0 = time.perf_counter()
    orbit = exact_forced(model, cfg, problem, curve.harmonics[-1], omega, whole_wheel=True)
    exact_s = time.perf_counter() - t0
    assert orbit.converged, orbit.reason
    fine = cfg.replace(**{"time.step": cfg.time.step / 2})  # the refined orbit's step
    print(f"exact state at {FREQUENCY_HZ} Hz: tip {orbit.tip_amplitude:.5e} m (balance "
          f"{100 * orbit.relative_difference:+.2f} %), {exact_s:.0f} s; neutral kinds "
          f"{orbit.neutral.tolist()}; largest |mu| {abs(orbit.wheel_multipliers[0]):.5f} "
          f"(ND {orbit.wheel_nodal_diameters[0]}), pattern {orbit.largest:.5f}, at twice the "
          f"step {orbit.coarse_largest:.5f}", flush=True)
    out = {"frequency_hz": FREQUENCY_HZ, "tip_amplitude_m": orbit.tip_amplitude,
           "exact_s": exact_s, "wheel_largest": abs(orbit.wheel_multipliers[0]),
           "wheel_largest_nd": int(orbit.wheel_nodal_diameters[0]), "seeded": []}
    for parity, (mu, nd) in families(orbit.wheel_multipliers,
                                     orbit.wheel_nodal_diameters).items():
        s = seeded_growth(model, fine, problem, orbit, nd, periods=80, size=1e-8, skip=30)
        print(f"{'odd' if parity else 'even'} NDs: largest |mu| {mu:.5f} (ND {nd}); a seeded "
              f"ND {nd} wave grows {s.growth:.5f} a period (periods {s.first}..{s.last}, "
              f"{s.wall_s:.0f} s), its largest ND then {int(np.argmax(s.nd_energy))}",
              flush=True)
        out["seeded"].append({"nd": nd, "multiplier": mu, "growth": s.growth,
                              "first": s.first, "last": s.last})
    nd = int(orbit.wheel_nodal_diameters[0])
    big = seeded_growth(model, fine, problem, orbit, nd, periods=80, size=1e-3, skip=0)
    d = big.deviation
    print(f"a 1e-3 seed in ND {nd}: distance {d[0]:.2e} at the start, {d[20]:.2e}, "
          f"{d[40]:.2e}, {d[80]:.2e} after 20, 40, 80 periods (RMS, in the vibration)",
          flush=True)
    out["large_seed"] = {"nd": nd, "deviation": d[[0, 20, 40, 80]].tolist()}
    settled = settle_forced(model, fine, problem, orbit)
    top = np.argsort(-settled.nd_energy)[:3]
    print(f"where the wheel goes: {'bounded' if settled.bounded else 'not bounded'} after "
          f"{settled.periods} periods ({settled.wall_s:.0f} s): largest blade "
          f"{settled.largest:.5e} m ({100 * (settled.largest / orbit.tip_amplitude - 1):+.3f} "
          f"% of the travelling wave), blades {100 * settled.spread:.3f} % apart, tips at "
          f"most {100 * settled.deviation / orbit.tip_amplitude:.3f} % of the amplitude from "
          f"the state's, the difference in NDs {top.tolist()} "
          f"({', '.join(f'{settled.nd_energy[k]:.0%}' for k in top)})", flush=True)
    out["settled"] = {"bounded": settled.bounded, "periods": settled.periods,
                      "largest_m": settled.largest, "spread": settled.spread,
                      "deviation_m": settled.deviation, "nds": top.tolist(),
                      "wall_s": settled.wall_s}
    if args.out:
        with open(args.out, "w") as f:
            json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
