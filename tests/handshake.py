"""A handshake between a test and the command it runs as a subprocess, so that no outcome
depends on how fast the machine is.

A test that signals or kills a command "while case 2 runs" must know that case 2 runs: a line
printed before it proves only that case 1 is done, and a fast machine had finished case 2
too before the signal came (the command exited 0, not 130). So the command runs through
:func:`script`: a small Python file that patches one function of wheelrom to call
:func:`hold` at the known point, then runs the CLI. ``hold`` says on stderr that the process
is there (:data:`HOLDING`, with its pid) and stays there until it is released: by a signal
that raises in it (SIGINT's ``KeyboardInterrupt``, SIGTERM under an output lock, SIGKILL), or
by ``released()`` turning true (a stop request under
:func:`wheelrom.runtime.interrupts.deferred`). The test acts once it has read that line
(:func:`read_until`): however fast or loaded the machine, the command is then at that point.

Every process of the script (every MPI rank) also says its pid and rank when it starts
(:data:`STARTED`), so a test signals the ranks themselves, never mpirun by a name that also
matches mpirun's own command line."""

from __future__ import annotations

import os
import re
import sys
import textwrap
import threading
import time

HOLDING = "handshake: holding"
ARRIVED = "handshake: arrived"
STARTED = "handshake: started"
TESTS = os.path.dirname(os.path.abspath(__file__))

#: [s] the timeout of every subprocess of the suite (conftest re-exports it), of the wait for
#: a handshake's line and of a hold a test never released: a guard against a hang only,
#: never a limit a working command reaches (a cold kernel cache on a 2-core machine loaded
#: by other jobs takes minutes)
HANG_S = 1800


#: a :func:`script` patch for ``wheelrom sweep``: rank 0's second round holds before it
#: integrates until a stop is requested (SIGINT or SIGTERM, under interrupts.deferred), then
#: runs, and its first window's progress stops it; a SIGKILL ends it where it holds. Either
#: way the file holds the first round's cases and no other, whatever the machine's speed.
SWEEP_SECOND_ROUND = """
    import wheelrom.studies.sweep as sweep
    from wheelrom.runtime import interrupts
    integrate, calls = sweep.run_cases, []
    def run_cases(*args, **kwargs):
        calls.append(args)
        if rank == 0 and len(calls) == 2:
            hold("rank 0's second round", released=interrupts.requested)
        return integrate(*args, **kwargs)
    sweep.run_cases = run_cases
    """


def hold(where: str, released=lambda: False) -> None:
    """Say on stderr that this process is at ``where`` and wait there until ``released()``
    is true or a signal raises out of the wait."""
    print(f"{HOLDING} {where} (pid {os.getpid()})", file=sys.stderr, flush=True)
    give_up = time.monotonic() + HANG_S
    while not released():
        if time.monotonic() > give_up:
            raise SystemExit(f"handshake: never released at {where}")
        time.sleep(0.01)


def arrived(where: str) -> None:
    """Say on stderr that this process reached ``where`` (and goes on)."""
    print(f"{ARRIVED} {where} (pid {os.getpid()})", file=sys.stderr, flush=True)


def script(folder, patch: str, name: str = "held.py") -> list[str]:
    """The command ``[python, folder/name]``: a script that says it started
    (:data:`STARTED`), runs ``patch`` (Python source with :func:`hold`, :func:`arrived` and
    ``rank``, the MPI rank, in scope), then the ``wheelrom`` command line of its own
    arguments."""
    path = os.path.join(folder, name)
    with open(path, "w") as f:
        f.write("import os, signal, sys\n"
                # Ctrl-C as at a terminal: a test run started in the background ('&' in a
                # script) ignores SIGINT, and Python then leaves it ignored
                "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
                f"sys.path.insert(0, {TESTS!r})\n"
                "from wheelrom.runtime.environment import bootstrap\n"
                "bootstrap()  # one BLAS thread a process, before numpy loads (as the CLI)\n"
                "from handshake import STARTED, arrived, hold\n"
                "rank = int(os.environ.get('OMPI_COMM_WORLD_RANK', '0'))\n"
                "print(f'{STARTED} rank {rank} pid {os.getpid()}', file=sys.stderr, "
                "flush=True)\n"
                + textwrap.dedent(patch) +
                "\nfrom wheelrom.cli.main import main\n"
                "sys.exit(main())\n")
    return [sys.executable, path]


def read_until(proc, *wanted: str) -> list[str]:
    """The lines of the ``subprocess.Popen`` ``proc``'s stderr read until every text of
    ``wanted`` was seen (in any order: the ranks' lines reach mpirun's stderr as they come).
    Raises AssertionError with everything read when the stream ends first (the command
    stopped before reaching the point), or when ``proc`` has not said them in :data:`HANG_S`
    (then it is stopped by SIGTERM, which mpirun passes on to its ranks)."""
    watchdog = threading.Timer(HANG_S, proc.terminate)
    watchdog.start()
    seen: list[str] = []
    try:
        for line in proc.stderr:
            seen.append(line)
            if all(any(w in ln for ln in seen) for w in wanted):
                return seen
    finally:
        watchdog.cancel()
    raise AssertionError(f"the command ended before saying {wanted}:\n{''.join(seen)}")


def pids(lines: list[str]) -> dict[int, int]:
    """``{rank: pid}`` of the :data:`STARTED` lines in ``lines``."""
    found = (re.search(rf"{STARTED} rank (\d+) pid (\d+)", ln) for ln in lines)
    return {int(m[1]): int(m[2]) for m in found if m}


def held_pid(lines: list[str]) -> int:
    """The pid in the (first) :data:`HOLDING` line of ``lines``."""
    line = next(ln for ln in lines if HOLDING in ln)
    return int(re.search(r"\(pid (\d+)\)", line)[1])
