"""Angle sweeps across MPI ranks into one parallel HDF5 file (layout: ``docs/output.md``).

The reduced model is built once on rank 0 and broadcast, so case results cannot depend on
the number of ranks. The pending cases (tie-boss angle x shroud angle) are dealt round-robin
to the ranks; each rank integrates its cases in batches of ``batch`` cases, one TS on
``COMM_SELF`` per batch (:func:`wheelrom.transient.run.run_cases`: a case's result is bitwise the
same in any batch). Rounds: every rank integrates one batch, then all ranks write their cases
into preallocated datasets and flush collectively. A sweep killed at any moment therefore
leaves a file holding every case of every finished round; ``--resume`` runs the cases still
pending. ``batch = 0`` (default) puts all of a rank's cases in one batch: fastest, but a kill
loses the whole round; ``batch = 1`` writes every case as soon as it is done.
"""

from __future__ import annotations

import json
import math
import os
import time

from wheelrom.config import Config
from wheelrom.results import layout as results
from wheelrom.results.info import resume_hint
from wheelrom.rom.build import build_model
from wheelrom.runtime import interrupts
from wheelrom.runtime.environment import petsc, slepc
from wheelrom.runtime.errors import InputError, Interrupted
from wheelrom.runtime.locks import output_lock
from wheelrom.runtime.outputs import create_collectively, output_problem
from wheelrom.studies.rounds import check_space_collectively, run_rounds
from wheelrom.studies.stability import attach_linear, refuse_study
from wheelrom.transient.run import check_run_memory, run_cases
from wheelrom.transient.ts import PREFIX, ts_settings


def run_sweep(cfg: Config, out: str, comm, resume: bool = False, force: bool = False,
              log=print, options: dict | None = None, model_comm: str = "rank0",
              batch: int = 0) -> int:
    """Run the sweep of ``cfg`` into ``out``; returns the number of failed cases.

    Collective over ``comm`` (mpi4py). Progress lines go to ``log`` on rank 0.
    ``model_comm``: ``"rank0"`` builds the model on rank 0 and broadcasts it (results
    independent of the number of ranks); ``"world"`` runs the segment eigen-solve distributed
    over all ranks (for segments too large for one rank; the modes then agree with a serial
    build to the eigen-solver tolerance, not bitwise). ``batch``: cases per TS on a rank (0:
    all of the rank's cases at once; see the module docstring). ``options``: PETSc options
    of the case TS (keys without the ``wheel_`` prefix). Raises :class:`Interrupted` after a
    Ctrl-C / SIGTERM, once the finished rounds are safely in the file. ``out`` is locked
    for the whole sweep (:func:`wheelrom.runtime.locks.output_lock`): another job on it
    is refused before anything is computed.
    """
    with output_lock(out, comm):
        return _sweep(cfg, out, comm, resume, force, log, options, model_comm, batch)


def _sweep(cfg: Config, out: str, comm, resume: bool, force: bool, log, options: dict | None,
           model_comm: str, batch: int) -> int:
    import h5py

    # PetscInitialize is collective on COMM_WORLD: every rank initialises before rank 0
    # alone builds the model
    petsc()
    slepc()
    say = log if comm.rank == 0 else (lambda *_: None)
    refuse_study(cfg, "sweep")
    if batch < 0:
        raise InputError(f"--batch {batch}: must be >= 0 (0: all of a rank's cases at once)")
    if model_comm not in ("rank0", "world"):
        raise InputError(f"model_comm must be 'rank0' or 'world', not {model_comm!r}")
    if resume and force:
        raise InputError("--resume and --force exclude each other (complete the file, or "
                         "start it again)")
    cases = len(results.case_angles(cfg))
    check_run_memory(cfg, min(batch, cases) or max(math.ceil(cases / comm.size), 1))
    # decide what to do with the output file before computing anything
    settings = ts_settings(cfg, PREFIX, options)
    recorded = len(json.dumps(settings))  # /cases/options holds STATUS_LEN bytes per case
    if recorded > results.STATUS_LEN:
        raise InputError(f"too many TS options to record ({recorded} bytes of JSON, at most "
                         f"{results.STATUS_LEN}): pass fewer -wheel_ts_* options")
    problem = None
    if comm.rank == 0:
        try:
            problem = _output_problem(out, cfg, resume, force, settings)
        except Exception as exc:  # rank 0's surprise must not leave the others waiting
            problem = InputError(f"{out}: cannot be checked for --resume ({exc})")
    problem = comm.bcast(problem)
    if problem:
        raise problem
    fresh = not (resume and os.path.exists(out))
    t0 = time.perf_counter()
    model = _shared_model(cfg, comm, model_comm, say)
    say(f"model ready in {time.perf_counter() - t0:.1f} s: {model.blades} blades x "
        f"{model.modes} modes")
    # the whole file, or what a resumed one still lacks, checked against the free disk space
    # before any case is integrated
    needed = results.layout_bytes(lambda f: results.create_layout(f, cfg, model))
    check_space_collectively(out, needed - (0 if fresh else os.path.getsize(out)), comm)
    if fresh:
        _create(out, cfg, model, comm)
    with interrupts.deferred(), h5py.File(out, "r+", driver="mpio", comm=comm) as f:
        stopped = _run_rounds(f, cfg, model, comm, batch, options, say, settings)
        status = results.statuses(f)
    failed = sum(1 for s in status if s.startswith("failed"))
    done = sum(1 for s in status if s != "pending")
    if stopped:
        counts = {"pending": len(status) - done, "failed": failed}
        raise Interrupted(f"interrupted: {done} of {len(status)} cases done and saved in {out}; "
                          + resume_hint(out, cfg.source, counts))
    say(f"sweep finished in {time.perf_counter() - t0:.1f} s; {failed} case(s) failed")
    return failed


def _create(out: str, cfg: Config, model, comm) -> None:
    """The file with its full layout, every case pending: built under a temporary name
    (collectively) and renamed into place by rank 0, so ``out`` is readable from the moment
    it exists; an existing ``out`` (``--force``) is replaced only then."""
    create_collectively(out, comm, lambda f: results.create_layout(f, cfg, model))


def _output_problem(out: str, cfg: Config, resume: bool, force: bool,
                    settings: dict) -> InputError | None:
    """Why ``out`` must not be written (None: go ahead)."""
    problem = output_problem(out, force=resume or force)
    if problem or not (resume and os.path.exists(out)):
        return problem
    why = results.resume_problem(out, cfg) or results.options_problem(out, settings)
    return InputError(why) if why else None


def _shared_model(cfg: Config, comm, model_comm: str, say):
    """The reduced model on every rank: built on rank 0 and broadcast, or built by all."""
    if model_comm == "world":
        return build_model(cfg, petsc().COMM_WORLD, log=say)
    model = build_model(cfg, petsc().COMM_SELF, log=say) if comm.rank == 0 else None
    return comm.bcast(model)


def _run_rounds(f, cfg: Config, model, comm, batch: int, options, say,
                settings: dict) -> bool:
    """Deal the pending cases to the ranks and run them in rounds of one batch per rank
    (:func:`wheelrom.studies.rounds.run_rounds`). Returns whether a stop was requested (then
    the unfinished batch stays pending)."""
    angles = results.case_angles(cfg)
    C = angles.shape[0]
    status = results.statuses(f)
    todo = [i for i in range(C) if status[i] == "pending"]
    say(f"{C} cases, {len(todo)} to run on {comm.size} rank(s)")
    done = [C - len(todo)]
    mine = todo[comm.rank :: comm.size]
    width = batch or max(math.ceil(len(todo) / comm.size), 1)
    plan = [mine[start : start + width] for start in range(0, len(mine), width)]

    def run_batch(chunk, progress):
        cases = [results.angles_of(angles[i]) for i in chunk]
        return run_cases(model, cfg, cases, options=options, progress=progress)

    def attach(i, res):
        attach_linear(model, cfg, results.angles_of(angles[i]), res)

    def line(i, status, wall, width_used, compiled, verdict):
        done[0] += 1
        tb, sh = angles[i]
        share = f"{wall:.3g} s" + ("" if width_used == 1 else f", batch of {width_used}")
        share += f" + {compiled:.2g} s kernels" if compiled > 0.05 else ""
        return (f"[{done[0]}/{C}] tie-boss {tb:g} deg, shroud {sh:g} deg: {status} ({share}); "
                f"{verdict}")

    return run_rounds(f, plan, comm, run_batch, settings, attach, line, say, cfg.time.end)
