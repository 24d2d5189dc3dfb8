"""``wheelrom limit-cycle`` under ``mpirun -n 2`` writes the same numbers as one process: the
cases are dealt to the ranks, each case computed alone on its rank, gathered on rank 0."""

from wheelrom.runtime.environment import bootstrap, petsc

bootstrap()  # one BLAS thread per rank, before numpy loads

import os  # noqa: E402

import numpy as np  # noqa: E402

from wheelrom import config  # noqa: E402
from wheelrom.studies.limit_cycles import run_limit_cycles  # noqa: E402

SMALL = os.path.join(os.path.dirname(os.path.dirname(__file__)), "data", "small.toml")
KEYS = ["sweep.shroud_angles_deg=[70.0, 80.0]", "limit_cycle.steps=4", "limit_cycle.seeds=[]",
        'limit_cycle.floquet="off"', "limit_cycle.harmonics=3"]


def test_two_ranks_give_the_cycles_of_one():
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    assert comm.size == 2
    petsc()
    cfg = config.load(SMALL, overrides=KEYS)
    _, parallel = run_limit_cycles(cfg, comm, log=None, waves=(7,))
    _, serial = run_limit_cycles(cfg, None, log=None, waves=(7,)) if comm.rank == 0 else (0, [])
    if comm.rank != 0:
        assert parallel == []
        return
    assert len(parallel) == len(serial) == 2
    for a, b in zip(parallel, serial, strict=True):
        assert a.verdict() == b.verdict()
        for wa, wb in zip(a.branches, b.branches, strict=True):
            assert len(wa.points) == len(wb.points) > 1
            for pa, pb in zip(wa.points, wb.points, strict=True):
                np.testing.assert_array_equal(pa.harmonics, pb.harmonics)
                assert pa.lam == pb.lam and pa.frequency_hz == pb.frequency_hz
