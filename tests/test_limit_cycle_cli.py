"""``wheelrom limit-cycle``: the file holds what rebuilds the motion (a second evaluation of the
harmonic-balance residual from the stored harmonics), the JSON and the figures; bad input
is named before anything is computed."""

import json
import math

import h5py
import numpy as np
import pytest

from conftest import SMALL
from wheelrom import config
from wheelrom.analysis.periodic.harmonic_balance import WaveBalance
from wheelrom.cli import main as cli
from wheelrom.forces.parameters import force_parameters

KEYS = ["--set", "sweep.shroud_angles_deg=[80.0]", "--set", "limit_cycle.steps=4", "--set",
        "limit_cycle.seeds=[1e-4]", "--set", "limit_cycle.harmonics=5", "--set",
        'limit_cycle.method="hb"']


@pytest.fixture(scope="module")
def limit_cycle_file(tmp_path_factory):
    out = tmp_path_factory.mktemp("lc") / "lc.h5"
    assert cli.main(["limit-cycle", SMALL, *KEYS, "--nd", "6", "--out", str(out)]) == 0
    return out


def test_the_stored_harmonics_solve_the_balance(limit_cycle_file, small_model):
    """Every stored point, re-evaluated from its harmonics, frequency and factor with a
    fresh harmonic balance on more samples: its residual is the truncation's, small."""
    cfg = config.load(SMALL, overrides=["sweep.shroud_angles_deg=[80.0]"])
    params = force_parameters(small_model, cfg, {"tieboss": 45.0, "shroud": 80.0})
    params = params.__class__(**{**params.__dict__, "nozzle_force": 0.0})
    with h5py.File(limit_cycle_file) as f:
        assert f.attrs["format"] == "wheelrom-limit-cycle-1"
        g = f["limit_cycle/case_0/wave_6"]
        assert g.attrs["nodal_diameter"] == 6
        cycles = g["cycles"]
        c, lam = cycles["harmonics"][0], cycles["lam"][0]
        assert lam == pytest.approx(1.0, abs=1e-12)
        omega = 2 * math.pi * cycles["frequency_hz"][0]
        tip = cycles["tip_amplitude"][0]
    balance = WaveBalance(small_model, params, cfg.wheel.damping_beta, 6, 5, 48)
    X = balance.packed(c)
    R = balance.residual(X, omega, lam)
    terms = np.abs(balance.linear_term(X, omega, lam)).max()
    assert np.abs(R).max() < 1e-8 * terms
    assert 5e-5 < tip < 5e-4  # the vibro-impact cycle of ND 6 (~130 um)


def test_json_reports_the_cycle(capsys):
    assert cli.main(["limit-cycle", SMALL, *KEYS, "--set", 'limit_cycle.floquet="off"',
                     "--nd", "6", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    wave = out["cases"][0]["waves"][0]
    assert wave["wave"] == 6 and wave["nodal_diameter"] == 6
    assert 0 < wave["critical_mu_factor"] < 1
    cycle = wave["cycles"][0]
    assert cycle["stable"] is None and cycle["mu_factor"] == pytest.approx(1.0)
    assert set(cycle["contacts"]) == {"tieboss", "shroud"}
    verdict = out["cases"][0]["verdict"]
    assert verdict.startswith("flutters (ND 6): limit cycle at") and "not computed" in verdict


def test_figures_of_a_limit_cycle_file(limit_cycle_file, tmp_path, capsys):
    assert cli.main(["plot", str(limit_cycle_file), "--outdir", str(tmp_path)]) == 0
    names = capsys.readouterr().out
    assert "limit_cycle_branches_case0.png" in names and "limit_cycle_damping_case0.png" in names


@pytest.mark.parametrize("args, words", [
    (["--nd", "12"], "--nd: waves [12] must be below wheel.blades = 12"),
    (["--nd", "a,3"], "--nd: 'a,3' is not a list"),
    (["--set", 'flutter.model="off"'], "limit cycles need self-excitation"),
    (["--set", "limit_cycle.samples=5"], "limit_cycle.samples = 5: at least 2 H + 1"),
])
def test_bad_input_is_named(args, words, capsys, tmp_path):
    out = tmp_path / "never.h5"
    assert cli.main(["limit-cycle", SMALL, *KEYS, *args, "--out", str(out)]) == 2
    assert words in capsys.readouterr().err
    assert not out.exists()


def test_a_study_of_any_key_is_its_cases_run_alone(tmp_path, capsys):
    """A [study] grid over the shroud preload: each case's cycle is the one a plain run with
    that preload gives (bitwise), and the file says which key varied."""
    keys = ["--set", "contacts.shroud.angle_deg=80.0", "--set", "limit_cycle.steps=4",
            "--set", "limit_cycle.seeds=[1e-4]", "--set", "limit_cycle.harmonics=3",
            "--set", 'limit_cycle.floquet="off"', "--set", 'limit_cycle.method="hb"',
            "--nd", "6"]
    grid = 'study.grid={"contacts.shroud.normal_preload" = [200.0, 400.0]}'
    out = tmp_path / "study.h5"
    assert cli.main(["limit-cycle", SMALL, *keys, "--set", grid, "--out", str(out)]) == 0
    alone = tmp_path / "alone.h5"
    assert cli.main(["limit-cycle", SMALL, *keys, "--set", "contacts.shroud.normal_preload=200.0",
                     "--set", "sweep.shroud_angles_deg=[80.0]", "--out", str(alone)]) == 0
    capsys.readouterr()
    with h5py.File(out) as f, h5py.File(alone) as g:
        p = f["limit_cycle/parameters"]
        assert p.attrs["names"] == "contacts.shroud.normal_preload"
        np.testing.assert_array_equal(p[:, 0], [200.0, 400.0])
        a = f["limit_cycle/case_0/wave_6/cycles/harmonics"][()]
        b = g["limit_cycle/case_0/wave_6/cycles/harmonics"][()]
        np.testing.assert_array_equal(a, b)
        different = f["limit_cycle/case_1/wave_6/cycles/tip_amplitude"][()]
        assert not np.isin(different, g["limit_cycle/case_0/wave_6/cycles/tip_amplitude"][()]).any()


def test_a_failed_case_is_named_and_the_others_are_written(tmp_path, capsys):
    """A study over mu that includes 0: that case cannot have a limit cycle and says why; the
    other is computed and written; the command exits 1."""
    out = tmp_path / "mu.h5"
    status = cli.main(["limit-cycle", SMALL, "--set", "contacts.shroud.angle_deg=80.0",
                       "--set", "limit_cycle.steps=4", "--set", "limit_cycle.seeds=[]",
                       "--set", 'limit_cycle.floquet="off"', "--set",
                       'study.grid={"flutter.mu" = [0.0, 100.0]}', "--nd", "7",
                       "--out", str(out)])
    assert status == 1
    capsys.readouterr()
    with h5py.File(out) as f:
        verdicts = [v.decode() for v in f["limit_cycle/verdict"][()]]
        assert verdicts[0].startswith("failed: limit cycles need self-excitation")
        assert "wave_7" in f["limit_cycle/case_1"]


def test_info_reads_a_limit_cycle_file(limit_cycle_file, capsys):
    """`info` on a limit-cycle file: the verdict and the cycle's amplitude and frequency as
    stored, per wave its Hopf point (issue #40: it was refused as an unknown format)."""
    assert cli.main(["info", str(limit_cycle_file), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["kind"] == "limit-cycle" and out["settings"]["method"] == "hb"
    case = out["cases"][0]
    assert case["shroud_deg"] == 80.0
    with h5py.File(limit_cycle_file, "r") as f:
        g = f["limit_cycle/case_0/wave_6"]
        assert case["verdict"] == f["limit_cycle/verdict"][0].decode()
        wave = case["waves"][0]
        assert wave["nodal_diameter"] == 6 and wave["hopf_hz"] == g.attrs["hopf_hz"]
        assert wave["cycles"][0]["tip_amplitude_m"] == g["cycles/tip_amplitude"][0]
        assert wave["cycles"][0]["frequency_hz"] == g["cycles/frequency_hz"][0]
    assert cli.main(["info", str(limit_cycle_file)]) == 0
    text = capsys.readouterr().out
    assert "limit cycles, 1 case(s) (harmonic balance; H = 5" in text
    assert "tieboss 45 deg, shroud 80 deg" in text and "wave 6 (ND 6 forward, Hopf at" in text
