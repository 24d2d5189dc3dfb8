"""Limit cycles of travelling waves (:mod:`wheelrom.analysis.periodic.harmonic_balance`,
:mod:`wheelrom.analysis.periodic.limit_cycle`, :mod:`wheelrom.analysis.periodic.floquet`)
against truth that does not come from the harmonic balance:

- Van der Pol alone (contacts off) on the small wheel: the single-mode reduction of the cycle
  to the classical Van der Pol oscillator, its averaging amplitude and Lindstedt-Poincare
  frequency, for the absolute law on ND 0 and the relative law on ND N/2;
- the Floquet exponents of those cycles against the averaging's amplitude exponent, for stable
  cycles and for unstable ones (the Van der Pol intensity reversed, ``lam = -1``);
- dry friction: a hand-built three-blade wheel with Coulomb-regime friction between neighbours
  and Van der Pol on every blade, against a time integration of the whole wheel (scipy's DOP853
  on the transient's force law) from a start off the cycle.
"""

import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from conftest import SMALL, one_mode_ring
from wheelrom import config
from wheelrom.analysis.periodic.floquet import exponents, floquet, hill_matrix
from wheelrom.analysis.periodic.harmonic_balance import WaveBalance
from wheelrom.analysis.periodic.limit_cycle import periodic_solution
from wheelrom.forces.contact_law import PAPER, ContactLaw
from wheelrom.forces.parameters import (
    VDP_ABSOLUTE,
    ForceParameters,
    force_parameters,
)
from wheelrom.forces.reference import ReferenceForces

# --------------------------------------------------------------------------- Van der Pol alone
VDP_ONLY = ["contacts.tieboss.enabled=false", "contacts.shroud.enabled=false",
            "wheel.damping_beta=1e-9", "flutter.mu=10.0"]
# law -> (wave index k on the 12-blade wheel, factor on mu, factor on r) of the equivalent
# single Van der Pol oscillator (see VdpTruth)
LAWS = {"absolute": (0, 1.0, 1.0), "relative": (6, 4.0, 0.5)}


@dataclasses.dataclass
class VdpTruth:
    """The cycle predicted by reducing wave ``k`` to its one mode ``phi`` (mass-normalised
    eigenvector of ``nd_stiffness(k)`` with the largest aero participation ``p . phi``).

    With ``y = p . q_0`` of that mode alone, both laws give the classical oscillator::

        y'' + w^2 y = [lam eps (1 - (y / rho)^2) - beta w^2] y'

    - absolute law: ``eps = mu (p . phi)^2``, ``rho = r``;
    - relative law on ND N/2 (neighbours in antiphase, ``y_{s-1} = -y_s``): ``D_s = 2 y_s``,
      ``g_{s+1} = -g_s``, so blade s gets ``p (g_s - g_{s+1}) = 2 p g_s =
      4 mu (1 - (y_s / (r / 2))^2) y_s' p``: ``eps = 4 mu (p . phi)^2``, ``rho = r / 2``
      (checked on the force law itself by ``test_van_der_pol_law_on_the_wave``).

    With ``eps_eff = lam eps - beta w^2`` and ``y = rho sqrt(eps_eff / (lam eps)) x`` it is
    ``x'' + x = e (1 - x^2) x'`` in ``w t``, ``e = eps_eff / w``: averaging gives the first
    harmonic of ``x`` as 2 (``|p . c_1| = 2 rho sqrt(eps_eff / (lam eps))``, i.e. ``2 rho
    sqrt(1 -+ lam_c)``, ``lam_c = beta w^2 / eps``, for ``lam = +-1``), the Lindstedt-Poincare
    series the frequency ``w (1 - e^2 / 16 + O(e^4))`` and the slow flow
    ``A' = eps_eff A (1 - A^2 / 4) / 2`` the amplitude's Floquet exponent ``-eps_eff``."""

    amplitude: float
    omega: float
    exponent: float
    phi: np.ndarray  # (m,) complex
    p_phi: complex

    @classmethod
    def of(cls, model, params, beta, law, lam):
        wave, mu_factor, r_factor = LAWS[law]
        w2, V = np.linalg.eigh(model.nd_stiffness(wave))
        p = params.aero
        j = int(np.argmax(np.abs(p @ V)))
        w, phi = math.sqrt(w2[j]), V[:, j]
        eps = mu_factor * params.vdp_mu * abs(p @ phi) ** 2
        eps_eff = lam * eps - beta * w2[j]
        rho = r_factor * params.vdp_r
        return cls(amplitude=2 * rho * math.sqrt(eps_eff / (lam * eps)),
                   omega=w * (1 - (eps_eff / w) ** 2 / 16), exponent=-eps_eff, phi=phi,
                   p_phi=complex(p @ phi))


@dataclasses.dataclass
class VdpCycle:
    balance: WaveBalance
    point: object  # continuation.Point
    truth: VdpTruth
    lam: float

    @property
    def amplitude(self) -> float:
        """``|p . c_1|``: the first harmonic of blade 0's Van der Pol displacement ``y``."""
        c = self.balance.complex_harmonics(self.point.X)
        return float(abs(self.balance.params.aero @ c[1]))


def vdp_params(model, law):
    cfg = config.load(SMALL, [*VDP_ONLY, f'flutter.model="{law}"'])
    params = dataclasses.replace(force_parameters(model, cfg), nozzle_force=0.0)
    assert params.contacts.kinds == ()  # the model is the same, the contacts are off
    return params, cfg.wheel.damping_beta


@pytest.fixture(scope="module")
def vdp_cycle(small_model):
    """``solve(law, H, lam)``: the cycle of ``LAWS[law]``'s wave with ``H`` harmonics at
    factor ``lam`` on the Van der Pol intensity, from the averaging's guess; memoised, so the
    tests share the solves."""
    cache = {}

    def solve(law, H, lam=1.0):
        if (law, H, lam) not in cache:
            params, beta = vdp_params(small_model, law)
            wave = LAWS[law][0]
            balance = WaveBalance(small_model, params, beta, wave, H, 4 * (H + 1))
            truth = VdpTruth.of(small_model, params, beta, law, lam)
            X = np.zeros((2 * H + 1, small_model.modes))
            c1 = truth.phi * truth.amplitude / truth.p_phi  # y = p . c_1 = amplitude
            X[1], X[2] = c1.real, c1.imag
            point = periodic_solution(balance, X, truth.omega, lam)
            assert point is not None, f"Newton failed ({law}, H = {H}, lam = {lam})"
            cache[law, H, lam] = VdpCycle(balance, point, truth, lam)
        return cache[law, H, lam]

    return solve


@pytest.mark.parametrize("law", sorted(LAWS))
def test_van_der_pol_law_on_the_wave(small_model, law):
    """The premise of ``VdpTruth``: on the law's wave (ND 0 / ND N/2, any modal state of
    blade 0) the transient's force law puts ``f mu (1 - (y_s / rho)^2) y_s' p`` on blade
    ``s``, ``f = 1, rho = r`` (absolute) and ``f = 4, rho = r / 2`` (relative)."""
    params, _ = vdp_params(small_model, law)
    wave, mu_factor, r_factor = LAWS[law]
    rng = np.random.default_rng(1)
    N, m = small_model.blades, small_model.modes
    q0, v0 = rng.normal(size=m) * 1e-3, rng.normal(size=m) * 1.0
    sign = np.cos(2 * math.pi * wave / N * np.arange(N))[:, None]  # +-1
    q, v = np.ascontiguousarray(sign * q0), np.ascontiguousarray(sign * v0)
    force = ReferenceForces(params).evaluate(0.0, q, v)
    p = params.aero
    y, yd = sign[:, 0] * (p @ q0), sign[:, 0] * (p @ v0)
    rho = r_factor * params.vdp_r
    expected = (mu_factor * params.vdp_mu * (1 - (y / rho) ** 2) * yd)[:, None] * p[None, :]
    np.testing.assert_allclose(force, expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())


@pytest.mark.parametrize("lam", [1.0, -1.0], ids=["stable", "reversed"])
@pytest.mark.parametrize("H", [3, 5, 7])
@pytest.mark.parametrize("law", sorted(LAWS))
def test_van_der_pol_cycle_matches_averaging(vdp_cycle, law, H, lam):
    """Amplitude and frequency of the cycle against the single-mode Van der Pol oscillator
    (``VdpTruth``; the weak limit ``e = eps_eff / w ~ 2e-3 (absolute), 6e-3 (relative)``, so
    the averaging amplitude holds to ``O(e^2)`` and the second-order frequency to ``O(e^4)``;
    measured: 6e-8 and 3e-7 in amplitude, 2e-10 in frequency)."""
    cycle = vdp_cycle(law, H, lam)
    assert cycle.amplitude == pytest.approx(cycle.truth.amplitude, rel=1e-5)
    assert cycle.point.omega == pytest.approx(cycle.truth.omega, rel=2e-8)


@pytest.mark.parametrize("law", sorted(LAWS))
def test_van_der_pol_cycle_converged_in_harmonics(vdp_cycle, law):
    """H = 3, 5, 7 give the same cycle (the weak Van der Pol cycle's third harmonic is
    ``e / 8`` of the first, its fifth ``O(e^2)``)."""
    cycles = [vdp_cycle(law, H) for H in (3, 5, 7)]
    amplitudes = np.array([c.amplitude for c in cycles])
    omegas = np.array([c.point.omega for c in cycles])
    np.testing.assert_allclose(amplitudes, amplitudes[-1], rtol=1e-9)
    np.testing.assert_allclose(omegas, omegas[-1], rtol=1e-10)


def _real_pair(sigma: np.ndarray, omega: float, copies: bool) -> tuple[complex, complex]:
    """``(trivial, amplitude)``: the two real exponents among ``sigma`` (with ``copies``:
    real modulo ``i omega``, for the 2 m kept ones of a family; without: the centred ones of
    a whole Hill spectrum, whose other copies are shifted by ``i h omega``). Every other
    exponent of these cycles is another mode's, ``Im`` far from a multiple of ``omega``; the
    trivial one is the one nearer 0."""
    if copies:
        offset = np.abs((sigma.imag + omega / 2) % omega - omega / 2)
    else:
        offset = np.abs(sigma.imag)
    real = sigma[offset < 1e-6 * omega].real
    # copies (slots within max(1, H/3) of harmonic 0) repeat a real part: two distinct ones
    distinct = [r for i, r in enumerate(sorted(real, key=abs))
                if all(abs(r - x) > 1e-6 * max(1.0, abs(x)) for x in sorted(real, key=abs)[:i])]
    assert len(distinct) == 2, real
    trivial, amplitude = distinct
    return complex(trivial), complex(amplitude)


@pytest.mark.parametrize("lam", [1.0, -1.0], ids=["stable", "reversed"])
def test_floquet_absolute_nd0_matches_averaging(vdp_cycle, lam):
    """ND 0, absolute law: the cycle at ``lam = 1`` is stable in every Bloch family, the one
    with the intensity reversed unstable; the phase-shift multiplier is 1 and the amplitude
    exponent is the averaging's ``-eps_eff`` (``-eps (1 - lam_c)`` = -1.158/s stable,
    ``+eps (1 + lam_c)`` = +1.159/s reversed; measured to 3e-7)."""
    cycle = vdp_cycle("absolute", 5, lam)
    b, pt = cycle.balance, cycle.point
    result = floquet(b, pt.linearisation, pt.omega, lam, range(b.blades))
    assert result.trivial < 1e-6
    assert result.stable is (lam > 0)
    sigma = exponents(b, pt.linearisation, pt.omega, lam, 0.0)
    trivial, amplitude = _real_pair(sigma, pt.omega, copies=True)
    assert abs(np.exp(trivial * 2 * math.pi / pt.omega) - 1) < 1e-6
    assert amplitude.real == pytest.approx(cycle.truth.exponent, rel=1e-5)
    if lam < 0:  # the amplitude exponent is family 0's fastest
        assert result.growth[0] == pytest.approx(cycle.truth.exponent, rel=1e-5)


@pytest.mark.parametrize("lam", [1.0, -1.0], ids=["stable", "reversed"])
def test_floquet_relative_nd_half_linearisation(vdp_cycle, lam):
    """ND N/2, relative law: the Hill matrix of family 0 has the phase-shift exponent 0 and the
    amplitude exponent ``-eps_eff`` (-4.633/s, +4.634/s reversed) among its eigenvalues (the
    force linearisation and Hill's method are right), and the verdict is stable / unstable."""
    cycle = vdp_cycle("relative", 5, lam)
    b, pt = cycle.balance, cycle.point
    values = np.linalg.eigvals(hill_matrix(b, pt.linearisation, pt.omega, lam, 0.0))
    trivial, amplitude = _real_pair(values, pt.omega, copies=False)
    assert abs(trivial) < 1e-6
    assert amplitude.real == pytest.approx(cycle.truth.exponent, rel=1e-5)
    assert floquet(b, pt.linearisation, pt.omega, lam, range(b.blades)).stable is (lam > 0)


# --------------------------------------------------------------------------- dry friction
N3 = 3
W0 = 2 * math.pi * 100.0  # [rad/s] a blade alone
COUPLING = 0.05 * W0**2  # [1/s^2] spring to each neighbour
MU, R = 40.0, 1e-3  # Van der Pol [N s/m], [m]
PRELOAD = 10.0  # [N]
FRICTION = ContactLaw(PAPER, 0.6, 0.4, 2.0, 0.05, 0.4)  # f_s, f_d, decay [s/m], v_k [m/s]
BETA = 1e-6  # [s]
WAVE = 1  # blade s + 1 leads blade s by 120 deg
T_END = 0.5  # [s] of transient: ~55 periods, 14 time constants of the slowest exponent


def friction_wheel():
    """Three one-mode blades (unit modal mass, the mode moves the tip, the aerofoil and both
    profile points by 1 m in y), a spring ``COUPLING`` to each neighbour, an absolute Van der
    Pol force on each and a dry-friction contact between neighbours whose normal is ``z``
    (``contact_frame(90)``): the profile translates rigidly along ``y``, the gap never
    changes, so the normal force stays ``PRELOAD`` and the friction acts on the relative
    ``y`` velocity (arm length 0: A itself is the contact point)."""
    model, contacts = one_mode_ring(N3, W0, COUPLING, 90.0, 1e7, PRELOAD)
    params = ForceParameters(
        blades=N3, modes=1, omega=0.0, stator_vanes=0, nozzle_force=0.0,
        excitation=np.zeros(1), nozzle_phase=np.zeros(N3), vdp_model=VDP_ABSOLUTE, vdp_mu=MU,
        vdp_r=R, aero=np.array([1.0]), aero_displacement=np.zeros(N3),
        aero_velocity=np.zeros(N3), law=FRICTION, rotation=np.eye(3),
        contacts=contacts)
    return model, params


def wave_frequency(model) -> float:
    """[rad/s] of the linear travelling wave ``WAVE``."""
    return math.sqrt(model.nd_stiffness(WAVE)[0, 0].real)


@dataclasses.dataclass
class Transient:
    frequency: float  # [Hz]
    amplitudes: np.ndarray  # (N,) 0-peak of each blade over the last 5 periods [m]
    lead: np.ndarray  # (N,) phase lead of blade b over blade 0 [rad]
    crossing: np.ndarray  # (2 N,) state at blade 0's last upward zero crossing
    decay: float  # [1/s] of the blade-mean amplitude's approach


@pytest.fixture(scope="module")
def transient():
    """The whole three-blade wheel integrated in time (DOP853 on ``ReferenceForces``, no
    harmonic balance involved) from the linear travelling wave at 1.5 mm (16 % below the
    cycle) plus a 1 % displacement that breaks the wave's symmetry (it seeds the other Bloch
    families: the cycle must attract them too)."""
    model, params = friction_wheel()
    forces = ReferenceForces(params)
    S = np.roll(np.eye(N3), 1, axis=1)  # S[s, s + 1] = 1
    K = model.A0[0, 0] * np.eye(N3) + model.A1[0, 0] * (S + S.T)

    def rhs(t, z):
        q, v = z[:N3], z[N3:]
        f = forces.evaluate(t, q.reshape(N3, 1), v.reshape(N3, 1))[:, 0]
        return np.concatenate([v, f - K @ (q + BETA * v)])

    def peak(b):  # velocity of blade b through zero downwards
        event = lambda t, z: z[N3 + b]  # noqa: E731
        event.direction = -1
        return event

    def upward(b):  # blade b through zero upwards
        event = lambda t, z: z[b]  # noqa: E731
        event.direction = 1
        return event

    a0, w, s = 1.5e-3, wave_frequency(model), np.arange(N3)
    phase = 2 * math.pi * WAVE / N3 * s
    z0 = np.concatenate([a0 * np.cos(phase) + 0.01 * a0 * np.array([1.0, -0.5, 0.2]),
                         -a0 * w * np.sin(phase)])
    sol = solve_ivp(rhs, (0.0, T_END), z0, method="DOP853", rtol=1e-8, atol=1e-15,
                    events=[peak(b) for b in s] + [upward(b) for b in s])
    assert sol.status == 0
    ups = [sol.t_events[N3 + b] for b in s]
    period = float(np.mean(np.diff(ups[0][-6:])))
    peaks = [(sol.t_events[b], sol.y_events[b][:, b]) for b in s]
    amplitudes = np.array([values[-5:].mean() for _, values in peaks])
    lead = np.array([(ups[0][-1] - ups[b][-1]) / period % 1.0 * 2 * math.pi for b in s])
    # the blade-mean amplitude (the Bloch family 0 part: the other families' first-order
    # changes of the amplitude cancel in the mean) relative to its final value
    times = peaks[0][0]
    mean = np.mean([np.interp(times, t, values) for t, values in peaks], axis=0)
    gap = np.abs(mean / amplitudes.mean() - 1)
    fit = (gap < 1e-2) & (gap > 3e-4)
    decay = float(np.polyfit(times[fit], np.log(gap[fit]), 1)[0])
    return Transient(1 / period, amplitudes, lead, sol.y_events[N3][-1], decay)


@pytest.fixture(scope="module")
def friction_cycle():
    """``solve(H, samples)``: the travelling wave's cycle by harmonic balance, from the
    friction-free Van der Pol amplitude's guess; memoised."""
    cache = {}

    def solve(H, samples):
        if (H, samples) not in cache:
            model, params = friction_wheel()
            w = wave_frequency(model)
            balance = WaveBalance(model, params, BETA, WAVE, H, samples)
            X = np.zeros((2 * H + 1, 1))
            X[1, 0] = 0.9 * free_amplitude(model)
            point = periodic_solution(balance, X, w, 1.0)
            assert point is not None, f"Newton failed (H = {H}, samples = {samples})"
            cache[H, samples] = balance, point
        return cache[H, samples]

    return solve


def free_amplitude(model) -> float:
    """[m] the friction-free cycle: Van der Pol alone, ``p = 1`` (``VdpTruth``)."""
    return 2 * R * math.sqrt(1 - BETA * wave_frequency(model) ** 2 / MU)


FRICTION_GRIDS = [(15, 256), (31, 512)]


@pytest.mark.parametrize("H, samples", FRICTION_GRIDS)
def test_friction_cycle_matches_transient(friction_cycle, transient, H, samples):
    """The friction-held cycle of the travelling wave by harmonic balance against the time
    integration: amplitude of every blade, frequency, blade-to-blade phase (a travelling wave
    of the same index) and the whole state at blade 0's upward zero crossing (the balance's
    ``wheel_state``).

    Friction matters: the cycle is 10 % below the friction-free Van der Pol amplitude and the
    slip velocity is 40 ``v_k`` (Coulomb regime, Stribeck decay and micro-slip zone both
    crossed every half period). The friction force kinks at ``|v| = v_k``, so the AFT grid
    must resolve the micro-slip zone (~1.6 % of the period): with the default ``4 (H + 1)``
    samples the amplitude is off by 0.2-0.4 %, with these by ~1e-5 (transient: ~1e-4 per
    blade, 3e-6 in frequency)."""
    balance, pt = friction_cycle(H, samples)
    # blade 0's motion over one period, finely
    tau = np.linspace(0.0, 2 * math.pi, 8193)
    h = np.arange(H + 1)
    rotor = np.exp(1j * np.outer(tau, h))
    c = balance.complex_harmonics(pt.X)[:, 0]
    y, yd = (rotor @ c).real, (rotor @ (1j * h * pt.omega * c)).real
    amplitude = y.max()
    assert amplitude < 0.95 * free_amplitude(balance.model)
    slip = (rotor @ ((np.exp(1j * h * balance.phi) - 1) * 1j * h * pt.omega * c)).real
    assert np.abs(slip).max() > 10 * FRICTION.microslip_velocity
    # amplitude, frequency and travelling wave
    np.testing.assert_allclose(transient.amplitudes, amplitude, rtol=5e-4)
    assert transient.frequency == pytest.approx(pt.omega / (2 * math.pi), rel=5e-5)
    expected_lead = 2 * math.pi * WAVE / N3 * np.arange(N3)
    np.testing.assert_allclose(np.angle(np.exp(1j * (transient.lead - expected_lead))), 0.0,
                               atol=2e-3)
    # the whole wheel's state where blade 0 crosses zero upwards
    i = int(np.flatnonzero((y[:-1] < 0) & (y[1:] >= 0))[0])
    t_up = brentq(lambda t: (np.exp(1j * t * h) @ c).real, tau[i], tau[i + 1], xtol=1e-14)
    q, v = balance.wheel_state(pt.X, pt.omega, t_up)
    np.testing.assert_allclose(transient.crossing[:N3], q[:, 0], atol=1e-3 * amplitude)
    np.testing.assert_allclose(transient.crossing[N3:], v[:, 0], atol=1e-3 * np.abs(yd).max())


def kept_exponents(balance, pt, lam) -> np.ndarray:
    """The exponents ``floquet`` keeps, of every family ``p = 0..N-1``."""
    return np.concatenate([exponents(balance, pt.linearisation, pt.omega, lam,
                                     2 * math.pi * p / balance.blades)
                           for p in range(balance.blades)])


@pytest.mark.parametrize("H, samples", FRICTION_GRIDS)
def test_friction_cycle_floquet(friction_cycle, transient, H, samples):
    """Floquet against the transient: the cycle attracts every Bloch family (the transient's
    symmetry-breaking start settles onto the travelling wave) and the amplitude exponent the
    transient approaches the cycle with (its fit: -27.7/s) is in family 0's Hill spectrum and
    among the exponents kept (-27.9/s). The phase-shift multiplier is 1 only up to the AFT
    grid's error here (1.2e-3: the kinked friction force makes the sampled balance not quite
    invariant under time shifts)."""
    balance, pt = friction_cycle(H, samples)
    result = floquet(balance, pt.linearisation, pt.omega, 1.0, range(N3))
    assert result.stable
    assert result.trivial < 1e-2
    values = np.linalg.eigvals(hill_matrix(balance, pt.linearisation, pt.omega, 1.0, 0.0))
    offset = np.abs((values.imag + pt.omega / 2) % pt.omega - pt.omega / 2)
    real = values[offset < 1e-6 * pt.omega].real
    assert np.abs(real - transient.decay).min() < 0.03 * abs(transient.decay)
    kept = kept_exponents(balance, pt, 1.0)
    assert np.abs(kept.real - transient.decay).min() < 0.03 * abs(transient.decay)


def test_floquet_keeps_phase_shift_of_nd_half_wave(vdp_cycle):
    """For a wave ``k != 0`` too the phase-shift multiplier is 1 (it was 0.0099 for the
    relative law's ND 6 cycle when each family kept only its 2 m most centred eigenvalues,
    though the Hill matrix of family 0 has the exponent at 6e-9/s:
    ``test_floquet_relative_nd_half_linearisation``)."""
    cycle = vdp_cycle("relative", 5)
    balance, pt = cycle.balance, cycle.point
    result = floquet(balance, pt.linearisation, pt.omega, 1.0, range(balance.blades))
    assert result.trivial < 1e-6


def test_a_seed_between_a_branch_crossing_of_lam_1_is_known():
    """A seed cycle at lam = 1 whose amplitude lies between the two branch points that
    bracket lam = 1 is that crossing's cycle (not traced again); one outside is new."""
    from types import SimpleNamespace

    from wheelrom.analysis.periodic.continuation import Point
    from wheelrom.analysis.periodic.limit_cycle import WaveAnalysis

    analysis = WaveAnalysis.__new__(WaveAnalysis)
    analysis.model = SimpleNamespace(tip=np.eye(1, 1))  # tip amplitude = |c_1| of mode 0

    def point(lam, amplitude):
        X = np.array([[0.0], [amplitude], [0.0]])
        return Point(np.zeros(3), X, 1.0, lam, 1)

    branch = [[point(0.8, 1e-6), point(0.95, 20e-6), point(1.05, 24e-6), point(1.2, 30e-6)]]
    assert analysis._known(22e-6, branch)  # between the crossing's points
    assert analysis._known(30e-6 * (1 + 5e-4), branch)  # next to a point
    assert not analysis._known(26e-6, branch)  # on the branch's far side of lam = 1: another
    assert not analysis._known(5e-6, branch)
