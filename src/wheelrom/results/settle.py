"""``/settle`` of a settle file (``wheelrom settle --out``; docs/output.md): per case where the
flutter settled, how it was decided, and the last window's tip histories."""

from __future__ import annotations

import numpy as np

from wheelrom import config as config_mod
from wheelrom.config import Config
from wheelrom.config.settle import at_settle_step
from wheelrom.results.file_checksums import write_file_checksums
from wheelrom.results.layout import write_model
from wheelrom.results.limit_cycles import study_number
from wheelrom.rom.model import ReducedModel

FORMAT = "wheelrom-settle-1"
KINDS = ("periodic", "quasi-periodic", "chaotic")


def write_settle(f, cfg: Config, model: ReducedModel, cases: list) -> None:
    """The whole file from ``[(angles, parameters, Settled)]`` in case order."""
    f.attrs["format"] = FORMAT
    f.attrs["config"] = config_mod.to_toml(cfg)
    f.attrs["config_source"] = cfg.source
    write_model(f.create_group("model"), model)
    g = f.create_group("settle")
    s = cfg.settle
    for key in ("window_periods", "tolerance", "consecutive", "min_time", "max_time",
                "bounded_span", "bounded_drift", "perturbation", "seed", "start", "nozzle"):
        g.attrs[key] = getattr(s, key)
    g.attrs["time_step"] = at_settle_step(cfg).time.step  # the step asked (settle.step)
    g["angles_deg"] = np.array([[a.get(k, np.nan) for k in ("tieboss", "shroud")]
                                for a, _, _ in cases])
    g["angles_deg"].attrs["columns"] = "tieboss, shroud"
    names = list(cases[0][1]) if cases else []
    if names:
        g["parameters"] = np.array([[study_number(p[n]) for n in names] for _, p, _ in cases])
        g["parameters"].attrs["names"] = ", ".join(names)
    g["verdict"] = np.array([r.verdict().encode() for _, _, r in cases])
    g["settled"] = np.array([r.settled for _, _, r in cases])
    g["time"] = np.array([r.time for _, _, r in cases])
    g["kind"] = np.array([(r.classification.kind if r.classification else "").encode()
                          for _, _, r in cases])
    g["max_amplitude"] = np.array([r.amplitude.max() if r.amplitude.size else np.nan
                                   for _, _, r in cases])
    g["wall_s"] = np.array([r.wall_s for _, _, r in cases])
    g["step"] = np.array([r.step for _, _, r in cases])
    g["step"].attrs["meaning"] = "the step [s] each case was integrated at: whole steps of " \
        "its window no longer than time_step, lowered where the exponential scheme's " \
        "stability check lowers them (case_<i>'s step_lowered says why; NaN: no window ran)"
    trends = [r.trend() for _, _, r in cases]
    g["trend"] = np.array([(t.rate, t.error, t.correlation) if t else (np.nan,) * 3
                           for t in trends]).reshape(-1, 3)
    g["trend"].attrs["columns"] = ("rate [1/s], its standard error [1/s] (adjusted for the "
                                   "windows' correlation), the residuals' lag-1 correlation")
    g["trend"].attrs["meaning"] = "least-squares slope of the largest blade's amplitude over " \
        "the windows of the last bounded_span, relative to their mean (NaN: settled, or " \
        "fewer than 8 windows there)"
    g["bounded"] = np.array([r.bounded for _, _, r in cases], dtype=bool)
    g["bounded"].attrs["meaning"] = "not stationary, but its trend kept it within " \
        "bounded_drift over bounded_span: the run ended there"
    bands = [None if r.settled else r.band() for _, _, r in cases]
    g["band"] = np.array([b if b else (np.nan,) * 3 for b in bands]).reshape(-1, 3)
    g["band"].attrs["columns"] = "low [m], high [m], over [s]"
    g["band"].attrs["meaning"] = "range of the largest blade's window amplitude over the last " \
        "bounded_span of a case that did not settle (NaN: settled)"
    g["still_growing"] = np.array([r.still_growing() for _, _, r in cases], dtype=bool)
    g["start_amplitude"] = np.array([r.start_amplitude for _, _, r in cases])
    g["start_amplitude"].attrs["meaning"] = "tip amplitude [m] of the single-wave exact orbit " \
        "the case started from (NaN: started from the preloaded equilibrium)"
    for i, (_, _, r) in enumerate(cases):
        _write_case(g.create_group(f"case_{i}"), r)
    write_file_checksums(f, {"settle": len(cases)})


def _write_case(g, r) -> None:
    g.attrs["verdict"] = r.verdict()
    g.attrs["status"] = r.status
    g.attrs["start"] = r.start
    g.attrs["start_amplitude"] = r.start_amplitude
    g.attrs["settled"] = r.settled
    g.attrs["bounded"] = r.bounded
    g.attrs["time"] = r.time
    g.attrs["energy_balance"] = r.energy_balance
    g.attrs["step"] = r.step
    g.attrs["step_lowered"] = r.step_lowered
    g["window_end"] = np.array([w.end for w in r.windows])
    g["window_amplitude"] = np.array([w.amplitude for w in r.windows])
    g["window_nd_energy"] = np.array([w.nd_energy for w in r.windows])
    g["window_change"] = np.array([w.change for w in r.windows], dtype=float).reshape(-1, 2)
    g["window_change"].attrs["columns"] = "amplitude, ND energy distribution"
    if r.classification is not None:  # a settled state only
        for key in ("kind", "frequency_hz", "modulation_hz", "modulation_depth", "line_share",
                    "return_distance", "decided_by"):
            g.attrs[key] = getattr(r.classification, key)
    if not r.amplitude.size:
        return
    g["amplitude"] = r.amplitude
    g["nd_energy"] = r.nd_energy
    g["fractions"] = r.fractions
    g["fractions"].attrs["columns"] = "open, micro-slip (stick), slip"
    g["normal_force_range"] = r.normal_force_range
    g.create_dataset("tip_time", data=r.tip_time)
    g.create_dataset("tip", data=r.tip, compression="gzip", shuffle=True)


def layout_problems(f) -> list[dict]:
    """What in the settle file ``f`` does not fit its wheel (``/model``'s blades ``N``):
    per case its windows ``(W,)``, their ``(W, N)`` amplitudes, ``(W, N // 2 + 1)`` ND
    shares and ``(W, 2)`` changes, the last window's ``(N,)`` amplitude and ND shares,
    ``(K, 3)`` contact shares and ``(K, 2)`` normal-force range, ``(T, N, 3)`` tip samples.
    Each ``{"path", "case", "why"}``: a file whose checksums agree (written whole from what
    it was given) can still hold a case of another wheel. ``info --verify`` reports them."""
    blades = int(f["model"].attrs["blades"])
    shares = blades // 2 + 1
    problems = []
    g = f["settle"]
    for i in range(g["verdict"].shape[0]):
        case = g.get(f"case_{i}")
        if case is None:
            problems.append({"path": f"settle/case_{i}", "case": i, "why": "missing"})
            continue
        windows = case["window_end"].shape[0] if "window_end" in case else 0
        kinds = case["fractions"].shape[0] if "fractions" in case else 0
        samples = case["tip_time"].shape[0] if "tip_time" in case else 0
        want = {"window_end": (windows,), "window_change": (windows, 2)}
        if windows:
            want.update(window_amplitude=(windows, blades), window_nd_energy=(windows, shares))
        if "amplitude" in case:  # a case that ran to its end
            want.update(amplitude=(blades,), nd_energy=(shares,), fractions=(kinds, 3),
                        normal_force_range=(kinds, 2), tip_time=(samples,),
                        tip=(samples, blades, 3))
        for name, shape in want.items():
            got = case[name].shape if name in case else None
            if got != shape:
                problems.append({"path": f"settle/case_{i}/{name}", "case": i,
                                 "why": f"shape {got}, the wheel's {blades} blades want "
                                        f"{shape}" if got is not None else "missing"})
    return problems
