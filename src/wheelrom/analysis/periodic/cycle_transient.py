"""Stability of a limit cycle by the transient (``limit_cycle.floquet = "transient"``): where
Hill's method does not converge (a contact that opens within the cycle), the wheel itself is
integrated from the cycle with a small perturbation of every nodal diameter, and the growth of
the nodal diameters the cycle does not hold says whether it is an attractor
(docs/theory.md, "Limit cycles").

The cycle holds the NDs of its harmonics (``h k`` mod ``N``, ``h = 0..H``); every other ND
starts at ``PERTURBATION`` of the tip amplitude (the lowest mode of every ND, random phases:
:func:`wheelrom.transient.preload.start_perturbation`) and is followed over ``PERIODS``
periods in windows of five periods; its growth rate is the slope of ``log`` of its window
amplitude over the second half. The result has :class:`~wheelrom.analysis.periodic.floquet.
FloquetResult`'s shape (the families are the NDs), so reports treat both alike.
"""

from __future__ import annotations

import math

import numpy as np

from wheelrom.analysis.periodic.floquet import FloquetResult
from wheelrom.analysis.periodic.harmonic_balance import WaveBalance
from wheelrom.config import Config
from wheelrom.rom.model import ReducedModel, nodal_diameter
from wheelrom.transient.preload import start_perturbation
from wheelrom.transient.run import run_case

PERIODS = 60  # periods integrated
WINDOW_PERIODS = 5  # periods per statistics window
PERTURBATION = 1e-3  # of the tip amplitude, on every ND
#: growth rate [1/s] of the perturbed NDs above which the cycle is called unstable (the fit
#: of a decaying, noisy amplitude scatters by a fraction of 1 /s)
GROWTH = 0.5


def transient_stability(model: ReducedModel, cfg: Config, angles_deg: dict | None,
                        balance: WaveBalance, X: np.ndarray, omega: float, lam: float,
                        tip_amplitude: float) -> FloquetResult:
    """The cycle ``X`` ``(2H + 1, m)``, ``omega`` [rad/s] at factor ``lam`` of wave
    ``balance.wave``, integrated with ``cfg``'s scheme from every blade's state on it plus the
    perturbation; growth [1/s] per ND (the cycle's own NDs: ``-inf``)."""
    N, period = model.blades, 2 * math.pi / omega
    scaled = {"flutter.table_scale": cfg.flutter.table_scale * lam} if \
        cfg.flutter.model == "table" else {"flutter.mu": cfg.flutter.mu * lam}
    steps = max(1, math.ceil(period / cfg.time.step))  # whole steps per period, <= time.step
    run_cfg = cfg.replace(**scaled, **{
        "excitation.force": 0.0, "time.step": period / steps,
        "time.end": PERIODS * period, "time.window": WINDOW_PERIODS * period,
        "output.history_rate_hz": 0.0, "output.state_rate_hz": 0.0,
        "output.sample_rate_hz": 0.5 * steps / period,  # every other step (no round-off)
        "time.perturbation": PERTURBATION * tip_amplitude, "time.perturbation_waves": []})
    q, v = balance.wheel_state(X, omega)
    q = q + start_perturbation(model, run_cfg)
    res = run_case(model, run_cfg, angles_deg, u0=np.concatenate([q.ravel(), v.ravel()]))
    own = {int(nodal_diameter(h * balance.wave, N)) for h in range(balance.H + 1)}
    half = res.window_end.size // 2
    t = res.window_end[half:]
    growth = np.full(N // 2 + 1, -math.inf)
    for nd in range(N // 2 + 1):
        amplitude = res.nd_spectrum[half:, nd]
        if nd in own or t.size < 2 or not np.all(amplitude > 0):
            continue
        growth[nd] = float(np.polyfit(t, np.log(amplitude), 1)[0])
    worst = float(growth.max())
    failed = not res.status.startswith("done")
    return FloquetResult(np.arange(N // 2 + 1), growth, math.exp(worst * period), 0.0,
                         bool(worst <= GROWTH and not failed), by="transient: ND")

