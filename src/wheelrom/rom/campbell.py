"""Campbell data: segment and wheel (per nodal diameter) frequencies versus rotor speed.

Every speed rebuilds the prestressed segment modes and the reduced wheel
(``segment.prestress`` forced on), so the lines include stress stiffening and spin softening.
"""

from __future__ import annotations

import numpy as np

from wheelrom.config import Config
from wheelrom.rom.build import build_model, quiet


def campbell(cfg: Config, speeds_hz, comm, log=quiet) -> dict:
    """``{"speeds_hz": (S,), "segment_hz": (S, m), "wheel_hz_by_nd": (S, N//2+1, m)}``."""
    say = log
    speeds = np.asarray(speeds_hz, dtype=float)
    seg_hz, wheel_hz = [None] * speeds.size, [None] * speeds.size
    # the fastest first: a speed beyond the linear prestress (rom.build.MAX_PRESTRESS_STRAIN)
    # is refused before any other is computed
    ascending = np.argsort(speeds, kind="stable").tolist()
    for i in ascending[-1:] + ascending[:-1]:
        model = build_model(cfg.replace(**{"wheel.speed_hz": float(speeds[i]),
                                           "segment.prestress": True}), comm)
        seg_hz[i] = model.segment_hz
        wheel_hz[i] = model.frequencies_by_nodal_diameter()
        say(f"{speeds[i]:7.2f} Hz: segment "
            + ", ".join(f"{f:.1f}" for f in model.segment_hz[:4]))
    return {
        "speeds_hz": speeds,
        "segment_hz": np.array(seg_hz),
        "wheel_hz_by_nd": np.array(wheel_hz),
        "stator_vanes": cfg.wheel.stator_vanes,
        "blades": cfg.wheel.blades,
    }
