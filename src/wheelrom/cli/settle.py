"""``wheelrom settle``: parse, call :func:`wheelrom.studies.settle.run_settle`, write and
format."""

from __future__ import annotations

import argparse
import os
import shutil

from wheelrom.cli.args import json_out, load_config, locked
from wheelrom.cli.output import log, report_and_save, throttled
from wheelrom.runtime.errors import InputError
from wheelrom.runtime.outputs import agree, check_output, check_side_folder

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
    from wheelrom.studies.settle import (
        check_cycles,
        resume_problem,
        run_settle,
        sidecar_dir,
        summary,
    )
    from wheelrom.studies.stability import world_if_parallel

    cfg = load_config(args)
    if args.out:
        check_output(args.out, args.force or args.resume)
        if args.resume and not args.force and os.path.exists(args.out):
            why = resume_problem(args.out)  # another command's file is replaced only by --force
            if why:
                raise InputError(why)
        check_side_folder(sidecar_dir(args.out), args.out)  # before it is used or removed
    if args.cycles:  # before any model is built: a wrong file fails every case late
        check_cycles(args.cycles, cfg)
    if args.out and not args.resume and os.path.isdir(sidecar_dir(args.out)):
        shutil.rmtree(sidecar_dir(args.out))  # an earlier run's cases, not asked for
    from wheelrom.results.settle import write_settle

    comm = world_if_parallel()
    model, cases, directory = run_settle(
        cfg, args.out, comm, log=quiet if args.json else log, resume=args.resume,
        cycles_file=args.cycles, progress=None if args.json else throttled(PROGRESS_EVERY_S),
        warn=log)  # fmt: skip
    failure = None
    if cases:
        failure = report_and_save(
            [summary(a, p, r) for a, p, r in cases], args.json, _print_rows, args.out,
            lambda f: write_settle(f, cfg, model, cases),
            f"the finished cases stay in {directory}")  # fmt: skip
        if args.out and failure is None and directory and os.path.isdir(directory):
            shutil.rmtree(directory)
    agree(comm, failure)
    return 1 if any(r.status != "done" for _, _, r in cases) else 0


def _print_rows(rows: list[dict]) -> None:
    for row in rows:
        print(f"{row['label']}: {row['verdict']}")
