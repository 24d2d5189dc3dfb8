"""wheelrom export: one case of a results file as CSV, read back to the same doubles."""

import h5py
import numpy as np
import pytest

from conftest import SMALL
from wheelrom.cli import main as cli


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    out = tmp_path_factory.mktemp("export") / "r.h5"
    assert cli.main(["run", SMALL, "--set", "time.end=0.002", "--out", str(out)]) == 0
    return out


def test_tips_and_windows_read_back_exactly(run_file, tmp_path, capsys):
    prefix = str(tmp_path / "case0")
    assert cli.main(["export", str(run_file), "--case", "0", "--csv", prefix]) == 0
    assert capsys.readouterr().out.split() == [f"{prefix}_tips.csv", f"{prefix}_windows.csv"]
    tips = np.loadtxt(f"{prefix}_tips.csv", delimiter=",", skiprows=1)
    windows = np.loadtxt(f"{prefix}_windows.csv", delimiter=",", skiprows=1, ndmin=2)
    header = open(f"{prefix}_windows.csv").readline().strip().split(",")
    with h5py.File(run_file, "r") as f:
        c = f["cases"]
        S, W = int(c["samples_done"][0]), int(c["windows_done"][0])
        np.testing.assert_array_equal(tips[:, 0], c["sample_time"][0, :S])
        np.testing.assert_array_equal(tips[:, 1:], c["tip_history"][0, :S].reshape(S, -1))
        column = dict(zip(header, windows.T, strict=True))
        np.testing.assert_array_equal(column["max_tip_amplitude_m"], c["max_tip_amplitude"][0, :W])
        np.testing.assert_array_equal(column["min_normal_force_shroud_N"],
                                      c["min_normal_force/shroud"][0, :W])
        np.testing.assert_array_equal(column["work_friction_J"], c["work"][0, :W, 2])
        np.testing.assert_array_equal(column["nd3_amplitude_m"], c["nd_spectrum"][0, :W, 3])


def test_export_refuses_what_it_cannot_do(run_file, tmp_path, capsys):
    prefix = str(tmp_path / "x")
    assert cli.main(["export", str(run_file), "--case", "5", "--csv", prefix]) == 2
    assert "--case 5: the file has cases 0..0" in capsys.readouterr().err
    assert cli.main(["export", str(run_file), "--csv", prefix, "--what", "tips"]) == 0
    assert cli.main(["export", str(run_file), "--csv", prefix, "--what", "tips"]) == 2
    assert "x_tips.csv exists: pass --force" in capsys.readouterr().err
