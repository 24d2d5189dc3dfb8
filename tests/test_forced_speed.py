"""The forced response over the rotor speed (``forced.over = "speed"``, issue #45): the
nozzle's frequency is ``n_s`` times the speed and the stiffness follows the speed, so that a
curve is the Campbell crossing itself. Truth: models built at each speed (their own
prestress and modes), the whole-wheel linear solve beside the one-blade balance, the
balance's derivative by differences, the shot on the transient's equations."""

import math

import numpy as np
import pytest

from conftest import SMALL
from test_forced_wave import _harmonic_1
from wheelrom import config
from wheelrom.analysis import forced
from wheelrom.analysis.forced_peak import tuned_reference
from wheelrom.analysis.periodic.forced_shooting import exact_forced
from wheelrom.analysis.periodic.forced_wave import ForcedWave, forced_curve
from wheelrom.rom.build import build_model
from wheelrom.rom.campbell import campbell
from wheelrom.studies.forced_nonlinear import forced_inputs

#: engine order 2 meets the small wheel's first ND 2 family near 70.8 Hz (141.6 Hz), where
#: the model is built; no contacts: the linear wheel
CROSSING = ["wheel.stator_vanes=2", "wheel.speed_hz=70.0", 'flutter.model="off"',
            "contacts.tieboss.enabled=false", "contacts.shroud.enabled=false"]


@pytest.fixture(scope="module")
def crossing(comm):
    cfg = config.load(SMALL, ['forced.over="speed"'] + CROSSING)
    return cfg, build_model(cfg, comm)


@pytest.mark.parametrize("factor", [0.9, 1.1])
def test_the_wheel_at_another_speed_is_the_wheel_built_there(small_cfg, small_model, comm,
                                                             factor):
    """The stiffening's share in the model's basis (both prestress terms scale with the
    speed squared) moved to 0.9 and 1.1 times the speed: every ND's first three families
    as a model built there (its own prestress, modes and basis) to 1e-3 (measured up to
    7e-4: the basis is the build speed's); left at the build speed they are 5 % off."""
    speed = factor * small_cfg.wheel.speed_hz
    built = build_model(small_cfg.replace(**{"wheel.speed_hz": speed}), comm)
    moved = small_model.at_speed(speed)
    for nd in range(small_model.blades // 2 + 1):
        truth = np.linalg.eigvalsh(built.nd_stiffness(nd))[:3]
        ours = np.linalg.eigvalsh(moved.nd_stiffness(nd))[:3]
        left = np.linalg.eigvalsh(small_model.nd_stiffness(nd))[:3]
        assert np.abs(np.sqrt(ours / truth) - 1).max() < 1e-3, nd
        assert np.abs(np.sqrt(left / truth) - 1).max() > 4e-2, nd


def test_the_linear_peak_over_the_speed_is_the_campbell_crossing(crossing, comm):
    """The peak found over the speed (the crossings' eigenproblem, then the refined search
    with the stiffness at each frequency's speed) sits at the crossing of the engine order's
    line with the ND 2 family that models built at 66..74 Hz give (measured 1.1e-5 apart);
    over the frequency at the build speed it sits 0.6 % away."""
    cfg, model = crossing
    peak = tuned_reference(model, cfg, [None], contacts=False, comm=comm)
    speeds = np.linspace(66.0, 74.0, 5)
    family = campbell(cfg, speeds, comm)["wheel_hz_by_nd"][:, 2, 0]
    gap = family - 2 * speeds
    i = int(np.flatnonzero(np.diff(np.sign(gap)))[0])
    crossing_hz = speeds[i] - gap[i] * (speeds[i + 1] - speeds[i]) / (gap[i + 1] - gap[i])
    assert peak.frequency_hz / 2 == pytest.approx(crossing_hz, rel=1e-4)
    fixed = tuned_reference(model, cfg.replace(**{"forced.over": "frequency"}), [None],
                            contacts=False, comm=comm)
    assert abs(fixed.frequency_hz / 2 / crossing_hz - 1) > 3e-3


def test_the_balance_over_the_speed_is_the_whole_wheels_linear_solve(crossing):
    """The one-blade harmonic balance over the speed (its stiffness moved per frequency)
    equals the whole wheel's KSP solve over the speed to 1e-6 of the peak, and its
    frequency derivative (the arclength's column, with the stiffness's share) equals central
    differences of its residual."""
    cfg, model = crossing
    params, q = forced_inputs(model, cfg)
    assert params.follows_speed
    w = 2 * math.pi * np.linspace(139.0, 144.0, 6)
    curve = forced_curve(model, params, cfg.wheel.damping_beta, w, q, harmonics=3)
    assert curve.converged.all()
    K, C = forced.operators(model, cfg, contacts=False)
    F = forced.nozzle_amplitude(model, cfg.wheel.stator_vanes, cfg.excitation.force)
    solver = forced.HarmonicSolver(K, C, speed=forced.speed_following(model, cfg))
    try:
        Q = np.array([solver.solve(F, wi).reshape(model.blades, -1)[0] for wi in w])
    finally:
        solver.destroy()
    np.testing.assert_allclose(_harmonic_1(curve), Q, rtol=1e-6, atol=1e-6 * np.abs(Q).max())
    # at the build speed's stiffness the peak is elsewhere: 0.9 of the peak apart
    fixed = forced.forced_response(model, cfg.replace(**{"forced.over": "frequency"}), w,
                                   contacts=False).blade_amplitude[:, 0]
    assert np.abs(fixed - curve.tip_amplitude).max() > 0.05 * curve.tip_amplitude.max()
    problem = ForcedWave(model, params, cfg.wheel.damping_beta, 3)
    X, omega = curve.harmonics[2], w[2]
    _, _, dRdw, _ = problem.balance.jacobian(X, omega, 0.0)
    h = 1e-4 * omega
    differences = (problem.balance.residual(X, omega + h, 0.0)
                   - problem.balance.residual(X, omega - h, 0.0)) / (2 * h)
    assert np.abs(dRdw - differences).max() < 1e-6 * np.abs(differences).max()


def test_the_shot_over_the_speed_is_the_balance(crossing):
    """The exact state by shooting at a frequency of the curve (the transient's flow on the
    wheel at that frequency's speed) is the balance's, linear here: to 1e-5 (measured 8e-8;
    the shot on the build speed's stiffness lands 50 % off)."""
    cfg, model = crossing
    params, q = forced_inputs(model, cfg)
    w = 2 * math.pi * 141.0
    curve = forced_curve(model, params, cfg.wheel.damping_beta, np.array([w]), q, harmonics=3)
    problem = ForcedWave(model, params, cfg.wheel.damping_beta, 3)
    orbit = exact_forced(model, cfg, problem, curve.harmonics[0], w, refine=False)
    assert orbit.converged and abs(orbit.relative_difference) < 1e-5


def test_the_command_sweeps_the_speed(tmp_path, capsys):
    """``forced-response --speeds`` with ``forced.over = "speed"``: the refined peak at the
    crossing (the rotor speed of the test above), ``over`` in the JSON and the file."""
    import json

    import h5py

    from wheelrom.cli import main as cli

    path = tmp_path / "f.h5"
    argv = ["forced-response", SMALL, "--speeds", "69:72:7", "--no-contacts", "--json",
            "--out", str(path), "--set", 'forced.over="speed"']
    for key in CROSSING:
        argv += ["--set", key]
    assert cli.main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["over"] == "speed"
    assert out["peak_speed_hz"] == pytest.approx(70.8211, rel=1e-4)  # models built there
    with h5py.File(path) as f:
        assert f.attrs["over"] == "speed"


def test_the_crossing_of_a_wheel_that_is_not_circulant_is_its_excited_nds(crossing):
    """The automatic band's centre over the speed: on a stiffness that is not exactly
    block-circulant (every ND's crossings from the whole wheel, the excited ND's picked by
    its shapes) the same crossing as the ND block's of the tuned wheel."""
    import scipy.sparse as sp

    from wheelrom.analysis.forced_peak import resonance

    cfg, model = crossing
    speed = forced.speed_following(model, cfg)
    K = model.sparse_stiffness().tolil()
    K[0, 0] *= 1.0 + 1e-8  # a trace of mistuning: the general branch
    for family in (0, 1):
        circulant = resonance(model.sparse_stiffness(), model, 2, family, speed)
        general = resonance(sp.csr_matrix(K), model, 2, family, speed)
        assert general == pytest.approx(circulant, rel=1e-6)
    assert resonance(model.sparse_stiffness(), model, 2, 0, speed) / (2 * math.pi) == \
        pytest.approx(2 * 70.8211, rel=1e-4)
