"""One periodic solution of a travelling wave, as the harmonic balance or the shooting finds
it: what both report (:mod:`wheelrom.analysis.periodic.limit_cycle`, :mod:`.exact`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from wheelrom.analysis.periodic.floquet import FloquetResult


def cycle_source(method: str | None, missed: bool = False,
                 residual: float | None = None) -> str:  # fmt: skip
    """Which method gave a cycle's numbers, in words: the exact orbit, or the harmonic
    balance's cycle (``missed``: a shot from it did not converge, with its ``residual`` when
    the flow got that far)."""
    if method == "shooting":
        return "exact orbit by shooting"
    if not missed:
        return "harmonic balance"
    value = f": residual {residual:.2g}" if residual is not None and math.isfinite(residual) \
        else ""  # fmt: skip
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
