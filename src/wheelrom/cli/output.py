"""What the command line prints: JSON, lines for people, errors and warnings (rank 0 only
under mpirun), progress on stderr."""

from __future__ import annotations

import contextlib
import json
import math
import os
import sys

from wheelrom.cli.output_mistuning import print_statistics

EXIT_CONFIG = 2
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as a shell reports Ctrl-C


def log(msg: str) -> None:
    """A progress line on stderr."""
    print(msg, file=sys.stderr, flush=True)


def throttled(every_s: float = 5.0):
    """A ``progress(text)`` that logs at most one line every ``every_s`` seconds."""
    import time

    last = [time.monotonic()]

    def progress(text: str) -> None:
        if time.monotonic() - last[0] >= every_s:
            last[0] = time.monotonic()
            log(text)

    return progress


def report_and_save(rows: list[dict], as_json: bool, printer, out: str | None, fill,
                    kept: str = "the summary is printed above", extra: dict | None = None):
    """Rank 0 of a per-case command: the rows printed (JSON or ``printer(rows)``) before the
    file is written, so a full disk still leaves the numbers; ``fill(f)`` builds the HDF5
    file ``out`` (None: none); ``extra``: more JSON keys beside ``cases``. Returns the
    write's failure for ``agree``."""
    from wheelrom.runtime.outputs import save_hdf5

    if as_json:
        print_json({"cases": rows, **(extra or {})})
    else:
        printer(rows)
    if not out:
        return None
    return save_hdf5(out, fill, kept)


def world_rank() -> int:
    """This process's rank under mpirun (from the launcher's environment: no MPI import)."""
    for name in ("OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK"):
        if os.environ.get(name, "").isdigit():
            return int(os.environ[name])
    return 0


@contextlib.contextmanager
def numpy_warnings_off():
    """No numpy ``RuntimeWarning`` reaches the user: "invalid value encountered in subtract"
    with a source line says nothing a user can act on. What such a value means is the
    commands' to say, in their own lines (a NaN amplitude is "no solution", a diverged
    case "failed"), and the keys' ranges keep the inputs that caused them out."""
    import warnings

    import numpy as np

    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore", RuntimeWarning)
        yield


def fail(message: str, status: int = EXIT_CONFIG) -> int:
    """One line on stderr (rank 0 only: under mpirun every rank meets the same bad input)."""
    if world_rank() == 0:
        print(f"wheelrom: {message}", file=sys.stderr, flush=True)
    return status


def warn_unused(petsc_args: list[str]) -> None:
    """PETSc options no solver read (as PETSc's -options_left): most likely misspelt. Under
    mpirun an option counts as read when any rank read it (every rank calls this)."""
    if not petsc_args:
        return
    from wheelrom.transient.options import unused

    left = set(unused(petsc_args))
    MPI = sys.modules.get("mpi4py.MPI")
    if MPI is not None and MPI.Is_initialized() and not MPI.Is_finalized():
        if MPI.COMM_WORLD.size > 1:
            for other in MPI.COMM_WORLD.allgather(left):
                left &= other
    if world_rank() != 0:
        return
    for name in sorted(left):
        print(f"wheelrom: warning: PETSc option -{name} was not used by any solver "
              "(misspelt? prefixes in docs/usage.md)", file=sys.stderr)


def print_modes(model, table, reference, assembled) -> None:
    print("segment modes [Hz]: " + ", ".join(f"{x:.2f}" for x in model.segment_hz))
    if "prestress_peak_von_mises_pa" in model.info:
        from wheelrom.rom.build import stress_line

        print(f"prestress (linear elastic, at the Gauss points): {stress_line(model.info)}")
    for kind_name, rep in model.info.items():
        if isinstance(rep, dict) and "arm_length" in rep:
            print(
                f"{kind_name}: arm L = {rep['arm_length']:.4g} m, pitch chord "
                f"{rep['pitch_chord']:.4g} m, arm end misses next A by "
                f"{rep['tip_to_next_A'] * 1e3:.2f} mm"
            )
    print("wheel frequencies by nodal diameter [Hz] (first 4 families):")
    for k, row in enumerate(table):
        print(f"  ND {k:3d}: " + "  ".join(f"{x:9.2f}" for x in row[:4]))
    if reference is not None:
        err = 100 * (table / reference - 1)
        print("reduced model vs full-wheel FE (exact cyclic symmetry), error [%] by family:")
        print("  family:  " + "  ".join(f"{j + 1:7d}" for j in range(table.shape[1])))
        print("  max:     " + "  ".join(f"{x:7.2f}" for x in err.max(axis=0)))
        print("  mean:    " + "  ".join(f"{x:7.2f}" for x in err.mean(axis=0)))
    if assembled is not None:
        print("assembled full wheel, lowest [Hz]: " + ", ".join(f"{x:.3f}" for x in assembled))


def print_result(out: dict, as_json: bool) -> None:
    """One JSON object on stdout (:func:`print_json`), or aligned ``key: value`` lines for
    people (:func:`human_value`)."""
    if as_json:
        print_json(out)
        return
    width = max((len(str(k)) for k in out), default=0)
    for key, value in out.items():
        print_human(str(key), value, width)


def print_human(key: str, value, width: int = 0, indent: str = "", unit: str = "") -> None:
    """``key: value`` for people; a dict holding dicts or tables as indented lines."""
    unit = unit_of(key) or unit
    if isinstance(value, (list, tuple)) and any(isinstance(v, dict) for v in value):
        print(f"{indent}{key}:")
        for i, item in enumerate(value):
            print(f"{indent}  [{i}] {human_value(item, unit)}")
        return
    if isinstance(value, dict) and any(_is_nested(v) for v in value.values()):
        print(f"{indent}{key}:")
        inner = max((len(str(k)) for k in value), default=0)
        for k, v in value.items():
            print_human(str(k), v, inner, indent + "  ", unit)
        return
    print(f"{indent}{key + ':':{width + 1}s} {human_value(value, unit)}")


def _is_nested(value) -> bool:
    """A dict, or a list holding lists or dicts (printed on lines of their own)."""
    return isinstance(value, dict) or (
        isinstance(value, (list, tuple)) and any(isinstance(v, (list, tuple, dict)) for v in value)
    )


#: units of keys whose names do not carry them
KEY_UNITS = {"max_tip_amplitude": "m", "min_normal_force": "N"}
#: unit from how a key ends (checked in order)
SUFFIX_UNITS = (("gmadd_per_s", "Gmadd/s"), ("_per_s", "/s"), ("_n_per_m", "N/m"),
                ("_m_per_n", "m/N"), ("_hz", "Hz"), ("_deg", "deg"), ("_s", "s"), ("_m", "m"),
                ("_n", "N"), ("_j", "J"))


def unit_of(key: str) -> str:
    """The unit a key names (``wall_s`` -> s, ``us_per_rhs`` -> us, ``segment_hz`` -> Hz),
    "" when it names none."""
    base = key.lower().removesuffix("_in_batch")
    if base in KEY_UNITS:
        return KEY_UNITS[base]
    if base.startswith("us_per_") or "_us_per_" in base:
        return "us"
    return next((unit for end, unit in SUFFIX_UNITS if base.endswith(end)), "")


def human_number(x) -> str:
    """An int as is, a float to 4 significant digits (``0.020000000000000788`` -> 0.02)."""
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, int):
        return str(x)
    x = float(x)
    if math.isnan(x):
        return "NaN"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return f"{x:.4g}"


def human_value(value, unit: str = "", max_items: int = 8) -> str:
    """One value on one line: numbers with ``unit``, None as ``n/a``, dicts as ``name value``
    pairs, lists compact (a long one as its first and last values and its length)."""
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):
        value = value.tolist()  # numpy arrays and scalars
    if value is None:
        return "n/a"
    if isinstance(value, str):
        return value
    if isinstance(value, dict):
        return ", ".join(f"{k} {human_value(v, unit_of(str(k)) or unit)}"
                         for k, v in value.items()) or "-"
    if isinstance(value, (list, tuple)):
        if not value:
            return "-"
        if any(isinstance(v, (list, tuple)) for v in value):
            return f"table of {len(value)} rows (--json for the values)"
        shown = [human_value(v) for v in value]
        count = f" ({len(shown)} values)" if len(shown) > max_items else ""
        if count:
            shown = [*shown[:3], "...", shown[-1]]
        return ", ".join(shown) + (f" {unit}" if unit else "") + count
    try:
        text = human_number(value)
    except (TypeError, ValueError):
        return str(value)
    finite = unit and text not in ("NaN", "inf", "-inf")
    return f"{text} {unit}" if finite else text


#: why a value of this key may be non-finite (the JSON says so next to its null)
NULL_REASONS = {
    **dict.fromkeys(("max_tip_amplitude", "min_normal_force", "open_fraction"),
                    "no output sample in the last window, or a non-finite state (see status)"),
    "energy_balance_error": "no energy balance (energy or work not finite in the last window)",
    "relative_error_by_nd": "no full-wheel reference value",
}


def print_json(obj: object) -> None:
    """``obj`` as strict JSON on stdout: non-finite floats (also in numpy arrays) become null
    and a top-level ``null_fields`` says, per key, which values were not finite and why."""
    found: dict = {}
    clean = jsonable(obj, "", found)
    nulls = {path: null_reason(path, seen) for path, seen in found.items()
             if seen["NaN"] or seen["inf"] or seen["-inf"]}
    if nulls and isinstance(clean, dict):
        clean["null_fields"] = nulls
    json.dump(clean, sys.stdout, indent=1, allow_nan=False)
    sys.stdout.write("\n")


def jsonable(value, path: str, found: dict):
    """``value`` with JSON types only (numpy arrays and scalars converted, tuples as lists,
    non-finite floats as None). ``found[path]`` counts what was replaced under each key path
    (``a.b``, ``a[3].b`` for dicts in lists): ``{"NaN": n, "inf": n, "-inf": n, "values":
    numbers seen, "list": inside a list}``."""
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):
        value = value.tolist()
    if isinstance(value, dict):
        return {str(k): jsonable(v, f"{path}.{k}" if path else str(k), found)
                for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        out = [jsonable(v, f"{path}[{i}]" if isinstance(v, dict) else path, found)
               for i, v in enumerate(value)]
        if path in found:
            found[path]["list"] = True
        return out
    if value is None or isinstance(value, (str, bool, int)):
        return value
    try:
        x = float(value)
    except (TypeError, ValueError):
        return str(value)
    seen = found.setdefault(path, {"NaN": 0, "inf": 0, "-inf": 0, "values": 0, "list": False})
    seen["values"] += 1
    if math.isfinite(x):
        return x
    seen["NaN" if math.isnan(x) else "inf" if x > 0 else "-inf"] += 1
    return None


def null_reason(path: str, seen: dict) -> str:
    """Why the value(s) at ``path`` are null (:data:`NULL_REASONS` by key, else generic)."""
    keys = [part.partition("[")[0] for part in path.split(".")]
    known = next((NULL_REASONS[k] for k in reversed(keys) if k in NULL_REASONS), None)
    kinds = [k for k in ("NaN", "inf", "-inf") if seen[k]]
    label = "/".join(kinds)
    if seen["list"]:
        bad = sum(seen[k] for k in kinds)
        what = f"{bad} of {seen['values']} values {label}"
        return f"{what}: {known}" if known else f"{what} (not finite)"
    if known:
        return f"{label}: {known}"
    return "not finite (NaN)" if label == "NaN" else f"infinite ({label})"


def print_stability(cases: list[dict]) -> None:
    """One line per case (verdict, fastest mode), then contact states and the count."""
    for case in cases:
        angles = ", ".join(f"{k} {v:g} deg" for k, v in case["angles_deg"].items())
        verdict = case["verdict"].upper() if case["verdict"] == "unstable" else case["verdict"]
        print(f"{angles}: {verdict}; {case['mode']}")
        contacts = "; ".join(
            f"{k} min F_n {case['min_normal_force_n'][k]:.4g} N, margin "
            f"{case['min_margin_m'][k] * 1e6:.3g} um"
            for k in case["min_normal_force_n"]
        )
        nds = case["unstable_nodal_diameters"]
        unstable = f"; unstable NDs {number_ranges(nds)}" if nds else ""
        print(f"    {contacts}{unstable}")
        if "flutter_margin" in case:
            print(f"    {_margin_words(case['flutter_margin'])}")
    bad = sum(c["verdict"] == "unstable" for c in cases)
    print(f"{len(cases)} case(s): {len(cases) - bad} stable, {bad} unstable")


def print_study(summary: dict, path: str) -> None:
    """``wheelrom study`` for people: what the file holds, in three lines."""
    v, t = summary["verdicts"], summary["transients"]
    chosen = ", ".join(f"{k} {n}" for k, n in summary["selected_by"].items())
    print(f"{path}: {summary['cases']} cases of {', '.join(summary['parameters'])} "
          f"({summary['mode']}, {summary['models']} model(s))")
    print(f"  linear stability: {v['stable']} stable, {v['unstable']} unstable, "
          f"{v['failed']} failed")
    print(f"  transients:       {t['done']} done, {t['failed']} failed, {t['pending']} "
          f"pending, {t['skipped']} not run (selected by: {chosen})")
    print_statistics(summary.get("statistics") or {}, "  ")
    design = summary.get("design")
    if design:
        print(f"  nonlinear forced response (H = {design['harmonics']}), peak tip amplitude "
              f"per case [{', '.join(summary['parameters'])}]:")
        for i, (label, a, hz) in enumerate(zip(design["labels"], design["peak_amplitude_m"],
                                               design["peak_frequency_hz"], strict=True)):
            mark = "  <- smallest" if i == design["optimum"] else ""
            words = "failed" if a is None else f"{a * 1e6:.4g} um at {hz:.5g} Hz"
            exact, mu = design["exact_tip_amplitude_m"][i], design["exact_largest_multiplier"][i]
            every = design["exact_wheel_largest_multiplier"][i]
            mu = mu if every is None else every
            if exact is not None and mu is None:  # converged, its multipliers failed
                words += f" (exact {exact * 1e6:.4g} um, multipliers not computed)"
            elif exact is not None:  # forced.exact
                words += (f" (exact {exact * 1e6:.4g} um, largest |mu| {mu:.4f}: "
                          f"{'stable' if design['exact_stable'][i] else 'unstable'})")
            elif a is not None and design.get("exact_asked"):
                words += " (exact: the shot did not converge)"
            print(f"    [{i}] {label}: {words}{mark}")


def _margin_words(m: dict) -> str:
    table = m.get("scaled") == "aerodynamic table"
    if m["critical_mu"] is None:
        scanned = "factor on the aerodynamic table" if table else "Van der Pol mu"
        return f"flutter margin: stable for every scanned {scanned} (up to 1024 x)"
    if m["critical_mu"] == 0:
        return (f"flutter margin: none, unstable without self-excitation (growth "
                f"{m['growth_rate_without_self_excitation']:+.3g} /s)")
    if table:
        return (f"flutter margin: {m['ratio']:.3g} x (the wheel flutters once the aerodynamic "
                f"table is {m['critical_mu']:.4g} x as strong: ND {m['nodal_diameter']} at "
                f"{m['frequency_hz']:.4g} Hz)")
    return (f"flutter margin: {m['ratio']:.3g} x (unstable above mu = {m['critical_mu']:.4g} "
            f"N s/m, ND {m['nodal_diameter']} at {m['frequency_hz']:.4g} Hz)")


def number_ranges(values: list[int]) -> str:
    """``[3, 4, 5, 9]`` -> ``"3..5, 9"``."""
    out, start = [], None
    for i, v in enumerate(values):
        if start is None:
            start = v
        if i + 1 == len(values) or values[i + 1] != v + 1:
            out.append(f"{start}" if start == v else f"{start}..{v}")
            start = None
    return ", ".join(out)


def print_contact_stiffness(out: dict, dofs: int) -> None:
    """``contact-stiffness`` for people: per kind, k_c [N/m] from the FE and as configured."""
    for kind, row in out.items():
        print(f"{kind}: k_c [N/m] from the segment FE ({dofs} DOFs), configured value")
        conf = row["configured_n_per_m"] or [None] * len(row["angle_deg"])
        for a, k, c in zip(row["angle_deg"], row["fe_stiffness_n_per_m"], conf, strict=True):
            print(f"  {a:5.1f} deg  {k:11.4g}  " + ("" if c is None else f"{c:11.4g}"))


def print_accuracy(table: dict) -> None:
    """``accuracy`` for people: per basis, the largest error over the NDs per family [%]
    (``nan``: the basis has fewer families)."""
    import numpy as np

    families = table["reference_hz"].shape[1]
    print("max over nodal diameters of |reduced / FE - 1| [%], by family")
    print(f"{'basis':18s} {'vectors':>7s} "
          + " ".join(f"{'fam ' + str(j + 1):>9s}" for j in range(families)))
    for label, row in table["bases"].items():
        err = 100 * np.abs(row["relative_error"]).max(axis=0)
        print(f"{label:18s} {row['vectors']:7d} " + " ".join(f"{x:9.3f}" for x in err))

