"""The exponential scheme (time.scheme = "exponential", ETDRK4 with A0 exact): the linear part
against the analytic damped oscillator, its design order and the energy balance on the
attachment basis from the preloaded equilibrium, batches, the resonance guard."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from convergence import assert_order, rounding_floor
from wheelrom.transient.run import run_case, run_cases


@pytest.fixture(scope="module")
def attachment(small_cfg, comm):
    """The small wheel on the default (attachment) basis: the stiff vectors are in."""
    from wheelrom.rom.build import build_model

    cfg = small_cfg.replace(**{"wheel.basis": "attachment"})
    return build_model(cfg, comm), cfg


def _exponential(cfg, **keys):
    return cfg.replace(**{"time.scheme": "exponential", **keys})


def _tips(model, state):
    n = model.size
    return state[:n].reshape(model.blades, model.modes) @ model.tip.T


def test_free_decay_of_every_segment_mode_is_the_analytic_oscillator(small_model, small_cfg):
    """Contacts, nozzle and Van der Pol off and no coupling between blades (A1 = 0): the
    scheme's exact part is the whole problem, so every segment mode of every blade decays as
    q'' + beta a q' + a q = 0, written here in closed form (cos/sin/exp, not the expm of the
    scheme), to 1e-10 after 2000 steps of a step far beyond RK3's limit."""
    model = dataclasses.replace(small_model, A1=np.zeros_like(small_model.A1))
    beta = 2e-6  # strong damping: the decay, not only the phase, is checked
    cfg = _exponential(small_cfg, **{
        "contacts.tieboss.enabled": False, "contacts.shroud.enabled": False,
        "excitation.force": 0.0, "flutter.model": "off", "wheel.damping_beta": beta,
        "time.step": 2e-5, "time.end": 0.04, "time.window": 0.04,
    })
    a, P = np.linalg.eigh(model.A0)  # the kernel's basis: z_s = P^T q_s
    rng = np.random.default_rng(3)
    z0 = rng.standard_normal((model.blades, model.modes)) * 1e-4
    v0 = rng.standard_normal((model.blades, model.modes)) * 1e-2
    u0 = np.concatenate([(z0 @ P.T).ravel(), (v0 @ P.T).ravel()])
    res = run_case(model, cfg, u0=u0)
    assert res.status == "done" and res.steps == 2000
    t = res.window_end[-1]
    sigma = beta * a / 2
    wd = np.sqrt(a - sigma**2)
    decay = np.exp(-sigma * t)
    c, s = np.cos(wd * t), np.sin(wd * t)
    z = decay * (z0 * (c + sigma * s / wd) + v0 * s / wd)
    v = decay * (v0 * (c - sigma * s / wd) - z0 * a * s / wd)
    n = model.size
    got_z = res.final_state[:n].reshape(model.blades, model.modes) @ P
    got_v = res.final_state[n : 2 * n].reshape(model.blades, model.modes) @ P
    assert np.abs(got_z - z).max() <= 1e-10 * np.abs(z0).max()
    assert np.abs(got_v - v).max() <= 1e-10 * np.abs(v0).max()
    # the damping work the scheme records is the energy the oscillators lost
    assert res.energy_balance_error() < 1e-6


def _preloaded(cfg, end):
    return cfg.replace(**{"time.start": "preload", "time.perturbation": 1e-6,
                          "time.end": end, "time.window": end})


def test_design_order_on_the_attachment_basis(attachment):
    """From the preloaded equilibrium with a 1 um physical seed, contacts on: the tip error
    against a fine RK reference falls ~16x per halving (fourth order; measured 13.9, 21.4)."""
    model, cfg = attachment
    cfg = _preloaded(cfg, 0.0048)
    refs = [_tips(model, run_case(model, cfg.replace(**{"time.scheme": "rk"}),
                                  options={"ts_rk_type": "5dp", "ts_dt": dt}).final_state)
            for dt in (5e-7, 2.5e-7)]
    tip_ref = refs[1]
    scale = np.abs(tip_ref).max()
    floor = np.abs(refs[0] - tip_ref).max() / scale  # the reference's own error
    errors = []
    for step in (1.6e-5, 8e-6, 4e-6):
        res = run_case(model, _exponential(cfg, **{"time.step": step}))
        assert res.options["ts_scheme"] == "etdrk4" and res.options["ts_dt"] == step
        errors.append(np.abs(_tips(model, res.final_state) - tip_ref).max() / scale)
    assert errors[1] < 1e-4, errors
    assert_order(errors, floor, 10.0)


def test_energy_balance_closes_on_the_attachment_basis(attachment):
    """0.15 s from the preloaded equilibrium with a 1 um seed, contacts on: the balance
    E - E0 = sum W closes to 1e-3 at the default step and falls at least 4x per halving
    (the energy a scheme removes is recorded: the damping power has its whole K_R)."""
    model, cfg = attachment
    cfg = _preloaded(cfg, 0.15)
    balances = []
    for step in (1e-5, 5e-6, 2.5e-6):
        res = run_case(model, _exponential(cfg, **{"time.step": step}))
        assert res.status == "done"
        balances.append(res.energy_balance_error())
    assert balances[0] < 1e-3, balances
    assert_order(balances, rounding_floor(round(0.15 / 2.5e-6)), 4.0)


def test_batch_results_are_those_of_single_runs(small_model, small_cfg):
    """Each column of the exponential step touches its own case only: a batch of two is
    bitwise the two single runs."""
    cfg = _exponential(small_cfg, **{"time.step": 1e-5, "time.end": 0.001,
                                     "time.window": 0.0005})
    angles = [{"shroud": 20.0}, {"shroud": 80.0}]
    batch = run_cases(small_model, cfg, angles)
    for a, res in zip(angles, batch, strict=True):
        alone = run_case(small_model, cfg, a)
        assert np.array_equal(res.final_state, alone.final_state)
        assert np.array_equal(res.max_tip_amplitude, alone.max_tip_amplitude)


def test_a_resonant_step_is_moved_below_the_resonance_and_recorded(attachment):
    """A step at one period of the stiffest segment mode is lowered out of the 7 % band
    (and the reason is in the result's options); a safe step is kept."""
    from wheelrom.transient.exponential import RESONANCE_BAND, safe_step

    model, cfg = attachment
    f = np.sqrt(np.linalg.eigvalsh(model.A0).max()) / (2 * np.pi)
    step, why = safe_step(model, 1.0 / f)
    assert step <= (1 - RESONANCE_BAND) / f and step > 0.9 * (1 - RESONANCE_BAND) / f
    assert "resonance of the exponential scheme" in why
    assert safe_step(model, 0.5 / f) == (0.5 / f, None)
    cfg = _exponential(cfg, **{"time.step": 1.0 / f, "time.end": 2e-4, "time.window": 2e-4})
    res = run_case(model, cfg)
    assert res.options["ts_dt"] == step and "lowered" in res.options["ts_dt_lowered"]


def test_the_paper_rk3_stays_available_by_option(small_model, small_cfg):
    """-wheel_ts_type rk over time.scheme = 'exponential' integrates the full right-hand side
    with RK 3bs: the same numbers as time.scheme = 'rk'."""
    cfg = small_cfg.replace(**{"time.end": 0.0005, "time.window": 0.0005})
    rk = run_case(small_model, cfg)
    switched = run_case(small_model, _exponential(cfg), options={"ts_type": "rk"})
    assert switched.options["ts_type"] == "rk" and "ts_scheme" not in switched.options
    assert np.array_equal(rk.final_state, switched.final_state)


def _elastic_flow(attachment, shroud: float):
    """The attachment wheel under the elastic law, nozzle off, as a flow of the exponential
    scheme (whole steps as asked: the flow does not lower them), its force parameters."""
    from wheelrom.analysis.periodic.flow import WheelFlow

    model, cfg = attachment
    cfg = _exponential(cfg, **{"contacts.law": "elastic", "excitation.force": 0.0})
    flow = WheelFlow(model, cfg, {"shroud": shroud})
    return model, cfg, flow


def test_the_step_matrix_is_the_compiled_step(attachment):
    """:func:`step_matrix` of ND ``k`` (the scheme's linear step, assembled from the
    coefficients and the explicit part's Jacobian) against the compiled ``etd4_step`` on
    the whole wheel: one step of 10 us from the preloaded equilibrium (the contacts closed
    and stuck), perturbed by the step matrix's dominant eigenvector expanded over the blades;
    the difference of the two flows is that matrix's product, to 1e-6 (measured 1.4e-7: the
    difference's rounding against the equilibrium and the arm's geometry at 1 nm; from rest,
    which the preload moves within the step, 4.8e-6)."""
    from wheelrom.analysis.stability import analyse
    from wheelrom.forces.reference import ReferenceForces
    from wheelrom.transient.exponential import (
        _force_jacobian,
        _nd_explicit,
        coefficients,
        step_matrix,
    )
    from wheelrom.transient.stuck_shift import shift_matrix

    model, cfg, flow = _elastic_flow(attachment, 80.0)
    N, m, h = model.blades, model.modes, 1e-5
    q = analyse(model, cfg, {"shroud": 80.0}).equilibrium
    sliders = ReferenceForces(flow.params).sliders_at_rest(q).ravel()
    shift = shift_matrix(model, flow.params)  # the stuck springs' share the kernel propagates
    assert np.abs(shift).max() > 0.01 * np.abs(model.A0).max()
    a, V = np.linalg.eigh(model.A0 + shift)
    jacobian = _force_jacobian(model, flow.params, q)
    coef = coefficients(a, cfg.wheel.damping_beta, h)
    for k in (0, 2, N // 2):
        explicit = _nd_explicit(model, *jacobian, cfg.wheel.damping_beta, k, shift=shift)[1]
        R = step_matrix(coef, explicit, h)
        values, vectors = np.linalg.eig(R)
        x = vectors[:, np.argmax(np.abs(values))]
        wave = np.exp(2j * np.pi * k * np.arange(N) / N)[:, None]

        def on_wheel(y, wave=wave):  # (2m,) kernel basis, blade 0 -> (2 N m,), real
            return np.concatenate([(wave * (V @ y[:m])[None]).real.ravel(),
                                   (wave * (V @ y[m:])[None]).real.ravel()])

        size = 1e-9 / np.abs(model.tip @ V @ x[:m]).max()
        rest = np.concatenate([q.ravel(), np.zeros(N * m)])
        states = np.stack([rest, rest + size * on_wheel(x)])
        moved = flow.advance(np.concatenate([states, np.stack([sliders] * 2)], axis=1), h,
                             steps=1)[:, : 2 * N * m]
        truth = on_wheel(R @ x)
        np.testing.assert_allclose((moved[1] - moved[0]) / size, truth, rtol=0,
                                   atol=1e-6 * np.abs(truth).max())
    flow.destroy()


def test_a_step_the_stuck_contacts_make_unstable_is_lowered(attachment):
    """Elastic law, shroud 80 deg: at 15 us the scheme grows ND 0 at +126 /s where the wheel
    decays (``stable_step``'s step matrices, the stuck springs' share propagated exactly:
    :mod:`wheelrom.transient.stuck_shift`; without it 10 us grew at +22.5 /s); the compiled
    flow from the preloaded equilibrium plus that step matrix's growing mode grows at that
    rate (over 0.3 s of whole steps); at the lowered step (10.9 us) the same start decays.
    ``run_case`` takes the lowered step and says why."""
    from wheelrom.analysis.stability import analyse
    from wheelrom.forces.reference import ReferenceForces
    from wheelrom.transient.exponential import (
        SPURIOUS_GROWTH,
        _force_jacobian,
        _nd_explicit,
        coefficients,
        stable_step,
        step_growth,
        step_matrix,
    )
    from wheelrom.transient.stuck_shift import shift_matrix

    model, cfg, flow = _elastic_flow(attachment, 80.0)
    beta, h = cfg.wheel.damping_beta, 1.5e-5
    shift = shift_matrix(model, flow.params)
    lowered, why = stable_step(model, flow.params, beta, h)
    assert 1e-5 < lowered < h and "grows ND 0" in why and "stuck springs" in why
    scheme, wheel = step_growth(model, _force_jacobian(model, flow.params), beta, h,
                                shift=shift)
    assert scheme[0] > 50.0 and wheel[0] < 0
    q = analyse(model, cfg, {"shroud": 80.0}).equilibrium
    sliders = ReferenceForces(flow.params).sliders_at_rest(q)
    N, m = model.blades, model.modes
    a, V = np.linalg.eigh(model.A0 + shift)
    explicit = _nd_explicit(model, *_force_jacobian(model, flow.params), beta, 0,
                            shift=shift)[1]
    values, vectors = np.linalg.eig(step_matrix(coefficients(a, beta, h), explicit, h))
    x = vectors[:, np.argmax(np.abs(values))]  # ND 0: the same on every blade
    seed = np.concatenate([np.tile((V @ x[:m]).real, N), np.tile((V @ x[m:]).real, N)])
    # 1e-15 m of tip: the stiff mode moves the contacts far more than the tip, and beyond
    # the stick range (0.14 um) the slip would damp it
    seed *= 1e-15 / np.abs(seed[: N * m].reshape(N, m) @ model.tip.T).max()
    start = np.concatenate([q.ravel(), np.zeros(N * m)]) + seed
    start = np.concatenate([start, sliders.ravel()])

    span = 0.05  # [s]: e^6 at the predicted rate, the contacts still far inside their stick range

    def growth(step):  # of the modal velocities' envelope, over ``span`` in 6 blocks
        n = round(span / step)
        path = flow.trajectory(start, n * step, n, stride=n // 36)
        speed = np.linalg.norm(path[1:37, N * m : 2 * N * m], axis=1).reshape(6, 6).max(axis=1)
        return np.polyfit((np.arange(6) + 0.5) * span / 6, np.log(speed), 1)[0]

    assert growth(h) == pytest.approx(scheme[0], rel=0.05)
    assert growth(lowered) < SPURIOUS_GROWTH + 1.0
    res = run_case(model, flow.cfg.replace(**{"time.step": h, "time.end": 1e-3,
                                              "time.window": 1e-3}),
                   {"shroud": 80.0})
    assert res.options["ts_dt"] == lowered and "stuck springs" in res.options["ts_dt_lowered"]


def test_cases_whose_steps_differ_are_not_batched(small_model, small_cfg, monkeypatch):
    """A batch takes one step: cases for which the scheme's stability check gives different
    steps (here made to: 10 us at 20 deg, 8 us at 80 deg) run apart, each bitwise as alone
    at its own step (taking the batch's smallest changed the 20 deg case with its company)."""
    from wheelrom.transient import exponential

    stable = exponential.stable_step

    def by_angle(model, params, beta, step):
        if params.contacts.angles_deg["shroud"][0] > 50.0:
            return 0.8 * step, "lowered"
        return stable(model, params, beta, step)

    monkeypatch.setattr(exponential, "stable_step", by_angle)
    cfg = _exponential(small_cfg, **{"time.step": 1e-5, "time.end": 0.001,
                                     "time.window": 0.0005})
    angles = [{"shroud": 20.0}, {"shroud": 80.0}, {"shroud": 30.0}]
    batch = run_cases(small_model, cfg, angles)
    assert [r.options["ts_dt"] for r in batch] == pytest.approx([1e-5, 8e-6, 1e-5], rel=1e-12)
    for a, res in zip(angles, batch, strict=True):
        alone = run_case(small_model, cfg, a)
        assert np.array_equal(res.final_state, alone.final_state)


def test_a_mistuned_wheel_is_checked_at_its_extreme_mistuning(attachment):
    """Paper law, shroud 80 deg, 18.5 us (20 us off the 50 kHz resonance): the tuned wheel is
    stable there, every blade mistuned by +0.2 is not (the kernel adds ``delta_s K_seg``
    explicitly: ND 6 grows at +7047 /s in ``step_growth``, where the wheel decays); ``stable_step``
    of a wheel mistuned between -0.05 and +0.2 lowers the step for it and says why. Truth:
    the compiled flow of the uniformly mistuned wheel (cyclic, so the ND analysis is exact)
    from its equilibrium plus the growing mode grows at the predicted rate at the refused
    step (measured +6909 against +7047 /s) and decays at the lowered 16.6 us (-4.2 /s)."""
    from wheelrom.analysis.periodic.flow import WheelFlow
    from wheelrom.analysis.stability import analyse
    from wheelrom.forces.parameters import force_parameters
    from wheelrom.transient.exponential import (
        SPURIOUS_GROWTH,
        _force_jacobian,
        _nd_explicit,
        coefficients,
        safe_step,
        stable_step,
        step_growth,
        step_matrix,
    )

    tuned, cfg = attachment
    cfg = _exponential(cfg, **{"excitation.force": 0.0})
    N, m, beta = tuned.blades, tuned.modes, cfg.wheel.damping_beta
    h = safe_step(tuned, 2e-5)[0]
    angles = {"shroud": 80.0}
    params = force_parameters(tuned, cfg, angles)
    assert stable_step(tuned, params, beta, h) == (h, None)
    spread = dataclasses.replace(tuned, mistuning=np.linspace(-0.05, 0.2, N))
    lowered, why = stable_step(spread, params, beta, h)
    assert lowered < h and "mistuning" in why
    uniform = dataclasses.replace(tuned, mistuning=np.full(N, 0.2))
    jacobian = _force_jacobian(uniform, params)
    scheme, wheel = step_growth(uniform, jacobian, beta, h, 0.2)
    k = int(np.argmax(scheme - np.maximum(wheel, 0)))
    assert scheme[k] > 1000.0 and wheel[k] < 0
    assert stable_step(uniform, params, beta, h)[0] == lowered  # the extreme decides
    q = analyse(uniform, cfg, angles).equilibrium
    a, V = np.linalg.eigh(uniform.A0)
    explicit = _nd_explicit(uniform, *jacobian, beta, k, delta=0.2)[1]
    values, vectors = np.linalg.eig(step_matrix(coefficients(a, beta, h), explicit, h))
    x = vectors[:, np.argmax(np.abs(values))]  # the growing step mode of ND k on blade 0
    wave = np.exp(2j * np.pi * k * np.arange(N) / N)[:, None]
    seed = np.concatenate([(wave * (V @ x[:m])[None]).real.ravel(),
                           (wave * (V @ x[m:])[None]).real.ravel()])
    seed *= 1e-15 / np.abs(seed[: N * m].reshape(N, m) @ uniform.tip.T).max()
    start = np.concatenate([q.ravel(), np.zeros(N * m)]) + seed
    flow = WheelFlow(uniform, cfg, angles)

    def growth(step, duration):  # of the modal velocities' envelope, in 6 blocks
        n = round(duration / step)
        path = flow.trajectory(start, n * step, n, stride=max(1, n // 36))
        speed = np.linalg.norm(path[1:37, N * m :], axis=1).reshape(6, 6).max(axis=1)
        return np.polyfit((np.arange(6) + 0.5) * duration / 6, np.log(speed), 1)[0]

    try:
        assert growth(h, 10 / scheme[k]) == pytest.approx(scheme[k], rel=0.05)
        assert growth(lowered, 0.05) < SPURIOUS_GROWTH + 1.0
    finally:
        flow.destroy()
