"""A disk that fills under mpirun -n 2 while only rank 1 writes: every rank stops with the
same one-line error (exit 1), none is left waiting in a collective call, and the finished
round stays in the file."""

from wheelrom.runtime.environment import bootstrap

bootstrap()  # one BLAS thread per rank, parallel HDF5, before numpy and h5py load

import errno  # noqa: E402
import os  # noqa: E402

HERE = os.path.dirname(os.path.dirname(__file__))
SMALL = os.path.join(HERE, "data", "small.toml")


def test_rank_1_out_of_space_stops_both_ranks_with_one_line(tmp_path_factory, monkeypatch,
                                                            capsys):
    import h5py
    from mpi4py import MPI

    from wheelrom.cli import main as cli
    from wheelrom.results import layout as results

    comm = MPI.COMM_WORLD
    assert comm.size == 2, "tests/mpi must run under mpirun -n 2"
    out = comm.bcast(str(tmp_path_factory.mktemp("full") / "s.h5") if comm.rank == 0 else None)
    real_write, calls = results.write_case, []

    def write(f, i, res):
        calls.append(i)
        if comm.rank == 1 and len(calls) == 2:  # rank 1's second round: the disk is full
            raise OSError(errno.ENOSPC, "No space left on device")
        real_write(f, i, res)

    monkeypatch.setattr(results, "write_case", write)
    # 4 cases, batch 1: two rounds of one case per rank
    status = cli.main(["sweep", SMALL, "--out", out, "--batch", "1",
                       "--set", "sweep.shroud_angles_deg=[20.0, 40.0, 60.0, 80.0]"])
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("wheelrom:")]
    assert status == 1
    assert err == ([f"wheelrom: {out}: the disk is full (errno 28, ENOSPC: No space left on "
                    "device); the cases of every finished round are in the file: free space "
                    "and rerun with --resume"] if comm.rank == 0 else [])
    comm.Barrier()
    with h5py.File(out, "r", driver="mpio", comm=comm) as f:
        done = [s.decode() for s in f["cases/status"][:]]
    assert done.count("done") == 3 and done.count("pending") == 1  # rank 0 wrote its second
