"""The results file of a design study, format ``wheelrom-sweep-2`` (docs/output.md): the
layout of format 1 (``/model``, ``/cases``, one row per case) plus the study's parameters
per case, the model each case used (``/models/<g>``), why a case got a transient
(``/cases/selected_by``) and the linear stability of every case (``/stability``), side by
side with the transient results of the same index.

Creation is collective on an ``mpio`` file (every rank passes the same data) or serial.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np

from wheelrom import config as config_mod
from wheelrom.analysis.periodic.forced_shooting import UNIT
from wheelrom.config import CONTACT_KINDS, Config
from wheelrom.config.study import Study
from wheelrom.results import layout as results
from wheelrom.results.file_checksums import write_file_checksums

FORMAT = "wheelrom-sweep-2"
MODES = ("full", "screen", "stability")
TEXT_LEN = 64


def case_angles(study: Study) -> np.ndarray:
    """``(C, 2)`` the tie-boss and shroud angle [deg] of every case."""
    return np.array([[c.contacts.tieboss.angle_deg, c.contacts.shroud.angle_deg]
                     for c in study.configs], dtype=float).reshape(-1, 2)


def create(f, cfg: Config, study: Study, models: list, model_of: list[int], stability: dict,
           selected_by: list[str], mode: str, mistuning: np.ndarray | None = None,
           forced: dict | None = None, forced_nonlinear: dict | None = None) -> None:
    """The whole file but the transient results: every selected case ``pending``, the
    others ``skipped``. ``stability``: :func:`stability_arrays`; ``models``: one reduced
    model per group (tuned), ``model_of`` ``(C,)`` the group of every case; ``mistuning``
    ``(C, N)`` every case's ``delta_s``; ``forced``: the ``/forced`` datasets
    (:func:`wheelrom.studies.mistuning.forced_arrays`) or None; ``forced_nonlinear``: the
    ``/forced_nonlinear`` datasets (the nonlinear forced response per case,
    :func:`wheelrom.studies.forced_nonlinear.design_arrays`) or None."""
    angles = case_angles(study)
    C = angles.shape[0]
    if mode == "stability":  # no transient datasets at all
        f.attrs["config"] = config_mod.to_toml(cfg)
        f.attrs["config_source"] = cfg.source
        cases = f.create_group("cases")
        cases.create_dataset("angles_deg", data=angles)
        cases.create_dataset("status", (C,), dtype=f"S{results.STATUS_LEN}")
        results.write_model(f.create_group("model"), models[0])
    else:
        results.create_layout(f, cfg, models[0], angles,
                              modes=max(m.modes for m in models))
        cases = f["cases"]
    f.attrs["format"] = FORMAT
    f.attrs["study_mode"] = mode
    cases["angles_deg"].attrs["columns"] = "tieboss, shroud"
    status = [b"pending" if s != "none" else b"skipped" for s in selected_by]
    cases["status"][...] = np.array(status, dtype=f"S{results.STATUS_LEN}")
    cases.create_dataset("selected_by", data=np.array([s.encode() for s in selected_by],
                                                      dtype="S16"))
    cases.create_dataset("model", data=np.array(model_of, dtype="i8"))
    write_parameters(cases.create_group("parameters"), study)
    for g, model in enumerate(models):
        results.write_model(f.create_group(f"models/{g}"), model)
    group = f.create_group("stability")
    group.attrs["kinds"] = ", ".join(CONTACT_KINDS)
    group.create_dataset("angles_deg", data=angles)
    for name, data in stability.items():
        group.create_dataset(name, data=data)
    if mistuning is not None:
        cases.create_dataset("mistuning", data=mistuning)
    f.attrs["forced"] = forced is not None
    if forced is not None:
        group = f.create_group("forced")
        group.attrs["whitehead_bound"] = whitehead_bound(models[0].blades)
        for name, data in forced.items():
            group.create_dataset(name, data=data)
    f.attrs["forced_nonlinear"] = forced_nonlinear is not None
    if forced_nonlinear is not None:
        group = f.create_group("forced_nonlinear")
        group.attrs["harmonics"] = cfg.forced.harmonics
        laws = {c.contacts.law for c in study.configs} or {cfg.contacts.law}
        group.attrs["law"] = laws.pop() if len(laws) == 1 else "per case"
        for name, data in forced_nonlinear.items():
            group.create_dataset(name, data=data)
    if mode == "stability":  # complete: nothing is written into it later
        write_file_checksums(f, {"cases": C, "stability": C, "forced": C,
                                 "forced_nonlinear": C})


def write_parameters(g, study: Study) -> None:
    """``names`` (P,), ``values`` (C, P) (numbers; true/false as 1/0; NaN for a named
    choice), ``text`` (C, P) the values as written, ``axis`` (P,) and attribute ``shape``."""
    def number(v):
        return float(v) if isinstance(v, int | float) else math.nan

    g.create_dataset("names", data=np.array([n.encode() for n in study.names]))
    g.create_dataset("axis", data=np.array(study.axis, dtype="i8"))
    values = np.array([[number(v) for v in row] for row in study.values], dtype=float)
    g.create_dataset("values", data=values.reshape(study.size, len(study.names)))
    text = [[str(v).lower() if isinstance(v, bool) else f"{v!r}" if isinstance(v, float)
             else str(v) for v in row] for row in study.values]
    g.create_dataset("text", data=np.array(text, dtype=f"S{TEXT_LEN}").reshape(values.shape))
    g.attrs["shape"] = np.array(study.shape, dtype="i8")
    g.attrs["legacy_sweep"] = study.legacy


def read_parameters(f) -> dict | None:
    """``{"names", "values", "text", "axis", "shape"}`` of a format-2 file (None: format 1:
    the angle pair is the only parameter)."""
    if "cases/parameters" not in f:
        return None
    g = f["cases/parameters"]
    return {
        "names": [n.decode() for n in g["names"][()]],
        "values": g["values"][()],
        "text": [[t.decode() for t in row] for row in g["text"][()]],
        "axis": [int(a) for a in g["axis"][()]],
        "shape": tuple(int(n) for n in g.attrs["shape"]),
    }


def stability_arrays(cases: list) -> dict[str, np.ndarray]:
    """``/stability`` datasets from one :class:`~wheelrom.analysis.stability.StabilityResult`
    per case, or a ``str`` (why its analysis failed). Modes fastest first; arrays padded to
    the largest model (NaN, ND -1) and to both contact kinds (NaN for a kind not present)."""
    ok = [r for r in cases if not isinstance(r, str)]
    C, K = len(cases), len(CONTACT_KINDS)
    E = max((r.eigenvalue.size for r in ok), default=0)
    N, m = max(((r.equilibrium.shape) for r in ok), default=(0, 0))
    nan = np.nan
    out = {name: np.full(shape, nan) for name, shape in (
        ("growth_rate", (C, E)), ("frequency_hz", (C, E)), ("damping_ratio", (C, E)),
        ("tip_amplitude", (C, E)), ("contact_normal", (C, E, K)),
        ("contact_tangential", (C, E, K)), ("modal_share", (C, E, m)),
        ("normal_force", (C, K, N)), ("margin", (C, K, N)), ("equilibrium", (C, N, m)),
        ("max_growth_rate", (C,)), ("residual", (C,)), ("wall_s", (C,)))}
    out["nodal_diameter"] = np.full((C, E), -1, dtype="i8")
    out["cyclic"] = np.zeros(C, dtype=bool)
    verdict = []
    for c, r in enumerate(cases):
        if isinstance(r, str):
            verdict.append(f"failed: {r}"[: results.STATUS_LEN])
            continue
        verdict.append(r.verdict())
        _fill_case(out, c, r)
    out["verdict"] = np.array([v.encode() for v in verdict], dtype=f"S{results.STATUS_LEN}")
    return out


def _fill_case(out: dict, c: int, r) -> None:
    order = np.argsort(-r.growth_rate, kind="stable")
    e = order.size
    n, mm = r.equilibrium.shape
    for name in ("nodal_diameter", "growth_rate", "frequency_hz", "damping_ratio",
                 "tip_amplitude"):
        out[name][c, :e] = getattr(r, name)[order]
    out["modal_share"][c, :e, :mm] = r.modal_share[order]
    out["equilibrium"][c, :n, :mm] = r.equilibrium
    for k, kind in enumerate(r.kinds):
        j = CONTACT_KINDS.index(kind)
        out["contact_normal"][c, :e, j] = r.contact_normal[order, k]
        out["contact_tangential"][c, :e, j] = r.contact_tangential[order, k]
        out["normal_force"][c, j, :n] = r.normal_force[k]
        out["margin"][c, j, :n] = r.margin[k]
    out["max_growth_rate"][c] = r.growth_rate.max()
    out["residual"][c] = r.residual
    out["wall_s"][c] = r.wall_s
    out["cyclic"][c] = r.cyclic


def resume_problem(path: str, cfg: Config, mode: str, forced: bool = False,
                   nonlinear: bool = False) -> str | None:
    """Why the study file at ``path`` cannot be completed for ``cfg``, ``mode``, ``forced``
    (``--forced``) and ``nonlinear`` (``--forced-nonlinear``)."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            if f.attrs.get("format") != FORMAT:
                return f"{path} is not a wheelrom study file (format {FORMAT!r})"
            changed = results.config_changes(f.attrs.get("config"), cfg)
            if changed:
                return (f"{path} was written for a different configuration ({changed}); use "
                        "--force to start again")
            if f.attrs.get("study_mode") != mode:
                return (f"{path} was written by a {f.attrs.get('study_mode')!r} study, this is "
                        f"{mode!r}; use --force to start again")
            if bool(f.attrs.get("forced", False)) != forced:
                was = "with" if f.attrs.get("forced", False) else "without"
                return (f"{path} was written {was} --forced; use --force to start again, or "
                        f"resume {was} it")
            if bool(f.attrs.get("forced_nonlinear", False)) != nonlinear:
                was = "with" if f.attrs.get("forced_nonlinear", False) else "without"
                return (f"{path} was written {was} --forced-nonlinear; use --force to start "
                        f"again, or resume {was} it")
    except OSError as exc:
        return f"{path} cannot be opened for --resume ({exc}); use --force to start again"
    return None


def summary(f) -> dict:
    """What the study holds, for people and ``--json``: counts of verdicts, of transient
    statuses and of the reasons cases were selected."""
    verdicts = [v.decode().partition(":")[0] for v in f["stability/verdict"][()]]
    status = [s.partition(":")[0] for s in results.statuses(f)]
    chosen = [s.decode() for s in f["cases/selected_by"][()]]
    return {
        "format": FORMAT,
        "mode": f.attrs.get("study_mode"),
        "cases": len(status),
        "parameters": read_parameters(f)["names"],
        "models": int(f["cases/model"][()].max()) + 1 if len(status) else 0,
        "verdicts": {k: verdicts.count(k) for k in ("stable", "unstable", "failed")},
        "transients": {k: status.count(k) for k in ("done", "failed", "pending", "skipped")},
        "selected_by": {k: chosen.count(k) for k in sorted(set(chosen))},
        "statistics": statistics(f),
        "design": design_summary(f),
    }


def design_summary(f) -> dict | None:
    """The friction damper's design answer of a ``--forced-nonlinear`` study (None without):
    per case the refined peak tip amplitude [m] and frequency [Hz], its label (the study's
    values as written), and the case whose peak is smallest (the optimum over the cases)."""
    if "forced_nonlinear" not in f:
        return None
    g = f["forced_nonlinear"]
    peak = g["peak_amplitude"][()]
    text = f["cases/parameters/text"][()] if "cases/parameters" in f else None
    labels = [", ".join(t.decode() for t in row) for row in text] if text is not None else \
        [str(i) for i in range(peak.size)]
    done = np.isfinite(peak)
    best = int(np.nanargmin(np.where(done, peak, np.nan))) if done.any() else None
    def listed(name):  # forced.exact's per case, None where not computed (or older files)
        if name not in g:
            return [None] * peak.size
        return [float(v) if np.isfinite(v) else None for v in g[name][()]]

    config = f.attrs.get("config", "")
    config = config.decode() if isinstance(config, bytes) else config
    return {
        "law": str(g.attrs["law"]), "harmonics": int(g.attrs["harmonics"]),
        # forced.exact of the study (absent in files of before it was on by default: off)
        "exact_asked": bool(tomllib.loads(config).get("forced", {}).get("exact", False)),
        "exact_tip_amplitude_m": listed("exact_tip_amplitude"),
        "exact_largest_multiplier": listed("exact_largest_multiplier"),
        "exact_wheel_largest_multiplier": listed("exact_wheel_largest_multiplier"),
        # in every ND where computed, else inside the pattern's symmetry
        "exact_stable": [None if mu is None else (every if every is not None else mu) <= 1 + UNIT
                         for mu, every in zip(listed("exact_largest_multiplier"),
                                              listed("exact_wheel_largest_multiplier"),
                                              strict=True)],
        "peak_amplitude_m": [float(a) if ok else None for a, ok in zip(peak, done, strict=True)],
        "peak_frequency_hz": [float(h) if ok else None
                              for h, ok in zip(g["peak_frequency_hz"][()], done, strict=True)],
        "labels": labels,
        "failed": int((~done).sum()),
        "optimum": best,
    }


def whitehead_bound(blades: int) -> float:
    """Whitehead's bound ``(1 + sqrt(N)) / 2`` on the forced-response amplification of a
    mistuned wheel (one mode per blade, light damping)."""
    return (1 + math.sqrt(blades)) / 2


def distribution(values) -> dict:
    """``count``, ``mean``, ``std`` (population), ``p95`` (numpy's linear percentile),
    ``max`` and ``argmax`` (the case) of the finite values (None when there are none)."""
    values = np.asarray(values, dtype=float)
    finite = np.flatnonzero(np.isfinite(values))
    if not finite.size:
        return {"count": 0, "mean": None, "std": None, "p95": None, "max": None, "argmax": None}
    x = values[finite]
    return {"count": int(x.size), "mean": float(x.mean()), "std": float(x.std()),
            "p95": float(np.percentile(x, 95)), "max": float(x.max()),
            "argmax": int(finite[np.argmax(x)])}


def stable_amplification(f) -> tuple[np.ndarray, int]:
    """``(C,)`` the amplification factors of the linearly stable cases (NaN elsewhere) and
    how many unstable cases had a factor. Why: an unstable case's linearisation has a
    negatively damped mode, whose "peak" is set by the band searched, not by the wheel
    (docs/theory.md "Peak refinement")."""
    factor = np.array(f["forced/amplification"][()], dtype=float)
    unstable = np.array([v != b"stable" for v in f["stability/verdict"][()]])
    excluded = int(np.sum(unstable & np.isfinite(factor)))
    factor[unstable] = np.nan
    return factor, excluded


def statistics(f) -> dict:
    """The distribution (:func:`distribution`) over the cases of the largest linear growth
    rate [1/s] and, with ``/forced``, of the amplification factor of the linearly stable
    cases (``amplification_unstable_cases``: the unstable ones left out), with Whitehead's
    bound."""
    out = {"max_growth_rate": distribution(f["stability/max_growth_rate"][()])}
    if "forced" in f:
        factor, excluded = stable_amplification(f)
        out["amplification"] = distribution(factor)
        out["amplification_unstable_cases"] = excluded
        out["whitehead_bound"] = float(f["forced"].attrs["whitehead_bound"])
    return out
