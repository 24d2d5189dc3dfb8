"""Limit cycles of the wheel (contacts on) against the transient: a second implementation (the
compiled right-hand side in PETSc TS) started on the harmonic-balance cycle must stay on it."""

import math

import numpy as np
import pytest

from wheelrom.analysis.periodic.continuation import BranchSettings
from wheelrom.analysis.periodic.harmonic_balance import WaveBalance
from wheelrom.analysis.periodic.limit_cycle import Settings, case_limit_cycles
from wheelrom.forces.parameters import force_parameters
from wheelrom.transient.run import run_case

ANGLES = {"tieboss": 45.0, "shroud": 80.0}
WAVE = 7  # ND 5, backward: unstable at 80 deg on the small wheel


@pytest.fixture(scope="module")
def autonomous(small_cfg):
    return small_cfg.replace(**{"excitation.force": 0.0, "time.scheme": "exponential"})


@pytest.fixture(scope="module")
def branch(small_model, autonomous):
    """The first points of wave 7's branch from its Hopf point: the tie-boss closed, the shroud
    open all the cycle (a smooth cycle: arm kinematics, micro-slip friction, Van der Pol)."""
    settings = Settings(harmonics=5, waves=(WAVE,), seeds=(), floquet="all",
                        branch=BranchSettings(steps=3))
    return case_limit_cycles(small_model, autonomous, settings, ANGLES).branches[0]


def test_the_branch_starts_at_the_linear_hopf_point(branch, small_model, autonomous):
    """The first cycle (1 nm) sits at the wave's linear crossing: frequency of the linear mode
    at ``lam_c`` (the eigenvalue problem, not the harmonic balance) to 1e-6."""
    first = branch.points[0]
    assert first.tip_amplitude == pytest.approx(1e-9, rel=1e-3)
    assert first.lam == pytest.approx(branch.critical_lam, rel=1e-6)
    assert first.frequency_hz == pytest.approx(branch.hopf_hz, rel=1e-6)
    # at 1 nm the trivial multiplier is exact and the Hopf cycle is neutral
    assert first.stability.trivial < 1e-6


def test_a_transient_started_on_a_cycle_returns_to_it(branch, small_model, autonomous):
    """Two periods of the transient (exponential scheme, 2000 steps per period) from the
    cycle's state of every blade return to that state: the harmonic balance is a periodic
    solution of the transient's equations, to 1e-6 of the vibration."""
    cycle = branch.points[-1]
    assert cycle.tip_amplitude > 5e-8 and np.all(cycle.fractions[:, 2] == 0)
    cfg = autonomous.replace(**{"flutter.mu": autonomous.flutter.mu * cycle.lam})
    params = force_parameters(small_model, cfg, ANGLES)
    balance = WaveBalance(small_model, params, cfg.wheel.damping_beta, WAVE, 5, 48)
    X = balance.packed(cycle.harmonics)
    omega = 2 * math.pi * cycle.frequency_hz
    q, v = balance.wheel_state(X, omega)
    period, steps = 2 * math.pi / omega, 2000
    run_cfg = cfg.replace(**{"time.step": period / steps, "time.end": 2 * period,
                             "time.window": 2 * period, "output.history_rate_hz": 0.0,
                             "output.sample_rate_hz": steps / period})
    res = run_case(small_model, run_cfg, ANGLES, u0=np.concatenate([q.ravel(), v.ravel()]))
    n = q.size
    vibration = np.abs(q - X[0]).max()
    assert np.abs(res.final_state[:n] - q.ravel()).max() < 1e-6 * vibration
    assert np.abs(res.final_state[n : 2 * n] - v.ravel()).max() < 1e-6 * np.abs(v).max()


def test_the_energy_per_cycle_balances(branch):
    """Work of the Van der Pol force = friction + beta_D dissipation per cycle, 1e-6 of it."""
    for cycle in branch.points[1:]:
        assert cycle.energy_in > 0
        assert cycle.energy_residual < 1e-6
        assert cycle.energy_residual_fine < 1e-6


def test_the_transient_check_agrees_with_hill_on_a_smooth_cycle(small_model, small_cfg):
    """Van der Pol alone (contacts off), relative form, ND N/2: Hill's method (converged for
    a smooth cycle: trivial multiplier 1 to 1e-6) and the transient check (the wheel
    integrated 60 periods from the cycle, every other ND perturbed) both call it stable; on
    the vibro-impact ND 6 cycle at 80 deg the transient check finds other NDs growing."""
    from wheelrom.analysis.periodic.cycle_transient import transient_stability
    from wheelrom.analysis.periodic.floquet import floquet
    from wheelrom.analysis.periodic.limit_cycle import periodic_solution
    from wheelrom.analysis.stability import linearise

    cfg = small_cfg.replace(**{"contacts.tieboss.enabled": False, "contacts.shroud.enabled": False,
                               "wheel.damping_beta": 1e-9, "flutter.mu": 10.0,
                               "excitation.force": 0.0, "time.scheme": "exponential"})
    params = force_parameters(small_model, cfg)
    balance = WaveBalance(small_model, params, cfg.wheel.damping_beta, 6, 3, 32)
    w2, V = np.linalg.eigh(small_model.nd_stiffness(6))
    i = int(np.argmax(np.abs(V.T @ params.aero)[:4]))
    X = np.zeros((7, small_model.modes))
    X[1] = V[:, i].real * cfg.flutter.r / abs(params.aero @ V[:, i])  # y amplitude r
    point = periodic_solution(balance, X, math.sqrt(w2[i]), 1.0)
    hill = floquet(balance, point.linearisation, point.omega, 1.0, range(small_model.blades))
    assert hill.trusted and hill.stable
    tip = float(np.linalg.norm(np.abs(small_model.tip @ (point.X[1] + 1j * point.X[2]))))
    check = transient_stability(small_model, cfg, None, balance, point.X, point.omega, 1.0, tip)
    assert check.stable and check.growth.max() < 0
    assert check.by == "transient: ND"
    # the vibro-impact cycle of ND 6 at 80 deg (~130 um, the shroud open half the time)
    params = force_parameters(small_model, autonomous_cfg(small_cfg), ANGLES)
    balance = WaveBalance(small_model, params, small_cfg.wheel.damping_beta, 6, 5, 48)
    w2, V = np.linalg.eigh(small_model.nd_stiffness(6))
    v = V[:, 0] / np.linalg.norm(small_model.tip @ V[:, 0])
    X = np.zeros((11, small_model.modes))
    X[0] = linearise(small_model, autonomous_cfg(small_cfg), ANGLES)[1][0]  # equilibrium
    X[1] = 1e-4 * v.real
    point = periodic_solution(balance, X, math.sqrt(w2[0]), 1.0)
    tip = float(np.linalg.norm(np.abs(small_model.tip @ (point.X[1] + 1j * point.X[2]))))
    check = transient_stability(small_model, autonomous_cfg(small_cfg), ANGLES, balance,
                                point.X, point.omega, 1.0, tip)
    assert not check.stable and check.growth.max() > 1.0
    assert check.worst_family not in (0, 6)


def autonomous_cfg(cfg):
    return cfg.replace(**{"excitation.force": 0.0, "time.scheme": "exponential"})




def test_the_physical_differencing_equals_the_modal_one(small_model, small_cfg, comm):
    """The force Jacobian by central differences over the blade-0 force's 2 x 33 physical
    inputs (contact points, Van der Pol y) equals the one over the window's 6 m modal
    coordinates: the force depends on q through those inputs only (a second implementation
    of the same derivative; both O(step^2), step 1e-10 m). The free basis's 6 modes cannot
    move 13 inputs of a blade apart: the modal differencing serves there."""
    from wheelrom.analysis.stability import linearise
    from wheelrom.rom.build import build_model

    free = WaveBalance(small_model, force_parameters(small_model, autonomous_cfg(small_cfg),
                                                     ANGLES), 5e-8, 6, 1, 8)
    assert free.inputs is None
    cfg = autonomous_cfg(small_cfg).replace(**{"wheel.basis": "attachment"})
    model = build_model(cfg, comm)
    params = force_parameters(model, cfg, ANGLES)
    balance = WaveBalance(model, params, small_cfg.wheel.damping_beta, 6, 5, 48)
    assert balance.inputs is not None and balance.inputs[0].size == 33
    small_model = model
    w2, V = np.linalg.eigh(small_model.nd_stiffness(6))
    v = V[:, 0] / np.linalg.norm(small_model.tip @ V[:, 0])
    X = np.zeros((11, small_model.modes))
    X[0] = linearise(small_model, cfg, ANGLES)[1][0]
    X[1], X[4] = 1.5e-4 * v.real, 3e-5 * v.real  # the shroud opens and closes in the period
    omega = math.sqrt(w2[0])
    q, v_ = balance.samples(X, omega)
    physical = balance._linearise_physical(q, v_, omega, 1.0)
    modal = balance._linearise_modal(q, v_, omega, 1.0)
    _, normal, _, _ = balance._evaluate(q, v_, 1.0)
    assert (normal == 0).any() and (normal > 0).any()  # a contact opens within the period
    np.testing.assert_array_equal(physical.force, modal.force)
    for a, b in ((physical.dq, modal.dq), (physical.dv, modal.dv)):
        scale = np.abs(b).max()
        assert scale > 0
        # measured 1.7e-7: differences straddling the lift-off kink at a sample
        assert np.abs(a - b).max() <= 1e-6 * scale, np.abs(a - b).max() / scale
