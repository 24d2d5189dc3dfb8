"""The aerodynamic damping table (flutter.model = "table") against independent truth: the DFT
of its influence coefficients, the closed-form single-mode growth rate, the linearised
relative Van der Pol force, a second implementation of the force (reference model) and a
transient from the preloaded equilibrium; bad tables are named errors."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from conftest import SMALL
from wheelrom import config
from wheelrom.analysis.margin import case_margin
from wheelrom.analysis.stability import analyse
from wheelrom.config.aero import read_aero_table
from wheelrom.forces.aero import influence_coefficients, nd_coefficients
from wheelrom.forces.parameters import force_parameters
from wheelrom.runtime.environment import petsc

SELF = petsc().COMM_SELF
OFF = ["contacts.tieboss.enabled=false", "contacts.shroud.enabled=false"]


def wave_operator(a, b):
    """``(A, B)``: ``A_k = sum_j a_j e^{i j sigma_k}`` computed as written (no FFT)."""
    N = a.size
    phase = np.exp(2j * np.pi * np.outer(np.arange(N), np.arange(N)) / N)  # [k, j]
    return phase @ a, phase @ b


def _write(path, header, rows):
    path.write_text(header + "\n" + "\n".join(",".join(repr(float(v)) for v in r)
                                              for r in rows) + "\n")
    return str(path)


def _table_cfg(path, *more):
    return config.load(SMALL, ['flutter.model="table"', f'flutter.table="{path}"', *more])


@pytest.mark.parametrize("kind", ["damping_ratio", "complex"])
def test_influence_coefficients_reproduce_the_table_at_every_nd(tmp_path, kind):
    """The travelling-wave operator of the influence coefficients, ``A_k + i omega_k B_k``,
    equals the table's ``k_a + i omega_k c_a`` at every ND (real and complex tables, the two
    directions different, frequencies different per ND pair)."""
    N = 12
    rng = np.random.default_rng(3)
    nd = np.arange(N)
    freq = 150.0 + 10.0 * np.minimum(nd, N - nd)  # equal for k and N - k (one family)
    if kind == "damping_ratio":
        rows = np.column_stack([nd, 0.01 + 0.005 * rng.normal(size=N), freq])
        path = _write(tmp_path / "t.csv", "nd,damping_ratio,frequency_hz", rows)
    else:
        rows = np.column_stack([nd, rng.normal(size=N) * 1e5, 20 + rng.normal(size=N) * 30,
                                freq])
        path = _write(tmp_path / "t.csv", "nd,aero_stiffness,aero_damping,frequency_hz", rows)
    table = read_aero_table(path, "<test>", N, sign=1)
    omega = 2 * math.pi * freq
    p_mode = 0.37
    kappa = nd_coefficients(table, omega, p_mode)
    a, b = influence_coefficients(kappa, omega)
    A, B = wave_operator(a, b)
    np.testing.assert_allclose(A + 1j * omega * B, kappa, rtol=0, atol=1e-12 * abs(kappa).max())
    if kind == "damping_ratio":  # 2 zeta omega / p^2 as the damping per ND
        np.testing.assert_allclose(kappa.imag / omega, 2 * rows[:, 1] * omega / p_mode**2,
                                   rtol=1e-13)
    else:
        np.testing.assert_allclose(kappa.real, rows[:, 1], rtol=1e-13)


def test_lag_convention_and_phase_angles_are_the_same_table(tmp_path):
    """One wave written four ways: ND in the lead convention, ND in the lag convention
    (``k -> N - k``), negative NDs, and phase angles (interpolated exactly at the NDs)."""
    N = 12
    zeta = 0.01 + 0.004 * np.sin(2 * math.pi * np.arange(N) / N + 0.3)
    nd = np.arange(N)
    lead = read_aero_table(_write(tmp_path / "a.csv", "nd,damping_ratio",
                                  np.column_stack([nd, zeta])), "<t>", N)
    lag = read_aero_table(_write(tmp_path / "b.csv", "nd,damping_ratio",
                                 np.column_stack([(N - nd) % N, zeta])), "<t>", N,
                          phase="lag")
    signed = read_aero_table(_write(tmp_path / "c.csv", "nd,damping_ratio",
                                    np.column_stack([np.where(nd > N // 2, nd - N, nd), zeta])),
                             "<t>", N)
    angles = read_aero_table(_write(tmp_path / "d.csv", "ibpa_deg,damping_ratio",
                                    np.column_stack([360.0 * nd / N - 360.0 * (nd > 6), zeta])),
                             "<t>", N)
    for other in (lead, lag, signed, angles):
        np.testing.assert_allclose(other.damping_ratio, zeta, rtol=1e-14)
    symmetric = read_aero_table(_write(tmp_path / "e.csv", "ibpa_deg,damping_ratio",
                                       [[0.0, 0.01], [180.0, 0.03]]), "<t>", N,
                                directions="symmetric")
    expected = 0.01 + 0.02 * np.minimum(nd, N - nd) / (N / 2)
    np.testing.assert_allclose(symmetric.damping_ratio, expected, rtol=1e-14)


@pytest.fixture(scope="module")
def one_mode():
    """The small wheel with one segment mode, contacts off: each ND is one oscillator."""
    from wheelrom.rom.build import build_model

    cfg = config.load(SMALL, ["wheel.modes_per_segment=1", *OFF])
    return cfg, build_model(cfg, SELF)


def test_growth_rate_of_each_nd_is_the_single_mode_closed_form(one_mode, tmp_path):
    """Contacts off, one mode: ND ``k`` is ``q'' + (beta omega_k^2 + 2 zeta_k omega_k) q' +
    omega_k^2 q = 0``, growth ``-(beta omega_k^2 + 2 zeta_k omega_k) / 2`` exactly for a table
    the same in both directions; unequal directions split the pair (each to first order)."""
    cfg, model = one_mode
    N = model.blades
    nd = np.arange(N)
    half = np.minimum(nd, N - nd)
    zeta = 0.02 - 0.006 * half  # negative from ND 4 on: some NDs grow
    path = _write(tmp_path / "sym.csv", "nd,damping_ratio", np.column_stack([nd, zeta]))
    tab = config.load(SMALL, ["wheel.modes_per_segment=1", *OFF, 'flutter.model="table"',
                              f'flutter.table="{path}"'])
    res = analyse(model, tab)
    omega = np.sqrt(np.array([model.block_circulant_eigenvalues()[k][0].real
                              for k in range(N)]))
    beta = cfg.wheel.damping_beta
    for k in range(N // 2 + 1):
        expected = -(beta * omega[k] ** 2 + 2 * zeta[k] * omega[k]) / 2
        got = res.growth_rate[res.nodal_diameter == k]
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-8 * abs(expected))
    assert res.verdict() == "unstable"
    # directions apart: ND 3 forward destabilised, its backward partner ND 9 damped
    zeta2 = np.full(N, 0.01)
    zeta2[3] = -0.03
    path = _write(tmp_path / "asym.csv", "nd,damping_ratio", np.column_stack([nd, zeta2]))
    tab2 = tab.replace(**{"flutter.table": path})
    res2 = analyse(model, tab2)
    lam = res2.eigenvalue[res2.nodal_diameter == 3]
    forward, backward = lam[lam.imag > 0][0], lam[lam.imag < 0][0]
    for value, z in ((forward, zeta2[3]), (backward, zeta2[9])):
        expected = -(beta * omega[3] ** 2 + 2 * z * omega[3]) / 2
        assert value.real == pytest.approx(expected, rel=1e-3)


def _matched_distance(a, b):
    """Largest distance between two spectra (per ND, optimal pairing)."""
    worst = 0.0
    for k in np.unique(a.nodal_diameter):
        x, y = a.eigenvalue[a.nodal_diameter == k], b.eigenvalue[b.nodal_diameter == k]
        cost = np.abs(x[:, None] - y[None, :])
        r, c = linear_sum_assignment(cost)
        worst = max(worst, cost[r, c].max())
    return worst


@pytest.mark.parametrize("shroud", [20.0, 80.0])
def test_table_of_the_linearised_relative_van_der_pol_gives_its_spectrum(
        small_model, small_cfg, tmp_path, shroud):
    """At rest the relative Van der Pol force is ``mu (2 - 2 cos sigma_k) y'`` on ND ``k``: a
    table of ``aero_damping = -mu (2 - 2 cos sigma_k)`` gives the same spectrum (contacts on,
    six modes, the equilibrium unchanged up to the LU ordering of a wider pattern)."""
    N, mu = small_model.blades, small_cfg.flutter.mu
    nd = np.arange(N)
    damping = -mu * (2 - 2 * np.cos(2 * math.pi * nd / N))
    path = _write(tmp_path / "vdp.csv", "nd,aero_damping", np.column_stack([nd, damping]))
    tab = _table_cfg(path, "flutter.table_sign=1")
    angles = {"shroud": shroud}
    a, b = analyse(small_model, small_cfg, angles), analyse(small_model, tab, angles)
    assert _matched_distance(a, b) <= 1e-10 * np.abs(a.eigenvalue).max()
    np.testing.assert_allclose(b.equilibrium, a.equilibrium, rtol=1e-10)


def test_margin_is_the_factor_on_the_table(small_model, tmp_path):
    """The flutter margin of a table case is the factor on its aerodynamic forces: a fresh
    analysis at 0.995 and 1.005 times it is stable, then unstable."""
    N = small_model.blades
    nd = np.arange(N)
    zeta = 0.01 - 0.03 * np.sin(2 * math.pi * nd / N)  # the usual shape: negative in a band
    path = _write(tmp_path / "m.csv", "nd,damping_ratio", np.column_stack([nd, zeta]))
    tab = _table_cfg(path)
    res = analyse(small_model, tab, {"shroud": 50.0}, keep_jacobian=True)
    margin = case_margin(small_model, tab, res)
    assert 0 < margin.critical_mu < math.inf
    for factor, verdict in ((0.995, "stable"), (1.005, "unstable")):
        scaled = tab.replace(**{"flutter.table_scale": margin.critical_mu * factor})
        assert analyse(small_model, scaled, {"shroud": 50.0}).verdict() == verdict


def test_compiled_rhs_equals_reference_forces_with_a_table(coarse_model, coarse_cfg, tmp_path):
    """The kernel's influence-coefficient sum against the reference force model (a complex
    table, unequal directions, contacts opening and slipping, per-blade angles)."""
    from wheelrom.transient import bridge
    from wheelrom.transient.problem import WheelProblem

    N = coarse_model.blades
    rng = np.random.default_rng(5)
    nd = np.arange(N)
    rows = np.column_stack([nd, rng.normal(size=N) * 1e4, 50 + rng.normal(size=N) * 80])
    path = _write(tmp_path / "c.csv", "nd,aero_stiffness,aero_damping", rows)
    cfg = coarse_cfg.replace(**{"flutter.model": "table", "flutter.table": path,
                                "flutter.table_sign": 1})
    angles = {"shroud": np.linspace(10.0, 80.0, N), "tieboss": 45.0}
    params = force_parameters(coarse_model, cfg, angles)
    assert np.abs(params.aero_displacement).max() > 0 and np.abs(params.aero_velocity).max() > 0
    problem = WheelProblem(coarse_model, cfg, [params], SELF)
    u = rng.normal(size=problem.size()) * 2e-3
    u[problem.n : 2 * problem.n] *= 1000.0
    expected = problem.rhs_numpy(0.0123, u)
    got = bridge.evaluate(problem.context, 0.0123, u)
    scale = np.abs(expected[problem.n : 2 * problem.n]).max()
    assert np.abs(got[: 2 * problem.n] - expected[: 2 * problem.n]).max() < 1e-12 * scale
    np.testing.assert_allclose(got[2 * problem.n :], expected[2 * problem.n :], rtol=1e-10)
    problem.destroy()


def test_transient_from_the_preload_grows_at_the_linear_rate(small_model, tmp_path):
    """Contacts on, started from the preloaded equilibrium with a 1 nm perturbation: the
    fastest ND component grows at the stability analysis's largest growth rate (1 %)."""
    from wheelrom.transient.run import run_case

    N = small_model.blades
    nd = np.arange(N)
    zeta = np.full(N, 0.01)
    zeta[3] = -0.04  # one forward wave destabilised
    path = _write(tmp_path / "g.csv", "nd,damping_ratio", np.column_stack([nd, zeta]))
    cfg = _table_cfg(path, "excitation.force=0.0", 'time.start="preload"',
                     "time.perturbation=1e-9", "time.end=0.3", "time.window=0.01",
                     "output.sample_rate_hz=20000.0")
    angles = {"shroud": 50.0}
    linear = analyse(small_model, cfg, angles)
    assert linear.nodal_diameter[linear.critical()] == 3
    res = run_case(small_model, cfg, angles)
    assert res.status == "done"
    _, per_nd = res.growth_rates()
    assert int(np.argmax(per_nd)) == 3
    assert per_nd[3] == pytest.approx(linear.growth_rate.max(), rel=1e-2)


BAD = [
    ("nd,damping_ratio\n0,0.01\n1,0.01\n1,0.02\n", "lines 3 and 4 give the same nodal diameter"),
    ("nd,damping_ratio\n0,0.01\n1,0.01\n", "nodal diameter(s) 2, 3,"),
    ("nd,damping_ratio\n" + "".join(f"{k},0.01\n" for k in range(11)) + "11,1.5\n",
     "line 13, damping_ratio = 1.5 is not below 1"),
    ("nd,damping_ratio\n" + "".join(f"{k},-0.01\n" for k in range(12)),
     "negative at 12 of 12 nodal diameters"),
    ("ibpa_deg,damping_ratio\n0,0.01\n360,0.02\n", "lines 2 and 3 give the same phase angle"),
    ("nd,damping\n0,0.01\n", "unknown column 'damping'"),
    ("nd,damping_ratio\n0,abc\n", "line 2, damping_ratio = 'abc' is not a number"),
    ("nd,damping_ratio\n0.5,0.01\n", "line 2, nd = 0.5 is not an integer"),
    ("nd,aero_damping,frequency_hz\n" + "".join(f"{k},1.0,100\n" for k in range(11))
     + "11,1.0,-5\n", "line 13, frequency_hz = -5 is not positive"),
]


@pytest.mark.parametrize(("text", "message"), BAD)
def test_bad_tables_are_named_errors(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(config.ConfigError) as err:
        _table_cfg(str(path))
    assert "flutter.table" in str(err.value) and message in str(err.value), str(err.value)


def test_a_bad_table_exits_2_before_anything_is_computed(tmp_path, capsys):
    from wheelrom.cli import main as cli

    (tmp_path / "bad.csv").write_text("nd,damping_ratio\n0,0.01\n")
    toml = tmp_path / "case.toml"
    toml.write_text(open(SMALL).read() + '\n[flutter]\nmodel = "table"\ntable = "bad.csv"\n')
    out = tmp_path / "out.h5"
    assert cli.main(["stability", str(toml), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "flutter.table" in err and "bad.csv" in err and "missing" in err
    assert not out.exists()

