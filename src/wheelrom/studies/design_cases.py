"""The design study's finished curves kept on disk as they finish (``study
--forced-nonlinear``): a nonlinear forced-response curve of the paper wheel under the elastic
law takes minutes, and the study writes its file only once every case's curve is done, so
each case's :class:`~wheelrom.studies.forced_nonlinear.DesignPoint` is saved at once by the
rank that computed it in a folder beside the output (``.name.design/case_<i>.npz`` and
``.json``: plain arrays, no pickles, each renamed into place when complete). ``--resume``
reads the cases found there with the same configuration instead of computing them again; the
folder is removed once the study's file is written. A case's file that cannot be read is
computed again (a warning names it); a full disk keeps the case in memory only.
"""

from __future__ import annotations

import os

import numpy as np

from wheelrom.analysis.periodic.forced_wave import ForcedCurve, RefinedPeak
from wheelrom.config import Config
from wheelrom.runtime.outputs import is_disk_full
from wheelrom.studies.forced_nonlinear import DesignPoint
from wheelrom.studies.kept_cases import DamagedCase, KeptCases, expect_shapes

_CURVE = ("frequency", "harmonics", "tip_amplitude", "converged", "iterations", "fractions",
          "folds", "growth")
_PEAK = ("harmonics", "fractions")


def kept_folder(out: str) -> KeptCases:
    """The folder of the finished curves of the study writing ``out`` (the one guarded
    folder of kept cases, :class:`~wheelrom.studies.kept_cases.KeptCases`)."""
    return KeptCases(out, "design")


def design_dir(out: str) -> str:
    """The path of :func:`kept_folder`."""
    return kept_folder(out).path


def save_point(folder: KeptCases, index: int, cfg: Config, point: DesignPoint) -> bool:
    """Case ``index``'s curve (configuration ``cfg``) as ``case_<index>.npz`` + ``.json``
    (the JSON last: it marks the case complete); False when the disk is full (the case then
    stays in memory only)."""
    c = point.curve
    arrays = {f"curve_{k}": np.asarray(getattr(c, k)) for k in _CURVE}
    arrays["band"] = np.asarray(point.band, dtype=float)
    scalars = {"wave": c.wave, "nodal_diameter": c.nodal_diameter,
               "wall_s": c.wall_s, "kinds": list(c.kinds), "trace": c.trace,
               "point_wall_s": point.wall_s, "refined": None,
               "exact": point.exact}
    if c.refined is not None:
        r = c.refined
        scalars["refined"] = {"frequency": r.frequency, "tip_amplitude": r.tip_amplitude,
                              "solves": r.solves}
        arrays.update({f"peak_{k}": np.asarray(getattr(r, k)) for k in _PEAK})
    try:
        folder.save(index, cfg, scalars, arrays)
    except OSError as exc:
        if is_disk_full(exc):
            return False
        raise
    return True


def load_point(folder: KeptCases, index: int, cfg: Config, warn=None) -> DesignPoint | None:
    """The saved curve of case ``index`` with configuration ``cfg``, else None (none
    saved, another configuration's, or damaged: then ``warn`` names the file and why)."""
    try:
        kept = folder.read(index, cfg)
        if kept is None:
            return None
        scalars, arrays = kept
        try:
            check_shapes(arrays, scalars, cfg.forced.harmonics)
            return _point_of(scalars, arrays)
        except Exception as exc:  # a field missing, of the wrong kind or shape
            raise DamagedCase(os.path.join(folder.path, f"case_{index}.json"), exc) from None
    except DamagedCase as exc:
        if warn is not None:
            warn(f"{exc}; case {index}'s curve is computed again")
        return None


def check_shapes(arrays: dict, scalars: dict, harmonics: int) -> None:
    """Raise ``ValueError`` naming the first array of a kept curve that does not fit a case
    of ``harmonics`` harmonics: ``F`` frequencies, their ``(F, 2H + 1, m)`` harmonics and
    ``(F, K, 3)`` contact shares (``K`` the JSON's kinds), the band's two ends, the refined
    peak's ``(2H + 1, m)`` and ``(K, 3)``."""
    expect_shapes(arrays, {"curve_frequency": (None,), "curve_harmonics": (None, None, None)})
    points, modes = arrays["curve_frequency"].shape[0], arrays["curve_harmonics"].shape[2]
    rows, kinds = 2 * harmonics + 1, len(scalars["kinds"])
    growth = (points,) if arrays.get("curve_growth", np.zeros(0)).size else (0,)
    expect_shapes(arrays, {
        "curve_harmonics": (points, rows, modes), "curve_tip_amplitude": (points,),
        "curve_converged": (points,), "curve_iterations": (points,),
        "curve_fractions": (points, kinds, 3), "curve_folds": (None,), "curve_growth": growth,
        "band": (2,)})
    if scalars["refined"] is not None:
        expect_shapes(arrays, {"peak_harmonics": (rows, modes), "peak_fractions": (kinds, 3)})


def _point_of(scalars: dict, arrays: dict) -> DesignPoint:
    curve = ForcedCurve(*(arrays[f"curve_{k}"] for k in _CURVE[:6]), wave=int(scalars["wave"]),
                        nodal_diameter=int(scalars["nodal_diameter"]),
                        wall_s=float(scalars["wall_s"]), kinds=tuple(scalars["kinds"]),
                        folds=arrays["curve_folds"], trace=str(scalars["trace"]),
                        growth=arrays["curve_growth"])
    r = scalars["refined"]
    if r is not None:
        curve.refined = RefinedPeak(float(r["frequency"]), float(r["tip_amplitude"]),
                                    arrays["peak_harmonics"], arrays["peak_fractions"],
                                    int(r["solves"]))
    exact = scalars.get("exact")
    if exact is not None:  # JSON has no NaN of its own: json writes and reads it as NaN
        exact = {k: (v if k in ("converged", "nodal_diameter", "wheel_nodal_diameter")
                     else float(v))
                 for k, v in exact.items()}
    return DesignPoint(curve, tuple(float(b) for b in arrays["band"]),
                       float(scalars["point_wall_s"]), exact)
