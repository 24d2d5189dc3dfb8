"""``wheelrom settle`` under ``mpirun -n 2`` gives the numbers of one process: the batches of
cases (``settle.batch``, planned from the cases alone) are dealt to the ranks, each integrated
on its rank, gathered on rank 0."""

from wheelrom.runtime.environment import bootstrap, petsc

bootstrap()  # one BLAS thread per rank, before numpy loads

import numpy as np  # noqa: E402

from conftest import SMALL, VDP_WHEEL  # noqa: E402
from wheelrom import config  # noqa: E402
from wheelrom.studies.settle import run_settle  # noqa: E402

KEYS = [*VDP_WHEEL,
        "sweep.shroud_angles_deg=[50.0, 60.0, 70.0]", "settle.batch=2", 'settle.start="preload"',
        "settle.seed_amplitude=5e-6", "settle.min_time=0.4", "settle.max_time=0.4"]


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
    assert len(parallel) == len(serial) == 3  # two batches, each on whichever rank was free
    for (_, _, a), (_, _, b) in zip(parallel, serial, strict=True):
        assert a.verdict() == b.verdict() and len(a.windows) == len(b.windows) > 1
        np.testing.assert_array_equal(a.amplitude, b.amplitude)
        np.testing.assert_array_equal(a.tip, b.tip)


def test_a_stale_case_folder_is_removed_once_under_force(tmp_path_factory, monkeypatch):
    """``settle --out F --force`` with an earlier run's case folder beside ``F``: one rank
    removes it, before any rank keeps a case (both ranks removed it, racing: one unlinked
    what the other had listed, FileNotFoundError, the run lost). Rank 0's removal takes
    effect only once every rank has passed the point where it decides (the command's barrier,
    before run_settle), so a second rank that also removes it always finds it there and is
    caught doing so (a sleep in rank 0's removal caught it only if rank 1 came within it)."""
    import os

    from mpi4py import MPI

    from wheelrom.cli import main as cli
    from wheelrom.studies import settle as study
    from wheelrom.studies.kept_cases import KeptCases
    from wheelrom.studies.settle import sidecar_dir

    comm = MPI.COMM_WORLD
    folder = comm.bcast(str(tmp_path_factory.mktemp("stale")) if comm.rank == 0 else None)
    out = os.path.join(folder, "settle.h5")
    if comm.rank == 0:
        os.makedirs(sidecar_dir(out))
        for i in range(20):
            with open(os.path.join(sidecar_dir(out), f"case_{i}.json"), "w") as f:
                f.write("stale")
    comm.barrier()
    removed, held = [], []
    remove, settle = KeptCases.clear, study.run_settle

    def recorded_clear(self):
        if os.path.abspath(self.path) == os.path.abspath(sidecar_dir(out)):
            removed.append(self.path)
            if comm.rank == 0 and len(removed) == 1:  # the stale folder: held back
                held.append(self)
                return None
        return remove(self)

    def run_settle(*args, **kwargs):  # every rank has decided: the stale folder goes now
        for folder in held:
            remove(folder)
        return settle(*args, **kwargs)

    monkeypatch.setattr(KeptCases, "clear", recorded_clear)
    monkeypatch.setattr(study, "run_settle", run_settle)
    keys = [*KEYS[:-2], "settle.min_time=0.05", "settle.max_time=0.05",
            "settle.window_periods=2"]
    status = cli.main(["settle", SMALL, *sum((["--set", k] for k in keys), []), "--out", out,
                       "--force", "--json"])
    assert status == 0
    calls = comm.gather(len(removed))
    if comm.rank == 0:
        assert calls[0] == 2 and calls[1] == 0  # the stale one, and the run's own once written
        assert os.path.exists(out) and not os.path.exists(sidecar_dir(out))
