"""The monodromy under ``mpirun -n 2`` with more cases on one rank than on the other: every
PETSc object of a case lives on COMM_SELF (a COMM_WORLD vector in the phase-shift check once
made the rank with more cases wait for the other in a collective: the job hung), and the
numbers are those of one process."""

from wheelrom.runtime.environment import bootstrap, petsc

bootstrap()  # one BLAS thread per rank, before numpy loads

import numpy as np  # noqa: E402

from conftest import SMALL, VDP_WHEEL  # noqa: E402
from wheelrom import config  # noqa: E402
from wheelrom.studies.limit_cycles import run_limit_cycles  # noqa: E402

KEYS = [*VDP_WHEEL,
        "sweep.shroud_angles_deg=[40.0, 50.0, 60.0]", "limit_cycle.steps=4",
        "limit_cycle.seeds=[1e-5]", "limit_cycle.harmonics=3", "limit_cycle.multipliers=2",
        "limit_cycle.refine=1"]


def test_three_cases_on_two_ranks_finish_with_the_serial_numbers():
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    assert comm.size == 2
    petsc()
    cfg = config.load(SMALL, overrides=KEYS)
    _, parallel = run_limit_cycles(cfg, comm, log=None)
    _, serial = run_limit_cycles(cfg, None, log=None) if comm.rank == 0 else (0, [])
    if comm.rank != 0:
        assert parallel == []
        return
    assert len(parallel) == len(serial) == 3
    for a, b in zip(parallel, serial, strict=True):
        ca, cb = a.branches[0].cycles[-1], b.branches[0].cycles[-1]
        assert ca.method == cb.method == "shooting" and ca.multipliers is not None
        assert ca.tip_amplitude == cb.tip_amplitude
        np.testing.assert_array_equal(ca.orbit.state, cb.orbit.state)
        assert ca.refined == cb.refined
