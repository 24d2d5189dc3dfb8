"""``wheelrom settle``: parse, call :func:`wheelrom.studies.settle.run_settle`, write and
format."""

from __future__ import annotations

import argparse
import os
import shlex
import shutil

from wheelrom.cli.args import json_out, load_config, locked
from wheelrom.cli.output import log, number_ranges, report_and_save, throttled
from wheelrom.runtime.errors import InputError, Interrupted
from wheelrom.runtime.outputs import agree, check_output, check_side_folder

PROGRESS_EVERY_S = 5.0


def args_settle(p: argparse.ArgumentParser) -> None:
    json_out(p)
    p.add_argument("--out", help="write the settled states to this HDF5 file (finished cases "
                   "are kept beside it while the job runs: --resume continues)")
    p.add_argument("--cycles", help="a limit-cycle file (wheelrom limit-cycle --out) whose "
                   "exact orbits start the cases (settle.start = 'cycle')")
    p.add_argument("--force", action="store_true", help="overwrite an existing --out")
    p.add_argument("--resume", action="store_true",
                   help="keep the cases an interrupted run of the same configuration finished")


@locked("--out")
def cmd_settle(args: argparse.Namespace) -> int:
    """Where the flutter settles: per case the wheel integrated from the fastest wave's exact
    orbit (settle.start = 'cycle', from --cycles or computed here; 'preload': the preloaded
    equilibrium with the unstable waves seeded), every ND perturbed, until stationary; the
    settled state classified (periodic, quasi-periodic, chaotic), its amplitude over the
    blades, ND content, contacts; a case not settled by settle.max_time is 'still growing' or
    'bounded' by its amplitude's trend. Cases are integrated in batches (settle.batch); under
    mpirun the batches go to the ranks as they become free."""
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
    from wheelrom.results.settle import write_settle

    comm = world_if_parallel()
    # an earlier run's cases, not asked for: removed by one rank before any rank keeps a case
    # (two ranks removing it raced, one unlinking what the other had listed)
    if args.out and not args.resume and (comm is None or comm.rank == 0) and \
            os.path.isdir(sidecar_dir(args.out)):
        shutil.rmtree(sidecar_dir(args.out))
    if comm is not None:
        comm.barrier()
    try:
        model, cases, directory = run_settle(
            cfg, args.out, comm, log=quiet if args.json else log, resume=args.resume,
            cycles_file=args.cycles, progress=None if args.json else throttled(PROGRESS_EVERY_S),
            warn=log)
    except KeyboardInterrupt:  # Ctrl-C, or mpirun's SIGTERM (a rank killed): say what is kept
        raise _interrupted(args, cfg) from None
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


def _which(kept: dict, total: int) -> str:
    """``"case 2 of 3"``, ``"cases 1..3, 5 of 8"``: the kept cases, numbered from 1."""
    which = number_ranges([i + 1 for i in sorted(kept)])
    return f"case{'s' if len(kept) > 1 else ''} {which} of {total}"


def _kept_beside(directory: str, cfg) -> str:
    """Which cases stay in the side folder for ``--resume`` ("" none)."""
    from wheelrom.studies.settle import kept_cases

    kept, total = kept_cases(directory, cfg)
    if not kept:
        return ""
    if len(kept) == 1:
        return f"{_which(kept, total)} also stays in {directory} (--resume reuses it)"
    return f"{_which(kept, total)} also stay in {directory} (--resume reuses them)"


def _interrupted(args: argparse.Namespace, cfg) -> Interrupted:
    """What a stop leaves: the finished cases kept beside ``--out`` (each saved as it
    finished, on every rank) and the shell-quoted line that resumes with them."""
    from wheelrom.results.info import resume_line
    from wheelrom.studies.settle import kept_cases, sidecar_dir

    if not args.out:
        return Interrupted("interrupted: nothing was being saved (no --out)")
    directory = sidecar_dir(args.out)
    kept, total = kept_cases(directory, cfg)
    if not kept:
        return Interrupted(f"interrupted: none of the {total} case(s) had finished; nothing "
                           "is kept")
    failed = sum(status != "done" for status in kept.values())
    failed = f" ({failed} failed: --resume does not rerun them)" if failed else ""
    left = total - len(kept)
    then = f"to compute only the other {left}" if left else "to write the file from them"
    flags = f" --cycles {shlex.quote(args.cycles)}" if args.cycles else ""
    return Interrupted(f"interrupted: {_which(kept, total)} finished and kept in {directory}"
                       f"{failed}; {then}, rerun the settle with{flags} --resume"
                       + resume_line(args.out, cfg.source, "settle", flags))


def _print_rows(rows: list[dict]) -> None:
    for row in rows:
        print(f"{row['label']}: {row['verdict']}")
