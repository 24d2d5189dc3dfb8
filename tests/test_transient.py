"""Transient solver against the serial reference, the frequency domain and energy laws."""

import math

import numpy as np
import pytest

from convergence import assert_order, rounding_floor
from wheelrom.forces.parameters import OPEN, SLIP, STICK, force_parameters
from wheelrom.runtime.environment import petsc
from wheelrom.transient import bridge, layout
from wheelrom.transient.problem import WheelProblem, nd_amplitudes
from wheelrom.transient.reference import BOGACKI_SHAMPINE, reference_solution, rk_step
from wheelrom.transient.run import run_case, run_cases
from wheelrom.transient.ts import make_ts, time_grid

SELF = petsc().COMM_SELF


def _problem(model, cfg, angles=(None,)):
    return WheelProblem(model, cfg, [force_parameters(model, cfg, a) for a in angles], SELF)


def test_petsc_ts_equals_serial_reference_all_forces_on(coarse_model, coarse_cfg):
    steps = 2000
    cfg = coarse_cfg.replace(**{"time.end": steps * 5e-6, "time.window": steps * 5e-6})
    res = run_case(coarse_model, cfg)
    assert res.status == "done" and res.steps == steps
    _, states, _ = reference_solution(coarse_model, cfg, steps, 5e-6, sample_every=steps)
    n = coarse_model.size
    ref, got = states[-1][: 2 * n], res.final_state[: 2 * n]
    assert np.abs(ref).max() > 0
    assert np.abs(got - ref).max() <= 1e-9 * np.abs(ref).max()


def test_tableau_step_is_third_order_on_an_oscillator():
    """The generic tableau step against the analytic solution of u'' = -u: the global error
    falls by 2^3 when the step halves."""

    def fun(t, u):
        return np.array([u[1], -u[0]])

    def error(h):
        u = np.array([1.0, 0.0])
        steps = int(round(2.0 / h))
        for i in range(steps):
            u = rk_step(fun, i * h, u, h, BOGACKI_SHAMPINE)
        return abs(u[0] - math.cos(steps * h))

    assert_order([error(0.02), error(0.01)], rounding_floor(200), 7.0, 9.0)


def test_linear_steady_state_matches_frequency_domain(small_model, small_cfg):
    """Started on the frequency-domain steady state, the TS must stay on it; the ND spectrum
    of that travelling wave reports the tip amplitude at its nodal diameter."""
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
    res = run_case(small_model, cfg, u0=u0)
    t = res.sample_time
    expect = np.real(np.exp(1j * w * t)[:, None, None] * (X.reshape(N, m) @ small_model.tip.T))
    amp = np.abs(X.reshape(N, m) @ small_model.tip[1]).max()
    assert amp > 0
    assert np.abs(res.tip_history - expect).max() < 5e-3 * amp
    nd = abs(N - cfg.wheel.stator_vanes)  # the nozzle's travelling wave
    np.testing.assert_allclose(res.nd_spectrum[:, nd], amp, rtol=5e-3)
    others = np.delete(res.nd_spectrum, nd, axis=1)
    assert others.max() < 5e-3 * amp


@pytest.mark.parametrize("nd", [0, 3, 6])
def test_nd_amplitude_of_a_pure_wave_is_its_amplitude(nd):
    """A travelling wave (or, at ND 0 and N/2, a standing pattern) of amplitude a reports a
    at its nodal diameter and nothing elsewhere."""
    N, a = 12, 2.5e-4
    theta = 2 * np.pi * np.arange(N) / N
    t = np.linspace(0.0, 1e-2, 7)[:, None]
    wave = a * np.cos(nd * theta[None, :] - 2 * np.pi * 150.0 * t + 0.3)
    spec = nd_amplitudes(wave)
    assert spec.shape == (7, N // 2 + 1)
    if nd in (0, N // 2):  # a standing pattern: its amplitude at the peak sample
        assert spec[:, nd].max() <= a * (1 + 1e-12)
    else:
        np.testing.assert_allclose(spec[:, nd], a, rtol=1e-12)
    assert np.delete(spec, nd, axis=1).max() < 1e-12 * a


def _free_oscillation(model, cfg, step):
    """The undamped, force-free wheel from a random velocity for 4 ms at ``step``."""
    forces_off = {
        "flutter.model": "off",
        "excitation.force": 0.0,
        "wheel.damping_beta": 0.0,
        "contacts.tieboss.enabled": False,
        "contacts.shroud.enabled": False,
        "time.step": step,
        "time.end": 0.004,
        "time.window": 0.004,
        "output.sample_rate_hz": 1.0 / step,
    }
    cfg = cfg.replace(**forces_off)
    rng = np.random.default_rng(2)
    u0 = np.zeros(2 * model.size)
    u0[model.size :] = rng.normal(size=model.size) * 1e-2
    return cfg, u0, run_case(model, cfg, u0=u0)


def test_petsc_ts_is_the_tableau_and_third_order(small_model, small_cfg):
    """PETSc's RK "3bs" against the tableau-driven reference (same step: equal to round-off),
    and its energy drift of order 3 in the step (RK3 dissipation ~ h^4 per period)."""
    drift = []
    for step in (2e-5, 1e-5):
        cfg, u0, res = _free_oscillation(small_model, small_cfg, step)
        assert res.status == "done" and res.steps == round(0.004 / step)
        steps = res.steps
        _, states, _ = reference_solution(small_model, cfg, steps, step, sample_every=steps,
                                          u0=u0)
        n2 = 2 * small_model.size
        ref = states[-1][:n2]
        assert np.abs(res.final_state[:n2] - ref).max() < 1e-10 * np.abs(ref).max()
        drift.append(abs(res.energy[-1] - res.energy0) / res.energy0)
    assert drift[0] > 0
    assert_order(drift, rounding_floor(round(0.004 / 1e-5)), 6.0, 20.0)


def test_energy_balance_closes_with_all_forces(coarse_model, coarse_cfg):
    """E - E0 = sum of the works, up to the time integration's error, which falls with the
    step at (at least) the RK3 order (measured: 2.0e-3 at 5 us, 1.0e-4 at 2.5 us)."""
    errors = []
    for step in (5e-6, 2.5e-6):
        cfg = coarse_cfg.replace(**{"time.end": 0.01, "time.window": 0.0025, "time.step": step})
        res = run_case(coarse_model, cfg)
        assert res.status == "done"
        assert np.abs(res.work[-1]).sum() > 0
        assert res.work[-1, 2] < 0 and res.work[-1, 3] < 0  # friction and damping dissipate
        errors.append(res.energy_balance_error())
    assert errors[0] < 5e-3
    assert_order(errors, rounding_floor(round(0.01 / 2.5e-6)), 8.0)


def test_preload_start_is_static_equilibrium_in_a_batch(small_model, small_cfg):
    """time.start = "preload": every case of a batch starts on its own static equilibrium
    (accelerations zero), the same as alone."""
    from wheelrom.transient.preload import initial_state

    cfg = small_cfg.replace(**{"time.start": "preload", "time.end": 5e-4,
                               "time.window": 5e-4})
    angles = [{"shroud": 20.0}, {"shroud": 80.0}]
    problem = _problem(small_model, cfg, angles)
    starts = []
    for b in range(2):
        u0, residual = initial_state(problem, case=b)
        acc = problem.rhs_numpy(0.0, u0, case=b)[problem.n : 2 * problem.n]
        scale = np.abs(problem.Kd @ u0[: problem.n]).max()
        assert scale > 0 and np.abs(acc).max() < 1e-9 * scale
        assert residual < 1e-9 * scale
        starts.append(u0)
    assert np.abs(starts[0] - starts[1]).max() > 1e-6 * np.abs(starts[0]).max()
    batch = run_cases(small_model, cfg, angles)
    for res, a, u0 in zip(batch, angles, starts, strict=True):
        alone = run_case(small_model, cfg, a)
        assert res.batch == 2 and res.preload_residual == alone.preload_residual
        assert res.energy0 == alone.energy0 == problem.energy(u0, case=angles.index(a))
        assert np.array_equal(res.tip_history, alone.tip_history)


def test_adaptive_steps_run_a_batch_case_by_case(small_model, small_cfg):
    """An adaptive step would be shared by the cases of a batch: the batch falls back to one
    TS per case, each equal to its run alone."""
    cfg = small_cfg.replace(**{"time.end": 1e-3, "time.window": 5e-4})
    options = {"ts_adapt_type": "basic", "ts_rk_type": "5dp"}
    angles = [{"shroud": 20.0}, {"shroud": 80.0}]
    batch = run_cases(small_model, cfg, angles, options=options)
    for res, a in zip(batch, angles, strict=True):
        alone = run_case(small_model, cfg, a, options=options)
        assert res.batch == 1 and res.status == "done"
        assert res.options["ts_adapt_type"] == "basic"
        assert res.steps == alone.steps and np.array_equal(res.tip_history, alone.tip_history)
    fixed = run_case(small_model, cfg, angles[0])
    assert batch[0].steps != fixed.steps  # it did adapt


def test_divergence_stops_case_and_keeps_windows(small_model, small_cfg):
    # a step far beyond the stiff modes' reach; 3bs would be refused up front
    # (test_a_step_beyond_the_schemes_reach_is_refused), Heun's RK 2a is not checked
    cfg = small_cfg.replace(
        **{
            "time.step": 4e-4,
            "time.window": 4e-4 * 5,  # two samples per window
            "time.end": 0.02,
            "output.sample_rate_hz": 1000.0,
        }
    )
    res = run_case(small_model, cfg, options={"ts_rk_type": "2a"})
    assert res.status.startswith("failed:") and "t =" in res.status
    stopped = float(res.status.split("t = ")[1].split()[0])
    # the windows before the divergence are kept, with finite statistics
    kept = res.window_end.size
    assert 1 <= kept < len(time_grid(cfg).window_end)
    assert res.window_end[-1] < stopped
    assert np.isfinite(res.max_tip_amplitude).all() and res.energy.size == kept


def test_window_ends_when_end_is_not_a_multiple_of_the_window(small_model, small_cfg):
    """The last window runs to time.end (up to 1.5 windows long), as the time grid says."""
    cfg = small_cfg.replace(**{"time.end": 0.0025, "time.window": 0.001})
    grid = time_grid(cfg)
    assert grid.window_end == (0.001, 0.0025)
    res = run_case(small_model, cfg)
    np.testing.assert_allclose(res.window_end, grid.window_end, rtol=1e-12)
    assert res.sample_time[-1] == pytest.approx(0.0025, abs=1e-4)


@pytest.mark.parametrize("rk", ["3bs", "5dp"])
def test_ts_options_reach_the_solver(small_model, small_cfg, rk):
    cfg = small_cfg.replace(**{"time.end": 1e-3, "time.window": 1e-3})
    res = run_case(small_model, cfg, options={"ts_rk_type": rk})
    assert res.options["ts_rk_type"] == rk and res.status == "done"
    # the 5-stage scheme takes more right-hand sides per step than the 3-stage FSAL one
    per_step = res.rhs_evaluations / res.steps
    assert per_step == pytest.approx(3.0 if rk == "3bs" else 6.0, abs=0.1)


def test_ts_options_are_scoped_and_recorded_by_prefix(small_model, small_cfg):
    """Options of other solvers in the database stay out of the TS record; a dict of options
    lives in the database only while the TS reads it, and a user's value is restored."""
    db = petsc().Options()
    cfg = small_cfg.replace(**{"time.end": 5e-4, "time.window": 5e-4})
    db.setValue("segment_eps_ncv", "40")
    db.setValue("wheel_ts_rk_type", "4")
    try:
        res = run_case(small_model, cfg, options={"ts_rk_type": "5dp", "ts_max_snes_failures": 3})
        assert res.options["ts_rk_type"] == "5dp"
        assert all(k.startswith("ts_") for k in res.options), res.options
        assert db.getString("wheel_ts_rk_type") == "4"  # restored
        assert not db.hasName("wheel_ts_max_snes_failures")  # removed again
        assert run_case(small_model, cfg).options["ts_rk_type"] == "4"
    finally:
        db.delValue("segment_eps_ncv")
        db.delValue("wheel_ts_rk_type")


@pytest.mark.parametrize("vdp", ["off", "absolute", "relative"])
def test_compiled_rhs_equals_reference_forces_and_dense_stiffness(coarse_model, coarse_cfg, vdp):
    """Two implementations: the fused compiled RHS against the reference force model + dense
    K_R (numpy), on states that open, stick and slip contacts with per-blade angles."""
    cfg = coarse_cfg.replace(**{"flutter.model": vdp, "flutter.mu": 2e3})
    N = coarse_model.blades
    angles = {"shroud": np.linspace(10.0, 80.0, N), "tieboss": 45.0}
    problem = _problem(coarse_model, cfg, [angles])
    forces = problem.forces[0]
    rng = np.random.default_rng(7)
    u = rng.normal(size=problem.size()) * 2e-3
    u[problem.n : 2 * problem.n] *= 1000.0
    expected = problem.rhs_numpy(0.0123, u)
    assert {OPEN, STICK, SLIP} <= set(np.unique(forces.contact_state))
    got = bridge.evaluate(problem.context, 0.0123, u)
    scale = np.abs(expected[problem.n : 2 * problem.n]).max()
    assert np.abs(got[: 2 * problem.n] - expected[: 2 * problem.n]).max() < 1e-12 * scale
    np.testing.assert_allclose(got[2 * problem.n :], expected[2 * problem.n :], rtol=1e-10)
    np.testing.assert_array_equal(problem.context.view("contact_state"), forces.contact_state)
    np.testing.assert_allclose(problem.context.view("normal_force"), forces.normal_force,
                               atol=1e-9)


def test_compiled_and_python_callbacks_agree(small_model, small_cfg):
    """The C callbacks and the petsc4py callbacks (BAIJ products) give the same TS run."""
    cfg = small_cfg.replace(**{"time.end": 0.001, "time.window": 0.0005})
    a = run_case(small_model, cfg, rhs_kind="compiled")
    b = run_case(small_model, cfg, rhs_kind="python")
    assert a.status == b.status == "done"
    assert a.steps == b.steps == 200 and a.rhs_evaluations == b.rhs_evaluations
    scale = np.abs(b.tip_history).max()
    assert scale > 0
    assert np.abs(a.tip_history - b.tip_history).max() < 1e-9 * scale
    np.testing.assert_allclose(a.max_tip_amplitude, b.max_tip_amplitude, rtol=1e-9)


def test_batch_refuses_cases_that_differ_beyond_contact_angles(small_model, small_cfg):
    """A batch shares every force parameter but the contact frames and stiffnesses (the
    context takes them from its first case): other differences are refused, not ignored."""

    def context(cases):
        return layout.Context(cases, small_model, 0.0, 1e-4, 1.0, 4)

    base = force_parameters(small_model, small_cfg, {"shroud": 20.0})
    assert context([base, force_parameters(small_model, small_cfg, {"shroud": 60.0})]).B == 2
    louder = small_cfg.replace(**{"excitation.force": 2.0 * small_cfg.excitation.force + 1.0})
    with pytest.raises(ValueError, match="differ only in contact angles"):
        context([base, force_parameters(small_model, louder, {"shroud": 20.0})])


def test_noop_integrator_steps_and_leaves_the_state_alone(small_model, small_cfg):
    """`wheelrom bench`'s floor (PETSc's integrator with a no-op right-hand side) must be the
    configured TS really stepping, with the real kernel and sampling detached: the steps are
    taken, the kernel is never called, and the state does not move (every stage adds zero)."""
    problem = _problem(small_model, small_cfg)
    ts, f, used = make_ts(problem, small_cfg, options={"ts_rk_type": "3bs"})
    assert used["ts_rk_type"] == "3bs" and used["ts_adapt_type"] == "none"
    bridge.attach_null(ts, f)
    u = f.duplicate()
    start = np.random.default_rng(3).normal(size=u.getSize())
    u.setArray(start)
    ts.setMaxSteps(37)
    ts.solve(u)
    assert ts.getStepNumber() == 37
    assert ts.getTime() == pytest.approx(37 * small_cfg.time.step, rel=1e-12)
    assert problem.context.header(layout.H_RHS_CALLS) == 0
    np.testing.assert_array_equal(u.getArray(), start)
    ts.destroy()


def test_bench_batches_only_the_angles_that_share_the_propagated_springs(small_model, small_cfg):
    """Under the elastic law with an angle-dependent ``k_c`` (a table) each angle's stuck
    springs differ, and so does the share the exponential scheme propagates
    (:mod:`wheelrom.transient.stuck_shift`): ``bench``'s batch figure times the angles that
    can share one context (the first and those like it) instead of failing."""
    from wheelrom.bench.transient import _batch_figures
    from wheelrom.forces.parameters import force_parameters
    from wheelrom.transient.stuck_shift import shift_stiffness

    cfg = small_cfg.replace(**{"contacts.law": "elastic", "time.scheme": "exponential",
                               "contacts.shroud.stiffness": [[0.0, 5e7], [90.0, 1e8]],
                               "sweep.shroud_angles_deg": [0.0, 90.0]})
    shifts = [shift_stiffness(small_model, force_parameters(small_model, cfg, {"shroud": a}))
              for a in (0.0, 90.0)]
    assert not np.array_equal(*shifts)  # the two angles cannot share a context
    h = 1e-6
    figures, problem = _batch_figures(small_model, cfg, 200, h, 3, 0.1 / h, lambda _: None)
    assert problem.B == 3 and figures["us_per_rhs_in_batch"] > 0


def test_batch_gives_each_case_bitwise_its_single_result(small_model, small_cfg):
    """Cases integrated together in one TS (SIMD across cases) equal their runs alone,
    bit for bit, including a case that diverges (frozen, reported, the others go on)."""
    import dataclasses

    cfg = small_cfg.replace(**{"time.end": 0.004, "time.window": 0.001})
    # 1e14 N/m at 90 deg, past the key's range (1e10 N/m, which RK 3bs steps through): set
    # past the validation, the one case that diverges
    shroud = dataclasses.replace(cfg.contacts.shroud,
                                 stiffness=((0.0, 7.6e7), (80.0, 7.6e7), (90.0, 1e14)))
    cfg = dataclasses.replace(cfg, contacts=dataclasses.replace(cfg.contacts, shroud=shroud))
    angles = [{"shroud": a, "tieboss": 45.0} for a in (20.0, 90.0, 50.0)]
    batch = run_cases(small_model, cfg, angles)
    assert [r.batch for r in batch] == [3, 3, 3]
    assert batch[0].status == batch[2].status == "done"
    assert batch[1].status.startswith("failed:") and "t =" in batch[1].status
    for res, a in zip(batch, angles, strict=True):
        alone = run_case(small_model, cfg, a)
        assert alone.status == res.status and alone.steps == res.steps
        assert np.array_equal(alone.sample_time, res.sample_time)
        assert np.array_equal(alone.tip_history, res.tip_history, equal_nan=True)
        assert np.array_equal(alone.max_tip_amplitude, res.max_tip_amplitude)
        assert np.array_equal(alone.work, res.work)
        for kind in alone.min_normal_force:
            assert np.array_equal(alone.min_normal_force[kind], res.min_normal_force[kind])
            assert np.array_equal(alone.open_fraction[kind], res.open_fraction[kind])
    assert batch[0].window_end.size == 4 and batch[1].window_end.size < 4


def correctly_rounded_exp(x: np.ndarray) -> np.ndarray:
    """``exp(x)`` rounded once to double: computed in extended precision where the platform
    has it (x86-64: 80-bit, aarch64: 128-bit long double), else by libm (``math.exp``), never
    by numpy's float64 ``exp``, whose SIMD paths (AVX-512 here, AVX2 or scalar elsewhere) may
    differ by an ulp or two from machine to machine."""
    if np.finfo(np.longdouble).nmant > np.finfo(np.float64).nmant + 8:
        out = np.exp(x.astype(np.longdouble)).astype(np.float64)
    else:
        out = np.array([math.exp(v) for v in x])
    libm = np.array([math.exp(v) for v in x[:: max(1, x.size // 1000)]])
    assert (np.abs(out[:: max(1, x.size // 1000)] - libm) <= np.spacing(libm)).all()
    return out


def test_kernel_exp_is_within_two_ulp_of_the_correctly_rounded_value():
    """The kernel's own branch-free exp against the correctly rounded exp over the whole
    double range it accepts (and its clamping outside), in units in the last place."""
    import numba

    from wheelrom.forces.fastmath import fexp

    @numba.njit
    def kernel_exp(x):
        out = np.empty_like(x)
        for i in range(x.size):
            out[i] = fexp(x[i])
        return out

    rng = np.random.default_rng(3)
    x = np.concatenate([np.linspace(-708.0, 709.0, 200_001), rng.uniform(-3.0, 3.0, 100_000)])
    x = np.concatenate([x, [0.0, -0.0, 1e-300, -1e-20, math.log(2.0)]])
    expected = correctly_rounded_exp(x)
    ulps = np.abs(kernel_exp(x) - expected) / np.spacing(expected)
    assert ulps.max() <= 2.0
    assert kernel_exp(np.array([0.0]))[0] == 1.0
    clamped = kernel_exp(np.array([-1e4, 1e4]))
    np.testing.assert_array_equal(clamped, kernel_exp(np.array([-708.0, 709.0])))
    assert np.isfinite(clamped).all() and clamped[0] > 0.0


def test_a_step_beyond_the_schemes_reach_is_refused(small_model, small_cfg):
    """A fixed 3bs step with 2 pi f_max dt > sqrt 3 for the stiffest wheel mode of K_R is a
    named error before any step (it would only diverge); just inside the reach it runs."""
    import math

    from wheelrom.runtime.errors import InputError

    f_max = small_model.frequencies_by_nodal_diameter().max()
    limit = math.sqrt(3) / (2 * math.pi * f_max)
    cfg = small_cfg.replace(**{"time.step": 1.05 * limit, "time.end": 40 * limit,
                               "time.window": 40 * limit, "output.sample_rate_hz": 0.5 / limit,
                               "output.history_rate_hz": 0.5 / limit})
    with pytest.raises(InputError, match="time.step .* beyond the stability of RK 3bs"):
        run_case(small_model, cfg)
    fine = cfg.replace(**{"time.step": 0.95 * limit})
    assert run_case(small_model, fine).status == "done"


def test_bench_times_both_contact_laws_alternately(small_model, small_cfg):
    """``bench``'s law figures (issue #44's 1.5x): both laws from their preloaded equilibria,
    each at the step its TS takes (the elastic law's lowered to its stable step, the paper
    law's the configured one), min and median over the rounds, their ratio."""
    from wheelrom.bench.laws import law_figures
    from wheelrom.transient.exponential import taken_step

    cfg = small_cfg.replace(**{"time.scheme": "exponential", "time.step": 1e-5})
    lines = []
    figures = law_figures(small_model, cfg, lines.append, rounds=2, end=2e-3)
    cost, ratio = figures["law_s_per_simulated_s"], figures["elastic_vs_paper"]
    for law in ("paper", "elastic"):
        assert 0 < cost[law][0] <= cost[law][1]
    assert ratio == pytest.approx([cost["elastic"][0] / cost["paper"][0],
                                   cost["elastic"][1] / cost["paper"][1]])
    elastic = cfg.replace(**{"contacts.law": "elastic"})
    assert figures["law_steps_s"]["paper"] == taken_step(small_model, cfg, 1e-5)
    assert figures["law_steps_s"]["elastic"] == taken_step(small_model, elastic, 1e-5)
    assert len(lines) == 1 and "x /" in lines[0]


def test_bench_times_the_settle_step_against_the_time_step(small_model, small_cfg):
    """``bench``'s settle figures (issue #70's same-run ratio): the configured case at
    ``time.step`` and at twice it (``settle.step`` 0, as ./run/paper asks), each at the step
    its TS takes, and their ratio."""
    from wheelrom.bench.laws import settle_figures
    from wheelrom.transient.exponential import taken_step

    cfg = small_cfg.replace(**{"time.scheme": "exponential", "time.step": 1e-5})
    lines = []
    figures = settle_figures(small_model, cfg, lines.append, rounds=2, end=4e-3)
    cost, ratio = figures["settle_s_per_simulated_s"], figures["settle_speedup"]
    steps = figures["settle_steps_s"]
    assert steps == {"time_step": taken_step(small_model, cfg, 1e-5),
                     "settle_step": taken_step(small_model, cfg, 2e-5)}
    assert ratio == pytest.approx([cost["time_step"][0] / cost["settle_step"][0],
                                   cost["time_step"][1] / cost["settle_step"][1]])
    assert all(0 < c[0] <= c[1] for c in cost.values())  # min, median (no timing compared)
    assert len(lines) == 1 and "settle's step" in lines[0]
