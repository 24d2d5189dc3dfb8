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
from wheelrom.rom.build import build_model
from wheelrom.runtime import interrupts
from wheelrom.runtime.environment import petsc, slepc
from wheelrom.runtime.errors import InputError, Interrupted
from wheelrom.runtime.outputs import create_collectively, output_problem
from wheelrom.studies.stability import attach_linear, refuse_study
from wheelrom.transient.problem import CaseResult
from wheelrom.transient.run import run_cases
from wheelrom.transient.ts import PREFIX, ts_settings


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
    of the case TS (keys without the ``wheel_`` prefix). Raises :class:`Interrupted` after a
    Ctrl-C / SIGTERM, once the finished rounds are safely in the file.
    """
    import h5py

    # PetscInitialize is collective on COMM_WORLD: every rank initialises before rank 0
    # alone builds the model
    petsc()
    slepc()
    say = log if comm.rank == 0 else (lambda *_: None)
    refuse_study(cfg, "sweep")
    if batch < 0:
        raise InputError(f"sweep batch must be >= 0, not {batch}")
    if model_comm not in ("rank0", "world"):
        raise InputError(f"model_comm must be 'rank0' or 'world', not {model_comm!r}")
    if resume and force:
        raise InputError("--resume and --force exclude each other (complete the file, or "
                         "start it again)")  # fmt: skip
    # decide what to do with the output file before computing anything
    settings = ts_settings(cfg, PREFIX, options)
    recorded = len(json.dumps(settings))  # /cases/options holds STATUS_LEN bytes per case
    if recorded > results.STATUS_LEN:
        raise InputError(f"too many TS options to record ({recorded} bytes of JSON, at most "
                         f"{results.STATUS_LEN}): pass fewer -wheel_ts_* options")  # fmt: skip
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
        f"{model.modes} modes")  # fmt: skip
    if fresh:
        _create(out, cfg, model, comm)
    with interrupts.deferred(), h5py.File(out, "r+", driver="mpio", comm=comm) as f:
        stopped = _run_rounds(f, cfg, model, comm, batch, options, say, settings)
        status = results.statuses(f)
    failed = sum(1 for s in status if s.startswith("failed"))
    done = sum(1 for s in status if s != "pending")
    if stopped:
        raise Interrupted(f"interrupted: {done} of {len(status)} cases done and saved in {out}; "
                          "rerun with --resume to complete it")  # fmt: skip
    say(f"sweep finished in {time.perf_counter() - t0:.1f} s; {failed} case(s) failed")
    return failed


def _create(out: str, cfg: Config, model, comm) -> None:
    """The file with its full layout, every case pending: built under a temporary name
    (collectively) and renamed into place by rank 0, so ``out`` is readable from the moment
    it exists; an existing ``out`` (``--force``) is replaced only then."""
    create_collectively(out, comm, lambda f: results.create_layout(f, cfg, model))


def _output_problem(out: str, cfg: Config, resume: bool, force: bool,
                    settings: dict) -> InputError | None:  # fmt: skip
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
                settings: dict) -> bool:  # fmt: skip
    """Deal the pending cases to the ranks and run them in rounds of one batch per rank;
    after every round all ranks flush the file (collective) and rank 0 reports. Returns
    whether a stop was requested (then the unfinished batch stays pending)."""
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
    clock = _Progress(say, cfg.time.end, settings["ts_dt"], rounds)
    for r in range(rounds):
        chunk = mine[r * width : (r + 1) * width]
        finished: list[CaseResult] = []
        if chunk:
            try:
                cases = [results.angles_of(angles[i]) for i in chunk]
                finished = run_cases(model, cfg, cases, options=options,
                                     progress=clock.window(r, len(chunk)))  # fmt: skip
            except KeyboardInterrupt:  # a stop asked for: this batch stays pending
                finished, chunk = [], []
            except Exception as exc:  # a solver error fails this batch, not the sweep
                finished = [CaseResult(status=f"failed: {type(exc).__name__}: {exc}",
                                       options=settings) for _ in chunk]  # fmt: skip
            for i, res in zip(chunk, finished, strict=True):
                attach_linear(model, cfg, results.angles_of(angles[i]), res)
                results.write_case(f, i, res)
        f.flush()  # collective: every finished round is on disk
        report = [(i, res.status, res.wall_s, res.batch, res.compile_s, res.classification)
                  for i, res in zip(chunk, finished, strict=True)]  # fmt: skip
        gathered = comm.gather(report, root=0)
        if comm.rank == 0:
            for i, st, wall, width_used, compiled, verdict in sorted(
                item for part in gathered for item in part
            ):
                done += 1
                tb, sh = angles[i]
                share = f"{wall:.3g} s" + ("" if width_used == 1 else f", batch of {width_used}")
                share += f" + {compiled:.2g} s kernels" if compiled > 0.05 else ""
                say(f"[{done}/{C}] tie-boss {tb:g} deg, shroud {sh:g} deg: {st} ({share}); "
                    f"{verdict}")  # fmt: skip
        if comm.allreduce(interrupts.requested(), op=_lor()):
            return True
    return False


def _lor():
    from mpi4py import MPI

    return MPI.LOR


class _Progress:
    """Rank 0's progress lines while its batch integrates: simulated time reached, steps per
    second and an ETA from the integration rate alone (measured from the end of the first
    window, so kernel compilation and the static preload do not count), at most one line a
    second. Its window callback also stops the batch when a stop was requested."""

    def __init__(self, say, t_end: float, step: float, rounds: int):
        self.say, self.rounds = say, rounds
        self.t_end, self.step = t_end, step  # [s]: simulated end, the TS step

    def window(self, round_index: int, cases: int):
        first: list[tuple[float, float]] = []  # (simulated, wall) at the end of window 1
        last_line = [-math.inf]

        def progress(window, windows, t, amplitude):
            if interrupts.requested():
                raise KeyboardInterrupt  # caught by the round: the batch stays pending
            now = time.perf_counter()
            if not first:
                first.append((t, now))
            if now - last_line[0] < 1.0 and window < windows:
                return
            last_line[0] = now
            t1, wall1 = first[0]
            rate = (t - t1) / (now - wall1) if now > wall1 and t > t1 else 0.0  # [s / s]
            left = (self.t_end - t) + (self.rounds - round_index - 1) * self.t_end  # [s]
            if rate > 0:
                eta = f", {_duration(left / rate)} left" if left > 0.5 * self.step else ""
                pace = f"{rate / self.step:,.0f} steps/s{eta}"
            else:
                pace = "measuring the rate"
            self.say(
                f"  round {round_index + 1}/{self.rounds} ({cases} case(s)): window "
                f"{window}/{windows}, t = {t:.4g} of {self.t_end:g} s, largest tip amplitude "
                f"{amplitude:.3g} m; {pace}"
            )

        return progress


def _duration(seconds: float) -> str:
    """``75.2`` -> ``"about 1 min 15 s"``; under a second: ``"under a second"``."""
    if seconds < 1:
        return "under a second"
    minutes, secs = divmod(round(seconds), 60)
    hours, minutes = divmod(minutes, 60)
    if hours:
        return f"about {hours} h {minutes} min"
    return f"about {minutes} min {secs} s" if minutes else f"about {secs} s"
