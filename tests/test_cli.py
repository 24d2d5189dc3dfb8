"""Commands through the CLI: compare, modes --out/--vtu, run --out with a short last window."""

import json

import h5py
import numpy as np
import pytest

from conftest import SMALL
from wheelrom import cli


def test_compare_command_agrees_with_the_reference(capsys):
    assert cli.main(["compare", SMALL, "--steps", "200", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["steps"] == 200 and out["step_s"] == 5e-6
    assert 0 <= out["max_relative_difference"] < 1e-9


def test_compare_takes_the_step_from_the_ts():
    """-wheel_ts_dt overrides time.step: the reference integrates with the TS's step (in a
    subprocess: options after -- go into that process's PETSc database for good)."""
    import subprocess
    import sys

    res = subprocess.run([sys.executable, "-m", "wheelrom.cli", "compare", SMALL, "--steps",
                          "100", "--json", "--", "-wheel_ts_dt", "2.5e-6"],
                         capture_output=True, text=True, check=True, timeout=300)  # fmt: skip
    out = json.loads(res.stdout)
    assert out["step_s"] == 2.5e-6 and out["max_relative_difference"] < 1e-9


def test_modes_out_and_vtu(tmp_path, capsys, small_model):
    import meshio

    out, vtu = tmp_path / "m.h5", tmp_path / "w.vtu"
    assert cli.main(["modes", SMALL, "--json", "--out", str(out), "--vtu", str(vtu),
                     "--vtu-nd", "3"]) == 0  # fmt: skip
    printed = json.loads(capsys.readouterr().out)
    table = small_model.frequencies_by_nodal_diameter()
    np.testing.assert_allclose(printed["reduced_hz_by_nd"], table, rtol=1e-12)
    with h5py.File(out, "r") as f:
        np.testing.assert_allclose(f["model/frequencies_by_nd"][()], table, rtol=1e-12)
        np.testing.assert_array_equal(f["model/A1"][()], small_model.A1)
        assert f["model/wheel_hz"].shape == (small_model.size,)
        assert "config" in f.attrs
    mesh = meshio.read(vtu)
    u = mesh.point_data["displacement"]
    assert u.shape == mesh.points.shape and np.abs(u).max() == 1.0
    assert mesh.points.shape[0] % small_model.blades == 0


def test_run_out_window_end_is_the_runs(tmp_path, capsys):
    """time.end not a multiple of time.window: the file's window ends are the run's."""
    out = tmp_path / "r.h5"
    argv = ["run", SMALL, "--json", "--set", "time.end=0.0025", "--set", "time.window=0.001",
            "--out", str(out)]  # fmt: skip
    assert cli.main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["simulated_s"] == pytest.approx(0.0025, rel=1e-9)
    with h5py.File(out, "r") as f:
        ends = f["cases/window_end"][()]
        assert ends[-1] == pytest.approx(summary["simulated_s"], rel=1e-9)
        np.testing.assert_allclose(ends, [0.001, 0.0025])
        assert np.isfinite(f["cases/max_tip_amplitude"][0]).all()
