"""Ctrl-C (SIGINT) and mpirun's SIGTERM during a long computation: stop at the next safe
point and keep everything finished so far.

Inside :func:`deferred` the first signal only sets a flag that the computation polls
(:func:`requested`) where stopping is safe, e.g. after a window of a sweep batch, so that all
MPI ranks still meet in the same collective HDF5 calls; a second signal raises
``KeyboardInterrupt`` at once (the user insists).
"""

from __future__ import annotations

import contextlib
import signal

_REQUESTED = [False]
SIGNALS = (signal.SIGINT, signal.SIGTERM)


def requested() -> bool:
    """Whether a stop was asked for inside the current :func:`deferred` block."""
    return _REQUESTED[0]


def _handler(signum, frame):
    if _REQUESTED[0]:
        raise KeyboardInterrupt
    _REQUESTED[0] = True


@contextlib.contextmanager
def deferred():
    """SIGINT/SIGTERM set :func:`requested` instead of interrupting (main thread only)."""
    _REQUESTED[0] = False
    try:
        previous = {s: signal.signal(s, _handler) for s in SIGNALS}
    except ValueError:  # not the main thread: signals stay as they are
        previous = {}
    try:
        yield
    finally:
        for s, old in previous.items():
            signal.signal(s, old)
