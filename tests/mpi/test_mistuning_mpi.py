"""A Monte Carlo mistuning study (``--forced``, contacts linearised, normal and uniform
draws) gives the same /forced and /stability numbers on 2 ranks as on 1 (1e-12): every case
is computed on COMM_SELF by the rank that owns it, its pattern drawn from its own seed."""

from wheelrom.runtime.environment import bootstrap

bootstrap()  # one BLAS thread per rank, parallel HDF5, before numpy and h5py load

import os  # noqa: E402

import h5py  # noqa: E402
import numpy as np  # noqa: E402

from wheelrom import config  # noqa: E402

SMALL = os.path.join(os.path.dirname(os.path.dirname(__file__)), "data", "small.toml")
TIMING = ("stability/wall_s", "forced/wall_s")


def _numbers(path: str) -> dict:
    out = {}
    with h5py.File(path, "r") as f:
        for group in ("forced", "stability", "cases"):
            f[group].visititems(lambda name, obj, g=group: out.__setitem__(f"{g}/{name}", obj[()])
                                if isinstance(obj, h5py.Dataset) else None)
    return {k: v for k, v in out.items() if k not in TIMING}


def test_two_ranks_equal_one_rank(tmp_path_factory):
    from mpi4py import MPI

    from wheelrom.studies.study import run_study

    comm = MPI.COMM_WORLD
    assert comm.size == 2, "tests/mpi must run under mpirun -n 2"
    tmp = comm.bcast(str(tmp_path_factory.mktemp("mc")) if comm.rank == 0 else None)
    # linearly stable (no Van der Pol): the statistics count every realisation
    cfg = config.load(SMALL, ["mistuning.std=0.02", "flutter.mu=0.0",
                              'study.grid={"mistuning.seed"="0:3:1", '
                              '"mistuning.distribution"=["normal", "uniform"]}'])
    quiet = lambda *_: None  # noqa: E731
    two = run_study(cfg, os.path.join(tmp, "n2.h5"), comm, mode="stability", log=quiet,
                    forced=True)
    one = None
    if comm.rank == 0:
        one = run_study(cfg, os.path.join(tmp, "n1.h5"), MPI.COMM_SELF, mode="stability",
                        log=quiet, forced=True)
    comm.Barrier()
    if comm.rank:
        return
    assert one["statistics"]["amplification"]["count"] == 8
    a, b = _numbers(os.path.join(tmp, "n1.h5")), _numbers(os.path.join(tmp, "n2.h5"))
    assert a.keys() == b.keys() and "forced/amplification" in a and "cases/mistuning" in a
    for key, x in a.items():
        if x.dtype.kind == "f":
            scale = np.nanmax(np.abs(x)) if np.isfinite(x).any() else 1.0
            np.testing.assert_allclose(b[key], x, rtol=1e-12, atol=1e-12 * scale, err_msg=key)
        else:
            assert np.array_equal(b[key], x), key
    assert np.isfinite(a["forced/amplification"]).all()
    assert one["statistics"] == two["statistics"]
