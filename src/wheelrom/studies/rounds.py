"""The round runner of ``sweep`` and ``study``: every rank integrates one batch of its cases,
then all ranks write their cases into the preallocated datasets and flush collectively, and
rank 0 reports them. A batch that fails (a solver error) is recorded as failed cases with the
reason; a stop request (Ctrl-C / SIGTERM) leaves the unfinished batch pending and ends the
rounds after the flush, so the file always holds every case of every finished round.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

from wheelrom.results import layout as results
from wheelrom.runtime import interrupts
from wheelrom.runtime.outputs import disk_full, is_disk_full, space_problem
from wheelrom.transient.problem import CaseResult

KEPT = "the cases of every finished round are in the file: free space and rerun with --resume"


def run_rounds(f, plan: list[list[int]], comm, run_batch: Callable, settings: dict,
               attach: Callable, line: Callable, say, t_end: float) -> bool:
    """Run this rank's ``plan`` (a list of batches of case indices) in rounds; returns
    whether a stop was requested.

    Collective over ``comm``: the number of rounds is the longest plan of any rank.
    ``run_batch(chunk, progress) -> list[CaseResult]`` integrates one batch;
    ``attach(i, result)`` adds what the file records beside the transient (the linear
    verdict); ``line(i, status, wall_s, batch, compile_s, classification)`` is rank 0's
    report of case ``i`` (None: nothing). ``settings``: the TS settings, recorded with a failed
    case; its ``ts_dt`` [s] and ``t_end`` [s] pace the progress lines.
    """
    sizes = comm.allgather([len(chunk) for chunk in plan])  # every rank's batch per round
    rounds = max(len(s) for s in sizes)
    clock = Progress(say, t_end, settings["ts_dt"], rounds)
    for r in range(rounds):
        chunk = plan[r] if r < len(plan) else []
        elsewhere = sum(s[r] for k, s in enumerate(sizes) if k != comm.rank and r < len(s))
        progress = clock.window(r, len(chunk), elsewhere, comm.size)
        finished = _batch(chunk, run_batch, settings, progress)
        chunk = chunk if finished else []
        _write(f, comm, [(i, res) for i, res in zip(chunk, finished, strict=True)], attach)
        report = [(i, res.status, res.wall_s, res.batch, res.compile_s, res.classification)
                  for i, res in zip(chunk, finished, strict=True)]
        gathered = comm.gather(report, root=0)
        if comm.rank == 0:
            for item in sorted(item for part in gathered for item in part):
                text = line(*item)
                if text:
                    say(text)
        if comm.allreduce(interrupts.requested(), op=_mpi_op("LOR")):
            return True
    return False


def _write(f, comm, done: list, attach: Callable) -> None:
    """This rank's finished cases into the file, then the collective flush. A full disk on
    any rank is told to every rank (none is left waiting in a collective call) and raised as
    one :class:`~wheelrom.runtime.errors.DiskFull`; a case whose write failed stays
    ``pending`` (its status is written last)."""
    failure = None
    try:
        for i, res in done:
            attach(i, res)
            results.write_case(f, i, res)
    except OSError as exc:
        if not is_disk_full(exc):
            raise
        failure = exc
    failures = [e for e in comm.allgather(failure) if e is not None]
    if failures:
        raise disk_full(f.filename, failures[0], KEPT)
    wait_for_all(comm)
    try:
        f.flush()  # collective: every finished round is on disk
    except OSError as exc:
        if not is_disk_full(exc):
            raise
        raise disk_full(f.filename, exc, KEPT) from None


def check_space_collectively(out: str, needed: int, comm) -> None:
    """Rank 0 checks that ``needed`` more bytes fit at ``out`` and every rank raises its
    one-line refusal (:func:`wheelrom.runtime.outputs.space_problem`) or none."""
    problem = space_problem(out, needed) if comm.rank == 0 else None
    problem = comm.bcast(problem)
    if problem:
        raise problem


def _batch(chunk: list[int], run_batch: Callable, settings: dict, progress) -> list:
    """The results of one batch: a solver error fails the batch (not the run), a stop
    request returns nothing (the batch stays pending)."""
    if not chunk:
        return []
    try:
        return run_batch(chunk, progress)
    except KeyboardInterrupt:
        return []
    except Exception as exc:
        return [CaseResult(status=f"failed: {type(exc).__name__}: {exc}", options=settings)
                for _ in chunk]


def wait_for_all(comm, poll: float = 0.005) -> None:
    """A barrier that sleeps while it waits (MPI's blocking collectives spin): a rank done
    early leaves its core to the ranks still computing (several ranks on shared cores)."""
    request = comm.Ibarrier()
    while not request.Test():
        time.sleep(poll)


def _mpi_op(name: str):
    from mpi4py import MPI

    return getattr(MPI, name)


class Progress:
    """Rank 0's progress lines while its batch integrates: simulated time reached, steps per
    second and an ETA from the integration rate alone (measured from the end of the first
    window, so kernel compilation and the static preload do not count), at most one line a
    second. Its window callback also stops the batch when a stop was requested."""

    def __init__(self, say, t_end: float, step: float, rounds: int):
        self.say, self.rounds = say, rounds
        self.t_end, self.step = t_end, step  # [s]: simulated end, the TS step

    def window(self, round_index: int, cases: int, elsewhere: int = 0, ranks: int = 1):
        """The progress callback of one round: ``cases`` on this rank, ``elsewhere`` on the
        other ``ranks - 1`` at the same time (said in the line: under mpirun only rank 0
        prints, and its batch is not the whole round)."""
        first: list[tuple[float, float]] = []  # (simulated, wall) at the end of window 1
        what, whose = f"{cases} case(s)", ""
        if ranks > 1:
            what = (f"{cases} case(s) on rank 0, {elsewhere} more on {ranks - 1} other "
                    "rank(s) at the same time")
            whose = " on rank 0"
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
                f"  round {round_index + 1}/{self.rounds} ({what}): window "
                f"{window}/{windows}, t = {t:.4g} of {self.t_end:g} s, largest tip "
                f"amplitude{whose} {amplitude:.3g} m; {pace}"
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
