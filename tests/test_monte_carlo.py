"""Mistuning (issue #22) against independent truth: the peak refinement on a single-DOF
oscillator in closed form and on a grid that straddles the peak; the pruned candidates
against brute-force searches at every eigenfrequency; Monte Carlo realisations as study
cases (one model build, the stored pattern, the per-case amplification, numpy's statistics,
Whitehead's bound, figures); the configuration's new keys and their errors."""

import dataclasses
import json
import math
import re
from pathlib import Path

import h5py
import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from conftest import SMALL
from wheelrom import config
from wheelrom.analysis import forced
from wheelrom.analysis.forced_peak import peak_response, tuned_reference
from wheelrom.config import ConfigError
from wheelrom.rom.model import blade_mistuning

SEEDS = 20


@pytest.fixture(scope="module")
def one_mode(small_cfg, comm):
    """The small wheel with one mode per segment (a single DOF per blade)."""
    from wheelrom.rom.build import build_model, quiet

    cfg = small_cfg.replace(**{"wheel.modes_per_segment": 1})
    return build_model(cfg, comm, log=quiet), cfg


def _oscillator_peak(model, cfg) -> tuple[float, float]:
    """``(peak tip amplitude [m], its frequency [rad/s])`` of the tuned one-mode wheel without
    contacts: on the excited wave every blade is ``|F| / |k - w^2 + i w beta k|``, largest at
    ``w^2 = k - (beta k)^2 / 2`` where ``|k - w^2 + i w beta k|^2`` is
    ``beta^2 k^3 - beta^4 k^4 / 4``."""
    N, n_s, beta = model.blades, cfg.wheel.stator_vanes, cfg.wheel.damping_beta
    phase = 2 * math.pi * (n_s % N) / N
    k = float(model.A0[0, 0] + 2 * model.A1[0, 0] * math.cos(phase))  # the ND block, 1 x 1
    force = cfg.excitation.force * abs(model.excitation[0]) * np.linalg.norm(model.tip[:, 0])
    return (force / math.sqrt(beta**2 * k**3 - beta**4 * k**4 / 4),
            math.sqrt(k - (beta * k) ** 2 / 2))


def test_peak_of_a_single_dof_oscillator_is_the_closed_form(one_mode):
    model, cfg = one_mode
    exact, w_exact = _oscillator_peak(model, cfg)
    f0 = w_exact / (2 * math.pi)
    found = peak_response(model, cfg, (0.99 * f0, 1.01 * f0), contacts=False)
    assert found.amplitude == pytest.approx(exact, rel=1e-6)
    assert found.frequency == pytest.approx(w_exact, rel=1e-9)
    assert np.allclose(found.blade_amplitude, exact, rtol=1e-6)  # tuned: every blade alike
    # a grid of 8 points straddles the peak (its best point is far below): the refinement
    # from the grid alone finds it
    band = (0.99 * f0, 1.0103 * f0)
    grid = peak_response(model, cfg, band, contacts=False, points=8, use_modes=False)
    assert grid.grid_blade_amplitude.max() < 0.1 * exact
    assert grid.amplitude == pytest.approx(exact, rel=1e-6)
    assert grid.solves < 40 and found.solves < cfg.forced.points + 20


def _brute_peak(model, cfg, band) -> float:
    """The largest blade amplitude over Brent searches of +-10 half-power bandwidths about
    every eigenfrequency of ``K_R`` in ``band`` [rad/s] (scipy's direct solve, no pruning)."""
    K, C = forced.operators(model, cfg, contacts=False)
    F = forced.nozzle_amplitude(model, cfg.wheel.stator_vanes, cfg.excitation.force)
    omega = np.sqrt(np.linalg.eigvalsh(K.toarray()))
    beta, best = cfg.wheel.damping_beta, 0.0

    def minus(w):
        return -forced.tip_amplitudes(model, forced.direct_solve(K, C, F, w)).max()

    for w0 in omega[(omega >= band[0]) & (omega <= band[1])]:
        half = 10 * beta * w0**2 / 2
        lo, hi = max(w0 - half, band[0]), min(w0 + half, band[1])
        found = minimize_scalar(minus, bounds=(lo, hi), method="bounded",
                                options={"xatol": 1e-7 * half})
        best = max(best, -found.fun, -minus(w0))
    return best


def test_pruned_candidates_find_the_brute_force_peak(small_model, small_cfg):
    """Six modes per blade, 3 % random mistuning, contacts off: the peak equals the best of
    brute-force searches at every eigenfrequency of the band."""
    cfg = small_cfg.replace(**{"mistuning.std": 0.03, "mistuning.seed": 4})
    model = dataclasses.replace(small_model, mistuning=blade_mistuning(cfg))
    reference = tuned_reference(model, cfg, [model.mistuning], contacts=False)
    found = peak_response(model, cfg, reference.band_hz, contacts=False)
    truth = _brute_peak(model, cfg, reference.band)
    assert found.amplitude == pytest.approx(truth, rel=1e-7)
    assert found.modes < model.size  # the band and the pruning leave out most modes


def _study_cfg(tmp_path, overrides=(), seeds: int = SEEDS):
    text = Path(SMALL).read_text().split("[sweep]")[0] + f"""
[mistuning]
std = 0.02
[study.grid]
mistuning.seed = "0:{seeds - 1}:1"
"""
    path = tmp_path / "mc.toml"
    path.write_text(text)
    return config.load(path, overrides)


@pytest.fixture(scope="module")
def monte_carlo(tmp_path_factory, monkeypatch_module):
    """A 20-seed study with the forced response (contacts linearised), in this process;
    ``builds``: the reduced models it built."""
    from mpi4py import MPI

    from wheelrom.rom import build
    from wheelrom.studies import study

    tmp = tmp_path_factory.mktemp("mc")
    builds = []

    def counted(cfg, comm, log=build.quiet):
        builds.append(cfg)
        return build.build_model(cfg, comm, log)

    monkeypatch_module.setattr(study, "build_model", counted)
    cfg = _study_cfg(tmp, ["flutter.mu=0.0"])  # linearly stable: every factor counts
    summary = study.run_study(cfg, str(tmp / "mc.h5"), MPI.COMM_SELF, mode="stability",
                              log=lambda *_: None, forced=True)
    return cfg, tmp / "mc.h5", summary, builds


@pytest.fixture(scope="module")
def monkeypatch_module():
    with pytest.MonkeyPatch.context() as mp:
        yield mp


def test_a_monte_carlo_study_builds_one_model(monte_carlo):
    cfg, path, summary, builds = monte_carlo
    assert len(builds) == 1 and summary["models"] == 1 and summary["cases"] == SEEDS
    with h5py.File(path, "r") as f:
        assert f["cases/model"][()].tolist() == [0] * SEEDS
        assert "mistuning" not in f["models/0"]  # the group's model is tuned
        assert (f["forced/status"][()] == b"done").all()
        assert (f["forced/reference"][()] == 0).all()  # one tuned reference for all
        # each case's pattern is its own seeded draw (the same on any rank)
        for seed in (0, 7, 19):
            draw = 0.02 * np.random.default_rng(seed).standard_normal(12)
            assert np.array_equal(f["cases/mistuning"][seed], draw)


def test_case_amplification_equals_a_direct_peak_response(monte_carlo, small_model):
    """Case 7 again from the stored pattern and band alone."""
    cfg, path, _, _ = monte_carlo
    with h5py.File(path, "r") as f:
        delta, band = f["cases/mistuning"][7], tuple(f["forced/band_hz"][7])
        stored = {k: f[f"forced/{k}"][7] for k in ("peak_amplitude", "tuned_peak_amplitude",
                                                   "amplification", "peak_frequency_hz")}
        assert np.all(f["forced/band_hz"][()] == f["forced/band_hz"][0])  # a common band
    case = cfg.replace(**{"mistuning.seed": 7})
    model = dataclasses.replace(small_model, mistuning=delta)
    peak = peak_response(model, case, band)
    tuned = peak_response(forced.tuned_copy(model), case, band)
    assert peak.amplitude == pytest.approx(stored["peak_amplitude"], rel=1e-12)
    assert peak.frequency_hz == pytest.approx(stored["peak_frequency_hz"], rel=1e-12)
    assert tuned.amplitude == pytest.approx(stored["tuned_peak_amplitude"], rel=1e-12)
    assert stored["amplification"] == pytest.approx(peak.amplitude / tuned.amplitude, rel=1e-12)
    # the band: the tuned resonance +-2 max |delta| over the 20 realisations
    largest = max(np.abs(blade_mistuning(cfg.replace(**{"mistuning.seed": s}))).max()
                  for s in range(SEEDS))
    assert band[1] / band[0] == pytest.approx((1 + 2 * largest) / (1 - 2 * largest), rel=1e-12)


def test_statistics_are_numpys(monte_carlo):
    _, path, summary, _ = monte_carlo
    stats = summary["statistics"]
    with h5py.File(path, "r") as f:
        for name, data in (("amplification", f["forced/amplification"][()]),
                           ("max_growth_rate", f["stability/max_growth_rate"][()])):
            d = stats[name]
            assert d["count"] == SEEDS
            assert d["mean"] == pytest.approx(np.mean(data), rel=1e-14)
            assert d["std"] == pytest.approx(np.std(data), rel=1e-12)
            assert d["p95"] == pytest.approx(np.percentile(data, 95), rel=1e-14)
            assert d["max"] == np.max(data) and d["argmax"] == int(np.argmax(data))
    assert stats["whitehead_bound"] == pytest.approx((1 + math.sqrt(12)) / 2)


def test_unstable_realisations_are_left_out_of_the_amplification(tmp_path, capsys):
    """With the Van der Pol force on, the small wheel flutters in every realisation: their
    factors are stored, but the statistics (and `info`) leave them out and say so, since an
    unstable linearisation's peak is set by the band searched."""
    from mpi4py import MPI

    from wheelrom.cli.main import main
    from wheelrom.studies.study import run_study

    out = tmp_path / "u.h5"
    summary = run_study(_study_cfg(tmp_path, seeds=3), str(out), MPI.COMM_SELF,
                        mode="stability", log=lambda *_: None, forced=True)
    stats = summary["statistics"]
    with h5py.File(out, "r") as f:
        assert all(v == b"unstable" for v in f["stability/verdict"][()])
        assert np.isfinite(f["forced/amplification"][()]).all()
    assert stats["amplification"]["count"] == 0 and stats["amplification_unstable_cases"] == 3
    assert stats["max_growth_rate"]["count"] == 3
    assert main(["info", str(out)]) == 0
    assert "3 linearly unstable case(s) left out of the amplification" in capsys.readouterr().out


def test_info_and_figures_of_a_monte_carlo_study(monte_carlo, tmp_path, capsys):
    from wheelrom.plots.figures import plot_file
    from wheelrom.results.info import file_info

    _, path, summary, _ = monte_carlo
    info = json.loads(json.dumps(file_info(str(path))))
    assert info["statistics"] == json.loads(json.dumps(summary["statistics"]))
    assert info["cases"][3]["amplification"] > 0
    from wheelrom.cli.main import main

    assert main(["info", str(path)]) == 0  # the text table names every case's factor
    text = capsys.readouterr().out
    assert f"amplification {info['cases'][3]['amplification']:.4f}" in text
    import h5py

    from wheelrom.plots.study import StudyData

    with h5py.File(path, "r") as f:  # the study figures draw the factor over the varied keys
        np.testing.assert_array_equal(StudyData(f, str(path)).quantities["amplification"],
                                      f["forced/amplification"][()])
    names = {p.rsplit("/", 1)[-1] for p in plot_file(str(path), str(tmp_path))}
    assert {"mc_amplification.png", "mc_growth_rate.png", "mc_localisation.png"} <= names


def test_whitehead_bound_holds_for_one_mode_without_contacts(tmp_path):
    """One mode per blade, contacts off (the setting of the bound): no realisation of a
    uniform 3 % study exceeds (1 + sqrt(N)) / 2."""
    from mpi4py import MPI

    from wheelrom.studies.study import run_study

    cfg = _study_cfg(tmp_path, ['mistuning.distribution="uniform"', "mistuning.std=0.03",
                                "forced.contacts=false", "wheel.modes_per_segment=1"],
                     seeds=12)
    summary = run_study(cfg, str(tmp_path / "w.h5"), MPI.COMM_SELF, mode="stability",
                        log=lambda *_: None, forced=True)
    stats = summary["statistics"]
    assert stats["amplification"]["count"] == 12
    assert 1.0 < stats["amplification"]["max"] <= stats["whitehead_bound"]


def test_model_key_leaves_the_mistuning_to_the_cases(small_cfg):
    from wheelrom.config.study import model_key, tuned_key

    a = small_cfg.replace(**{"mistuning.std": 0.02, "mistuning.seed": 1})
    b = small_cfg.replace(**{"mistuning.alternate": 0.01, "forced.points": 5})
    assert model_key(a) == model_key(b) == model_key(small_cfg)
    assert tuned_key(a) == tuned_key(small_cfg) != tuned_key(b)  # forced.points differs


def test_uniform_distribution_has_the_standard_deviation(small_cfg):
    # 20000 draws: 20 seeds of the largest wheel (wheel.blades is at most 1000)
    delta = np.concatenate([blade_mistuning(small_cfg.replace(**{
        "wheel.blades": 1000, "mistuning.std": 0.02, "mistuning.distribution": "uniform",
        "mistuning.seed": seed})) for seed in range(20)])
    assert np.abs(delta).max() <= 0.02 * math.sqrt(3)
    assert np.std(delta) == pytest.approx(0.02, rel=0.02)
    assert np.abs(np.histogram(delta, bins=4)[0] / 5000 - 1).max() < 0.1  # flat


@pytest.mark.parametrize("suffix", [".csv", ".npy"])
def test_pattern_file_relative_to_the_toml(tmp_path, suffix):
    values = np.linspace(-0.03, 0.03, 12)
    if suffix == ".npy":
        np.save(tmp_path / "blades.npy", values)
    else:
        (tmp_path / "blades.csv").write_text("# delta_s\n" + "\n".join(map(repr, values)))
    toml = tmp_path / "w.toml"
    toml.write_text(Path(SMALL).read_text() + f'\n[mistuning]\nfile = "blades{suffix}"\n'
                    "alternate = 0.01\n")
    cfg = config.load(toml)
    expected = values + 0.01 * np.where(np.arange(12) % 2 == 0, 1, -1)
    assert np.array_equal(blade_mistuning(cfg), expected)


def test_a_study_reads_its_pattern_file_once_and_an_edited_file_again(tmp_path):
    from wheelrom.config import forced
    from wheelrom.config.study import expand
    from wheelrom.studies.mistuning import case_mistuning

    values = np.linspace(-0.03, 0.03, 12)
    (tmp_path / "blades.csv").write_text("\n".join(map(repr, values)))
    toml = tmp_path / "w.toml"
    toml.write_text(Path(SMALL).read_text().split("[sweep]")[0]
                    + '[mistuning]\nfile = "blades.csv"\n'
                    "[study.grid]\nmistuning.alternate = [0.0, 0.01, 0.02]\n"
                    "contacts.shroud.angle_deg = [20.0, 50.0]\n")
    forced._read_values.cache_clear()
    study = expand(config.load(toml))
    delta = case_mistuning(study, 12)
    assert forced._read_values.cache_info().misses == 1  # 6 cases validated and used
    assert np.array_equal(delta[5], values - 0.02 * (-1.0) ** np.arange(12) * -1)
    (tmp_path / "blades.csv").write_text("\n".join(map(repr, 2 * values)) + "\n")
    assert np.array_equal(blade_mistuning(config.load(toml)), 2 * values)  # edited: read again


@pytest.mark.parametrize("setting, message", [
    ('file = "missing.csv"', "mistuning.file: missing.csv: cannot be read"),
    ('file = "short.csv"', "mistuning.file: short.csv: 11 values for 12 blades (one per blade)"),
    ('file = "bad.csv"', "mistuning.file: bad.csv: value 3 ('x') is not a number"),
    ('file = "big.csv"', "mistuning.file: big.csv: blade 0's value 0.7 is not a finite number"),
    ('distribution = "gauss"', "mistuning.distribution: 'gauss' is not one of 'normal', "
                               "'uniform'"),
    ("pattern = [0.01, 0.02]", "mistuning.pattern: 2 values for 12 blades"),
])
def test_mistuning_errors_name_the_key_and_the_file(tmp_path, setting, message):
    (tmp_path / "short.csv").write_text(",".join(["0.01"] * 11))
    (tmp_path / "bad.csv").write_text("0.01, 0.02, x")
    (tmp_path / "big.csv").write_text("\n".join(["0.7"] * 12))
    toml = tmp_path / "w.toml"
    toml.write_text(Path(SMALL).read_text() + f"\n[mistuning]\n{setting}\n")
    with pytest.raises(ConfigError) as err:
        config.load(toml)
    assert message in str(err.value) and str(toml) in str(err.value)


@pytest.mark.parametrize("value, message", [
    ("[100.0]", "forced.band_hz: expected [] (automatic) or [lo, hi] with lo < hi"),
    ("[120.0, 110.0]", "forced.band_hz: expected [] (automatic) or [lo, hi]"),
    ("[-1.0, 110.0]", "forced.band_hz[0]: must be >= 0.0 Hz"),
])
def test_forced_band_errors(value, message):
    with pytest.raises(ConfigError, match=re.escape(message)):
        config.load(SMALL, [f"forced.band_hz={value}"])


def test_cli_forced_response_uses_the_forced_section(capsys, one_mode):
    """No --frequencies: the band and grid of [forced]; the refined peak and factor equal
    a direct call."""
    from wheelrom.cli import main as cli

    args = ["forced-response", SMALL, "--set", "wheel.modes_per_segment=1", "--set",
            "mistuning.alternate=0.01", "--set", "forced.contacts=false", "--set",
            "forced.points=7", "--json"]
    assert cli.main(args) == 0
    data = json.loads(capsys.readouterr().out)
    model, cfg = one_mode
    cfg = cfg.replace(**{"mistuning.alternate": 0.01, "forced.points": 7})
    model = dataclasses.replace(model, mistuning=blade_mistuning(cfg))
    tuned = tuned_reference(model, cfg, [model.mistuning], contacts=False)
    assert not data["contacts"] and len(data["frequency_hz"]) == 7
    assert data["band_hz"] == pytest.approx(list(tuned.band_hz), rel=1e-14)
    assert data["band_hz"][1] / data["band_hz"][0] == pytest.approx(1.02 / 0.98)  # +-1 %
    assert data["tuned_peak_amplitude_m"] == pytest.approx(tuned.amplitude, rel=1e-12)
    peak = peak_response(model, cfg, tuned.band_hz, contacts=False)
    assert data["amplification_factor"] == pytest.approx(peak.amplitude / tuned.amplitude,
                                                         rel=1e-12)



def test_case_stability_is_that_of_the_case_mistuned_model(monte_carlo, small_model):
    """``/stability`` of a realisation is the analysis of its own mistuned model (not the
    group's tuned one): the same growth rates as a direct ``analyse``, unlike the tuned
    wheel's."""
    from wheelrom.analysis.stability import analyse

    cfg, path, _, _ = monte_carlo
    with h5py.File(path, "r") as f:
        delta, stored = f["cases/mistuning"][7], f["stability/max_growth_rate"][7]
    case = cfg.replace(**{"mistuning.seed": 7})
    mistuned = analyse(dataclasses.replace(small_model, mistuning=delta), case)
    tuned = analyse(forced.tuned_copy(small_model), case)
    assert stored == pytest.approx(mistuned.growth_rate.max(), rel=1e-9, abs=1e-12)
    assert abs(tuned.growth_rate.max() - stored) > 1e-6 * abs(stored)


def test_resume_hint_of_a_forced_study_names_forced(tmp_path):
    """A ``--forced`` study with pending transients: ``info``'s resume command carries
    ``--forced`` (a resume without it is refused)."""
    from mpi4py import MPI

    from wheelrom.results.info import file_info
    from wheelrom.results.study_layout import resume_problem
    from wheelrom.studies.study import run_study

    cfg = _study_cfg(tmp_path, ["time.end=0.0005", "time.window=0.0005"], seeds=2)
    out = str(tmp_path / "f.h5")
    run_study(cfg, out, MPI.COMM_SELF, mode="full", log=lambda *_: None, forced=True)
    with h5py.File(out, "r+") as f:
        status = f["cases/status"][()]
        status[1] = b"pending"
        f["cases/status"][...] = status
    hint = file_info(out)["hint"]
    assert "--forced" in hint and "--resume" in hint
    assert resume_problem(out, cfg, "full", forced=False) is not None
    assert resume_problem(out, cfg, "full", forced=True) is None


def test_an_npz_archive_is_a_named_pattern_file_error(tmp_path):
    np.savez(tmp_path / "blades.npy", delta=np.zeros(12))  # numpy appends .npz
    (tmp_path / "blades.npy.npz").rename(tmp_path / "blades.npy")
    toml = tmp_path / "w.toml"
    toml.write_text(Path(SMALL).read_text() + '\n[mistuning]\nfile = "blades.npy"\n')
    with pytest.raises(ConfigError, match="blades.npy: is an .npz archive"):
        config.load(toml)


def test_a_blade_that_would_lose_its_stiffness_is_a_named_error():
    """pattern, file, alternate and random are each bounded, their sum is not: a blade with
    ``1 + delta_s <= 0.1`` is refused, naming the blade and the sources."""
    from wheelrom.rom.model import blade_mistuning
    from wheelrom.runtime.errors import InputError

    cfg = config.load(SMALL, ["mistuning.pattern=[-0.5, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]",
                              "mistuning.alternate=-0.45"])
    with pytest.raises(InputError, match=r"blade\(s\) 0 get delta_s = -0.95"):
        blade_mistuning(cfg)
    ok = blade_mistuning(cfg.replace(**{"mistuning.alternate": -0.3}))
    assert ok[0] == pytest.approx(-0.8)
