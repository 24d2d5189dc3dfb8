"""``wheelrom info`` of the periodic-solution files: a limit-cycle file (``limit-cycle --out``,
format ``wheelrom-limit-cycle-1``) and a settle file (``settle --out``,
``wheelrom-settle-1``). Plain Python values, ready for JSON (a value that is not there is
``None``); docs/output.md gives the layouts."""

from __future__ import annotations

import math
import os

import numpy as np


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _number(value) -> float | None:
    value = float(value)
    return value if np.isfinite(value) else None


def _cases(g) -> list[dict]:
    """Per case: index, the contact angles [deg], the study values and the verdict."""
    angles = g["angles_deg"][()]
    names = [n.strip() for n in _text(g["parameters"].attrs["names"]).split(",")] \
        if "parameters" in g else []
    values = g["parameters"][()] if names else np.zeros((len(angles), 0))
    return [{"index": i, "tieboss_deg": _number(a[0]), "shroud_deg": _number(a[1]),
             "parameters": {n: _number(v) for n, v in zip(names, values[i], strict=True)},
             "verdict": _text(g["verdict"][i]), "wall_s": _number(g["wall_s"][i])}
            for i, a in enumerate(angles)]


def _cycles(g) -> list[dict]:
    """The cycles at the configured intensity of one wave's ``cycles`` group."""
    n = g["tip_amplitude"].shape[0]

    def column(name, i, kind=_number):
        return kind(g[name][i]) if name in g else None

    rows = []
    for i in range(n):
        stable = int(g["stable"][i])
        modulus = g["multiplier_modulus"][i] if "multiplier_modulus" in g else np.zeros(0)
        modulus = modulus[np.isfinite(modulus)]
        method = column("method", i, _text)
        shot = float(g["shooting_residual"][i]) if "shooting_residual" in g else math.nan
        rows.append({
            "method": method,
            # a harmonic-balance cycle shooting was tried from (its residual set) and missed
            "shot_missed": method == "hb" and not math.isnan(shot),
            "tip_amplitude_m": column("tip_amplitude", i),
            "frequency_hz": column("frequency_hz", i),
            "hb_tip_amplitude_m": column("hb_tip_amplitude", i),
            "hb_frequency_hz": column("hb_frequency_hz", i),
            "shooting_residual": column("shooting_residual", i),
            "stable": None if stable < 0 else bool(stable),
            "largest_multiplier": float(modulus.max()) if modulus.size else None,
            "largest_multiplier_nd": int(g["multiplier_nd"][i][np.argmax(modulus)])
            if modulus.size else None,
        })
        if "band" in g and np.isfinite(g["band"][i, 0]):  # the elastic law's family
            rows[-1]["band"] = {"low_m": _number(g["band"][i, 0]),
                                "high_m": _number(g["band"][i, 1]),
                                "stuck_kinds": _text(g["band_kinds"][i]).split(", ")}
    return rows


def limit_cycle_info(f, path: str, header: dict) -> dict:
    """A limit-cycle file: the method and its settings, then per case the verdict and per
    travelling wave its Hopf point (factor on the self-excitation, frequency [Hz]) and its
    cycles at the configured intensity (tip amplitude [m], frequency [Hz], the harmonic
    balance's values beside the exact orbit's, stability, largest Floquet multiplier)."""
    g = f["limit_cycle"]
    cases = _cases(g)
    for case in cases:
        waves = []
        group = g.get(f"case_{case['index']}", {})
        for name in sorted(group, key=lambda k: (not k.startswith("wave_"), k)):
            if not name.startswith("wave_"):
                continue
            w = group[name]
            waves.append({
                "wave": int(w.attrs["wave"]), "nodal_diameter": int(w.attrs["nodal_diameter"]),
                "direction": int(w.attrs["direction"]),
                "hopf_factor": _number(w.attrs["critical_lam"]),
                "hopf_hz": _number(w.attrs["hopf_hz"]), "verdict": _text(w.attrs["verdict"]),
                "cycles": _cycles(w["cycles"]) if "cycles" in w else [],
            })
        case["waves"] = waves
    settings = {k: (v.item() if hasattr(v, "item") else _text(v)) for k, v in g.attrs.items()}
    return {**header, "settings": settings, "counts": {"total": len(cases)},
            "total_wall_s": float(np.nansum(g["wall_s"][()])),
            "file_bytes": os.path.getsize(path), "cases": cases}


def settle_info(f, path: str, header: dict) -> dict:
    """A settle file: the stationarity settings, then per case the verdict, whether and when
    [s] it settled, the kind of final state, the largest blade tip amplitude [m], the
    start's amplitude [m] (None: not a cycle) and its start in words (``start``: the cycle,
    or the preloaded equilibrium and why)."""
    g = f["settle"]
    cases = _cases(g)
    for case in cases:
        i = case["index"]
        case.update(settled=bool(g["settled"][i]), kind=_text(g["kind"][i]) or None,
                    time_s=_number(g["time"][i]), max_amplitude_m=_number(g["max_amplitude"][i]),
                    start_amplitude_m=_number(g["start_amplitude"][i]),
                    start=_text(g[f"case_{i}"].attrs.get("start", "")) if f"case_{i}" in g
                    else "")
        # (older files lack them; NaN: settled, or too few windows)
        case["bounded"] = bool(g["bounded"][i]) if "bounded" in g else False
        if "trend" in g and np.isfinite(g["trend"][i, 0]):
            case["trend_per_s"] = {"rate": _number(g["trend"][i, 0]),
                                   "error": _number(g["trend"][i, 1])}
            if g["trend"].shape[1] > 2:
                case["trend_per_s"]["correlation"] = _number(g["trend"][i, 2])
        if "band" in g and np.isfinite(g["band"][i, 0]):
            case["band_m"] = {"low": _number(g["band"][i, 0]), "high": _number(g["band"][i, 1]),
                              "over_s": _number(g["band"][i, 2])}
    settled = sum(c["settled"] for c in cases)
    settings = {k: (v.item() if hasattr(v, "item") else _text(v)) for k, v in g.attrs.items()}
    return {**header, "settings": settings,
            "counts": {"settled": settled, "not_settled": len(cases) - settled,
                       "bounded": sum(c["bounded"] for c in cases), "total": len(cases)},
            "total_wall_s": float(np.nansum(g["wall_s"][()])),
            "file_bytes": os.path.getsize(path), "cases": cases}
