"""Command line: a thin layer over the library (``wheelrom --help``).

Every subcommand takes an optional CONFIG (TOML; none = built-in default case), any number of
``--set section.key=value`` overrides, and after ``--`` options for the PETSc database.
Configuration errors exit with status 2 before anything is computed or written.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Sequence

from wheelrom import config as config_mod
from wheelrom.errors import InputError

EXIT_CONFIG = 2


def _add_config_args(p: argparse.ArgumentParser, required: bool = False) -> None:
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


def _load(args: argparse.Namespace) -> config_mod.Config:
    return config_mod.load(args.config, args.overrides)


def _petsc_options(args: argparse.Namespace) -> None:
    """Insert the arguments after ``--`` into the PETSc options database."""
    if getattr(args, "petsc_args", None):
        from wheelrom._environment import petsc

        petsc().Options().insertString(" ".join(args.petsc_args))


# --------------------------------------------------------------------------------------
# subcommands
# --------------------------------------------------------------------------------------


def cmd_config_show(args: argparse.Namespace) -> int:
    cfg = _load(args)
    sys.stdout.write(f"# effective configuration from {cfg.source}\n")
    sys.stdout.write(config_mod.to_toml(cfg))
    return 0


def cmd_config_check(args: argparse.Namespace) -> int:
    cfg = _load(args)
    print(f"{cfg.source}: OK")
    return 0


COMMANDS: dict[
    str, tuple[Callable[[argparse.Namespace], int], str, Callable[[argparse.ArgumentParser], None]]
] = {}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="wheelrom",
        description=(
            "Reduced modal model of a bladed turbine wheel with dry-friction tie-boss and "
            "shroud contacts, Van der Pol flutter and nozzle excitation (PETSc/SLEPc). "
            "Arguments after '--' go to the PETSc options database."
        ),
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p_cfg = sub.add_parser("config", help="show or check a configuration")
    cfg_sub = p_cfg.add_subparsers(dest="config_command", metavar="ACTION")
    cfg_sub.required = True
    p = cfg_sub.add_parser("show", help="print the effective configuration as TOML")
    _add_config_args(p)
    p.set_defaults(func=cmd_config_show)
    p = cfg_sub.add_parser("check", help="validate a configuration file (exit 2 if invalid)")
    _add_config_args(p, required=True)
    p.set_defaults(func=cmd_config_check)

    for name, (func, help_text, extra) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=func.__doc__)
        _add_config_args(p)
        extra(p)
        p.set_defaults(func=func)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    petsc_args: list[str] = []
    if "--" in argv:
        cut = argv.index("--")
        argv, petsc_args = argv[:cut], argv[cut + 1 :]
    parser = build_parser()
    args = parser.parse_args(argv)
    args.petsc_args = petsc_args
    try:
        _petsc_options(args)
        return int(args.func(args) or 0)
    except config_mod.ConfigError as exc:
        print(f"wheelrom: {exc}", file=sys.stderr)
        return EXIT_CONFIG
    except InputError as exc:
        print(f"wheelrom: {exc}", file=sys.stderr)
        return EXIT_CONFIG


def print_json(obj: object) -> None:
    json.dump(obj, sys.stdout, indent=1, default=float)
    sys.stdout.write("\n")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
