"""``forced-response --nonlinear``'s grid under ``mpirun -n 2`` (the frequencies shared in
segments, :mod:`wheelrom.analysis.periodic.forced_segments`) equals one process's: the small
wheel under the paper law through its ND 2 resonance, every frequency and the refined peak,
on every rank (each rank also computes one process's curve)."""

from wheelrom.runtime.environment import bootstrap, petsc

bootstrap()  # one BLAS thread per rank, before numpy loads

import math  # noqa: E402
import os  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from wheelrom import config  # noqa: E402
from wheelrom.rom.build import build_model  # noqa: E402
from wheelrom.studies.forced_nonlinear import forced_inputs, nonlinear_forced  # noqa: E402

SMALL = os.path.join(os.path.dirname(os.path.dirname(__file__)), "data", "small.toml")


def test_two_ranks_give_the_curve_of_one():
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    assert comm.size == 2
    cfg = config.load(SMALL)
    model = build_model(cfg, petsc().COMM_SELF)
    inputs = forced_inputs(model, cfg, None, petsc().COMM_SELF)
    grid = 2 * math.pi * np.linspace(250.0, 259.0, 12)
    parallel = nonlinear_forced(model, cfg, grid, harmonics=3, comm=petsc().COMM_SELF,
                                refine=True, inputs=inputs, ranks=comm)
    serial = nonlinear_forced(model, cfg, grid, harmonics=3, comm=petsc().COMM_SELF,
                              refine=True, inputs=inputs)
    assert serial.converged.all() and parallel.resolved_seams == []
    np.testing.assert_array_equal(parallel.converged, serial.converged)
    np.testing.assert_allclose(parallel.tip_amplitude, serial.tip_amplitude, rtol=1e-8)
    assert abs(parallel.refined.tip_amplitude / serial.refined.tip_amplitude - 1) < 1e-8
    assert abs(parallel.refined.frequency / serial.refined.frequency - 1) < 1e-8


def test_the_command_over_two_ranks_tells_its_curve_once(tmp_path_factory, capsys):
    """``mpirun -n 2 wheelrom forced-response --nonlinear --json --out``: rank 0 prints one
    JSON document and writes the file, rank 1 prints nothing; the curve is one process's.
    (At H = 1 Newton from rest fails at the seams of the three segments, 251.8 and 255.4
    Hz, where continuation succeeds: the segments after them are solved again in order, and
    said.)"""
    import json

    import h5py
    from mpi4py import MPI

    from wheelrom.cli import main as cli

    comm = MPI.COMM_WORLD
    out = comm.bcast(str(tmp_path_factory.mktemp("fr") / "f.h5") if comm.rank == 0 else None)
    argv = ["forced-response", SMALL, "--nonlinear", "--harmonics", "1", "--frequencies",
            "250:259:6", "--json", "--out", out]
    assert cli.main(argv) == 0
    printed = capsys.readouterr().out
    if comm.rank == 1:
        assert printed == ""
        return
    nonlinear = json.loads(printed)["nonlinear"]
    assert all(nonlinear["converged"])
    assert set(np.round(nonlinear["resolved_seams_hz"], 6)) <= {251.8, 255.4}  # the seams
    cfg = config.load(SMALL)
    model = build_model(cfg, petsc().COMM_SELF)
    serial = nonlinear_forced(model, cfg, 2 * math.pi * np.linspace(250.0, 259.0, 6),
                              harmonics=1, comm=petsc().COMM_SELF)
    np.testing.assert_allclose(nonlinear["tip_amplitude_m"], serial.tip_amplitude, rtol=1e-8)
    with h5py.File(out) as f:
        np.testing.assert_array_equal(f["nonlinear/tip_amplitude"][:],
                                      nonlinear["tip_amplitude_m"])


def test_the_exact_states_dealt_over_two_ranks(capsys):
    """``--exact all`` under ``mpirun -n 2``: the five solved frequencies' shots dealt over
    the ranks and gathered in grid order give one process's verdicts
    (tests/test_forced_shooting.py: unstable at 123-129 Hz, stable at 132 and 135 Hz; the
    peak's state is the 123 Hz row, its largest multiplier in ND 3)."""
    import json

    from mpi4py import MPI

    from wheelrom.cli import main as cli

    argv = ["forced-response", SMALL, "--nonlinear", "--exact", "all", "--frequencies",
            "120:135:6", "--harmonics", "11", "--set", 'flutter.model="off"', "--set",
            "excitation.force=10", "--json"]
    assert cli.main(argv) == 0
    printed = capsys.readouterr().out
    if MPI.COMM_WORLD.rank == 1:
        assert printed == ""
        return
    nl = json.loads(printed)["nonlinear"]
    rows = nl["exact_curve"]
    assert len(rows) == 6 and rows[0] is None  # 120 Hz: the balance has no solution
    assert [r["stable"] for r in rows[1:]] == [False, False, False, True, True]
    assert [r["frequency_hz"] for r in rows[1:]] == pytest.approx([123.0, 126.0, 129.0,
                                                                   132.0, 135.0])
    assert rows[1] == nl["exact"] and rows[1]["wheel_multiplier_nd"][0] == 3
