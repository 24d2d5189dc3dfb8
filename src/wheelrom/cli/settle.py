"""``wheelrom settle``: parse, call :func:`wheelrom.studies.settle.run_settle`, write and
format."""

from __future__ import annotations

import argparse
import os
import shutil

from wheelrom.cli.args import json_out, load_config, locked
from wheelrom.cli.output import log, number_ranges, report_and_save, throttled
from wheelrom.runtime.errors import InputError
from wheelrom.runtime.outputs import agree, check_output

PROGRESS_EVERY_S = 5.0


def args_settle(p: argparse.ArgumentParser) -> None:
    json_out(p)
    p.add_argument("--out", help="write the settled states to this HDF5 file (finished cases "
                   "are kept beside it while the job runs: --resume continues)")  # fmt: skip
    p.add_argument("--cycles", help="a limit-cycle file (wheelrom limit-cycle --out) whose "
                   "exact orbits start the cases (settle.start = 'cycle')")  # fmt: skip
    p.add_argument("--force", action="store_true", help="overwrite an existing --out")
    p.add_argument("--resume", action="store_true",
                   help="keep the cases an interrupted run of the same configuration finished")


@locked("--out")
def cmd_settle(args: argparse.Namespace) -> int:
    """Where the flutter settles: per case the wheel integrated from the fastest wave's orbit
    (every ND perturbed) until stationary, the settled state classified (periodic,
    quasi-periodic, chaotic), its amplitude over the blades, ND content, contacts. Under
    mpirun the cases are spread over the ranks."""
    from wheelrom.rom.build import quiet
    from wheelrom.studies.settle import run_settle, sidecar_dir, summary
    from wheelrom.studies.stability import world_if_parallel

    cfg = load_config(args)
    if args.out:
        check_output(args.out, args.force or args.resume)
    if args.cycles and not os.path.isfile(args.cycles):
        raise InputError(f"--cycles {args.cycles}: no such file")
    if args.out and not args.resume and os.path.isdir(sidecar_dir(args.out)):
        shutil.rmtree(sidecar_dir(args.out))  # an earlier run's cases, not asked for
    from wheelrom.results.settle import write_settle

    comm = world_if_parallel()
    model, cases, directory = run_settle(
        cfg, args.out, comm, log=quiet if args.json else log, resume=args.resume,
        cycles_file=args.cycles, progress=None if args.json else throttled(PROGRESS_EVERY_S))
    failure = None
    if cases:
        beside = _kept_beside(directory, cfg) if directory else ""
        failure = report_and_save(
            [summary(a, p, r) for a, p, r in cases], args.json, _print_rows, args.out,
            lambda f: write_settle(f, cfg, model, cases),
            "; ".join(["the summary is printed above", *([beside] if beside else [])]))
        if directory and os.path.isdir(directory) and (failure is None or not beside):
            shutil.rmtree(directory)  # in the file, or no case of it kept (a full disk)
    agree(comm, failure)
    return 1 if any(r.status != "done" for _, _, r in cases) else 0


def _kept_beside(directory: str, cfg) -> str:
    """Which cases stay in the side folder for ``--resume`` ("" none)."""
    from wheelrom.studies.settle import kept_cases

    kept, total = kept_cases(directory, cfg)
    if not kept:
        return ""
    which = number_ranges([i + 1 for i in kept])
    if len(kept) == 1:
        return f"case {which} of {total} also stays in {directory} (--resume reuses it)"
    return f"cases {which} of {total} also stay in {directory} (--resume reuses them)"


def _print_rows(rows: list[dict]) -> None:
    for row in rows:
        print(f"{row['label']}: {row['verdict']}")
