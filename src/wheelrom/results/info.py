"""What a wheelrom HDF5 file holds (``wheelrom info FILE``): format, configuration source,
model size, and per case the contact angles, status, windows done and wall time.

Works on sweep files and ``run --out`` files (docs/output.md, format ``wheelrom-sweep-1``),
study files (``wheelrom-sweep-2``), stability files, forced-response files
(``wheelrom-forced-1``), limit-cycle and settle files (:mod:`.info_periodic`) and
``modes --out`` model files (``/model`` and the configuration only). Returns plain Python
values (no NaN: a value that is not there is ``None``), ready for JSON.
"""

from __future__ import annotations

import json
import os
import shlex
import tomllib

import numpy as np

from wheelrom.results.checksums import verify
from wheelrom.results.file_checksums import GROUP as FILE_CHECKSUMS
from wheelrom.results.file_checksums import verify_file
from wheelrom.results.histories import case_bytes
from wheelrom.results.info_periodic import limit_cycle_info, settle_info
from wheelrom.results.layout import (
    FORCED_FORMAT,
    FORMAT,
    STABILITY_FORMAT,
    check_readable,
    not_readable,
    read_error,
    statuses,
)
from wheelrom.results.limit_cycles import FORMAT as LIMIT_CYCLE_FORMAT
from wheelrom.results.settle import FORMAT as SETTLE_FORMAT
from wheelrom.results.study_layout import FORMAT as STUDY_FORMAT
from wheelrom.results.study_layout import read_parameters, summary
from wheelrom.runtime.errors import InputError

#: model datasets beyond the sweep's, with what they are (``modes --out``)
MODEL_EXTRAS = {
    "wheel_hz": "all wheel frequencies with their ND",
    "full_wheel_hz": "exact cyclic-symmetry FE frequencies per ND (--full-wheel)",
    "assembled_wheel_hz": "assembled full-wheel FE frequencies (--full-wheel assembled)",
}


def file_info(path: str, verify: bool = False) -> dict:
    """Summary of the wheelrom file at ``path``.

    Returns ``{"file", "kind": "results" | "model", "format", "config_source", "model": {...},
    ...}``; a results file adds its time grid (``time_end_s``, ``window_s``, ``windows``),
    ``counts`` (done/failed/pending/total), ``total_wall_s``, ``bytes_per_case`` (what one
    case preallocates in the file, with ``bytes_per_case_by_dataset``), ``file_bytes``,
    ``cases`` (one dict per case,
    see :func:`case_rows`) and ``hint`` (what to do about pending cases, or None). Raises
    :class:`InputError` naming the file when it is missing or not a wheelrom file.
    ``verify``: adds ``checksums``, the stored checksums recomputed (:func:`_verify`).
    """
    import h5py

    check_readable(path)
    try:
        # no lock: a sweep still running holds the file open for writing; what it has
        # flushed (every finished round) is readable
        f = h5py.File(path, "r", locking=False)
    except OSError as exc:
        what = "not an HDF5 file" if "signature" in str(exc) else "cannot be read as HDF5"
        raise read_error(path, exc, f"{what}, not a wheelrom results or model file") from None
    with f:
        info = _info(f, path)
        if verify:
            info["checksums"] = _verify(f, info)
        return info


def _info(f, path: str) -> dict:
    """:func:`file_info` of the open file ``f`` by its format."""
    fmt = f.attrs.get("format")
    if fmt in (FORMAT, STUDY_FORMAT) and "cases" in f:
        return (_results_info if fmt == FORMAT else _study_info)(f, path)
    if fmt is None and "model" in f and "config" in f.attrs:
        return _model_file_info(f, path)
    if fmt == STABILITY_FORMAT and "stability" in f:
        return _stability_info(f, path)
    if fmt == FORCED_FORMAT and "blade_amplitude" in f:
        return _forced_info(f, path)
    if fmt == LIMIT_CYCLE_FORMAT and "limit_cycle" in f:
        return limit_cycle_info(f, path, _header(f, path, "limit-cycle"))
    if fmt == SETTLE_FORMAT and "settle" in f:
        return settle_info(f, path, _header(f, path, "settle"))
    found = f"format {fmt!r}" if fmt is not None else "no 'format' attribute"
    known = ", ".join(repr(k) for k in (FORMAT, STUDY_FORMAT, STABILITY_FORMAT,
                                        FORCED_FORMAT, LIMIT_CYCLE_FORMAT, SETTLE_FORMAT))
    raise InputError(f"{path}: not a wheelrom results or model file ({found}; "
                     f"expected {known} or a modes --out model)")


def _verify(f, info: dict) -> dict:
    """``info --verify``: the file's checksums recomputed, ``scope`` saying of what. A file
    written in one piece: every dataset and attribute (``"file"``,
    :func:`~wheelrom.results.file_checksums.verify_file`); a sweep, run or study with
    transients: every written case's rows (``"cases"``, :func:`verify_cases`). A settle
    file adds ``inconsistent``: what does not fit its wheel though its checksums agree
    (:func:`~wheelrom.results.settle.layout_problems`)."""
    if info["kind"] == "settle":
        from wheelrom.results.settle import layout_problems

        return {**verify_file(f), "scope": "file", "inconsistent": layout_problems(f)}
    if FILE_CHECKSUMS in f or info["kind"] not in ("results", "study"):
        return {**verify_file(f), "scope": "file"}
    return {**verify_cases(f["cases"], info["cases"]), "scope": "cases"}


#: what the file of each format is, in words for a refusal ("a stability file")
KIND_OF_FORMAT = {FORMAT: "sweep or run results", STUDY_FORMAT: "study",
                  STABILITY_FORMAT: "stability", FORCED_FORMAT: "forced-response",
                  LIMIT_CYCLE_FORMAT: "limit-cycle", SETTLE_FORMAT: "settle"}


def kind_of(path: str) -> tuple[str | None, str]:
    """``(format or None, what it is)`` of the existing file at ``path``, the words following
    "is" in a refusal: ``"a stability file (format 'wheelrom-stability-1')"``, ``"a model
    file (modes --out)"``, ``"an HDF5 file of format 'x'"``, ``"an HDF5 file without a
    wheelrom format"``, ``"a file that is not HDF5"``, ``"a file that cannot be read as HDF5
    (why)"``."""
    import h5py

    try:
        f = h5py.File(path, "r", locking=False)  # a reader only: no job's lock in its way
    except OSError as exc:
        if "signature" in str(exc):
            return None, "a file that is not HDF5"
        if not_readable(exc):
            return None, "a file this user may not read (permission denied)"
        return None, f"a file that cannot be read as HDF5 ({exc})"
    with f:
        return _text(f.attrs.get("format")), file_kind(f)


def file_kind(f) -> str:
    """What the open HDF5 file ``f`` is, in words following "is": ``"a stability file
    (format 'wheelrom-stability-1')"``, ``"a model file (modes --out)"``, ``"an HDF5 file
    without a wheelrom format"``."""
    fmt = _text(f.attrs.get("format"))
    if fmt in KIND_OF_FORMAT:
        return f"a {KIND_OF_FORMAT[fmt]} file (format {fmt!r})"
    if fmt is None and "model" in f and "config" in f.attrs:
        return "a model file (modes --out)"
    return f"an HDF5 file of format {fmt!r}" if fmt else "an HDF5 file without a wheelrom format"


def not_case_file(path: str, f, command: str, formats: tuple[str, ...]) -> InputError:
    """The refusal of ``command`` (``export``, ``animate``, ``contacts``), which reads the
    cases of a file of ``formats``, for the open file ``f`` at ``path``: what the file is
    (a stability, settle or forced-response file is a wheelrom file, just not one of cases
    with transients) and what the command reads."""
    kinds = " or ".join(f"{KIND_OF_FORMAT[fmt]} ({fmt!r})" for fmt in formats)
    return InputError(f"{path} is {file_kind(f)}: {command} reads the cases of a {kinds} "
                      "file")


def verify_cases(cases, rows: list[dict]) -> dict:
    """The stored checksums of the written (done or failed) cases recomputed
    (:mod:`wheelrom.results.checksums`): ``stored``, ``checked``, ``mismatched`` (case
    indices whose numbers changed since they were written)."""
    written = [r["index"] for r in rows if r["status"] in ("done", "failed")]
    return verify(cases, written)


def _text(value) -> str | None:
    """An HDF5 string attribute as ``str`` (h5py gives ``str`` or ``bytes``)."""
    if value is None:
        return None
    return value.decode() if isinstance(value, bytes) else str(value)


def _configured_time(f) -> dict:
    """``time.end`` and ``time.window`` [s] of the configuration stored in the file."""
    try:
        section = tomllib.loads(_text(f.attrs["config"])).get("time", {})
    except (KeyError, tomllib.TOMLDecodeError):
        return {}
    return {k: float(section[k]) for k in ("end", "window") if k in section}


def model_summary(group) -> dict:
    """The reduced model of a ``/model`` group: ``blades``, ``modes``, ``segment_hz``
    (m,) [Hz], ``nodal_diameters`` (rows of ``frequencies_by_nd``), ``preset``,
    ``segment_dofs`` and the extra datasets present (``extras``: name -> meaning)."""
    info = {}
    try:
        info = json.loads(_text(group.attrs.get("info")) or "{}")
    except ValueError:
        pass
    extras = {name: what for name, what in MODEL_EXTRAS.items() if name in group}
    fe_stiffness = [k for k in group.get("contacts", {}) if f"contacts/{k}/stiffness" in group]
    if fe_stiffness:
        extras["contacts/*/stiffness"] = "FE contact stiffness k_c(beta) of " + \
            ", ".join(fe_stiffness)
    segment_hz = group["segment_hz"][()] if "segment_hz" in group else np.zeros(0)
    by_nd = group.get("frequencies_by_nd")
    nodal_diameters = int(by_nd.shape[0]) if by_nd is not None else None
    return {
        "blades": int(group.attrs["blades"]) if "blades" in group.attrs else None,
        "modes": int(group.attrs["modes"]) if "modes" in group.attrs else None,
        "segment_hz": [float(x) for x in segment_hz],
        "nodal_diameters": nodal_diameters,
        "preset": info.get("preset"),
        "segment_dofs": info.get("segment_dofs"),
        "extras": extras,
    }


def _header(f, path: str, kind: str) -> dict:
    """What every kind of file reports first: file, kind, format, config source, model."""
    return {
        "file": path,
        "kind": kind,
        "format": _text(f.attrs.get("format")),
        "config_source": _text(f.attrs.get("config_source")),
        "model": model_summary(f["model"]) if "model" in f else None,
    }


def _model_file_info(f, path: str) -> dict:
    return _header(f, path, "model")


def ts_scheme(options: dict) -> str:
    """Short TS description from a case's options, e.g. ``rk/3bs dt=5e-06``
    (``adapt=basic`` when adaptive, other ``ts_*`` options as ``name=value``)."""
    if not options:
        return "-"
    rest = dict(options)
    scheme = "/".join(str(rest.pop(k)) for k in ("ts_type", "ts_rk_type") if k in rest)
    parts = [scheme] if scheme else []
    if "ts_dt" in rest:
        parts.append(f"dt={rest.pop('ts_dt'):g}" if isinstance(rest["ts_dt"], float)
                     else f"dt={rest.pop('ts_dt')}")
    adapt = rest.pop("ts_adapt_type", "none")
    if adapt != "none":
        parts.append(f"adapt={adapt}")
    parts += [f"{k.removeprefix('ts_')}={v}" for k, v in rest.items()]
    return " ".join(parts)


def _options(raw: bytes) -> dict | str:
    """A case's ``/cases/options`` entry: the JSON dict, or the raw text if it is not JSON
    (the field is cut at 256 bytes)."""
    text = raw.decode(errors="replace").rstrip("\x00")
    if not text:
        return {}
    try:
        return json.loads(text)
    except ValueError:
        return text


def case_rows(cases) -> list[dict]:
    """One dict per case of a ``/cases`` group: ``index``, ``tieboss_deg``, ``shroud_deg``,
    ``status`` (``done``/``failed``/``pending``), ``reason`` (of a failure, else None),
    ``windows_done``, ``steps``, ``batch``, ``wall_s`` [s] (None if not run), ``options``
    and ``scheme`` (:func:`ts_scheme`)."""
    angles = cases["angles_deg"][()]
    wall = cases["wall_s"][()]
    windows, steps = cases["windows_done"][()], cases["steps"][()]
    batch = cases["batch"][()] if "batch" in cases else np.ones_like(steps)
    rows = []
    for i, status in enumerate(statuses(cases.file)):
        state, _, reason = status.partition(": ")
        state = state.strip() or "pending"  # a layout killed before the statuses were set
        options = _options(cases["options"][i])
        rows.append({
            "index": i,
            "tieboss_deg": float(angles[i, 0]),
            "shroud_deg": float(angles[i, 1]),
            "status": state,
            "reason": reason or None,
            "windows_done": int(windows[i]),
            "steps": int(steps[i]),
            "batch": int(batch[i]),
            "wall_s": float(wall[i]) if np.isfinite(wall[i]) else None,
            "options": options,
            "scheme": ts_scheme(options) if isinstance(options, dict) else options,
        })
    return rows


def resume_hint(path: str, source: str | None, counts: dict, command: str = "sweep",
                flags: str = "") -> str | None:
    """What to do about the pending and failed cases of a sweep or study file (None: all
    done): the command that completes it, when the configuration is a plain file (or the
    built-in default). ``counts``: ``pending`` and ``failed`` cases; ``flags``: the options the
    resume must repeat (a study's `` --screen``, `` --forced``). Used by ``info`` and by
    ``sweep``/``study`` when they are interrupted."""
    failed = (f"{counts['failed']} case(s) failed (see their reasons); --resume does not rerun "
              "them") if counts.get("failed") else None
    if not counts["pending"]:
        return failed
    what = (f"{counts['pending']} case(s) pending: rerun the {command} with{flags} --resume"
            + resume_line(path, source, command, flags))
    return what + (f"; {failed}" if failed else "")


def resume_line(path: str, source: str | None, command: str, flags: str = "") -> str:
    """``": wheelrom COMMAND CONFIG --out PATH FLAGS --resume"``, shell-quoted, when the
    configuration is a plain file (or the built-in default); else which configuration to
    repeat (``--set`` overrides are not replayed)."""
    out = shlex.quote(path)  # a line to paste into a shell: spaces and quotes survive
    if source == "<built-in default>":
        return f": wheelrom {command} --out {out}{flags} --resume"
    if source and " + --set " not in source and not source.startswith("<"):
        return f": wheelrom {command} {shlex.quote(source)} --out {out}{flags} --resume"
    return f" and the same configuration ({source or 'the file attribute config'})"


def study_flags(mode: str, forced: bool, nonlinear: bool = False) -> str:
    """The options a study's resume must repeat: its mode, ``--forced`` and
    ``--forced-nonlinear``."""
    return {"screen": " --screen", "stability": " --stability-only"}.get(mode, "") + (
        " --forced" if forced else "") + (" --forced-nonlinear" if nonlinear else "")


def _results_info(f, path: str) -> dict:
    cases = f["cases"]
    rows = case_rows(cases)
    counts = {state: sum(r["status"] == state for r in rows)
              for state in ("done", "failed", "pending")}
    counts["total"] = len(rows)
    window_end = cases["window_end"][()]
    configured = _configured_time(f)
    walls = [r["wall_s"] for r in rows if r["wall_s"] is not None]
    header = _header(f, path, "results")
    per_case = case_bytes(cases)
    return {
        **header,
        "bytes_per_case": sum(per_case.values()),
        "bytes_per_case_by_dataset": per_case,
        "file_bytes": os.path.getsize(path),
        "time_end_s": float(window_end[-1]) if window_end.size else configured.get("end"),
        "window_s": configured.get("window"),
        "windows": int(window_end.size),
        "counts": counts,
        "total_wall_s": float(sum(walls)),
        "cases": rows,
        "hint": resume_hint(path, header["config_source"], counts),
    }


def _stability_info(f, path: str) -> dict:
    """A stability file (``wheelrom stability --out``): per case the angles, the verdict and
    the fastest mode (growth rate [1/s], ND, frequency [Hz]; modes are stored fastest first)."""
    g = f["stability"]
    verdicts = [v.decode() for v in g["verdict"][()]]
    cases = [
        {"index": i, "tieboss_deg": float(a[0]), "shroud_deg": float(a[1]), "verdict": v,
         "max_growth_rate": float(g["growth_rate"][i, 0]),
         "nodal_diameter": int(g["nodal_diameter"][i, 0]),
         "frequency_hz": float(g["frequency_hz"][i, 0])}
        for i, (a, v) in enumerate(zip(g["angles_deg"][()], verdicts, strict=True))
    ]
    return {
        **_header(f, path, "stability"),
        "counts": {"stable": verdicts.count("stable"), "unstable": verdicts.count("unstable"),
                   "total": len(verdicts)},
        "cases": cases,
    }


def _study_info(f, path: str) -> dict:
    """A study file (format 2): the study's parameters and counts, then per case its
    parameter values, linear verdict and fastest growth rate [1/s], why it got a transient
    (``selected_by``) and the transient's status, windows and wall time."""
    params = read_parameters(f)
    g = f["stability"]
    verdicts = [v.decode() for v in g["verdict"][()]]
    growth = g["max_growth_rate"][()]
    chosen = [s.decode() for s in f["cases/selected_by"][()]]
    transient = "max_tip_amplitude" in f["cases"]
    if transient:
        rows = case_rows(f["cases"])
    else:
        rows = [{"index": i, "status": "skipped", "reason": None, "windows_done": 0,
                 "wall_s": None, "scheme": "-"} for i in range(len(verdicts))]
    amplification = f["forced/amplification"][()] if "forced" in f else None
    for i, row in enumerate(rows):
        if amplification is not None:
            row["amplification"] = float(amplification[i]) if np.isfinite(amplification[i]) \
                else None
        verdict, _, why = verdicts[i].partition(": ")
        row.update(parameters=dict(zip(params["names"], params["text"][i], strict=True)),
                   verdict=verdict, stability_failure=why or None,
                   max_growth_rate=float(growth[i]) if np.isfinite(growth[i]) else None,
                   selected_by=chosen[i])
    header = _header(f, path, "study")
    done = summary(f)
    out = {**header, **{k: done[k] for k in ("mode", "parameters", "models", "verdicts")},
           "shape": list(params["shape"]), "counts": {**done["transients"], "total": len(rows)},
           "selected_by": done["selected_by"], "statistics": done["statistics"],
           "cases": rows}
    if transient:
        window_end = f["cases/window_end"][()]
        out.update(time_end_s=float(window_end[-1]), windows=int(window_end.size),
                   window_s=_configured_time(f).get("window"))
    flags = study_flags(out["mode"], bool(f.attrs.get("forced", False)),
                        bool(f.attrs.get("forced_nonlinear", False)))
    out["hint"] = resume_hint(path, header["config_source"], out["counts"], "study", flags)
    return out


def _peak(hz: np.ndarray, amplitude: np.ndarray) -> dict:
    """The largest blade tip amplitude of ``amplitude`` ``(F, N)`` [m]: where (frequency
    [Hz], blade) and how large."""
    i, blade = np.unravel_index(int(np.argmax(amplitude)), amplitude.shape)
    return {"amplitude_m": float(amplitude[i, blade]), "frequency_hz": float(hz[i]),
            "blade": int(blade)}


def _refined_peak(f, which: str) -> dict | None:
    """The refined peak of the configured (``which`` ``""``) or tuned (``"tuned_"``) wheel
    (``peak_amplitude_m``, ``peak_frequency_hz`` and ``peak_blade_amplitude``; None: a file
    written before the peak refinement)."""
    key = f"{which}peak_amplitude_m"
    if key not in f.attrs or f"{which}peak_blade_amplitude" not in f:
        return None
    return {"amplitude_m": float(f.attrs[key]),
            "frequency_hz": float(f.attrs[f"{which}peak_frequency_hz"]),
            "blade": int(np.argmax(f[f"{which}peak_blade_amplitude"][()]))}


def _forced_info(f, path: str) -> dict:
    """A forced-response file (``wheelrom forced-response --out``): the frequency range
    [Hz], engine order and ND, contacts (and their angles [deg]), the mistuning pattern's
    range, the peaks of the configured and the tuned wheel, the amplification factor, the
    size and the KSP settings. Attributes a file of an earlier version lacks are None
    (``modes``: then from the configuration)."""
    hz = f["frequency_hz"][()]
    amplitude, tuned = f["blade_amplitude"][()], f["tuned_blade_amplitude"][()]
    delta = f["mistuning"][()]
    attrs = f.attrs

    def number(key, kind=float):
        return kind(attrs[key]) if key in attrs else None

    wheel = {}
    try:
        wheel = tomllib.loads(_text(attrs["config"])).get("wheel", {})
    except (KeyError, tomllib.TOMLDecodeError):
        pass
    solver = json.loads(_text(attrs["solver"])) if "solver" in attrs else None
    angles = json.loads(_text(attrs["contact_angles_deg"])) if "contact_angles_deg" in attrs \
        else None
    peak, tuned_peak = _refined_peak(f, ""), _refined_peak(f, "tuned_")
    if peak is None:  # a file of an earlier version: the grid's largest values
        peak, tuned_peak = _peak(hz, amplitude), _peak(hz, tuned)
    band = [float(v) for v in attrs["band_hz"]] if "band_hz" in attrs else [float(hz[0]),
                                                                            float(hz[-1])]
    return {
        **_header(f, path, "forced"),
        "wheelrom_version": _text(attrs.get("wheelrom_version")),
        "frequency_hz": {"from": band[0], "to": band[1], "count": int(hz.size)},
        "stator_vanes": number("stator_vanes", int),
        "nodal_diameter": number("nodal_diameter", int),
        "contacts": bool(attrs["contacts"]) if "contacts" in attrs else None,
        "contact_angles_deg": angles,
        "mistuned": bool(np.any(delta)),
        "mistuning": {"min": float(delta.min()), "max": float(delta.max()),
                      "std": float(delta.std())},
        "peak": peak,
        "tuned_peak": tuned_peak,
        "amplification_factor": number("amplification_factor"),
        "blades": int(amplitude.shape[1]),
        "modes": number("modes", int) or wheel.get("modes_per_segment"),
        "frequencies": int(hz.size),
        "file_bytes": os.path.getsize(path),
        "solve_s_per_frequency": number("solve_s_per_frequency"),
        "solver": solver,
        "nonlinear": _nonlinear_info(f["nonlinear"]) if "nonlinear" in f else None,
    }


def _nonlinear_info(g) -> dict:
    """A forced-response file's nonlinear curve (``--nonlinear``): the law, harmonics,
    frequencies solved, the peak on the grid."""
    return {"law": _text(g.attrs["law"]), "harmonics": int(g.attrs["harmonics"]),
            "converged": int(np.sum(g["converged"][()])), "count": int(g["converged"].size),
            "peak_amplitude_m": float(g.attrs["peak_amplitude_m"])
            if "peak_amplitude_m" in g.attrs else None,
            "peak_frequency_hz": float(g.attrs["peak_frequency_hz"])
            if "peak_frequency_hz" in g.attrs else None,
            "exact": _exact_info(g["exact"]) if "exact" in g else None}


def _exact_info(g) -> dict:
    """``/nonlinear/exact`` (``--exact``): the shot's verdict, the exact amplitude, the
    balance's difference and the largest multiplier."""
    out = {"converged": bool(g.attrs["converged"])}
    for key in ("frequency_hz", "tip_amplitude_m", "hb_relative_difference",
                "largest_multiplier"):
        out[key] = float(g.attrs[key]) if key in g.attrs else None
    out["stable"] = bool(g.attrs["stable"]) if "stable" in g.attrs else None
    return out
