"""The shared case counter (studies/queue.py) under mpirun -n 2: every case is taken exactly
once, and a rank that is busy longer takes fewer (the cases go to whichever rank is free)."""

import time

from mpi4py import MPI

from wheelrom.studies.queue import CaseQueue


def test_every_case_once_and_the_free_rank_takes_more():
    comm = MPI.COMM_WORLD
    assert comm.size == 2
    queue = CaseQueue(12, comm)
    mine = []
    for i in queue:
        mine.append(i)
        time.sleep(0.3 if comm.rank == 0 else 0.02)  # rank 0 is the slow one
    parts = comm.allgather(mine)
    queue.free()
    assert sorted(parts[0] + parts[1]) == list(range(12))
    assert len(parts[1]) >= 2 * len(parts[0]), parts


def test_serial_takes_every_case_in_order():
    assert list(CaseQueue(5, None)) == [0, 1, 2, 3, 4]
    assert list(CaseQueue(0, MPI.COMM_SELF)) == []
