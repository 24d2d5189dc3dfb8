"""Linear forced response to the nozzle (wheelrom.analysis.forced) against independent
truth: the single-ND solution of the tuned wheel, scipy's sparse direct solve, Whitehead's
bound on the mistuned amplification."""

import json
import math

import h5py
import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from conftest import SMALL
from wheelrom.analysis import forced
from wheelrom.rom.model import nodal_diameter

WHITEHEAD_SAMPLES = 200


def _nd_frequency(model, nd: int, family: int = 0) -> float:
    """Frequency [rad/s] of mode ``family`` at nodal diameter ``nd``."""
    return 2 * math.pi * model.frequencies_by_nodal_diameter()[nd, family]


def test_tuned_response_is_the_single_nd_solution(small_model, small_cfg):
    """A tuned wheel without contacts answers on the excited travelling wave only, and that
    wave is the solution of the m x m ND block problem."""
    model, cfg = forced.tuned_copy(small_model), small_cfg
    N, m, n_s = model.blades, model.modes, cfg.wheel.stator_vanes
    K, C = forced.operators(model, cfg, contacts=False)
    F = forced.nozzle_amplitude(model, n_s, cfg.excitation.force)
    phi = 2 * math.pi * n_s / N
    Kk = model.A0 + model.A1 * np.exp(1j * phi) + model.A1.T * np.exp(-1j * phi)
    beta = cfg.wheel.damping_beta
    nd = int(nodal_diameter(n_s, N))
    assert nd == abs(N - n_s)
    w_res = _nd_frequency(model, nd)
    for w in (0.5 * w_res, 0.999 * w_res, w_res, 1.7 * w_res):
        Q = forced.direct_solve(K, C, F, w).reshape(N, m)
        harmonics = np.abs(np.fft.fft(Q, axis=0)).sum(axis=1)  # (N,) over blade harmonics
        assert np.argmax(harmonics) == n_s % N
        assert np.delete(harmonics, n_s % N).max() <= 1e-10 * harmonics.max()
        Q0 = np.linalg.solve(Kk - w**2 * np.eye(m) + 1j * w * beta * Kk, F[0])
        wave = Q0[None, :] * np.exp(1j * phi * np.arange(N))[:, None]
        assert np.abs(Q - wave).max() <= 1e-10 * np.abs(wave).max()


@pytest.mark.parametrize("contacts", [False, True])
def test_ksp_equals_scipy_direct(small_model, small_cfg, contacts):
    model, cfg = small_model, small_cfg
    K, C = forced.operators(model, cfg, contacts=contacts)
    F = forced.nozzle_amplitude(model, cfg.wheel.stator_vanes, cfg.excitation.force)
    solver = forced.HarmonicSolver(K, C)
    w_res = _nd_frequency(model, int(nodal_diameter(cfg.wheel.stator_vanes, model.blades)))
    for w in (0.0, 0.8 * w_res, w_res, 2.3 * w_res):
        ours = solver.solve(F, w)
        truth = forced.direct_solve(K, C, F, w)
        assert np.abs(ours - truth).max() <= 1e-10 * np.abs(truth).max()
    assert solver.solves == 4
    solver.destroy()


@pytest.mark.parametrize("contacts", [False, True])
def test_zero_mistuning_amplifies_by_one(small_model, small_cfg, contacts):
    model, cfg = small_model, small_cfg
    zero = forced.tuned_copy(model)
    zero.mistuning = np.zeros(model.blades)
    w_res = _nd_frequency(model, int(nodal_diameter(cfg.wheel.stator_vanes, model.blades)))
    w = np.linspace(0.9, 1.1, 41) * w_res
    ours = forced.forced_response(zero, cfg, w, contacts=contacts)
    tuned = forced.forced_response(forced.tuned_copy(model), cfg, w, contacts=contacts)
    assert ours.max_amplitude.shape == (41,)
    assert abs(forced.amplification_factor(ours, tuned) - 1) <= 1e-12


def _peak(model, cfg, K, C, F, around: np.ndarray) -> float:
    """The largest blade amplitude [m] over local maxima searched near every frequency of
    ``around`` [rad/s] (a bracket of +-10 half-power bandwidths)."""
    beta = cfg.wheel.damping_beta

    def minus_amplitude(w):
        return -forced.tip_amplitudes(model, forced.direct_solve(K, C, F, w)).max()

    best = 0.0
    for w0 in around:
        half = 10 * beta * w0**2 / 2  # zeta w0, zeta = beta w0 / 2
        found = minimize_scalar(minus_amplitude, bounds=(w0 - half, w0 + half),
                                method="bounded", options={"xatol": 1e-6 * half})
        best = max(best, -found.fun, -minus_amplitude(w0))
    return best


@pytest.fixture(scope="module")
def one_mode(small_cfg, comm):
    from wheelrom.rom.build import build_model, quiet

    cfg = small_cfg.replace(**{"wheel.modes_per_segment": 1})
    return build_model(cfg, comm, log=quiet), cfg


def test_whitehead_bound(one_mode, capsys):
    """One mode per blade, contacts off: random mistuning (std 1-5 %) never amplifies the
    peak blade response beyond Whitehead's (1 + sqrt(N)) / 2."""
    model, cfg = one_mode
    N, n_s = model.blades, cfg.wheel.stator_vanes
    F = forced.nozzle_amplitude(model, n_s, cfg.excitation.force)
    tuned = forced.tuned_copy(model)
    K, C = forced.operators(tuned, cfg, contacts=False)
    k = tuned.block_circulant_eigenvalues()[n_s % N, 0]
    c = cfg.wheel.damping_beta * k
    w_peak = math.sqrt(k - c**2 / 2)  # max of 1 / |k - w^2 + i w c|
    tuned_peak = _peak(tuned, cfg, K, C, F, np.array([w_peak]))
    rng = np.random.default_rng(2026)
    factors = []
    for std in np.linspace(0.01, 0.05, WHITEHEAD_SAMPLES):
        mistuned = forced.tuned_copy(model)
        mistuned.mistuning = std * rng.standard_normal(N)
        K, C = forced.operators(mistuned, cfg, contacts=False)
        omega = np.sqrt(np.linalg.eigvalsh(K.toarray()))
        factors.append(_peak(mistuned, cfg, K, C, F, omega) / tuned_peak)
    bound = (1 + math.sqrt(N)) / 2
    with capsys.disabled():
        print(f"\nWhitehead: max amplification {max(factors):.4f} over {len(factors)} "
              f"realisations (mean {np.mean(factors):.4f}), bound {bound:.4f}")
    assert min(factors) > 0.5 and max(factors) <= bound


def test_cli_forced_response(tmp_path, capsys):
    from wheelrom.cli import main as cli

    out = tmp_path / "forced.h5"
    args = ["forced-response", SMALL, "--frequencies", "380:395:4", "--angle", "shroud", "50",
            "--set", "mistuning.std=0.02", "--json", "--out", str(out)]
    assert cli.main(args) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["mistuned"] and data["nodal_diameter"] == 2 and len(data["max_amplitude_m"]) == 4
    assert data["grid_amplification_factor"] == pytest.approx(
        max(data["max_amplitude_m"]) / max(data["tuned_max_amplitude_m"]), rel=1e-12)
    # the refined peaks: at least every grid value, their ratio the amplification factor
    assert data["peak_amplitude_m"] >= max(data["max_amplitude_m"])
    assert data["tuned_peak_amplitude_m"] >= max(data["tuned_max_amplitude_m"])
    assert data["amplification_factor"] == pytest.approx(
        data["peak_amplitude_m"] / data["tuned_peak_amplitude_m"], rel=1e-12)
    assert 380 <= data["peak_frequency_hz"] <= 395 and data["band_hz"] == [380.0, 395.0]
    with h5py.File(out) as f:
        assert f.attrs["format"] == "wheelrom-forced-1"
        assert f["blade_amplitude"].shape == (4, 12)
        assert np.allclose(f["blade_amplitude"][()].max(axis=1), data["max_amplitude_m"])
    assert cli.main(args) == 2  # the file exists: --force needed
    assert "--force" in capsys.readouterr().err


@pytest.mark.parametrize("bad", ["1:2", "a:b:3", "5:1:3", "1:2:0", "-1:2:3", "3:3:4"])
def test_cli_forced_response_refuses_a_bad_range(bad, capsys):
    from wheelrom.cli import main as cli

    assert cli.main(["forced-response", SMALL, f"--frequencies={bad}"]) == 2
    assert capsys.readouterr().err.startswith(f"wheelrom: --frequencies {bad}")


def test_cli_forced_response_over_rotor_speeds(capsys):
    """``--speeds A:B:N`` is the nozzle band ``n_s A .. n_s B``: the same peaks as the
    equivalent ``--frequencies``, reported also as the rotor speed that meets them."""
    from wheelrom.cli import main as cli

    common = ["forced-response", SMALL, "--set", "mistuning.std=0.02", "--no-contacts", "--json"]
    assert cli.main([*common, "--frequencies", "380:395:4"]) == 0
    by_frequency = json.loads(capsys.readouterr().out)
    n_s = by_frequency["stator_vanes"]
    assert cli.main([*common, "--speeds", f"{380 / n_s!r}:{395 / n_s!r}:4"]) == 0
    by_speed = json.loads(capsys.readouterr().out)
    np.testing.assert_allclose(by_speed["band_hz"], [380.0, 395.0], rtol=1e-14)
    for key in ("peak_amplitude_m", "peak_frequency_hz", "amplification_factor"):
        assert by_speed[key] == pytest.approx(by_frequency[key], rel=1e-9)
    assert by_speed["peak_speed_hz"] == pytest.approx(by_speed["peak_frequency_hz"] / n_s,
                                                      rel=1e-14)
    assert cli.main([*common, "--speeds", "1:2:3", "--frequencies", "1:2:3"]) == 2
    assert "exclude each other" in capsys.readouterr().err
    assert cli.main([*common, "--speeds", "2:1:3"]) == 2
    assert capsys.readouterr().err.startswith("wheelrom: --speeds 2:1:3")
