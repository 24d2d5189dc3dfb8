"""``settle``'s finished cases kept beside its output while it runs (``.NAME.settle/``,
through the one guarded folder :class:`~wheelrom.studies.kept_cases.KeptCases`): each case's
:class:`~wheelrom.analysis.periodic.settle.Settled` saved at once by the rank that computed
it, read back by ``--resume``, the folder removed once the file holds every case. A disk that
fills keeps a case in memory only (a warning); a kept case that cannot be read, or does not
fit its case, is computed again (a warning names it).
"""

from __future__ import annotations

import dataclasses
import math
import os
import sys

import numpy as np

from wheelrom.analysis.periodic.settle import Classification, Settled, Window
from wheelrom.config import Config
from wheelrom.runtime.outputs import disk_full, is_disk_full
from wheelrom.studies.kept_cases import DamagedCase, KeptCases, expect_shapes

KEPT_IN_MEMORY = "the finished cases are kept in memory and written with the others at the end"


def kept_folder(out: str) -> KeptCases:
    """The folder of ``settle --out out``'s finished cases."""
    return KeptCases(out, "settle")


def save_case(folder: KeptCases, index: int, cfg: Config, result: Settled) -> None:
    """Case ``index`` (configuration ``cfg``) as ``case_<index>.npz`` + ``.json``, each built
    in memory and renamed into place once written whole: a full disk fails in one plain
    write and leaves no part of the case behind (numpy's own writer left its half zip open,
    and retried it at every garbage collection)."""
    c = result.classification
    scalars = {"settled": result.settled, "time": result.time,
               "status": result.status, "start": result.start, "wall_s": result.wall_s,
               "start_amplitude": result.start_amplitude,
               "energy_balance": result.energy_balance,
               "step": result.step, "step_lowered": result.step_lowered,
               "classification": dataclasses.asdict(c) if c else None,
               "changes": [list(w.change) for w in result.windows]}
    arrays = {"window_end": np.array([w.end for w in result.windows]),
              "window_amplitude": np.array([w.amplitude for w in result.windows]),
              "window_nd_energy": np.array([w.nd_energy for w in result.windows]),
              "amplitude": result.amplitude, "nd_energy": result.nd_energy,
              "fractions": result.fractions, "normal_force_range": result.normal_force_range,
              "tip_time": result.tip_time, "tip": result.tip}
    folder.save(index, cfg, scalars, arrays)


def save_or_keep(folder: KeptCases, index: int, cfg: Config, result: Settled,
                 warned: list) -> None:
    """:func:`save_case`; when it cannot be written (a full disk, a path planted meanwhile)
    the case stays in memory only, to reach ``--out`` (or its copy in the temporary
    directory) with the others at the end, and the first such case on this rank says so on
    stderr (any rank's write may fail: not rank 0's log)."""
    try:
        save_case(folder, index, cfg, result)
    except OSError as exc:
        if not warned:
            why = disk_full(os.path.join(folder.path, f"case_{index}.npz"), exc,
                            KEPT_IN_MEMORY) if is_disk_full(exc) else \
                f"{folder.path}: case {index} not saved ({exc.strerror or exc}); " \
                f"{KEPT_IN_MEMORY}"
            print(f"wheelrom: warning: {why}", file=sys.stderr, flush=True)
        warned.append(index)


def load_case(folder: KeptCases, index: int, cfg: Config, warn=None) -> Settled | None:
    """A saved case of the configuration ``cfg``, else None: none saved, another
    configuration's, or damaged (truncated by a full disk or a kill, garbled): then ``warn``
    is told in one line which file and why, and the case is computed again."""
    try:
        kept = folder.read(index, cfg)
        if kept is None:
            return None
        scalars, arrays = kept
        try:  # its windows and classification read back, once they fit this case
            check_shapes(arrays, cfg.wheel.blades)
            rows = zip(arrays["window_end"], arrays["window_amplitude"],
                       arrays["window_nd_energy"], scalars["changes"], strict=True)
            windows = [Window(float(e), a, n, tuple(ch)) for e, a, n, ch in rows]
            c = scalars["classification"]
            out = Settled(scalars["settled"], scalars["time"], windows,
                          Classification(**c) if c else None, arrays["amplitude"],
                          arrays["nd_energy"], arrays["fractions"],
                          arrays["normal_force_range"], scalars["energy_balance"],
                          arrays["tip_time"], arrays["tip"], scalars["start"],
                          scalars["start_amplitude"], scalars["wall_s"],
                          scalars["status"])
            # (a case kept before the step was recorded reads NaN: not known)
            out.step = float(scalars.get("step", math.nan))
            out.step_lowered = str(scalars.get("step_lowered", ""))
            return out
        except Exception as exc:
            raise DamagedCase(os.path.join(folder.path, f"case_{index}.json"), exc) from None
    except DamagedCase as exc:
        if warn is not None:
            warn(f"{exc}; case {index} is computed again")
        return None


def check_shapes(arrays: dict, blades: int) -> None:
    """Raise ``ValueError`` naming the first array of a kept case that does not fit a case of
    a wheel of ``blades`` blades: ``W`` windows of ``(blades,)`` amplitudes and ``(blades //
    2 + 1,)`` ND shares, and once described (a case that ran to its end) the last window's
    amplitude, ND shares, ``(K, 3)`` contact shares and ``(K, 2)`` normal-force range, ``T``
    tip samples ``(T, blades, 3)``; an undescribed case's arrays are empty."""
    expect_shapes(arrays, {"window_end": (None,), "amplitude": (None,), "fractions": (None, 3),
                           "tip_time": (None,)})
    windows, described = arrays["window_end"].shape[0], arrays["amplitude"].size > 0
    shares = blades // 2 + 1
    kinds, samples = arrays["fractions"].shape[0], arrays["tip_time"].shape[0]
    expect_shapes(arrays, {
        "window_amplitude": (windows, blades) if windows else (0,),
        "window_nd_energy": (windows, shares) if windows else (0,),
        "amplitude": (blades,) if described else (0,),
        "nd_energy": (shares,) if described else (0,),
        "normal_force_range": (kinds, 2),
        "tip": (samples, blades, 3) if described else (0, 0, 3)})
