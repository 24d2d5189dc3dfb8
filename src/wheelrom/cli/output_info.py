"""``wheelrom info`` for people: a header, then one line per case, for every kind of file
(:func:`wheelrom.results.info.file_info` gives the values)."""

from __future__ import annotations

from wheelrom.cli.output import human_value
from wheelrom.cli.output_mistuning import print_forced, print_statistics
from wheelrom.cli.output_periodic import PERIODIC_KINDS, periodic_title, print_periodic_cases

LONG_LISTING = 40  # cases above which `info` lists only the ends and the failed ones
ENDS_SHOWN = 5


def print_info(info: dict, show_all: bool = False) -> None:
    """``wheelrom info`` for people: a header, then one line per case (a long sweep: the
    first and last few and every failed one, unless ``show_all``)."""
    if info["kind"] == "forced":
        print_forced(info)
        if info.get("checksums"):
            print(f"  checksums:     {checksum_text(info['checksums'])}")
        return
    model = info.get("model") or {}
    if info["kind"] == "model":
        print(f"{info['file']}: reduced model (modes --out)")
    elif info["kind"] == "study":
        shape = " x ".join(map(str, info["shape"]))
        print(f"{info['file']}: {info['format']} study ({info['mode']}), {info['counts']['total']}"
              f" cases of {', '.join(info['parameters'])} ({shape}), {info['models']} model(s)")
    elif info["kind"] == "stability":
        n = info["counts"]
        print(f"{info['file']}: linear stability, {n['total']} cases: {n['stable']} stable, "
              f"{n['unstable']} unstable")
    elif info["kind"] in PERIODIC_KINDS:
        print(periodic_title(info))
    else:
        n = info["counts"]["total"]
        print(f"{info['file']}: {info['format']} results, {n} case{'s' * (n != 1)}")
    source = info.get("config_source") or "not recorded (the configuration is in attribute config)"
    print(f"  config source: {source}")
    if model:
        where = ", ".join(x for x in (model.get("preset") and f"{model['preset']} segment",
                                      model.get("segment_dofs") and f"{model['segment_dofs']} DOFs")
                          if x)
        print(f"  model:         {model['blades']} blades x {model['modes']} modes"
              + (f" ({where})" if where else ""))
        print(f"  segment modes: {human_value(model['segment_hz'], 'Hz')}")
        if model.get("nodal_diameters"):
            print(f"  wheel modes:   ND 0..{model['nodal_diameters'] - 1} x {model['modes']} "
                  "families (frequencies_by_nd)")
        for name, what in model.get("extras", {}).items():
            print(f"  also:          {name}: {what}")
    checks = info.get("checksums")
    if checks:
        print(f"  checksums:     {checksum_text(checks)}")
    if info["kind"] == "study":
        _print_study_cases(info, show_all)
        return
    if info["kind"] in PERIODIC_KINDS:
        print_periodic_cases(info)
        return
    if info["kind"] == "stability":
        print(" case tie-boss  shroud  verdict   growth [1/s]  ND  frequency [Hz]")
        for row in info["cases"]:
            print(f"{row['index']:5d} {row['tieboss_deg']:8g} {row['shroud_deg']:7g}  "
                  f"{row['verdict']:9s} {row['max_growth_rate']:+12.4g} {row['nodal_diameter']:3d}"
                  f"  {row['frequency_hz']:14.1f}")
        return
    if info["kind"] != "results":
        return
    window = human_value(info["window_s"], "s")
    print(f"  time:          end {human_value(info['time_end_s'], 's')}, window {window} "
          f"({info['windows']} windows)")
    c = info["counts"]
    print(f"  cases:         {c['done']} done, {c['failed']} failed, {c['pending']} pending; "
          f"total wall time {human_value(info['total_wall_s'], 's')} (sum over cases)")
    print(f"  storage:       {_storage(info)}")
    _print_cases(info["cases"], info["windows"], show_all)
    if info.get("hint"):
        print(info["hint"])


def changed_text(mismatched: list, most: int = 10) -> str:
    """What ``info --verify`` found changed: case indices (a sweep, run or study), or
    ``case 2 (limit_cycle/case_2/...)`` and ``path`` / ``object@attribute`` (a file written
    in one piece); the first ``most`` of them."""
    words = [str(m) if isinstance(m, int) else
             f"case {m['case']} ({m['path']})" if m["case"] is not None else m["path"]
             for m in mismatched[:most]]
    more = len(mismatched) - most
    return ", ".join(words) + (f" and {more} more (--json lists them all)" if more > 0 else "")


def checksum_text(checks: dict) -> str:
    """The ``checksums:`` line of ``info --verify``."""
    if not checks["stored"]:
        return "none stored (a file written before wheelrom kept them): nothing was checked"
    what = ("datasets, rows and attributes" if checks.get("scope") == "file"
            else "written case(s) (their /cases rows; the model and configuration have none)")
    bad, odd = checks["mismatched"], checks.get("inconsistent", [])
    words = [f"CHANGED since written: {changed_text(bad)}"] if bad else []
    if odd:
        words.append(f"INCONSISTENT with the wheel: {inconsistent_text(odd)}")
    return f"{checks['checked']} {what} checked: " + ("; ".join(words) or "all intact")


def inconsistent_text(found: list, most: int = 3) -> str:
    """What ``info --verify`` found not to fit the file's wheel: ``case 0 (settle/case_0/
    amplitude: shape (5,), the wheel's 12 blades want (12,))``, the first ``most``."""
    words = [f"case {m['case']} ({m['path']}: {m['why']})" for m in found[:most]]
    more = len(found) - most
    return ", ".join(words) + (f" and {more} more (--json lists them all)" if more > 0 else "")


def _megabytes(n: int) -> str:
    return f"{n / 1e6:.3g} MB"


def _storage(info: dict) -> str:
    """``4.77 MB per case (tip_history 4.75 MB, ...); file 91 MB``: the three largest
    per-case datasets."""
    parts = [f"{name} {_megabytes(n)}"
             for name, n in list(info["bytes_per_case_by_dataset"].items())[:3]]
    return (f"{_megabytes(info['bytes_per_case'])} per case ({', '.join(parts)}); "
            f"file {_megabytes(info['file_bytes'])}")


def _shown(rows: list[dict], shown: set):
    """The rows whose index is in ``shown``, printing a line for every gap in between."""
    hidden = 0
    for row in rows:
        if row["index"] not in shown:
            hidden += 1
            continue
        if hidden:
            print(f"  ... {hidden} case(s) not shown (--all lists every case)")
            hidden = 0
        yield row
    if hidden:
        print(f"  ... {hidden} case(s) not shown (--all lists every case)")


def _print_cases(rows: list[dict], windows: int, show_all: bool) -> None:
    """The case table of :func:`print_info`; gaps in a shortened one say how many are left."""
    shown = set(range(len(rows)))
    if len(rows) > LONG_LISTING and not show_all:
        ends = [*range(ENDS_SHOWN), *range(len(rows) - ENDS_SHOWN, len(rows))]
        shown = {*ends, *(r["index"] for r in rows if r["status"] == "failed")}
    print(f"{'case':>5s} {'tie-boss':>8s} {'shroud':>7s}  {'status':8s} {'windows':>7s} "
          f"{'wall [s]':>9s}  TS")
    for row in _shown(rows, shown):
        wall = "-" if row["wall_s"] is None else f"{row['wall_s']:.4g}"
        reason = f"  {row['reason']}" if row["reason"] else ""
        print(f"{row['index']:5d} {row['tieboss_deg']:8g} {row['shroud_deg']:7g}  "
              f"{row['status']:8s} {str(row['windows_done']) + '/' + str(windows):>7s} "
              f"{wall:>9s}  {row['scheme']}{reason}")


def _print_study_cases(info: dict, show_all: bool) -> None:
    """The counts and case table of a study file (:func:`print_info`)."""
    from wheelrom.config.study import short_name

    v, c = info["verdicts"], info["counts"]
    print(f"  stability:     {v['stable']} stable, {v['unstable']} unstable, {v['failed']} failed")
    print(f"  transients:    {c['done']} done, {c['failed']} failed, {c['pending']} pending, "
          f"{c['skipped']} not run")
    print_statistics(info.get("statistics") or {}, "  ")
    rows = info["cases"]
    shown = set(range(len(rows)))
    if len(rows) > LONG_LISTING and not show_all:
        shown = {*range(ENDS_SHOWN), *range(len(rows) - ENDS_SHOWN, len(rows)),
                 *(r["index"] for r in rows if "failed" in (r["status"], r["verdict"]))}
    print(f"{'case':>5s}  {'verdict':9s} {'growth [1/s]':>12s}  {'selected':13s} {'transient':9s}"
          f" {'wall [s]':>9s}  parameters")
    for row in _shown(rows, shown):
        growth = "-" if row["max_growth_rate"] is None else f"{row['max_growth_rate']:+.4g}"
        wall = "-" if row["wall_s"] is None else f"{row['wall_s']:.4g}"
        params = ", ".join(f"{short_name(k)}={t}" for k, t in row["parameters"].items())
        params += f"  amplification {row['amplification']:.4f}" if row.get("amplification") else ""
        why = "  " + (row["reason"] or row["stability_failure"] or "")
        print(f"{row['index']:5d}  {row['verdict']:9s} {growth:>12s}  {row['selected_by']:13s} "
              f"{row['status']:9s} {wall:>9s}  {params}{why.rstrip()}")
    if info.get("hint"):
        print(info["hint"])
