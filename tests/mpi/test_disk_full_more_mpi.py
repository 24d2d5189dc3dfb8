"""``stability --out`` on a full disk under mpirun -n 2: both ranks stop with the same one-line
error (exit 1, rank 0 prints it), none waits in a collective call, and the results file is
kept in the temporary directory."""

from wheelrom.runtime.environment import bootstrap

bootstrap()  # one BLAS thread per rank, parallel HDF5, before numpy and h5py load

import errno  # noqa: E402
import os  # noqa: E402

HERE = os.path.dirname(os.path.dirname(__file__))
SMALL = os.path.join(HERE, "data", "small.toml")


def test_stability_on_a_full_disk_stops_both_ranks_and_keeps_the_file(
        tmp_path_factory, monkeypatch, capsys):
    import tempfile

    import h5py
    from mpi4py import MPI

    from wheelrom.cli import main as cli
    from wheelrom.runtime import outputs

    comm = MPI.COMM_WORLD
    assert comm.size == 2, "tests/mpi must run under mpirun -n 2"
    base = comm.bcast(str(tmp_path_factory.mktemp("full")) if comm.rank == 0 else None)
    out_dir, spare = os.path.join(base, "out"), os.path.join(base, "tmp")
    if comm.rank == 0:
        os.mkdir(out_dir)
        os.mkdir(spare)
    comm.Barrier()
    real = outputs.write_image

    def write(path, data):
        if os.path.dirname(os.path.abspath(path)) == out_dir:
            raise OSError(errno.ENOSPC, "No space left on device")
        real(path, data)

    monkeypatch.setattr(outputs, "write_image", write)
    monkeypatch.setattr(tempfile, "tempdir", spare)
    out = os.path.join(out_dir, "s.h5")
    status = cli.main(["stability", SMALL, "--out", out])
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("wheelrom:")]
    assert status == 1
    comm.Barrier()
    kept = [os.path.join(spare, n) for n in os.listdir(spare)]
    assert len(kept) == 1 and not os.listdir(out_dir)
    if comm.rank == 0:
        assert len(err) == 1 and err[0].startswith(f"wheelrom: {out}: the disk is full "
                                                   "(errno 28"), err
        assert f"the results are kept in {kept[0]}" in err[0], err
        with h5py.File(kept[0], "r") as f:
            assert f.attrs["format"]
    else:
        assert err == []
