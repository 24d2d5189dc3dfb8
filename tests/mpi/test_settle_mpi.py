"""``wheelrom settle`` under ``mpirun -n 2`` gives the numbers of one process: the cases are
dealt to the ranks, each integrated alone on its rank, gathered on rank 0."""

from wheelrom.runtime.environment import bootstrap, petsc

bootstrap()  # one BLAS thread per rank, before numpy loads

import numpy as np  # noqa: E402

from conftest import SMALL, VDP_WHEEL  # noqa: E402
from wheelrom import config  # noqa: E402
from wheelrom.studies.settle import run_settle  # noqa: E402

KEYS = [*VDP_WHEEL,
        "sweep.shroud_angles_deg=[50.0, 60.0]", 'settle.start="preload"',
        "settle.seed_amplitude=5e-6", "settle.min_time=0.4", "settle.max_time=0.4"]  # fmt: skip


def test_two_ranks_settle_as_one():
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    assert comm.size == 2
    petsc()
    cfg = config.load(SMALL, overrides=KEYS)
    _, parallel, _ = run_settle(cfg, None, comm, log=None)
    _, serial, _ = run_settle(cfg, None, None, log=None) if comm.rank == 0 else (0, [], 0)
    if comm.rank != 0:
        assert parallel == []
        return
    assert len(parallel) == len(serial) == 2
    for (_, _, a), (_, _, b) in zip(parallel, serial, strict=True):
        assert a.verdict() == b.verdict() and len(a.windows) == len(b.windows) > 1
        np.testing.assert_array_equal(a.amplitude, b.amplitude)
        np.testing.assert_array_equal(a.tip, b.tip)
