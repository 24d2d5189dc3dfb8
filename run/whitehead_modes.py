"""Whitehead's bound with more than one mode per blade (docs/theory.md "Forced response"):
the worst amplification factor over random realisations of the 12-blade test wheel with all
its segment modes, contacts and Van der Pol off, peaks refined (transient/forced_peak.py).

    .venv/bin/python run/whitehead_modes.py [REALISATIONS]

Prints per strength the largest, mean and 95th-percentile factor against (1 + sqrt(N)) / 2.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import time

import numpy as np

from wheelrom import config
from wheelrom.analysis.forced_peak import peak_response, tuned_reference
from wheelrom.rom.build import build_model, quiet
from wheelrom.runtime.environment import petsc

HERE = os.path.dirname(os.path.abspath(__file__))


def main() -> None:
    count = int(sys.argv[1]) if len(sys.argv) > 1 else 100
    small = os.path.join(HERE, "..", "tests", "data", "small.toml")
    cfg = config.load(small).replace(**{"flutter.mu": 0.0})
    model = build_model(cfg, petsc().COMM_SELF, log=quiet)
    N = model.blades
    bound = (1 + np.sqrt(N)) / 2
    rng = np.random.default_rng(2026)
    t0 = time.perf_counter()
    for std in (0.01, 0.02, 0.05):
        deltas = [std * rng.standard_normal(N) for _ in range(count)]
        tuned = tuned_reference(model, cfg, deltas, contacts=False)
        band_hz = [w / (2 * np.pi) for w in tuned.band]
        factors = np.array([
            peak_response(dataclasses.replace(model, mistuning=d), cfg, band_hz,
                          contacts=False).amplitude / tuned.amplitude
            for d in deltas
        ])
        print(f"N = {N}, m = {model.modes}, std {100 * std:g} %: largest {factors.max():.3f}, "
              f"mean {factors.mean():.3f}, 95 % {np.percentile(factors, 95):.3f}, bound "
              f"{bound:.3f} ({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
