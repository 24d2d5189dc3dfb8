"""The output lock under mpirun -n 2 (issue #40): rank 0 takes it for all ranks, so a locked
--out stops both ranks with the same verdict (one line, on rank 0; nobody left waiting, nothing
computed); once free, the job runs and removes its lock."""

from wheelrom.runtime.environment import bootstrap

bootstrap()  # one BLAS thread per rank, parallel HDF5, before numpy and h5py load

import fcntl  # noqa: E402
import json  # noqa: E402
import os  # noqa: E402
import socket  # noqa: E402

HERE = os.path.dirname(os.path.dirname(__file__))
SMALL = os.path.join(HERE, "data", "small.toml")


def test_a_held_lock_stops_every_rank_then_the_job_runs(tmp_path_factory, monkeypatch, capsys):
    from mpi4py import MPI

    from wheelrom.cli import main as cli
    from wheelrom.runtime.locks import lock_name

    comm = MPI.COMM_WORLD
    assert comm.size == 2, "tests/mpi must run under mpirun -n 2"
    out = comm.bcast(str(tmp_path_factory.mktemp("lock") / "s.h5") if comm.rank == 0 else None)
    lock = lock_name(out)
    fd = None
    if comm.rank == 0:  # another job holds the output (its flock: here rank 0's own)
        fd = os.open(lock, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        fcntl.flock(fd, fcntl.LOCK_EX)
        os.write(fd, json.dumps({"host": socket.gethostname(), "pid": 4242,
                                 "started": "2024-01-02 03:04:05"}).encode())
    comm.Barrier()

    def computed(*_):
        raise AssertionError("a segment was built: the refusal came too late")

    with monkeypatch.context() as m:
        m.setattr("wheelrom.segment.load.build_builtin", computed)
        status = cli.main(["sweep", SMALL, "--out", out])
        assert status == 2
        status = cli.main(["stability", SMALL, "--out", out])
        assert status == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("wheelrom:")]
    if comm.rank == 0:
        assert len(err) == 2 and all("in use by another wheelrom job (host" in ln
                                     and "pid 4242" in ln for ln in err), err
        os.remove(lock)
        os.close(fd)
    else:
        assert err == []
    comm.Barrier()
    assert cli.main(["stability", SMALL, "--out", out]) == 0
    comm.Barrier()
    assert os.path.exists(out) and not os.path.exists(lock)
