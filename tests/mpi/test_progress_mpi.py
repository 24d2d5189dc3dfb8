"""Progress under mpirun -n 2 (issue #40): only rank 0 prints, so its line says what the other
rank integrates at the same time; the two counts add up to the round's cases."""

from wheelrom.runtime.environment import bootstrap

bootstrap()  # one BLAS thread per rank, parallel HDF5, before numpy and h5py load

import os  # noqa: E402
import re  # noqa: E402

HERE = os.path.dirname(os.path.dirname(__file__))
SMALL = os.path.join(HERE, "data", "small.toml")


def test_rank_0_says_what_the_other_rank_runs(tmp_path_factory, capsys):
    from mpi4py import MPI

    from wheelrom.cli import main as cli

    comm = MPI.COMM_WORLD
    assert comm.size == 2, "tests/mpi must run under mpirun -n 2"
    out = comm.bcast(str(tmp_path_factory.mktemp("progress") / "s.h5") if comm.rank == 0
                     else None)
    # three angles, one round: two cases on one rank, one on the other
    assert cli.main(["sweep", SMALL, "--out", out, "--set", "time.end=0.001"]) == 0
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if "round 1/1" in ln]
    if comm.rank == 0:
        assert lines, err
        found = re.search(r"\((\d+) case\(s\) on rank 0, (\d+) more on 1 other rank\(s\) at the "
                          r"same time\).*largest tip amplitude on rank 0", lines[-1])
        assert found, lines[-1]
        assert int(found[1]) + int(found[2]) == 3 and int(found[2]) >= 1, lines[-1]
    else:
        assert lines == []
