"""The forced response's exact state by shooting at the excitation's period
(:mod:`wheelrom.analysis.periodic.forced_shooting`, issue #45) against independent truth:

- the lift-off ring of ``test_forced_branch`` (three one-mode blades, a preloaded normal
  contact that lifts off, one nozzle's wave bending the peak into a fold pair): between the
  folds the three harmonic-balance states are made exact; each is periodic under scipy's
  DOP853 (the equations written out again, a second integrator); the lower one is linear
  (the contacts stay closed), so its Floquet multipliers are the closed ring's analytic
  ``exp(lambda T)`` per ND; the middle one has the fold's real multiplier above 1, the upper
  one none outside the unit circle (as Hill's method and the time integration found);
- the small wheel under the elastic law: the shot converges with the sliders in the state,
  the harmonic balance at H = 5 within 2 % of it, the stuck tie-boss's sliders neutral
  (``|mu| = 1``);
- ``forced-response --nonlinear --exact`` prints, writes JSON and ``/nonlinear/exact``, which
  ``info`` reads.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from test_forced_branch import (
    BETA,
    COUPLING,
    LIFT_OFF,
    W0,
    ring_curve,  # noqa: F401 (the fixture)
    ring_motion,
)
from wheelrom.analysis.periodic.forced_shooting import ForcedShooting, exact_forced
from wheelrom.analysis.periodic.forced_wave import ForcedWave, forced_curve
from wheelrom.analysis.periodic.newton import reduced_rank_extrapolation
from wheelrom.forces.parameters import force_parameters
from wheelrom.studies.forced_nonlinear import forced_inputs


def _states_between_the_folds(ring_curve):  # noqa: F811
    model, params, curve = ring_curve
    f_upper, f_lower = curve.folds
    omega = 0.5 * (f_upper + f_lower)
    w = curve.frequency
    H = (curve.harmonics.shape[1] - 1) // 2
    problem = ForcedWave(model, params, BETA, H, 16 * (H + 1), 0.0)
    states = []
    for i in np.flatnonzero((w[:-1] - omega) * (w[1:] - omega) <= 0):
        j = i if abs(w[i] - omega) < abs(w[i + 1] - omega) else i + 1
        X, ok, _ = problem.solve(curve.harmonics[j], omega)
        assert ok
        states.append(X)
    return model, problem, omega, states


def test_the_exact_states_between_the_folds(ring_curve, small_cfg):  # noqa: F811
    model, problem, omega, states = _states_between_the_folds(ring_curve)
    cfg = small_cfg.replace(**{"wheel.damping_beta": BETA, "time.scheme": "rk",
                               "time.step": 5e-6})
    T = 2 * math.pi / omega
    orbits = sorted((exact_forced(model, cfg, problem, X, omega) for X in states),
                    key=lambda o: o.tip_amplitude)
    low, middle, high = orbits
    assert all(o.converged and o.pattern == 3 for o in orbits)
    assert low.tip_amplitude < LIFT_OFF < middle.tip_amplitude < high.tip_amplitude
    for o in orbits:
        # the harmonic balance at H = 7 within its truncation of a kinked force (measured
        # 1.4e-5, 2.2e-4, 2.0e-4)
        assert abs(o.relative_difference) < 1e-3
        # periodic in the equations of motion written out and integrated by DOP853 (the
        # shot is periodic in RK 3bs's map at 5 us: measured 2e-9 of the vibration)
        y0 = o.state  # (q, q') of blades 0..2: unit modal masses, q = y
        sol = solve_ivp(ring_motion, (0.0, T), y0, args=(omega,), method="DOP853",
                        rtol=1e-11, atol=1e-15, max_step=T / 256)
        vibration = np.abs(y0[:3] - y0[:3].mean()).max()
        assert np.abs(sol.y[:3, -1] - y0[:3]).max() < 1e-6 * vibration
    # below lift-off the ring is linear: its multipliers are exp(lambda T) of the closed
    # ring, ND 0 (the contacts do not move: W0^2, damping beta W0^2) and ND 1 (W0^2 + 3
    # coupling + 3 contact, damping beta (W0^2 + 3 coupling): the contact is undamped)
    closed = {0: (W0**2, BETA * W0**2), 1: (W0**2 + 3 * COUPLING + 3 * 0.2 * W0**2,
                                            BETA * (W0**2 + 3 * COUPLING))}
    for nd, (k, c) in closed.items():
        lam = -c / 2 + 1j * math.sqrt(k - c**2 / 4)
        expected = np.exp(lam * T)
        found = low.multipliers[low.nodal_diameters == nd]
        assert np.abs(found - expected).min() < 1e-6 and \
            np.abs(found - np.conj(expected)).min() < 1e-6, (nd, found, expected)
    assert low.largest == pytest.approx(math.exp(-BETA * W0**2 * T / 2), rel=1e-7)
    # the middle state: the fold's real multiplier above 1, in the wave's ND; the upper
    # state stable (as Hill's method and the time integration of test_forced_branch)
    assert middle.multipliers[0].imag == 0 and middle.largest > 1.05
    assert middle.nodal_diameters[0] == 1 and not middle.stable
    assert high.stable and low.stable and high.largest < 1 - 1e-3
    # the coarse step's multiplier beside the finer one (the refinement ran)
    assert middle.coarse_largest == pytest.approx(middle.largest, rel=1e-3)


def test_the_elastic_law_shoots_with_its_sliders(small_model, small_cfg):
    cfg = small_cfg.replace(**{"contacts.law": "elastic", "flutter.model": "off",
                               "excitation.force": 10.0})
    angles = {"shroud": 50.0}
    params, q = forced_inputs(small_model, cfg, angles)
    w = 2 * math.pi * 250.0
    # up to 250 Hz along the curve: from rest at 250 Hz itself Newton's start is a matter
    # of luck where the shroud goes into partial slip
    curve = forced_curve(small_model, params, cfg.wheel.damping_beta,
                         2 * math.pi * np.array([240.0, 245.0, 250.0]), q,
                         harmonics=5)
    assert curve.converged[-1]
    shares = curve.fractions[-1]  # the shroud slips most of the period, the tie-boss sticks
    assert shares[1, 2] > 0.5 and shares[0, 1] == 1.0
    problem = ForcedWave(small_model, params, cfg.wheel.damping_beta, 5)
    orbit = exact_forced(small_model, cfg, problem, curve.harmonics[-1], w, angles)
    assert orbit.converged and orbit.state.size == 2 * 6 * small_model.modes + 2 * 2 * 6
    assert abs(orbit.relative_difference) < 0.02  # H = 5 (measured +1.26 %)
    # the stuck tie-boss's sliders: any stuck position repeats, multiplier 1 (neutral)
    assert abs(orbit.largest - 1) < 1e-8 and orbit.stable
    assert force_parameters(small_model, cfg, angles).sliders == 2 * 2 * small_model.blades


def test_reduced_rank_extrapolation_is_exact_for_a_linear_map():
    """A linear map with ``k`` modes in the start's error (real multipliers of either sign
    and a complex pair near the unit circle, as the forced march's): one extrapolation of
    ``k + 2`` iterates lands on the fixed point, where the iterates are still far."""
    rng = np.random.default_rng(1)
    n, k = 40, 5
    basis = np.linalg.qr(rng.normal(size=(n, n)))[0]
    block = np.diag([-0.95, 0.9, -0.6, 0.3, 0.05] + [0.0] * (n - 5))
    block[3:5, 3:5] = 0.97 * np.array([[np.cos(2.0), -np.sin(2.0)], [np.sin(2.0), np.cos(2.0)]])
    M = basis @ block @ basis.T
    fixed = rng.normal(size=n)
    x = [fixed + basis[:, :5] @ rng.normal(size=5)]
    for _ in range(k + 1):
        x.append(fixed + M @ (x[-1] - fixed))
    assert np.abs(x[-1] - fixed).max() > 0.1
    assert np.abs(reduced_rank_extrapolation(np.array(x)) - fixed).max() < 1e-9


def test_the_elastic_sliders_are_marched_to_their_loop_before_newton(small_model, small_cfg,
                                                                      monkeypatch):
    """Partial slip near the stuck resonance (256 Hz, the configured angles): the sliders
    walk to their shakedown loop with the wheel's own slow decay (1547 periods marched
    plainly, the moves of alternating sign: several modes at once), and the march there lets
    Newton end it (from 3 marched periods Newton stalled at 0.06-0.09 of the vibration). The
    extrapolated march gets there in 66 periods."""
    march_shots = []
    march = ForcedShooting.march

    def counted(self, x, tip_amplitude):
        shot = self.shot
        calls = [0]

        def one(y):
            calls[0] += 1
            return shot(y)

        self.shot = one
        try:
            return march(self, x, tip_amplitude)
        finally:
            del self.shot
            march_shots.append(calls[0] / self.shots)

    monkeypatch.setattr(ForcedShooting, "march", counted)
    cfg = small_cfg.replace(**{"contacts.law": "elastic", "flutter.model": "off"})
    params, q = forced_inputs(small_model, cfg)
    w = 2 * math.pi * 256.0
    curve = forced_curve(small_model, params, cfg.wheel.damping_beta,
                         2 * math.pi * np.array([259.0, 258.0, 257.0, 256.0]), q, harmonics=5)
    assert curve.converged[-1] and 0.2 < curve.fractions[-1, 1, 2] < 0.8  # the shroud
    problem = ForcedWave(small_model, params, cfg.wheel.damping_beta, 5)
    orbit = exact_forced(small_model, cfg, problem, curve.harmonics[-1], w, refine=False)
    assert orbit.converged and orbit.iterations <= 3
    assert abs(orbit.relative_difference) < 0.05  # H = 5 (measured -3.5 %)
    assert len(march_shots) == 1 and march_shots[0] < 200  # measured 66
    # the march starts from the balance's own loop: one period moves that start less than
    # one from the sliders at rest at the mean (the paper wheel's 1 N peak: 3.4 times)
    shooting = ForcedShooting(small_model, cfg, problem, w)
    try:
        X = curve.harmonics[-1]
        qs, vs = problem.balance.wheel_state(X, w)
        motion = np.concatenate([qs[: shooting.N].ravel(), vs[: shooting.N].ravel()])
        mean = np.repeat(np.asarray(X[0])[None], shooting.N, axis=0)
        rest = shooting.flow.forces().sliders_at_rest(mean)
        loop = shooting.balance_sliders(problem, X)
        assert loop.shape == rest.shape
        moves = []
        for sliders in (rest, loop):
            x = np.concatenate([motion, sliders.ravel()])[None]
            y = x
            for _ in range(shooting.shots):
                y = shooting.shot(y)
            scale = shooting._scale(x[0], problem.tip_amplitude(X, w))
            moves.append(float(np.abs((y - x) / scale).max()))
        assert moves[1] < 0.5 * moves[0], moves
    finally:
        shooting.destroy()


def test_the_command_checks_the_peak_by_shooting(tmp_path, capsys):
    import json

    import h5py

    from conftest import SMALL
    from wheelrom.cli import main as cli

    path = tmp_path / "f.h5"
    # forced.exact = true (the default; the tests' wheel sets it false): the peak shot
    argv = ["forced-response", SMALL, "--nonlinear", "--frequencies", "120:135:6",
            "--harmonics", "11", "--set", 'flutter.model="off"', "--set",
            "excitation.force=10", "--set", "forced.exact=true", "--json", "--out", str(path)]
    assert cli.main(argv) == 0
    nl = json.loads(capsys.readouterr().out)["nonlinear"]
    ex = nl["exact"]
    # at the refined peak when there is one (issue #74); here the largest solved point is
    # the first (120 Hz has no solution), no peak to refine: the grid's
    assert ex["converged"] and not ex["at_refined_peak"] and "refined_peak_frequency_hz" not in nl
    assert ex["frequency_hz"] == pytest.approx(nl["peak_frequency_hz"])
    assert ex["hb_tip_amplitude_m"] == pytest.approx(nl["peak_amplitude_m"], rel=1e-3)
    assert abs(ex["hb_relative_difference"]) < 1e-3  # H = 11, no contact opens
    assert len(ex["multipliers_re"]) == len(ex["multiplier_nd"]) > 0
    with h5py.File(path) as f:
        e = f["nonlinear/exact"]
        assert e.attrs["tip_amplitude_m"] == ex["tip_amplitude_m"]
        assert e["multipliers_re"].shape == (len(ex["multipliers_re"]),)
    capsys.readouterr()
    assert cli.main(["info", str(path)]) == 0
    line = [x for x in capsys.readouterr().out.splitlines() if "exact state:" in x]
    assert line and f"{ex['largest_multiplier']:.6f}" in line[0]
    capsys.readouterr()
    # every solved frequency: the curve's stable and unstable parts
    argv[argv.index("--nonlinear") + 1 : argv.index("--nonlinear") + 1] = ["--exact", "all"]
    assert cli.main(argv[:-2] + ["--out", str(tmp_path / "all.h5")]) == 0
    nl = json.loads(capsys.readouterr().out)["nonlinear"]
    rows = nl["exact_curve"]
    assert len(rows) == 6 and rows[0] is None  # 120 Hz: the balance has no solution
    assert all(r["converged"] for r in rows[1:])
    assert rows[1] == nl["exact"] and not rows[1]["at_refined_peak"]  # 123 Hz: the peak
    stable = [r["stable"] for r in rows[1:]]
    assert stable == [False, False, False, True, True]  # measured |mu| 1.89 .. 0.9997
    with h5py.File(tmp_path / "all.h5") as f:
        e = f["nonlinear/exact_curve"]
        assert list(e["stable"][()]) == [False] + stable
        assert np.isnan(e["tip_amplitude_m"][0]) and e["wheel_multiplier_nd"][1] == 3
    assert cli.main(["plot", str(tmp_path / "all.h5"), "--outdir", str(tmp_path / "fig")]) == 0
    capsys.readouterr()
    assert cli.main(["forced-response", SMALL, "--exact"]) == 2  # --nonlinear needed
    assert "--nonlinear" in capsys.readouterr().err
    # --exact none: the balance's peak alone, whatever forced.exact says
    none = argv[:-2]
    none[none.index("all")] = "none"
    none[none.index("120:135:6")] = "123:125:2"
    assert cli.main(none) == 0
    nl = json.loads(capsys.readouterr().out)["nonlinear"]
    assert "exact" not in nl and "exact_curve" not in nl and nl["converged"] == [True, True]


def test_every_nd_from_the_block_circulant_map(small_model, small_cfg):
    """The multipliers in every ND (:func:`wheel_multipliers`: the short map's Bloch blocks
    over the pattern's super-blocks) against the whole wheel's monodromy formed by central
    differences of whole periods of all 12 blades (no symmetry used): the same complex
    multipliers, the odd NDs (outside the 6-blade pattern of the ND-2 wave) included."""
    from wheelrom.analysis.periodic.flow import Nozzle, WheelFlow

    cfg = small_cfg.replace(**{"flutter.model": "off", "excitation.force": 10.0})
    angles = {"shroud": 50.0}
    params, q = forced_inputs(small_model, cfg, angles)
    w = 2 * math.pi * 250.0
    curve = forced_curve(small_model, params, cfg.wheel.damping_beta, np.array([w]), q,
                         harmonics=5)
    problem = ForcedWave(small_model, params, cfg.wheel.damping_beta, 5)
    orbit = exact_forced(small_model, cfg, problem, curve.harmonics[0], w, angles,
                         refine=False, whole_wheel=True)
    N, m, P = small_model.blades, small_model.modes, orbit.pattern
    assert orbit.converged and P == 6 and orbit.wheel_multipliers.size == 2 * N * m
    assert set(orbit.wheel_nodal_diameters) > set(orbit.nodal_diameters)  # odd NDs too
    blades = np.arange(N) % P
    x = np.concatenate([orbit.state[: P * m].reshape(P, m)[blades].ravel(),
                        orbit.state[P * m :].reshape(P, m)[blades].ravel()])
    n = x.size
    a = np.abs(x[N * m :]).max() / w
    scale = np.r_[np.full(N * m, a), np.full(N * m, w * a)]
    h = 1e-6 * scale
    perturbed = np.repeat(x[None], 2 * n, axis=0)
    perturbed[np.arange(n), np.arange(n)] += h
    perturbed[n + np.arange(n), np.arange(n)] -= h
    flow = WheelFlow(small_model, cfg, angles, 1.0, nozzle=Nozzle(w, params.nozzle_phase),
                     params=params)
    try:
        end = flow.advance(perturbed, 2 * math.pi / w, orbit.steps_per_period)
    finally:
        flow.destroy()
    M = ((end[:n] - end[n:]) / (2 * h[:, None])).T * scale[None, :] / scale[:, None]
    mu = np.linalg.eigvals(M)
    mu = mu[np.argsort(-np.abs(mu))]
    assert max(np.abs(mu - v).min() for v in orbit.wheel_multipliers) < 1e-4
    np.testing.assert_allclose(np.abs(orbit.wheel_multipliers[:12]), np.abs(mu[:12]),
                               atol=1e-6)
    # the pattern's own multipliers are among them (p = 0; another set of differences)
    assert max(np.abs(orbit.wheel_multipliers - v).min() for v in orbit.multipliers) < 1e-4
    assert abs(orbit.wheel_multipliers[0]) == pytest.approx(orbit.largest, abs=1e-6)


def test_a_transient_leaves_an_unstable_state_at_its_largest_multiplier(small_model,
                                                                        small_cfg):
    """The small wheel's paper-law state at 123 Hz (10 N, H = 11): its largest multiplier in
    every ND, a real one below -1 in ND 3 (outside the ND-2 wave's 6-blade pattern: a period
    doubling), against the whole wheel integrated from the state with a 1e-10 perturbation
    of every blade: the deviation grows by the multiplier's modulus a period while it is
    small (measured 1.736 against 1.743 over periods 8-24)."""
    from wheelrom.analysis.periodic.flow import Nozzle, WheelFlow

    cfg = small_cfg.replace(**{"flutter.model": "off", "excitation.force": 10.0})
    params, q = forced_inputs(small_model, cfg)
    w = 2 * math.pi * 123.0
    curve = forced_curve(small_model, params, cfg.wheel.damping_beta,
                         2 * math.pi * np.linspace(130.0, 123.0, 8), q, harmonics=11)
    problem = ForcedWave(small_model, params, cfg.wheel.damping_beta, 11)
    orbit = exact_forced(small_model, cfg, problem, curve.harmonics[-1], w, refine=False,
                         whole_wheel=True)
    mu = orbit.wheel_multipliers[0]
    assert orbit.converged and not orbit.stable
    assert mu.real < -1.5 and abs(mu.imag) < 1e-9 and orbit.wheel_nodal_diameters[0] == 3
    N, m, P = small_model.blades, small_model.modes, orbit.pattern
    blades = np.arange(N) % P
    x = np.concatenate([orbit.state[: P * m].reshape(P, m)[blades].ravel(),
                        orbit.state[P * m :].reshape(P, m)[blades].ravel()])
    a = np.abs(x[N * m :]).max() / w
    scale = np.r_[np.full(N * m, a), np.full(N * m, w * a)]
    y = x + 1e-10 * scale * np.random.default_rng(1).standard_normal(x.size)
    flow = WheelFlow(small_model, cfg, None, 1.0, nozzle=Nozzle(w, params.nozzle_phase),
                     params=params)
    deviation = []
    try:
        for _ in range(25):
            deviation.append(np.linalg.norm((y - x) / scale))
            y = flow.advance(y[None], 2 * math.pi / w, orbit.steps_per_period)[0]
    finally:
        flow.destroy()
    growth = (deviation[24] / deviation[8]) ** (1 / 16)
    assert growth == pytest.approx(abs(mu), rel=0.03)


def test_a_flow_that_fails_ends_one_shot_not_the_curve(small_model, small_cfg, monkeypatch):
    """A step of the flow that fails (a NaN column, a TS that stops) makes that state's shot
    a failure with its reason; the caller's curve and other states are kept."""
    from wheelrom.analysis.periodic import forced_shooting

    cfg = small_cfg.replace(**{"flutter.model": "off", "excitation.force": 10.0})
    params, q = forced_inputs(small_model, cfg)
    w = 2 * math.pi * 250.0
    curve = forced_curve(small_model, params, cfg.wheel.damping_beta, np.array([w]), q,
                         harmonics=3)
    problem = ForcedWave(small_model, params, cfg.wheel.damping_beta, 3)

    def broken(self, x):
        raise RuntimeError("the flow took 3 of 27 steps")

    monkeypatch.setattr(forced_shooting.ForcedShooting, "shot", broken)
    orbit = exact_forced(small_model, cfg, problem, curve.harmonics[0], w, whole_wheel=True)
    assert not orbit.converged and "RuntimeError: the flow took 3 of 27" in orbit.reason
    assert orbit.hb_tip_amplitude == pytest.approx(curve.tip_amplitude[0], rel=1e-3)


def test_under_an_aerodynamic_table_the_whole_period_is_shot(small_model, tmp_path):
    """An aerodynamic table couples every blade pair, so the shot is not cut to the ND-2
    wave's pattern: it takes the whole wheel over a whole period (``mu = nu``; the wave's
    shift over ``tau`` would raise the multipliers to the pattern's power with the shift's
    phase), and its multipliers are those of every ND (the block-circulant map's)."""
    from conftest import SMALL
    from wheelrom import config

    path = tmp_path / "aero.csv"
    path.write_text("nd,damping_ratio\n" + "\n".join(f"{k},0.002" for k in range(12)) + "\n")
    cfg = config.load(SMALL, ['flutter.model="table"', f'flutter.table="{path}"'])
    cfg = cfg.replace(**{"excitation.force": 0.1})
    params, q = forced_inputs(small_model, cfg)
    w = 2 * math.pi * 250.0
    curve = forced_curve(small_model, params, cfg.wheel.damping_beta, np.array([w]), q,
                         harmonics=3)
    assert curve.converged[0]
    problem = ForcedWave(small_model, params, cfg.wheel.damping_beta, 3)
    orbit = exact_forced(small_model, cfg, problem, curve.harmonics[0], w, refine=False,
                         whole_wheel=True)
    assert orbit.converged and orbit.pattern == small_model.blades
    assert abs(orbit.relative_difference) < 1e-4  # a linear state (micro-slip branch)
    # the same multipliers both ways (measured 2.5e-6 apart: two sets of differences; the
    # pattern's power taken for the whole period would square them, 5e-4 off), every ND,
    # stable (the table damps every ND)
    assert orbit.largest == pytest.approx(abs(orbit.wheel_multipliers[0]), abs=1e-5)
    assert max(np.abs(orbit.wheel_multipliers - v).min() for v in orbit.multipliers[:12]) < 1e-4
    assert orbit.stable and set(orbit.nodal_diameters) == set(orbit.wheel_nodal_diameters)


def test_the_exact_peak_is_shot_from_the_refined_peak(monkeypatch):
    """Issue #74: ``--exact`` shoots the refined peak (the balance's maximum off the grid),
    not the grid's largest point; at the band's edge (no peak to refine) and under ``--exact
    all`` the grid's states. The shot is replaced by a record of its start."""
    from types import SimpleNamespace

    import wheelrom.studies.forced_nonlinear as forced_nonlinear
    from wheelrom.cli import forced as cli_forced

    started = []
    monkeypatch.setattr(forced_nonlinear, "exact_peak",
                        lambda model, cfg, X, w, *a, **k: started.append((X, w)) or "orbit")
    monkeypatch.setattr(cli_forced, "_exact", lambda orbit: {"orbit": orbit})
    grid = np.array([1.0, 2.0, 3.0, 4.0])
    harmonics = np.arange(4.0)[:, None, None] * np.ones((4, 3, 2))
    refined = SimpleNamespace(harmonics=np.full((3, 2), 9.0), frequency=2.6)
    curve = SimpleNamespace(converged=np.ones(4, bool), peak=2, frequency=grid,
                            harmonics=harmonics, refined=refined)
    say = lambda *_: None  # noqa: E731
    states = cli_forced._exact_states(None, None, curve, (), None, 3, "peak", None, say)
    assert list(states) == [2] and states[2]["at_refined_peak"]
    assert started[-1][1] == 2.6 and np.all(started[-1][0] == 9.0)
    curve.peak = 3  # the last solved point: a largest value at the edge, not a peak
    states = cli_forced._exact_states(None, None, curve, (), None, 3, "peak", None, say)
    assert not states[3]["at_refined_peak"] and started[-1][1] == 4.0
    started.clear()
    states = cli_forced._exact_states(None, None, curve, (), None, 3, "all", None, say)
    assert [w for _, w in started] == [1.0, 2.0, 3.0, 4.0]
    assert not any(s["at_refined_peak"] for s in states.values())


def test_newton_keeps_its_jacobian_while_the_steps_contract():
    """``newton_least_squares(chord=True)`` on ``z + 0.3 z^3 = b`` (componentwise, each root
    the real one of its cubic by numpy's ``roots``): the same roots to 1e-9 as with a fresh
    Jacobian each iteration, with fewer Jacobians than iterations; a singular direction (a
    zero row and column, the stuck slider's neutral one) keeps its start."""
    from wheelrom.analysis.periodic.newton import newton_least_squares

    b = np.array([0.5, -1.0, 2.0, 0.0])
    mask = np.array([1.0, 1.0, 1.0, 0.0])  # the last unknown: neutral

    def residual(z):
        return mask * (z + 0.3 * z**3 - b)

    calls = []

    def jacobian(z):
        calls.append(1)
        return np.diag(mask * (1 + 0.9 * z**2))

    roots = [next(r.real for r in np.roots([0.3, 0, 1, -v]) if abs(r.imag) < 1e-12)
             for v in b[:3]]
    start = np.array([0.0, 0.0, 0.0, 0.7])
    for chord in (False, True):
        calls.clear()
        z, _, size, reason, it = newton_least_squares(residual, jacobian, start.copy(), 0.0,
                                                      30, chord=chord)
        assert reason == "converged" and size <= 1e-10
        np.testing.assert_allclose(z[:3], roots, rtol=1e-9)  # the residual within 1e-10
        assert z[3] == 0.7
        assert (len(calls) < it) if chord else (len(calls) == it)
