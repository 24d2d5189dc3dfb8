"""``wheelrom settle``: parse, call :func:`wheelrom.studies.settle.run_settle`, write and
format."""

from __future__ import annotations

import argparse
import os
import shlex

from wheelrom.cli.args import json_out, load_config, locked
from wheelrom.cli.output import log, report_and_save, throttled
from wheelrom.runtime.errors import InputError, Interrupted
from wheelrom.runtime.outputs import agree, output_problem

PROGRESS_EVERY_S = 5.0


def args_settle(p: argparse.ArgumentParser) -> None:
    json_out(p)
    p.add_argument("--out", help="write the settled states to this HDF5 file (finished cases "
                   "are kept beside it while the job runs: --resume continues)")
    p.add_argument("--cycles", help="a limit-cycle file (wheelrom limit-cycle --out) whose "
                   "exact orbits start the cases (settle.start = 'cycle')")
    existing = p.add_mutually_exclusive_group()
    existing.add_argument("--force", action="store_true",
                          help="overwrite an existing --out (and discard the cases kept "
                          "beside it)")
    existing.add_argument("--resume", action="store_true",
                          help="keep the cases an interrupted run of the same configuration "
                          "finished beside --out")


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
    from wheelrom.studies.settle import band_from_file, check_cycles, histories, run_settle, summary
    from wheelrom.studies.settle_cases import kept_folder
    from wheelrom.studies.stability import world_if_parallel

    if args.resume and not args.out:  # what it reuses is kept beside --out
        raise InputError("--resume: continues the cases an interrupted run kept beside its "
                         "--out; give that --out")
    cfg = load_config(args)
    comm = world_if_parallel()
    folder = kept_folder(args.out) if args.out else None
    problem = None
    if folder and (comm is None or comm.rank == 0):  # one rank reads: the others are told
        problem = _output_problem(args, cfg, folder)
    agree(comm, problem)
    if args.cycles:  # before any model is built: a wrong file fails every case late
        check_cycles(args.cycles, cfg)
    from wheelrom.results.settle import write_settle

    # an earlier run's cases, discarded (--force): removed by one rank before any rank keeps
    # a case (two ranks removing it raced, one unlinking what the other had listed)
    if folder and not args.resume and (comm is None or comm.rank == 0):
        folder.clear()
    if comm is not None:
        comm.barrier()
    try:
        model, cases, folder = run_settle(
            cfg, args.out, comm, log=quiet if args.json else log, resume=args.resume,
            cycles_file=args.cycles, progress=None if args.json else throttled(PROGRESS_EVERY_S),
            warn=log)
    except KeyboardInterrupt:  # Ctrl-C, or mpirun's SIGTERM (a rank killed): say what is kept
        raise _interrupted(args, cfg) from None
    failure = None
    if cases:
        beside = _kept_beside(folder, cfg) if folder else ""
        rows = [summary(a, p, r) for a, p, r in cases]
        # cases that differ only in how they started: their spread beside the band
        groups = histories(rows, (lambda angles: band_from_file(args.cycles, angles))
                           if args.cycles else None)
        failure = report_and_save(
            rows, args.json, lambda rows: _print_rows(rows, groups), args.out,
            lambda f: write_settle(f, cfg, model, cases),
            "; ".join(["the summary is printed above", *([beside] if beside else [])]),
            {"histories": groups} if groups else None)
        if folder and (failure is None or not beside):
            folder.clear()  # in the file, or no case of it kept (a full disk)
    agree(comm, failure)
    return 1 if any(r.status != "done" for _, _, r in cases) else 0


def _output_problem(args: argparse.Namespace, cfg, folder) -> InputError | None:
    """Why ``--out`` or the folder of its kept cases cannot serve this run (None: they
    can), before anything is computed: an existing file is replaced only with ``--force``
    (``--resume`` says why it cannot go on with it:
    :func:`~wheelrom.studies.settle.resume_problem`), and the folder passes
    :meth:`~wheelrom.studies.kept_cases.KeptCases.problem`."""
    from wheelrom.config.study import expand
    from wheelrom.studies.settle import resume_problem

    problem = output_problem(args.out, args.force)
    if problem is not None and args.resume and os.path.exists(args.out) and \
            not os.path.isdir(args.out):
        why = resume_problem(args.out, cfg)  # never replaced without --force
        problem = InputError(why) if why else problem
    return problem or folder.problem(expand(cfg).configs, args.resume, args.force)


def _which(kept: dict, total: int) -> str:
    """``"case 1 of 0..2"``, ``"cases 0..2, 4 of 0..7"``: the kept cases among all, numbered
    from 0 as the files, ``info`` and ``--confirm`` number them."""
    from wheelrom.studies.kept_cases import case_numbers

    return f"{case_numbers(kept)} of 0..{total - 1}"


def _kept_beside(folder, cfg) -> str:
    """Which cases stay in the side folder for ``--resume`` ("" none)."""
    from wheelrom.config.study import expand

    configs = expand(cfg).configs
    kept = folder.kept(configs)
    if not kept:
        return ""
    if len(kept) == 1:
        return f"{_which(kept, len(configs))} also stays in {folder.path} (--resume reuses it)"
    return f"{_which(kept, len(configs))} also stay in {folder.path} (--resume reuses them)"


def _interrupted(args: argparse.Namespace, cfg) -> Interrupted:
    """What a stop leaves: the finished cases kept beside ``--out`` (each saved as it
    finished, on every rank) and the shell-quoted line that resumes with them."""
    from wheelrom.config.study import expand
    from wheelrom.results.info import resume_line
    from wheelrom.studies.settle_cases import kept_folder

    if not args.out:
        return Interrupted("interrupted: nothing was being saved (no --out)")
    folder, configs = kept_folder(args.out), expand(cfg).configs
    kept, total = folder.kept(configs), len(configs)
    if not kept:
        return Interrupted(f"interrupted: none of the {total} case(s) had finished; nothing "
                           "is kept")
    failed = sum(status != "done" for status in kept.values())
    failed = f" ({failed} failed: --resume does not rerun them)" if failed else ""
    left = total - len(kept)
    then = f"to compute only the other {left}" if left else "to write the file from them"
    flags = f" --cycles {shlex.quote(args.cycles)}" if args.cycles else ""
    return Interrupted(f"interrupted: {_which(kept, total)} finished and kept in {folder.path}"
                       f"{failed}; {then}, rerun the settle with{flags} --resume"
                       + resume_line(args.out, cfg.source, "settle", flags))


def _print_rows(rows: list[dict], groups: list[dict]) -> None:
    from wheelrom.studies.settle import history_words

    for row in rows:
        print(f"{row['label']}: {row['verdict']}")
    # the step the integration took, once per distinct one (the exponential scheme's
    # stability check may lower the asked step: the user should not read 20 us where 18 ran)
    # (batches' windows differ in their last digits: one line per step as printed)
    said: dict[str, str] = {}
    for row in rows:
        if row.get("step_s"):
            said.setdefault(f"{row['step_s'] * 1e6:.4g}", row["step_lowered"])
    for step, why in said.items():
        print(f"integrated at {step} us" + (f" ({why})" if why else ""))
    for group in groups:
        print(history_words(group))
