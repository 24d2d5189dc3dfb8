"""Cases (or batches of cases: ``settle``) handed to the MPI ranks as they become free: a
shared counter on rank 0 (an MPI one-sided window, ``MPI_Fetch_and_op``) from which every rank
takes the next index.

The limit cycles and the settled states of the paper's six unstable angles cost 47 to 209 s
each, unknown before they are computed; dealt round-robin, one rank of ``./run/paper``
finished its three cases 110 s before the other. Taken from the counter, a rank that
finishes early takes the next case. The results do not depend on which rank computes a case
(the model is broadcast, the seeds belong to the case), only the order of the progress lines.
"""

from __future__ import annotations

import numpy as np


class CaseQueue:
    """The indices ``0 .. count - 1`` shared by the ranks of the mpi4py ``comm`` (``None``:
    serial, every index in order). Creating it is collective; :meth:`free` is too, and is
    called once every rank has met again (after a gather or a polled wait: a rank killed
    mid-case must not leave the others in a blocking collective)."""

    def __init__(self, count: int, comm=None):
        self.count, self.comm = int(count), comm
        self._next = 0
        self._window = None
        if comm is not None and comm.size > 1:
            from mpi4py import MPI

            self._mpi = MPI
            self._window = MPI.Win.Allocate(8 if comm.rank == 0 else 0, 8, comm=comm)
            if comm.rank == 0:
                self._window.Lock(0, MPI.LOCK_EXCLUSIVE)
                self._window.Put(np.zeros(1, dtype=np.int64), 0)
                self._window.Unlock(0)
            comm.Barrier()

    def __iter__(self):
        while True:
            i = self._take()
            if i >= self.count:
                return
            yield i

    def _take(self) -> int:
        if self._window is None:
            self._next += 1
            return self._next - 1
        MPI = self._mpi
        one, got = np.ones(1, dtype=np.int64), np.zeros(1, dtype=np.int64)
        self._window.Lock(0, MPI.LOCK_SHARED)
        self._window.Fetch_and_op(one, got, 0, 0, MPI.SUM)
        self._window.Unlock(0)
        return int(got[0])

    def free(self) -> None:
        if self._window is not None:
            self._window.Free()
            self._window = None
