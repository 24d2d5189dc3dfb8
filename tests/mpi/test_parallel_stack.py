"""The MPI stack under mpirun -n 2: PETSc sees both ranks, parallel HDF5 (mpio) works."""

from wheelrom.runtime.environment import bootstrap, petsc

bootstrap()  # one BLAS thread per rank, parallel HDF5, before numpy and h5py load

import numpy as np  # noqa: E402


def test_two_ranks_and_distributed_vec():
    PETSc = petsc()
    comm = PETSc.COMM_WORLD
    assert comm.getSize() == 2, "tests/mpi must run under mpirun -n 2"
    v = PETSc.Vec().createMPI(10, comm=comm)
    lo, hi = v.getOwnershipRange()
    v.setValues(range(lo, hi), np.arange(lo, hi, dtype=float))
    v.assemble()
    assert v.sum() == 45.0


def test_parallel_hdf5_each_rank_writes_its_row(tmp_path_factory):
    import h5py
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    path = comm.bcast(str(tmp_path_factory.mktemp("h5") / "p.h5") if comm.rank == 0 else None)
    with h5py.File(path, "w", driver="mpio", comm=comm) as f:
        d = f.create_dataset("x", (comm.size, 3), dtype="f8")
        d[comm.rank] = comm.rank + np.arange(3.0)
    comm.Barrier()
    with h5py.File(path, "r") as f:
        np.testing.assert_array_equal(f["x"][:], [[0, 1, 2], [1, 2, 3]])
