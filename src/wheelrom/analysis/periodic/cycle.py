"""One periodic solution of a travelling wave, as the harmonic balance or the shooting finds
it: what both report (:mod:`wheelrom.analysis.periodic.limit_cycle`, :mod:`.exact`), and
what a harmonic-balance cycle reports (:func:`describe`: its energies per cycle, tip
amplitude, contact states)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from wheelrom.analysis.periodic.floquet import FloquetResult
from wheelrom.analysis.periodic.harmonic_balance import WaveBalance

UNRESOLVED = 0.05  # energy balance residual above which a cycle is called poorly resolved
#: relative tip-amplitude difference between a shot orbit and its harmonic-balance start
#: above which they are called different orbits: the balance's truncation bias on the paper's
#: lift-off cycles is 2-8.5 % at H = 11 (docs/results.md), the 70 deg shot lands 26 % below
OTHER_ORBIT = 0.15


def cycle_source(method: str | None, missed: bool = False,
                 residual: float | None = None) -> str:
    """Which method gave a cycle's numbers, in words: the exact orbit, or the harmonic
    balance's cycle (``missed``: a shot from it did not converge, with its ``residual`` when
    the flow got that far)."""
    if method == "shooting":
        return "exact orbit by shooting"
    if not missed:
        return "harmonic balance"
    value = f": residual {residual:.2g}" if residual is not None and math.isfinite(residual) \
        else ""
    return f"harmonic balance (the shot did not converge{value})"


@dataclass
class Cycle:
    """One periodic solution. ``lam`` [-] factor on the configured intensity; ``frequency_hz``;
    ``harmonics`` ``(H + 1, m)`` complex ``c_h`` of blade 0 [sqrt(kg) m] (``c_0`` the mean);
    ``tip_amplitude`` [m] 0-peak of blade 0's tip vibration; ``tip_harmonics`` ``(H,)`` [m];
    per contact kind ``normal_force_range`` ``(K, 2)`` [N], ``fractions`` ``(K, 3)`` of the
    period open / sticking (micro-slip) / slipping; energy per cycle and blade [J]:
    ``energy_in`` (self-excitation), ``energy_friction`` ``(K,)`` and ``energy_damping``
    (``beta_D``) taken out, ``energy_residual`` ``|in - out| / in`` on the harmonic
    balance's samples (the friction dissipation against the work of the contact forces: the
    normal forces do no work over a cycle) and ``energy_residual_fine`` on 256 samples (the
    truncation of the harmonics shows there); ``damping_ratio``
    the mechanical damping of the nonlinear mode at this amplitude; ``residual``: the
    harmonic balance's relative residual; ``stability``: Floquet (None: not computed)."""

    lam: float
    frequency_hz: float
    harmonics: np.ndarray
    tip_amplitude: float
    tip_harmonics: np.ndarray
    normal_force_range: np.ndarray
    fractions: np.ndarray
    energy_in: float
    energy_friction: np.ndarray
    energy_damping: float
    energy_residual: float
    energy_residual_fine: float
    damping_ratio: float
    residual: float
    stability: FloquetResult | None = None
    method: str = "hb"  # 'hb' or 'shooting' (the exact orbit)
    shooting_residual: float = math.nan  # the shot's |phi_tau(x0) - S^j x0| / vibration
    floquet_skipped: str = ""  # why no stability was computed for it (in words)
    hb_tip_amplitude: float = math.nan  # [m] the harmonic balance's cycle it started from
    #: under the elastic law, the family of friction-limited orbits around this one
    #: (:class:`~.family.Band`; None: not traced, or no contact sticks the whole period)
    band: object = None
    hb_frequency_hz: float = math.nan
    orbit: object | None = None  # the Orbit (state at t = 0 of the pattern blades)
    multipliers: object | None = None  # the monodromy's Multipliers
    refined: list = field(default_factory=list)  # (step [s], dominant in-symmetry |mu|, ND)

    @property
    def shot_missed(self) -> bool:
        """Shooting was tried from this harmonic-balance cycle and did not converge (its
        residual set; infinite when every shot's flow failed)."""
        return self.method == "hb" and not math.isnan(self.shooting_residual)

    @property
    def source(self) -> str:
        """Which method gave the numbers, in words (:func:`cycle_source`)."""
        return cycle_source(self.method, self.shot_missed, self.shooting_residual)

    @property
    def stable(self) -> bool | None:
        """Floquet's verdict; None when not computed or not trusted (:attr:`FloquetResult.
        trusted`: the phase-shift multiplier is not 1 to 1e-3)."""
        st = self.stability
        return None if st is None or not st.trusted else st.stable


def _energies(b: WaveBalance, X: np.ndarray, omega: float, lam: float):
    """``(work_in, friction (K,), damping, samples)`` per cycle and blade [J] on ``b``'s time
    grid: the self-excitation's work on blade 0, the friction dissipation of one blade pair
    per contact kind, the ``beta_D`` dissipation; ``samples``: ``(q, v, normal, state)``."""
    q, v = b.samples(X, omega)
    force, normal, power, state = b._evaluate(q, v, lam)
    period = 2 * math.pi / omega
    c = b.complex_harmonics(X)
    h = np.arange(b.H + 1)
    if b.table:  # linear in the harmonics: its work per cycle from them
        ops = [b._table_operator(k * b.phi, k * omega) for k in h]
        work_in = sum(0.5 * period * float(np.real(np.conj(1j * k * omega * c[k])
                                                   @ (-lam * ops[k] @ c[k]))) for k in h[1:])
    else:
        force0 = b._evaluate(q, v, 0.0)[0]
        work_in = float(np.mean(np.sum((force - force0) * v[:, 0], axis=1))) * period
    friction = -power.mean(axis=0) * period  # (K,) taken out per cycle and blade
    damping = 0.5 * period * b.beta * sum(
        (k * omega) ** 2 * float(np.real(np.conj(c[k]) @ b.stiffness[k] @ c[k])) for k in h)
    return work_in, friction, float(damping), (q, v, normal, state)


def _balance_error(work_in: float, friction: np.ndarray, damping: float) -> float:
    return abs(work_in - friction.sum() - damping) / max(abs(work_in), 1e-300)


def describe(balance: WaveBalance, fine: WaveBalance, X: np.ndarray, omega: float,
             lam: float, residual: float) -> Cycle:
    """The reported quantities of a solved cycle, on ``fine``'s time grid; the energy balance
    also on ``balance``'s (the harmonic balance's own samples)."""
    work_in, friction, damping, (q, _, normal, state) = _energies(fine, X, omega, lam)
    own = _balance_error(*_energies(balance, X, omega, lam)[:3])
    c = fine.complex_harmonics(X)
    h = np.arange(fine.H + 1)
    tip = np.einsum("im,jm->ji", fine.model.tip, q[:, 0] - X[0])  # (n_t, 3)
    tip_h = np.linalg.norm(np.abs(c[1:] @ fine.model.tip.T), axis=1)
    kinetic = float(np.sum((h * omega) ** 2 * np.sum(np.abs(c) ** 2, axis=1)))
    K = normal.shape[1]
    fractions = np.array([[np.mean(state[:, k] == s) for s in range(3)] for k in range(K)])
    out = float(friction.sum() + damping)
    return Cycle(
        lam=float(lam), frequency_hz=omega / (2 * math.pi), harmonics=c,
        tip_amplitude=float(np.linalg.norm(tip, axis=1).max()), tip_harmonics=tip_h,
        normal_force_range=np.stack([normal.min(axis=0), normal.max(axis=0)], axis=1),
        fractions=fractions, energy_in=work_in, energy_friction=friction,
        energy_damping=damping, energy_residual=own,
        energy_residual_fine=_balance_error(work_in, friction, damping),
        damping_ratio=out / (2 * math.pi * kinetic) if kinetic > 0 else math.nan,
        residual=residual)


def coexisting(cycles: list, chosen) -> str:
    """The cycles at the configured intensity besides ``chosen``, in words ("" when none):
    two orbits of one wave can coexist (the paper wheel's 70 deg: the exact 16.6 um orbit
    beside a 20.6 um cycle whose shot missed); the verdict names the one it reports."""
    others = [c for c in cycles if c is not chosen]
    if not others:
        return ""
    listed = "; ".join(f"{c.tip_amplitude * 1e6:.3g} um, {c.frequency_hz:.4g} Hz, {c.source}"
                       for c in sorted(others, key=lambda c: c.tip_amplitude))
    return f"{len(others)} more cycle{'s' if len(others) > 1 else ''} at this intensity " \
        f"({listed})"


def orbit_words(c) -> str:
    """An exact orbit against the harmonic-balance cycle it was shot from, in words ("" for
    a balance's cycle or an orbit shot from none): the same cycle, or another orbit when
    their tip amplitudes are more than :data:`OTHER_ORBIT` apart."""
    if c.method != "shooting" or not math.isfinite(c.hb_tip_amplitude):
        return ""
    apart = abs(c.tip_amplitude / c.hb_tip_amplitude - 1.0)
    if apart > OTHER_ORBIT:
        return (f"exact orbit, not the harmonic balance's cycle it was shot from "
                f"({c.hb_tip_amplitude * 1e6:.3g} um, {c.hb_frequency_hz:.4g} Hz: "
                f"{100 * apart:.0f} % apart, beyond the balance's truncation; another orbit)")
    return (f"exact orbit (harmonic balance {c.hb_tip_amplitude * 1e6:.3g} um, "
            f"{c.hb_frequency_hz:.4g} Hz)")


def whole_wheel_words(c) -> str:
    """What the whole wheel's multipliers of cycle ``c`` say beside an instability inside its
    symmetry: not computed, the largest and its ND at the step they were computed at
    (``time.step`` for SLEPc's monodromy, the finest refined step for the Bloch waves'), or
    how far SLEPc got."""
    mu = c.multipliers
    if mu is None:
        return "the whole wheel's not computed (limit_cycle.whole_wheel)"
    if mu.worst >= 0:
        at = "time.step" if mu.by == "monodromy" else \
            f"a {mu.step * 1e6:.2g} us step (Bloch waves)"
        # the Bloch waves find the slow ones too (1.0003 would read 1 at three digits)
        digits = ".3g" if mu.by == "monodromy" else ".5g"
        return (f"the whole wheel's largest {mu.largest:{digits}} per period, ND "
                f"{mu.nd[mu.worst]} at {at}")
    # how far it got: the periods integrated and the one check it has
    return (f"no multiplier of the whole wheel converged at time.step in {mu.matvecs} "
            f"linearised periods (its phase-shift multiplier off 1 by {mu.trivial_error:.2g})")
