"""The exact periodic orbit by shooting and its Floquet multipliers from the monodromy
(:mod:`wheelrom.analysis.periodic`), against independent truth:

- Van der Pol alone (relative law, ND N/2 of the 12-blade wheel): the orbit is the harmonic
  balance's cycle (itself the averaging's: tests/test_limit_cycle.py), the multipliers of the
  pattern map are the averaging's amplitude exponent ``exp(-eps_eff T)`` and the phase shift's
  1; with the intensity reversed the cycle is unstable and the whole wheel's monodromy by
  SLEPc finds that multiplier first;
- the cyclic-symmetry reduction: the pattern wheel's flow equals the whole wheel's on
  patterns, bitwise;
- a cycle with contacts opening: Newton converges, the whole wheel's transient started on
  the orbit stays on it for 10 periods, and the dominant multiplier from the pattern map's
  Jacobian equals SLEPc's on the whole wheel (two computations of one number).
"""

import math

import numpy as np
import pytest

from conftest import SMALL
from wheelrom import config
from wheelrom.analysis.periodic.continuation import BranchSettings
from wheelrom.analysis.periodic.flow import WheelFlow, pattern_blades, pattern_model
from wheelrom.analysis.periodic.harmonic_balance import WaveBalance
from wheelrom.analysis.periodic.limit_cycle import Settings, case_limit_cycles, periodic_solution
from wheelrom.analysis.periodic.monodromy import floquet_multipliers
from wheelrom.analysis.periodic.shooting import Shooting, sample_orbit
from wheelrom.forces.parameters import force_parameters
from wheelrom.transient.run import run_case

VDP = ["contacts.tieboss.enabled=false", "contacts.shroud.enabled=false",
       "wheel.damping_beta=1e-9", "flutter.mu=10.0", 'flutter.model="relative"',
       'time.scheme="exponential"', "time.step=1e-5", "excitation.force=0.0"]
WAVE = 6  # ND N/2 of the 12-blade wheel


@pytest.mark.parametrize("wave", [0, 3, 4, 6, 5])
def test_pattern_wheel_is_the_whole_wheel_on_patterns(small_model, wave):
    """A state repeating every N' blades stays so, and the pattern wheel of N' blades
    integrates it bitwise as the whole wheel does (contacts on, exponential scheme)."""
    cfg = config.load(SMALL, ['time.scheme="exponential"', "time.step=1e-5"])
    pattern, g, j = pattern_model(small_model, wave)
    assert pattern.blades == 12 // math.gcd(wave, 12) and (j * wave - g) % 12 == 0
    rng = np.random.default_rng(wave)
    x = rng.normal(size=(2, pattern.blades, small_model.modes))
    x *= np.array([1e-6, 1e-3])[:, None, None]
    whole = WheelFlow(small_model, cfg, {"shroud": 80.0})
    part = WheelFlow(pattern, cfg, {"shroud": 80.0})
    try:
        end = whole.advance(x[None, :, np.arange(12) % pattern.blades], 2e-3)[0]
        end_part = part.advance(x[None], 2e-3)[0]
    finally:
        whole.destroy()
        part.destroy()
    assert np.array_equal(end[:, : pattern.blades], end_part)
    assert np.array_equal(end, end[:, np.arange(12) % pattern.blades])
    assert pattern_blades(wave, 12) == (pattern.blades, g, j)


def _vdp_orbit(model, lam):
    """The HB cycle of the relative Van der Pol ND N/2 wave at factor ``lam`` and the orbit
    shot from it: ``(point, balance, shooting, orbit)``."""
    cfg = config.load(SMALL, VDP)
    params = force_parameters(model, cfg)
    balance = WaveBalance(model, params, cfg.wheel.damping_beta, WAVE, 7, 32)
    w2, V = np.linalg.eigh(model.nd_stiffness(WAVE))
    j = int(np.argmax(np.abs(params.aero @ V)))
    X = np.zeros((15, model.modes))
    # the ratio cancels eigh's arbitrary complex phase of the (Hermitian) ND block's vector
    X[1] = (V[:, j] * params.vdp_r / (params.aero @ V[:, j])).real  # y = r / 2 per blade
    point = periodic_solution(balance, X, math.sqrt(w2[j]), lam)
    assert point is not None
    shooting = Shooting(model, cfg, WAVE, None, lam)
    q, v = balance.wheel_state(point.X, point.omega)
    orbit = shooting.solve(np.stack([q, v])[:, : shooting.N], 2 * math.pi / point.omega)
    return point, balance, shooting, orbit, cfg


@pytest.fixture(scope="module")
def vdp(small_model):
    out = {lam: _vdp_orbit(small_model, lam) for lam in (1.0, -1.0)}
    yield out
    for *_, shooting, _, _ in out.values():
        shooting.destroy()


@pytest.mark.parametrize("lam", [1.0, -1.0], ids=["stable", "reversed"])
def test_van_der_pol_orbit_is_the_harmonic_balance_cycle(vdp, small_model, lam):
    """Smooth cycle: the orbit's period and blade-0 harmonics are the harmonic balance's
    (7 harmonics of a 3 % Van der Pol) to the time integration's error."""
    point, balance, shooting, orbit, _ = vdp[lam]
    assert orbit.converged and orbit.residual < 1e-9
    assert orbit.pattern == 2 and orbit.shift == 1 and orbit.fraction == 0.5
    assert orbit.period == pytest.approx(2 * math.pi / point.omega, rel=1e-7)
    samples = sample_orbit(shooting, orbit).states[:, 0, 0]  # (S, m) blade 0
    c1 = 2 * np.fft.fft(samples, axis=0)[1] / samples.shape[0]
    hb = balance.complex_harmonics(point.X)[1]
    assert np.abs(np.abs(c1) - np.abs(hb)).max() < 1e-6 * np.abs(hb).max()


@pytest.mark.parametrize("lam", [1.0, -1.0], ids=["stable", "reversed"])
def test_van_der_pol_multipliers_are_the_averaging_exponent(vdp, lam):
    """The pattern map's multipliers hold the phase shift's 1 (to 5e-6: the fixed-step map is
    not exactly invariant under a time shift, its error that of the integration, 4e-7 and
    7e-7 measured) and the amplitude's ``exp(-eps_eff T)`` of the averaging = Hill
    (tests/test_limit_cycle.py: -4.633 /s, +4.634 reversed) to 1e-4 of the exponent."""
    point, balance, shooting, orbit, cfg = vdp[lam]
    mu = orbit.symmetric_multipliers
    T = orbit.period
    assert np.min(np.abs(mu - 1.0)) < 5e-6  # (the step's error moves with the orbit's phase)
    from test_limit_cycle import VdpTruth, vdp_params

    params, beta = vdp_params(shooting.full_model, "relative")
    truth = VdpTruth.of(shooting.full_model, params, beta, "relative", lam)
    # the averaging's own error is O(e^2) = 4e-5 of the exponent (measured 3e-5)
    exponents = np.log(np.abs(mu)) / T
    assert np.min(np.abs(exponents - truth.exponent)) < 1e-4 * abs(truth.exponent)
    if lam < 0:  # unstable: it is the largest
        assert exponents[0] == pytest.approx(truth.exponent, rel=1e-4)


def test_reversed_van_der_pol_cycle_unstable_by_the_whole_wheel_monodromy(vdp, small_model):
    """SLEPc on the whole wheel's linearised period: its largest multiplier is the averaging's
    ``exp(4.634 T)`` in ND 6, the orbit's own, as the pattern map's to 1e-5; the phase
    shift's multiplier is 1 to 1e-5 (the integration's error, ~1e-6)."""
    from wheelrom.runtime.environment import petsc

    point, balance, shooting, orbit, cfg = vdp[-1.0]
    # damping 1e-9: every other multiplier is within 1e-6 of the unit circle, so Krylov-Schur
    # needs more than the default 12 restarts to separate the 1.04 (an option, as for users)
    options = petsc().Options()
    options.setValue("limitcycle_floquet_eps_max_it", "100")
    try:
        mu = floquet_multipliers(small_model, cfg, orbit, orbit.steps_per_period, None, -1.0, 3)
    finally:
        options.delValue("limitcycle_floquet_eps_max_it")
    expected = abs(orbit.symmetric_multipliers[0])
    assert not mu.stable
    assert abs(mu.values[0]) == pytest.approx(expected, rel=1e-5), (mu.values, mu.nd)
    assert mu.nd[0] == 6, (mu.values, mu.nd)
    # the fixed step's error: 0.9-1.2e-6 measured, moving with the orbit's phase (where the
    # shot's start put x0), which rounding in the balance's Newton path moves
    assert mu.trivial_error < 1e-5


def test_every_nd_by_bloch_waves_is_slepcs_whole_wheel_monodromy(vdp, small_model):
    """A second implementation of the whole wheel's multipliers (the default for a pattern
    orbit, :func:`~wheelrom.analysis.periodic.bloch.bloch_multipliers`: the responses to
    pattern 0's differences assembled into every Bloch block, eigenvalues of each) against
    SLEPc's Krylov-Schur on the whole wheel's linearised period, on the reversed Van der Pol
    orbit: the same largest (ND 6, to 1e-5; measured 3e-6: half-period shots squared against
    whole periods), the phase shift's 1 to 1e-5, and every ND of
    the wheel present (the 12-blade wheel's 0..6)."""
    from wheelrom.analysis.periodic.bloch import bloch_multipliers
    from wheelrom.analysis.periodic.shooting import vibration_units
    from wheelrom.runtime.environment import petsc

    point, balance, shooting, orbit, cfg = vdp[-1.0]
    options = petsc().Options()
    options.setValue("limitcycle_floquet_eps_max_it", "100")
    try:
        slepc = floquet_multipliers(small_model, cfg, orbit, orbit.steps_per_period, None,
                                    -1.0, 3)
    finally:
        options.delValue("limitcycle_floquet_eps_max_it")
    keep = np.arange(orbit.state.size)
    units = vibration_units(orbit.state, orbit.period).ravel()
    bloch = bloch_multipliers(small_model, cfg, orbit, units, keep, None, -1.0)
    assert bloch.values.size == 2 * small_model.blades * small_model.modes
    assert abs(bloch.values[bloch.worst]) == pytest.approx(slepc.largest, rel=1e-5)
    assert bloch.nd[bloch.worst] == 6 and bloch.trivial_error < 1e-5  # (as above)
    assert set(bloch.nd) == set(range(small_model.blades // 2 + 1))


@pytest.fixture(scope="module")
def impact_cycle(small_model):
    """The small wheel's ND 6 cycle at shroud 60 deg (contacts open ~half the period), from a
    1e-3 m seed, polished by shooting, with the whole wheel's multipliers."""
    # uniform steps across the lift-offs: the two computations below are the same map's
    # (limit_cycle.events puts the Jacobian on the orbit's event schedule; test_events.py)
    cfg = config.load(SMALL, ['time.scheme="exponential"', "time.step=1e-5",
                              "excitation.force=0.0", "limit_cycle.events=false"])
    settings = Settings(harmonics=7, waves=(WAVE,), seeds=(1e-3,), method="shooting",
                        floquet="monodromy", multipliers=6, refine=1,
                        branch=BranchSettings(steps=2))
    angles = {"tieboss": 45.0, "shroud": 60.0}
    res = case_limit_cycles(small_model, cfg, settings, angles)
    cycles = [c for c in res.branches[0].cycles if c.method == "shooting"]
    assert cycles, res.verdict()
    return cfg, angles, cycles[-1]


def test_impact_orbit_converges_and_the_transient_stays_on_it(impact_cycle, small_model):
    cfg, angles, cycle = impact_cycle
    orbit = cycle.orbit
    assert orbit.residual <= 1e-9
    assert np.all(cycle.fractions[:, 0] > 0.2)  # both contacts open within the period
    # in = friction + damping + the energy's change over the orbit replayed at 1/8 step
    assert cycle.energy_residual < 1e-5
    state = orbit.wheel_state(small_model.blades)
    steps = orbit.steps_per_period
    run_cfg = cfg.replace(**{"time.step": orbit.period / steps, "time.end": 10 * orbit.period,
                             "time.window": 10 * orbit.period, "output.history_rate_hz": 0.0,
                             "output.sample_rate_hz": 0.5 * steps / orbit.period})
    res = run_case(small_model, run_cfg, angles, u0=state.ravel())
    n = state[0].size
    final = res.final_state[: 2 * n].reshape(state.shape)
    # unstable (multiplier ~1.3 per period): round-off grows ~15x over 10 periods
    assert np.abs(final[0] - state[0]).max() < 1e-7 * np.abs(state[1]).max() * orbit.period
    assert np.abs(final[1] - state[1]).max() < 1e-7 * np.abs(state[1]).max()


def test_impact_orbit_multiplier_by_two_computations(impact_cycle, small_model):
    """The dominant multiplier inside the orbit's own symmetry two ways: the eigenvalues of the
    pattern map's finite-difference Jacobian (half a period, shifted one blade, squared)
    and SLEPc on the pattern wheel's linearised whole period; the whole wheel's monodromy
    has others larger still (NDs 3, 4: the cycle is unstable), and a halved step keeps the
    verdict."""
    cfg, angles, cycle = impact_cycle
    mu = cycle.multipliers
    assert not cycle.stable and mu.largest > 1.1
    orbit = cycle.orbit
    pattern, _, _ = pattern_model(small_model, WAVE)
    inside = floquet_multipliers(pattern, cfg, orbit, orbit.steps_per_period, angles, 1.0, 2)
    step, dominant, nd = cycle.refined[0]
    assert abs(inside.values[0]) == pytest.approx(dominant, rel=1e-4)
    assert (inside.nd[0] == 1) == (nd == 6)  # on 2 pattern blades ND 1 is the wheel's N/2
    assert mu.largest >= dominant * (1 - 1e-6)
    assert cycle.refined[1][1] > 1.0


def test_chord_steps_find_the_same_orbit_with_fewer_jacobians(impact_cycle, small_model,
                                                              monkeypatch):
    """Newton on the shot keeps its last Jacobian while the residual falls at least 4x an
    iteration (each Jacobian is 2 n shots): from the impact orbit moved by 1e-3 of its
    vibration it finds the orbit Newton with a Jacobian every iteration finds, to 1e-8, with
    fewer Jacobians."""
    from wheelrom.analysis.periodic import shooting as shot

    cfg, angles, cycle = impact_cycle
    orbit = cycle.orbit
    rng = np.random.default_rng(2)
    start = orbit.state * (1 + 1e-3 * rng.standard_normal(orbit.state.shape))
    built = []
    real = shot._ShotSystem.jacobian
    monkeypatch.setattr(shot._ShotSystem, "jacobian",
                        lambda self, z: built.append(1) or real(self, z))
    found, jacobians = [], []
    for chord in (shot.CHORD, 0.0):  # 0: a Jacobian every iteration
        monkeypatch.setattr(shot, "CHORD", chord)
        built.clear()
        s = Shooting(small_model, cfg, WAVE, angles, 1.0)
        try:
            again = s.solve(start, orbit.period * (1 + 1e-4))
        finally:
            s.destroy()
        assert again.converged and again.residual <= 1e-9
        found.append(again)
        jacobians.append(len(built))
    chord, every = found
    vibration = np.abs(orbit.state[1]).max()
    assert np.abs(chord.state[1] - every.state[1]).max() < 1e-8 * vibration
    assert abs(chord.period - every.period) < 1e-8 * orbit.period
    assert jacobians[0] < jacobians[1], jacobians


def test_full_newton_steps_that_grow_the_residual_tenfold_stop_at_once():
    """The full-step phase hands over to the backtracking one as soon as the residual is 10x
    its start's (the paper wheel's 70 deg shots grew it 1e3-1e4 times over the six
    iterations the stall test needed); a smaller growth goes on."""
    from wheelrom.analysis.periodic import shooting as shot

    class Tolerances:
        def getTolerances(self):
            return 1e-30, 1e-10, 1e-14, 40

    system = object.__new__(shot._ShotSystem)
    system.floor = 0.0
    reasons = [system._converged(Tolerances(), i, (0.0, 0.0, norm))
               for i, norm in enumerate([1.0, 5.0, 9.9, 10.5])]
    assert reasons == [0, 0, 0, -3]


def test_a_monodromy_that_converged_nothing_decides_nothing():
    """SLEPc within its restarts found no multiplier: the cycle is not called stable (its
    largest would read 0), and the verdict says what happened."""
    from wheelrom.analysis.periodic.cycle import Cycle
    from wheelrom.analysis.periodic.floquet import FloquetResult
    from wheelrom.analysis.periodic.limit_cycle import WaveBranch
    from wheelrom.analysis.periodic.monodromy import Multipliers

    empty = Multipliers(np.zeros(0, complex), np.zeros(0, int), np.zeros(0, int), -1, 0.01)
    assert empty.largest == 0.0 and empty.worst == -1 and empty.stable
    cycle = Cycle(1.0, 100.0, np.zeros((2, 1), complex), 1e-5, np.zeros(1), np.zeros((1, 2)),
                  np.zeros((1, 3)), 1.0, np.zeros(1), 0.0, 0.0, 0.0, 0.0, 0.0,
                  stability=FloquetResult(np.zeros(0, int), np.zeros(0), 0.0, 0.1, True,
                                          by="monodromy: ND", trust=-math.inf),
                  multipliers=empty, method="shooting")
    assert cycle.stable is None and cycle.stability.worst_family == -1
    branch = WaveBranch(6, 6, 1, 0.5, 100.0, cycles=[cycle], kinds=("shroud",))
    assert "stability not decided" in branch.verdict()


def test_undecided_skips_the_whole_wheel_where_the_symmetry_proves_it(impact_cycle,
                                                                      small_model):
    """``whole_wheel = 'undecided'``: the in-symmetry multipliers above 1 at two steps prove
    the impact orbit unstable, so the whole wheel's monodromy is not computed; the verdict is
    the proof's, the same multiplier as with the whole wheel computed, and says what was
    skipped."""
    from wheelrom.analysis.periodic.exact import _instability_proof

    cfg, angles, full = impact_cycle
    assert _instability_proof(full) is not None  # the fixture's cycle is proven unstable
    assert full.stability.by.startswith("monodromy inside")
    settings = Settings(harmonics=7, waves=(WAVE,), seeds=(1e-3,), method="shooting",
                        floquet="monodromy", multipliers=6, refine=1, whole_wheel="undecided",
                        branch=BranchSettings(steps=2))
    res = case_limit_cycles(small_model, cfg, settings, angles)
    (cycle,) = [c for c in res.branches[0].cycles if c.method == "shooting"]
    assert cycle.multipliers is None and cycle.stable is False
    assert cycle.stability.multiplier == pytest.approx(full.stability.multiplier, rel=1e-9)
    assert "the whole wheel's not computed (limit_cycle.whole_wheel)" in res.verdict()


def test_a_shot_that_lands_on_another_orbit_says_so():
    """The paper's 70 deg: the shot from the 22.3 um harmonic-balance cycle converges to a
    16.6 um orbit, 26 % apart (the balance's truncation bias there is 2-8.5 %): the verdict
    calls it another orbit; 21.2 against 21.6 um (65 deg) is the same cycle."""
    from wheelrom.analysis.periodic.cycle import Cycle
    from wheelrom.analysis.periodic.limit_cycle import WaveBranch

    def verdict(tip_um, hb_um):
        cycle = Cycle(1.0, 136.0, np.zeros((2, 1), complex), tip_um * 1e-6, np.zeros(1),
                      np.zeros((1, 2)), np.zeros((1, 3)), 1.0, np.zeros(1), 0.0, 0.0, 0.0,
                      0.0, 0.0, method="shooting", hb_tip_amplitude=hb_um * 1e-6,
                      hb_frequency_hz=135.3)
        return WaveBranch(33, 33, 1, 0.8, 137.0, cycles=[cycle], kinds=("shroud",)).verdict()

    assert "not the harmonic balance's cycle it was shot from (22.3 um" in verdict(16.6, 22.3)
    assert "26 % apart" in verdict(16.6, 22.3)
    same = verdict(21.2, 21.6)
    assert "exact orbit (harmonic balance 21.6 um" in same and "another orbit" not in same


def test_a_verdict_names_the_other_cycles_at_its_intensity():
    """Two cycles of one wave at the configured intensity (the paper's 70 deg: the exact
    16.6 um orbit, and a 20.6 um harmonic-balance cycle whose shot missed): the verdict
    reports the smaller and names the other with its source; one cycle alone, no such
    words."""
    from wheelrom.analysis.periodic.cycle import Cycle
    from wheelrom.analysis.periodic.limit_cycle import WaveBranch

    def cycle(tip_um, hz, **kw):
        return Cycle(1.0, hz, np.zeros((2, 1), complex), tip_um * 1e-6, np.zeros(1),
                     np.zeros((1, 2)), np.zeros((1, 3)), 1.0, np.zeros(1), 0.0, 0.0, 0.0,
                     0.0, 0.0, **kw)

    exact = cycle(16.6, 136.08, method="shooting", hb_tip_amplitude=22.3e-6,
                  hb_frequency_hz=135.35)
    missed = cycle(20.6, 135.23, method="hb", shooting_residual=0.0054)
    text = WaveBranch(33, 33, 1, 0.8, 137.0, cycles=[exact, missed],
                      kinds=("shroud",)).verdict()
    assert text.startswith("limit cycle at 16.6 um tip"), text
    assert text.endswith("1 more cycle at this intensity (20.6 um, 135.2 Hz, harmonic balance "
                         "(the shot did not converge: residual 0.0054))"), text
    alone = WaveBranch(33, 33, 1, 0.8, 137.0, cycles=[exact], kinds=("shroud",)).verdict()
    assert "more cycle" not in alone


def test_a_whole_wheel_that_converged_nothing_says_how_far_it_got():
    """An in-symmetry proof of instability beside a whole-wheel monodromy that converged no
    multiplier: the verdict says how many linearised periods SLEPc integrated and how far the
    phase shift's multiplier was off 1 (the paper's 80 deg: 140 periods, 0.35)."""
    from wheelrom.analysis.periodic.cycle import Cycle
    from wheelrom.analysis.periodic.floquet import FloquetResult
    from wheelrom.analysis.periodic.limit_cycle import WaveBranch
    from wheelrom.analysis.periodic.monodromy import Multipliers

    empty = Multipliers(np.zeros(0, complex), np.zeros(0, int), np.zeros(0, int), -1, 0.007,
                        matvecs=140, trivial_check=0.35)
    proof = FloquetResult(np.array([33]), np.array([15.0]), 1.11, 0.35, False,
                          by="monodromy inside the cycle's symmetry at the finest step: ND",
                          trust=math.inf)
    cycle = Cycle(1.0, 143.0, np.zeros((2, 1), complex), 22e-6, np.zeros(1), np.zeros((1, 2)),
                  np.zeros((1, 3)), 1.0, np.zeros(1), 0.0, 0.0, 0.0, 0.0, 0.0,
                  stability=proof, multipliers=empty, method="shooting",
                  refined=[(6.25e-7, 1.11, 33)])
    text = WaveBranch(33, 33, 1, 0.74, 148.0, cycles=[cycle], kinds=("shroud",)).verdict()
    assert "unstable inside its own symmetry (ND 33: multiplier 1.11" in text, text
    assert "converged at time.step in 140 linearised periods (its phase-shift multiplier " \
           "off 1 by 0.35)" in text, text


def test_a_missed_shot_is_retried_from_the_cycle_balanced_with_more_harmonics(
        small_model, monkeypatch):
    """:func:`~wheelrom.analysis.periodic.exact.finer_balance` (the start of a second shot
    when the first misses: on the paper wheel at 75 deg the H = 11 cycle's missed, its H = 21
    balance's converged) against the continuation itself at the finer H: the small wheel's
    70 deg ND 6 cycle at ``lam = 1``, balanced with H = 5 and solved again with H = 7 by
    Newton at fixed intensity, is the H = 7 continuation's cycle (frequency to 1e-9, every
    harmonic's modulus to 1e-9 of the largest; measured 1e-12), with the default samples
    per harmonic kept (8 (H + 1): with 66 instead of 64 samples the cycle moved by 3e-3)."""
    from wheelrom.analysis.periodic import exact
    from wheelrom.analysis.periodic.limit_cycle import settings_of
    from wheelrom.analysis.stability import linearise

    angles = {"tieboss": 45.0, "shroud": 70.0}

    def cycle(harmonics):
        cfg = config.load(SMALL, [f"limit_cycle.harmonics={harmonics}", "limit_cycle.steps=4",
                                  "limit_cycle.seeds=[1e-4]", 'limit_cycle.floquet="off"',
                                  'limit_cycle.method="hb"'])
        res = case_limit_cycles(small_model, cfg, settings_of(cfg, [WAVE]), angles)
        (branch,) = res.branches
        (c,) = branch.cycles
        return cfg, c

    cfg, coarse = cycle(5)
    _, fine = cycle(7)
    params = linearise(small_model, cfg, angles)[0]  # the nozzle off, as the cycles'
    balance = WaveBalance(small_model, params, cfg.wheel.damping_beta, WAVE, 5, 48)
    X = balance.packed(coarse.harmonics)
    monkeypatch.setattr(exact, "FINER_HARMONICS", 7)
    result = exact.finer_balance(balance, X, 2 * math.pi * coarse.frequency_hz, 1.0)
    assert result is not None
    finer, X7, omega = result
    assert finer.H == 7 and finer.nt == 64
    assert omega / (2 * math.pi) == pytest.approx(fine.frequency_hz, rel=1e-9)
    c7 = np.abs(finer.complex_harmonics(X7))
    assert np.abs(c7 - np.abs(fine.harmonics)).max() <= 1e-9 * np.abs(fine.harmonics).max()
    assert abs(coarse.frequency_hz / fine.frequency_hz - 1) > 1e-5  # the two H differ
