"""The arguments of each ``wheelrom`` subcommand (argparse), apart from the commands."""

from __future__ import annotations

import argparse
import contextlib
import functools
import math

from wheelrom.cli.output_info import LONG_LISTING
from wheelrom.config import CONTACT_KINDS, with_option
from wheelrom.config.values import cut
from wheelrom.runtime.errors import InputError
from wheelrom.runtime.locks import output_lock
from wheelrom.runtime.outputs import check_output

#: every file `info` and `plot` read (their help lists them all)
ANY_FILE = ("sweep, run --out, study, stability --out, limit-cycle --out, settle --out, "
            "forced-response --out or modes --out")


def positive_number(text: str) -> float:
    """An argparse type: a finite number > 0 (``--scale``); anything else is argparse's one
    line naming the option, exit 2."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


def count(text: str) -> int:
    """An argparse type: a whole number >= 1 (mode counts, families)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def json_out(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")


def force(p: argparse.ArgumentParser) -> None:
    p.add_argument("--force", action="store_true", help="overwrite existing output files")


def args_modes(p):
    json_out(p)
    p.add_argument("--out", help="write the reduced model to this HDF5 file")
    p.add_argument(
        "--full-wheel",
        nargs="?",
        const="cyclic",
        choices=("cyclic", "assembled", "both"),
        help="full-wheel FE reference: exact cyclic symmetry per ND (default, any preset) "
        "and/or N assembled segment copies (SLEPc on all ranks; coarse preset)",
    )
    p.add_argument("--full-wheel-modes", type=count, default=20,
                   help="modes of the assembled wheel")
    p.add_argument("--vtu", help="write a wheel mode on the whole-wheel mesh (.vtu, meshio)")
    p.add_argument("--vtu-nd", type=int, help="nodal diameter of that mode (default 5)")
    p.add_argument("--vtu-family", type=int, help="mode family (default 0 = the lowest)")
    force(p)


def args_run(p):
    json_out(p)
    p.add_argument("--out", help="write the case to this HDF5 file (sweep layout)")
    force(p)


def args_compare(p):
    json_out(p)
    p.add_argument("--steps", type=int, default=2000, help="steps to compare (default 2000)")


def args_sweep(p):
    p.add_argument("--out", required=True, help="HDF5 results file")
    existing = p.add_mutually_exclusive_group()
    existing.add_argument(
        "--resume",
        action="store_true",
        help="complete an existing file: run only the cases still pending (a missing file is "
        "started afresh)",
    )
    existing.add_argument("--force", action="store_true", help="overwrite an existing file")
    p.add_argument(
        "--model-comm",
        choices=("rank0", "world"),
        default="rank0",
        help="build the model on rank 0 and broadcast it (default: results independent of "
        "the rank count), or solve the segment eigenproblem on all ranks (large segments)",
    )
    p.add_argument(
        "--batch",
        type=int,
        default=0,
        metavar="B",
        help="cases integrated together in one TS per rank (results are the same for any B): "
        "0 (default) = all of a rank's cases, fastest; 1 = every case written as soon as done",
    )


def args_study(p):
    json_out(p)
    p.add_argument("--out", required=True, help="HDF5 results file (format wheelrom-sweep-2)")
    what = p.add_mutually_exclusive_group()
    what.add_argument("--stability-only", action="store_true",
                      help="the linear stability of every case only (seconds)")
    what.add_argument("--screen", action="store_true",
                      help="stability of every case, then transients of the cases next to a "
                      "stability boundary and of the --confirm ones")
    p.add_argument("--confirm", default="", metavar="I,J,...",
                   help="case indices (0-based, as 'wheelrom info' lists them) the screen "
                   "runs a transient for in any case")
    p.add_argument("--forced", action="store_true",
                   help="also the peak linear forced response of every case ([forced]) "
                   "and its amplification factor over the tuned wheel (Monte Carlo "
                   "mistuning)")
    p.add_argument("--forced-nonlinear", action="store_true",
                   help="also the nonlinear forced response of every (tuned) case: harmonic "
                   "balance of the nozzle's wave under contacts.law over forced.band_hz (or "
                   "from the slipping to the stuck resonance) on forced.points frequencies, "
                   "H = forced.harmonics, the peak refined: the friction damper's design "
                   "curve (docs/usage.md)")
    existing = p.add_mutually_exclusive_group()
    existing.add_argument("--resume", action="store_true",
                          help="complete an existing file: run the transients still pending "
                          "(with --forced-nonlinear also reuse the design curves kept beside "
                          "it)")
    existing.add_argument("--force", action="store_true", help="overwrite an existing file")
    p.add_argument("--batch", type=int, default=0, metavar="B",
                   help="cases integrated together in one TS per rank (0, default: all of a "
                   "rank's cases that differ only in contact angles, up to 1 GiB of tip "
                   "histories; results the same for any B)")


def study_mode(args: argparse.Namespace) -> str:
    """``stability``, ``screen`` or ``full`` from ``--stability-only`` / ``--screen``."""
    if args.confirm and not args.screen:
        raise InputError("--confirm names the cases --screen must run; it needs --screen")
    return "stability" if args.stability_only else "screen" if args.screen else "full"


def parse_confirm(text: str) -> tuple[int, ...]:
    """``--confirm 3,17,40``: case indices (0-based)."""
    out = []
    for part in (p.strip() for p in text.split(",") if p.strip()):
        if not part.isdigit():
            raise InputError(f"--confirm: '{part}' is not a case index (0, 1, ...)")
        out.append(int(part))
    return tuple(sorted(set(out)))


def args_stability(p):
    json_out(p)
    p.add_argument("--out", help="write the stability of every case to this HDF5 file")
    p.add_argument("--margin", action="store_true",
                   help="also the flutter margin: the smallest Van der Pol mu at which each "
                   "case becomes unstable (docs/theory.md)")
    force(p)


def args_bench(p):
    json_out(p)
    p.add_argument("--steps", type=int, default=20000, help="TS steps timed (>= 20000)")
    p.add_argument(
        "--reference-steps", type=int, default=2000, help="steps of the numpy/scipy comparisons"
    )
    p.add_argument(
        "--batch", type=int, default=10, help="angle cases in one TS for the batched figures"
    )


def args_campbell(p):
    json_out(p)
    p.add_argument(
        "--speeds", default="0:60:13", help="rotor speeds [Hz]: start:stop:count or a,b,c"
    )
    p.add_argument(
        "--outdir",
        default="out/figures",
        help="directory for campbell.png (default: out/figures, created if missing)",
    )
    p.add_argument("--pdf", action="store_true", help="also write PDF")
    p.add_argument("--force", action="store_true", help="replace an existing campbell.png")


def args_mesh(p):
    p.add_argument(
        "--out",
        required=True,
        help="output file: .inp (+ <name>_cyclic.inp, a CalculiX deck), .vtu, .xdmf ...",
    )
    force(p)


def args_accuracy(p):
    json_out(p)
    p.add_argument("--modes", type=count, nargs="+", default=[10, 20, 40], help="free bases m")
    p.add_argument("--enriched-modes", type=count, default=10, help="m of the enriched basis")
    p.add_argument("--families", type=count, default=4, help="families compared")


def args_plot(p):
    p.add_argument(
        "--outdir",
        default=None,
        help="directory for the figures (default: <results>_figures next to the file, created "
        "if missing)",
    )
    p.add_argument("--pdf", action="store_true", help="also write PDF")
    p.add_argument(
        "--nd-angles",
        type=float,
        nargs=2,
        metavar=("A", "B"),
        help="shroud angles [deg] of the two ND-spectrum panels (default: most and least "
        "suppressed)",
    )
    p.add_argument("--force", action="store_true",
                   help="replace figures of the same name in the folder (default: refused, "
                   "nothing written)")


def args_export(p):
    p.add_argument("file", help="HDF5 file from sweep, study or run --out")
    p.add_argument("--case", type=int, default=0, help="case index as 'wheelrom info' lists it")
    p.add_argument("--csv", required=True, metavar="PREFIX",
                   help="writes PREFIX_<table>.csv per table of --what")
    p.add_argument("--what", choices=("all", "tips", "windows", "contact_forces"),
                   default="all",
                   help="tips: tip displacement of every blade per sample; windows: per-window "
                   "statistics (amplitude, contact forces and opening, energy, works, ND "
                   "amplitudes); contact_forces: normal and friction force and relative "
                   "displacement of every contact per state sample (needs a state history); "
                   "all (default): tips and windows")
    force(p)


def args_info(p):
    p.add_argument("file", help="HDF5 file of any wheelrom command: " + ANY_FILE)
    json_out(p)
    p.add_argument("--verify", action="store_true",
                   help="recompute the stored checksums (reads the whole file): every written "
                   "case's of a sweep, run or study, every dataset's and attribute's of the "
                   "other files; exit 1 naming what changed since it was written (a file "
                   "without checksums: says so, exit 0)")
    p.add_argument("--all", action="store_true",
                   help=f"list every case (default: a sweep of more than {LONG_LISTING} cases "
                   "lists the first and last few and the failed ones)")


def load_config(args: argparse.Namespace):
    """The validated configuration of a command's CONFIG and ``--set`` arguments."""
    from wheelrom import config

    return config.load(args.config, args.overrides)


def comm_self():
    from wheelrom.runtime.environment import petsc

    return petsc().COMM_SELF


def locked(*flags: str):
    """Decorate a command to run holding the lock of each output file it is given (``"--out"``,
    ``"--vtu"``, ...: :func:`wheelrom.runtime.locks.output_lock`; under mpirun rank 0
    holds them for all), so that a second job on the same file is refused, naming this one."""

    def wrap(cmd):
        @functools.wraps(cmd)
        def run(args: argparse.Namespace) -> int:
            from wheelrom.studies.stability import world_if_parallel

            comm = world_if_parallel()
            with contextlib.ExitStack() as held:
                for flag in flags:
                    path = getattr(args, flag.lstrip("-").replace("-", "_"), None)
                    held.enter_context(output_lock(path, comm, flag))
                return cmd(args)

        return run

    return wrap


def add_config_args(p: argparse.ArgumentParser, required: bool = False) -> None:
    p.add_argument(
        "config",
        nargs=None if required else "?",
        help="TOML configuration file" + ("" if required else " (default: built-in case)"),
    )
    p.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override one key, e.g. --set time.end=0.2 (repeatable)",
    )


def check_vtu_arguments(args: argparse.Namespace, cfg) -> None:
    """``--vtu-nd`` / ``--vtu-family`` ranges, before anything is computed."""
    given = [flag for flag, value in (("--vtu-nd", args.vtu_nd), ("--vtu-family", args.vtu_family))
             if value is not None]
    if not args.vtu:
        if given:
            raise InputError(f"{given[0]} needs --vtu FILE (the file the mode is written to)")
        return
    check_output(args.vtu, args.force, "--vtu")
    args.vtu_nd = 5 if args.vtu_nd is None else args.vtu_nd
    args.vtu_family = 0 if args.vtu_family is None else args.vtu_family
    largest = cfg.wheel.blades // 2
    if not 0 <= args.vtu_nd <= largest:
        raise InputError(f"--vtu-nd {args.vtu_nd}: nodal diameters of a {cfg.wheel.blades}-blade "
                         f"wheel are 0..{largest}")
    if args.vtu_family < 0:
        raise InputError(f"--vtu-family {args.vtu_family}: families count from 0 (the lowest)")


def parse_range(text: str, option: str, most: int, why: str,
                one_point: bool = False) -> tuple[float, float, int]:
    """``A:B:N`` of ``option`` -> ``(A, B, N)``: ``0 <= A <= B`` finite [Hz], ``N`` a whole
    number from 1 to ``most`` (``why``: what each costs, for the refusal); ``N = 1`` asks
    for ``A = B`` unless ``one_point`` (a band searched whole with one grid point: the
    forced response's peak search). A reversed, empty or oversized range is one line naming
    the option, before anything is computed."""
    shown = cut(text)
    try:
        start, stop, count = text.split(":")
        a, b, n = float(start), float(stop), int(count)
    except ValueError:
        raise InputError(f"{option} {shown}: expected A:B:N (Hz, N a whole number), "
                         "e.g. 300:400:201") from None
    if not (math.isfinite(a) and math.isfinite(b) and 0 <= a <= b):
        raise InputError(f"{option} {shown}: expected 0 <= A <= B (Hz; a reversed range is "
                         "not read backwards)")
    if n < 1 or (n > 1 and a == b) or (n == 1 and a < b and not one_point):
        raise InputError(f"{option} {shown}: N must be >= 1, 1 exactly when A = B"
                         if not one_point else
                         f"{option} {shown}: N must be >= 1 (and 1 when A = B)")
    if n > most:
        raise InputError(f"{option} {shown}: {n} values ({why}); at most {most}")
    return a, b, n


#: the most rotor speeds ``campbell --speeds`` may ask for: each builds the prestressed
#: segment and the wheel again (a second or more each on the coarse wheel)
MAX_SPEEDS = 1000


def parse_speeds(text: str, cfg=None):
    """``campbell --speeds``: ``"start:stop:count"`` [Hz] (inclusive, like numpy.linspace) or
    ``"a,b,c"`` (increasing), at most :data:`MAX_SPEEDS`; each within ``wheel.speed_hz``'s
    range of ``cfg`` (named as ``--speeds``)."""
    import numpy as np

    why = "each a prestressed segment solve"
    if ":" in text:
        speeds = np.linspace(*parse_range(text, "--speeds", MAX_SPEEDS, why))
    else:
        try:
            speeds = np.array([float(x) for x in text.split(",")])
        except ValueError:
            raise InputError(f"--speeds: expected start:stop:count or a,b,c in Hz, got "
                             f"{cut(text)!r}") from None
        if speeds.size > MAX_SPEEDS:
            raise InputError(f"--speeds: {speeds.size} values ({why}); at most {MAX_SPEEDS}")
        if not np.all(np.isfinite(speeds)) or np.any(np.diff(speeds) <= 0):
            raise InputError(f"--speeds {cut(text)}: expected finite speeds in increasing "
                             "order, each once")
    if cfg is not None:  # the range of wheel.speed_hz, which each speed sets
        for speed in (speeds[0], speeds[-1]):
            with_option(cfg, f"--speeds {cut(text)}", {"wheel.speed_hz": float(speed)})
    return speeds


#: the most frequencies ``--frequencies`` / ``--speeds`` may ask for (as forced.points)
MAX_FREQUENCIES = 100_000


def excitation_band(args: argparse.Namespace, cfg) -> tuple[tuple[float, float] | None,
                                                             int | None]:
    """``((A, B), N)``: the nozzle band [Hz] of ``--frequencies A:B:N`` or of ``--speeds``
    (``n_s A .. n_s B``) and its coarse grid's count, checked as ``forced.band_hz`` and
    ``forced.points`` (and the speeds as ``wheel.speed_hz``) would be but named by the
    option; ``(None, None)``: the band of ``[forced]``."""
    if args.frequencies and args.speeds:
        raise InputError("--frequencies and --speeds exclude each other (one range)")
    option, text = ("--speeds", args.speeds) if args.speeds else ("--frequencies",
                                                                  args.frequencies)
    if not text:
        return None, None
    why = "one linear solve each, twice when mistuned"
    a, b, n = parse_range(text, option, MAX_FREQUENCIES, why, one_point=True)
    if args.speeds:
        for speed in (a, b):
            with_option(cfg, f"{option} {text}", {"wheel.speed_hz": speed})
        a, b = cfg.wheel.stator_vanes * a, cfg.wheel.stator_vanes * b
    with_option(cfg, f"{option} {text}", {"forced.points": n} if a == b else
                {"forced.band_hz": [a, b], "forced.points": n})
    return (a, b), n


def parse_angles(pairs: list[list[str]], cfg) -> dict:
    """``--angle KIND DEG`` pairs -> kind -> angle [deg], each checked as
    ``contacts.<kind>.angle_deg`` (0..90 deg) and refused for a kind ``cfg`` disables (it
    would be silently unused)."""
    out = {}
    for kind, value in pairs:
        if kind not in CONTACT_KINDS:
            raise InputError(f"--angle {cut(kind)}: contact kinds are "
                             f"{', '.join(CONTACT_KINDS)}")
        option = f"--angle {kind} {cut(value)}"
        try:
            angle = float(value)
        except ValueError:
            raise InputError(f"{option}: the angle is a number [deg]") from None
        with_option(cfg, option, {f"contacts.{kind}.angle_deg": angle})
        if not cfg.contact(kind).enabled:
            raise InputError(f"{option}: contacts.{kind}.enabled is false, the angle would "
                             f"not be used (enable the {kind} contact or leave the option out)")
        if kind in out:
            raise InputError(f"{option}: --angle {kind} given twice")
        out[kind] = angle
    return out
