"""The shared case counter (studies/queue.py) under mpirun -n 2: every case is taken exactly
once, and a rank that is busy longer takes fewer (the cases go to whichever rank is free)."""

import pytest
from mpi4py import MPI

from wheelrom.studies.queue import CaseQueue


@pytest.mark.parametrize("busy", [0, 1])
def test_every_case_once_and_the_free_rank_takes_the_rest(busy):
    """Rank ``busy`` stays in its first case until the other rank found the queue empty: a
    handshake, not a sleep, so which rank takes what does not depend on the machine's speed
    (with 0.3 s against 0.02 s a case, the split was a matter of timing). The free rank
    starts only once the busy one holds its case, so it cannot take them all first."""
    comm = MPI.COMM_WORLD
    assert comm.size == 2
    free = 1 - busy
    ours = comm.Dup()  # the handshake's messages, apart from any other
    queue = CaseQueue(12, comm)
    if comm.rank == free:
        ours.recv(source=busy)  # the busy rank holds its first case
    mine = []
    for i in queue:
        mine.append(i)
        if comm.rank == busy and len(mine) == 1:
            ours.send("holding a case", dest=free)
            ours.recv(source=free)  # busy until the free rank found the queue empty
    if comm.rank == free:
        ours.send("the queue is empty", dest=busy)
    parts = comm.allgather(mine)
    queue.free()
    ours.Free()
    assert parts[busy] == [0] and parts[free] == list(range(1, 12)), parts


def test_serial_takes_every_case_in_order():
    assert list(CaseQueue(5, None)) == [0, 1, 2, 3, 4]
    assert list(CaseQueue(0, MPI.COMM_SELF)) == []
