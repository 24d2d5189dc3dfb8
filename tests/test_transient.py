"""Transient solver against the serial reference, the frequency domain and energy laws."""

import math

import numpy as np
import pytest

from wheelrom import transient


def test_petsc_ts_equals_serial_reference_all_forces_on(coarse_model, coarse_cfg):
    steps = 2000
    cfg = coarse_cfg.replace(**{"time.end": steps * 5e-6, "time.window": steps * 5e-6})
    res = transient.run_case(coarse_model, cfg)
    assert res.status == "done" and res.steps == steps
    _, states, _ = transient.reference_solution(coarse_model, cfg, steps, sample_every=steps)
    n = coarse_model.size
    ref, got = states[-1][: 2 * n], res.final_state[: 2 * n]
    assert np.abs(ref).max() > 0
    assert np.abs(got - ref).max() <= 1e-9 * np.abs(ref).max()


def test_linear_steady_state_matches_frequency_domain(small_model, small_cfg):
    """Started on the frequency-domain steady state, the TS must stay on it."""
    cfg = small_cfg.replace(
        **{
            "flutter.model": "off",
            "contacts.tieboss.enabled": False,
            "contacts.shroud.enabled": False,
            "wheel.damping_beta": 2e-6,
            "time.end": 0.02,
            "time.window": 0.005,
            "time.step": 5e-6,
            "output.sample_rate_hz": 20000.0,
        }
    )
    N, m = small_model.blades, small_model.modes
    w = cfg.wheel.stator_vanes * 2 * math.pi * cfg.wheel.speed_hz
    K = small_model.dense_stiffness()
    phase = 2 * math.pi * (1 - cfg.wheel.stator_vanes / N) * np.arange(N)
    F = (cfg.excitation.force * np.exp(-1j * phase)[:, None] * small_model.excitation).ravel()
    X = np.linalg.solve(K - w * w * np.eye(N * m) + 1j * w * cfg.wheel.damping_beta * K, F)
    u0 = np.concatenate([X.real, (1j * w * X).real])
    res = transient.run_case(small_model, cfg, u0=u0)
    t = res.sample_time
    expect = np.real(np.exp(1j * w * t)[:, None, None] * (X.reshape(N, m) @ small_model.tip.T))
    amp = np.abs(X.reshape(N, m) @ small_model.tip[1]).max()
    assert amp > 0
    assert np.abs(res.tip_history - expect).max() < 5e-3 * amp


def _free_energy_drift(model, cfg, step):
    cfg = cfg.replace(
        **{
            "time.step": step,
            "time.end": 0.004,
            "time.window": 0.004,
            "output.sample_rate_hz": 1.0 / step,
        }
    )
    forces_off = {
        "flutter.model": "off",
        "excitation.force": 0.0,
        "wheel.damping_beta": 0.0,
        "contacts.tieboss.enabled": False,
        "contacts.shroud.enabled": False,
    }
    cfg = cfg.replace(**forces_off)
    from wheelrom.forces import ForceModel

    fm = ForceModel(model, cfg)
    problem = transient.WheelProblem(model, cfg, fm)
    rng = np.random.default_rng(2)
    u = np.zeros(problem.size())
    u[problem.n : 2 * problem.n] = rng.normal(size=problem.n) * 1e-2
    e0 = problem.energy(u)
    t, h = 0.0, step
    for _ in range(int(round(0.004 / step))):
        k1 = problem.rhs_numpy(t, u)
        k2 = problem.rhs_numpy(t + h / 2, u + h / 2 * k1)
        k3 = problem.rhs_numpy(t + 0.75 * h, u + 0.75 * h * k2)
        u = u + h * (2 * k1 + 3 * k2 + 4 * k3) / 9
        t += h
    return abs(problem.energy(u) - e0) / e0


def test_undamped_energy_drift_is_third_order(small_model, small_cfg):
    d1 = _free_energy_drift(small_model, small_cfg, 2e-5)
    d2 = _free_energy_drift(small_model, small_cfg, 1e-5)
    assert d1 > 0
    assert 6.0 < d1 / d2 < 20.0  # ~2^3; RK3 dissipation ~ h^4 per period -> 8-16


def test_energy_balance_closes_with_all_forces(coarse_model, coarse_cfg):
    cfg = coarse_cfg.replace(**{"time.end": 0.01, "time.window": 0.0025})
    res = transient.run_case(coarse_model, cfg)
    assert res.status == "done"
    assert np.abs(res.work[-1]).sum() > 0
    assert res.energy_balance_error() < 1e-3
    assert res.work[-1, 2] < 0 and res.work[-1, 3] < 0  # friction and damping dissipate


def test_preload_start_is_static_equilibrium(small_model, small_cfg):
    cfg = small_cfg.replace(**{"time.start": "preload"})
    from wheelrom.forces import ForceModel

    problem = transient.WheelProblem(small_model, cfg, ForceModel(small_model, cfg))
    res = transient.CaseResult()
    u0 = transient.initial_state(problem, cfg, res)
    assert np.abs(u0).max() > 0
    acc = problem.rhs_numpy(0.0, u0)[problem.n : 2 * problem.n]
    scale = np.abs(problem.Kd @ u0[: problem.n]).max()
    assert np.abs(acc).max() < 1e-9 * scale
    assert res.preload_residual < 1e-9 * scale


def test_divergence_stops_case_and_keeps_windows(small_model, small_cfg):
    cfg = small_cfg.replace(
        **{
            "time.step": 4e-4,
            "time.window": 4e-4 * 2,
            "time.end": 0.02,
            "output.sample_rate_hz": 1000.0,
        }
    )
    res = transient.run_case(small_model, cfg)
    assert res.status.startswith("failed:")
    assert "t =" in res.status


@pytest.mark.parametrize("rk", ["3bs", "4", "5dp"])
def test_ts_options_reach_the_solver(small_model, small_cfg, rk):
    cfg = small_cfg.replace(**{"time.end": 1e-3, "time.window": 1e-3})
    res = transient.run_case(small_model, cfg, options={"ts_rk_type": rk})
    assert res.options["ts_rk_type"] == rk and res.status == "done"


@pytest.mark.parametrize("vdp", ["off", "absolute", "relative"])
def test_compiled_rhs_equals_force_model_and_dense_stiffness(coarse_model, coarse_cfg, vdp):
    """Two implementations: the fused compiled RHS against ForceModel + dense K_R (numpy),
    on states that open, stick and slip contacts with per-blade angles."""
    from wheelrom import rhs
    from wheelrom.forces import OPEN, SLIP, STICK, ForceModel

    cfg = coarse_cfg.replace(**{"flutter.model": vdp, "flutter.mu": 2e3})
    N = coarse_model.blades
    angles = {"shroud": np.linspace(10.0, 80.0, N), "tieboss": 45.0}
    fm = ForceModel(coarse_model, cfg, angles)
    problem = transient.WheelProblem(coarse_model, cfg, fm)
    rng = np.random.default_rng(7)
    u = rng.normal(size=problem.size()) * 2e-3
    u[problem.n : 2 * problem.n] *= 1000.0
    expected = problem.rhs_numpy(0.0123, u)
    states = set(np.unique(fm.contact_state))
    assert {OPEN, STICK, SLIP} <= states
    got = rhs.evaluate(problem.context, 0.0123, u)
    scale = np.abs(expected[problem.n : 2 * problem.n]).max()
    assert np.abs(got[: 2 * problem.n] - expected[: 2 * problem.n]).max() < 1e-12 * scale
    np.testing.assert_allclose(got[2 * problem.n :], expected[2 * problem.n :], rtol=1e-10)
    np.testing.assert_array_equal(problem.context.view("contact_state"), fm.contact_state)
    np.testing.assert_allclose(problem.context.view("normal_force"), fm.normal_force, atol=1e-9)


def test_compiled_and_python_callbacks_agree(small_model, small_cfg):
    """The C callbacks and the petsc4py callbacks (BAIJ products) give the same TS run."""
    cfg = small_cfg.replace(**{"time.end": 0.001, "time.window": 0.0005})
    a = transient.run_case(small_model, cfg, rhs_kind="compiled")
    b = transient.run_case(small_model, cfg, rhs_kind="python")
    assert a.status == b.status == "done"
    assert a.steps == b.steps == 200 and a.rhs_evaluations == b.rhs_evaluations
    scale = np.abs(b.tip_history).max()
    assert scale > 0
    assert np.abs(a.tip_history - b.tip_history).max() < 1e-9 * scale
    np.testing.assert_allclose(a.max_tip_amplitude, b.max_tip_amplitude, rtol=1e-9)


def test_batch_refuses_cases_that_differ_beyond_contact_angles(small_model, small_cfg):
    """A batch shares every force parameter but the contact frames and stiffnesses (the
    context takes them from its first case): other differences are refused, not ignored."""
    from wheelrom import rhs
    from wheelrom.forces import ForceModel

    def context(cases):
        return rhs.Context(cases, small_model, 0.0, 1e-4, 1.0, 4)

    base = ForceModel(small_model, small_cfg, {"shroud": 20.0})
    assert context([base, ForceModel(small_model, small_cfg, {"shroud": 60.0})]).B == 2
    louder = small_cfg.replace(**{"excitation.force": 2.0 * small_cfg.excitation.force + 1.0})
    with pytest.raises(ValueError, match="differ only in contact angles"):
        context([base, ForceModel(small_model, louder, {"shroud": 20.0})])


def test_noop_integrator_steps_and_leaves_the_state_alone(small_model, small_cfg):
    """`wheelrom bench`'s floor (PETSc's integrator with a no-op right-hand side) must be the
    configured TS really stepping, with the real kernel and sampling detached: the steps are
    taken, the kernel is never called, and the state does not move (every stage adds zero)."""
    from wheelrom import rhs
    from wheelrom.forces import ForceModel

    problem = transient.WheelProblem(small_model, small_cfg, ForceModel(small_model, small_cfg))
    ts, f, used = transient.make_ts(problem, small_cfg, options={"ts_rk_type": "3bs"})
    assert used["ts_rk_type"] == "3bs"
    rhs.attach_null(ts, f)
    u = f.duplicate()
    start = np.random.default_rng(3).normal(size=u.getSize())
    u.setArray(start)
    ts.setMaxSteps(37)
    ts.solve(u)
    assert ts.getStepNumber() == 37
    assert ts.getTime() == pytest.approx(37 * small_cfg.time.step, rel=1e-12)
    assert problem.context.header(rhs.H_RHS_CALLS) == 0
    np.testing.assert_array_equal(u.getArray(), start)
    ts.destroy()


def test_batch_gives_each_case_bitwise_its_single_result(small_model, small_cfg):
    """Cases integrated together in one TS (SIMD across cases) equal their runs alone,
    bit for bit, including a case that diverges (frozen, reported, the others go on)."""
    cfg = small_cfg.replace(
        **{
            "time.end": 0.004,
            "time.window": 0.001,
            "contacts.shroud.stiffness": [[0.0, 7.6e7], [80.0, 7.6e7], [90.0, 1e14]],
        }
    )
    angles = [{"shroud": a, "tieboss": 45.0} for a in (20.0, 90.0, 50.0)]
    batch = transient.run_cases(small_model, cfg, angles)
    assert [r.batch for r in batch] == [3, 3, 3]
    assert batch[0].status == batch[2].status == "done"
    assert batch[1].status.startswith("failed:") and "t =" in batch[1].status
    for res, a in zip(batch, angles, strict=True):
        alone = transient.run_case(small_model, cfg, a)
        assert alone.status == res.status and alone.steps == res.steps
        assert np.array_equal(alone.sample_time, res.sample_time)
        assert np.array_equal(alone.tip_history, res.tip_history, equal_nan=True)
        assert np.array_equal(alone.max_tip_amplitude, res.max_tip_amplitude)
        assert np.array_equal(alone.work, res.work)
        for kind in alone.min_normal_force:
            assert np.array_equal(alone.min_normal_force[kind], res.min_normal_force[kind])
            assert np.array_equal(alone.open_fraction[kind], res.open_fraction[kind])
    assert batch[0].window_end.size == 4 and batch[1].window_end.size < 4


def test_kernel_exp_is_within_two_ulp_of_libm():
    """The kernel's own branch-free exp against libm over the whole double range it
    accepts (and its clamping outside), in units in the last place."""
    import numba

    from wheelrom import rhs

    @numba.njit
    def kernel_exp(x):
        out = np.empty_like(x)
        for i in range(x.size):
            out[i] = rhs.fexp(x[i])
        return out

    rng = np.random.default_rng(3)
    x = np.concatenate([np.linspace(-708.0, 709.0, 200_001), rng.uniform(-3.0, 3.0, 100_000)])
    x = np.concatenate([x, [0.0, -0.0, 1e-300, -1e-20, math.log(2.0)]])
    expected = np.exp(x)
    ulps = np.abs(kernel_exp(x) - expected) / np.spacing(expected)
    assert ulps.max() <= 2.0
    assert kernel_exp(np.array([0.0]))[0] == 1.0
    clamped = kernel_exp(np.array([-1e4, 1e4]))
    np.testing.assert_array_equal(clamped, kernel_exp(np.array([-708.0, 709.0])))
    assert np.isfinite(clamped).all() and clamped[0] > 0.0
