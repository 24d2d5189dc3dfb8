"""What the command line prints: JSON, lines for people, errors and warnings (rank 0 only
under mpirun), progress on stderr."""

from __future__ import annotations

import json
import os
import sys

EXIT_CONFIG = 2
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as a shell reports Ctrl-C


def log(msg: str) -> None:
    """A progress line on stderr."""
    print(msg, file=sys.stderr, flush=True)


def world_rank() -> int:
    """This process's rank under mpirun (from the launcher's environment: no MPI import)."""
    for name in ("OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK"):
        if os.environ.get(name, "").isdigit():
            return int(os.environ[name])
    return 0


def fail(message: str, status: int = EXIT_CONFIG) -> int:
    """One line on stderr (rank 0 only: under mpirun every rank meets the same bad input)."""
    if world_rank() == 0:
        print(f"wheelrom: {message}", file=sys.stderr, flush=True)
    return status


def warn_unused(petsc_args: list[str]) -> None:
    """PETSc options no solver read (as PETSc's -options_left): most likely misspelt."""
    if not petsc_args or world_rank() != 0:
        return
    from wheelrom.transient.options import unused

    for name in unused(petsc_args):
        print(f"wheelrom: warning: PETSc option -{name} was not used by any solver "
              "(misspelt? prefixes in docs/usage.md)", file=sys.stderr)  # fmt: skip


def print_modes(model, table, reference, assembled) -> None:
    print("segment modes [Hz]: " + ", ".join(f"{x:.2f}" for x in model.segment_hz))
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
    """One JSON object on stdout, or ``key: value`` lines."""
    if as_json:
        print_json(out)
    else:
        for key, value in out.items():
            print(f"{key}: {value}")


def print_json(obj: object) -> None:
    json.dump(obj, sys.stdout, indent=1, default=float)
    sys.stdout.write("\n")


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
        unstable = f"; unstable NDs {_ranges(nds)}" if nds else ""
        print(f"    {contacts}{unstable}")
    bad = sum(c["verdict"] == "unstable" for c in cases)
    print(f"{len(cases)} case(s): {len(cases) - bad} stable, {bad} unstable")


def _ranges(values: list[int]) -> str:
    """``[3, 4, 5, 9]`` -> ``"3..5, 9"``."""
    out, start = [], None
    for i, v in enumerate(values):
        if start is None:
            start = v
        if i + 1 == len(values) or values[i + 1] != v + 1:
            out.append(f"{start}" if start == v else f"{start}..{v}")
            start = None
    return ", ".join(out)
