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

import math
import os
import time

from wheelrom import results
from wheelrom._environment import petsc, slepc
from wheelrom.config import Config
from wheelrom.errors import InputError, OutputExists
from wheelrom.rom.build import build_model
from wheelrom.transient.problem import CaseResult
from wheelrom.transient.run import run_cases


def run_sweep(cfg: Config, out: str, comm, resume: bool = False, force: bool = False,
              log=print, options: dict | None = None, model_comm: str = "rank0",
              batch: int = 0) -> int:  # fmt: skip
    """Run the sweep of ``cfg`` into ``out``; returns the number of failed cases.

    Collective over ``comm`` (mpi4py). Progress lines go to ``log`` on rank 0.
    ``model_comm``: ``"rank0"`` builds the model on rank 0 and broadcasts it (results
    independent of the number of ranks); ``"world"`` runs the segment eigen-solve distributed
    over all ranks (for segments too large for one rank; the modes then agree with a serial
    build to the eigen-solver tolerance, not bitwise). ``batch``: cases per TS on a rank (0:
    all of the rank's cases at once; see the module docstring). ``options``: PETSc options
    of the case TS (keys without the ``wheel_`` prefix).
    """
    import h5py

    # PetscInitialize is collective on COMM_WORLD: every rank initialises before rank 0
    # alone builds the model
    petsc()
    slepc()
    say = log if comm.rank == 0 else (lambda *_: None)
    if batch < 0:
        raise InputError(f"sweep batch must be >= 0, not {batch}")
    if model_comm not in ("rank0", "world"):
        raise InputError(f"model_comm must be 'rank0' or 'world', not {model_comm!r}")
    # decide what to do with the output file before computing anything
    problem = _output_problem(out, cfg, resume, force) if comm.rank == 0 else None
    problem = comm.bcast(problem)
    if problem:
        raise problem
    mode = "r+" if (resume and os.path.exists(out)) else "w"
    t0 = time.perf_counter()
    model = _shared_model(cfg, comm, model_comm, say)
    say(f"model ready in {time.perf_counter() - t0:.1f} s: {model.blades} blades x "
        f"{model.modes} modes")  # fmt: skip
    with h5py.File(out, mode, driver="mpio", comm=comm) as f:
        if mode == "w":
            results.create_layout(f, cfg, model)
            f.flush()
        _run_rounds(f, cfg, model, comm, batch, options, say)
        failed = sum(1 for s in results.statuses(f) if s.startswith("failed"))
    say(f"sweep finished in {time.perf_counter() - t0:.1f} s; {failed} case(s) failed")
    return failed


def _output_problem(out: str, cfg: Config, resume: bool, force: bool) -> InputError | None:
    """Why ``out`` must not be written (None: go ahead)."""
    if not os.path.exists(out):
        return None
    if not (resume or force):
        return OutputExists(out)
    if resume:
        why = results.resume_problem(out, cfg)
        return InputError(why) if why else None
    return None


def _shared_model(cfg: Config, comm, model_comm: str, say):
    """The reduced model on every rank: built on rank 0 and broadcast, or built by all."""
    if model_comm == "world":
        return build_model(cfg, petsc().COMM_WORLD, log=say)
    model = build_model(cfg, petsc().COMM_SELF, log=say) if comm.rank == 0 else None
    return comm.bcast(model)


def _run_rounds(f, cfg: Config, model, comm, batch: int, options, say) -> None:
    """Deal the pending cases to the ranks and run them in rounds of one batch per rank;
    after every round all ranks flush the file (collective) and rank 0 reports."""
    angles = results.case_angles(cfg)
    C = angles.shape[0]
    status = results.statuses(f)
    todo = [i for i in range(C) if status[i] == "pending"]
    say(f"{C} cases, {len(todo)} to run on {comm.size} rank(s)")
    done = C - len(todo)
    mine = todo[comm.rank :: comm.size]
    per_rank = math.ceil(len(todo) / comm.size)
    width = batch or max(per_rank, 1)
    rounds = math.ceil(per_rank / width)
    t_sweep = time.perf_counter()
    for r in range(rounds):
        chunk = mine[r * width : (r + 1) * width]
        finished: list[CaseResult] = []
        if chunk:
            progress = _progress_printer(say, len(chunk), cfg.time.end, r, rounds)
            try:
                finished = run_cases(model, cfg, [results.angles_of(angles[i]) for i in chunk],
                                     options=options, progress=progress)  # fmt: skip
            except Exception as exc:  # a solver error fails this batch, not the sweep
                finished = [CaseResult(status=f"failed: {type(exc).__name__}: {exc}")
                            for _ in chunk]  # fmt: skip
            for i, res in zip(chunk, finished, strict=True):
                results.write_case(f, i, res)
        f.flush()  # collective: every finished round is on disk
        report = [(i, res.status, res.wall_s, res.batch)
                  for i, res in zip(chunk, finished, strict=True)]  # fmt: skip
        gathered = comm.gather(report, root=0)
        if comm.rank == 0:
            eta = (time.perf_counter() - t_sweep) / (r + 1) * (rounds - r - 1)
            for i, st, wall, width_used in sorted(item for part in gathered for item in part):
                done += 1
                tb, sh = angles[i]
                share = f"{wall:.1f} s" + ("" if width_used == 1 else f", batch of {width_used}")
                say(f"[{done}/{C}] tie-boss {tb:g} deg, shroud {sh:g} deg: {st} ({share}); "
                    f"about {eta:.0f} s left")  # fmt: skip


def _progress_printer(say, cases: int, t_end: float, round_index: int, rounds: int):
    """Progress of a long batch (rank 0's view): about every tenth of the simulated time."""
    t0 = time.perf_counter()
    last = [0.0]

    def progress(window, windows, t, amplitude):
        if t - last[0] < 0.1 * t_end and window < windows:
            return
        last[0] = t
        elapsed = time.perf_counter() - t0
        left = elapsed * (t_end - t) / max(t, 1e-300)
        say(
            f"  round {round_index + 1}/{rounds}: {cases} case(s), t = {t:.4g} of {t_end:g} s, "
            f"largest tip amplitude {amplitude:.3g} m, {elapsed:.0f} s, about {left:.0f} s left"
        )

    return progress
