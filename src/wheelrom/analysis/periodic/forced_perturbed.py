"""The exact forced state perturbed and integrated on the whole wheel (issue #74; docs/theory.md,
"Nonlinear forced response: the exact state"): the growth of a seeded wave, the independent
check of the Floquet multipliers, and, where the state is unstable, where the wheel goes.

**A seeded wave's growth** (:func:`seeded_growth`). Blade ``s`` of the exact state gets
``Re(c e^{i 2 pi k s / N})`` in every modal coordinate and velocity (``c`` random per mode,
the largest entry ``size`` of the vibration in the shot's units), and the whole wheel is
integrated with the orbit's own steps period after period. Its distance from the state
(scaled ``q, q'``, RMS over the unknowns) grows by the largest ``|mu|`` of the NDs the seed
reaches (the forced wave of ND ``n`` couples ND ``k`` with ``k +- n``, ``k +- 2 n``, ...)
once the other multipliers have died out, while the perturbation is small enough that no
contact sticks or slips where the state does not: the rate is fitted from period
``skip`` to the last one below ``limit``.

**Where the wheel goes** (:func:`settle_forced`). From the state perturbed in the NDs of its
multipliers outside the unit circle, the wheel is integrated in windows of ``window``
periods, its tips sampled ``SAMPLES`` times a period, until the perturbation, grown
``GROWN`` times beyond its start, grows from window to window by less than a quarter of
the linear rate's ``|mu|^window - 1`` and less than ``CALM`` in ``CONSECUTIVE`` windows in
a row (bounded: the instability has saturated), or stays below its start, at most
``max_periods``. Reported from the last window: every blade's amplitude against the state's
at the same samples (the sampling's bias cancels: a period's peak from 48 samples is within
1.4 % of the orbit's; the largest, the smallest and their spread), the largest distance of
a tip from the state's, and the ND content of that difference (beside the forced wave).
An instability that saturates where a perturbation first makes a contact slip where the
state sticks (the paper wheel at 130 Hz: a stick phase within 2.8e-4 of the Coulomb limit;
the perturbation stops at 4e-4 of the vibration) leaves the wheel within a fraction of a
percent of the travelling wave.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from wheelrom.analysis.periodic.bloch import blade_indices
from wheelrom.analysis.periodic.forced_shooting import (
    UNIT,
    ForcedOrbit,
    ForcedShooting,
    guarded,
)
from wheelrom.analysis.periodic.forced_wave import ForcedWave
from wheelrom.analysis.periodic.settle import peak
from wheelrom.config import Config
from wheelrom.rom.model import ReducedModel
from wheelrom.transient.problem import nd_amplitudes

#: the seeded growth's fit: from period SKIP (the other multipliers' transient) to the last
#: period whose deviation is below LIMIT of the vibration (RMS, scaled units): the paper
#: wheel's state at 130 Hz saturates at 4e-4
SKIP, LIMIT = 10, 1e-4
#: tip samples a period (each blade's peak refined by a parabola, :func:`~.settle.peak`)
SAMPLES = 48
#: bounded: this many windows in a row grew by less than a quarter of ``|mu|^window - 1``
#: and less than CALM, the perturbation GROWN times its start's at least
CONSECUTIVE, CALM, GROWN = 2, 0.1, 10.0


@dataclass
class SeededGrowth:
    """A seeded wave of ND ``nd`` at the exact state: ``deviation`` ``(periods + 1,)`` its
    RMS distance from the state after each period (scaled ``q, q'``), ``first`` and ``last``
    the periods of the fit, ``nd_energy`` ``(N // 2 + 1,)`` the shares of the NDs in its
    modal displacements and velocities at ``last``."""

    nd: int
    deviation: np.ndarray
    first: int
    last: int
    nd_energy: np.ndarray
    wall_s: float = 0.0

    @property
    def growth(self) -> float:
        """The deviation's factor per period over the fit (NaN: fewer than 2 periods)."""
        if self.last - self.first < 2:
            return math.nan
        ratio = self.deviation[self.last] / self.deviation[self.first]
        return float(ratio ** (1.0 / (self.last - self.first)))


@dataclass
class SettledForced:
    """Where the wheel goes from the unstable exact state (:func:`settle_forced`):
    ``bounded`` (the growth stopped) or not after ``periods``; over the last window:
    ``ratio`` ``(N,)`` every blade's tip amplitude about its mean over the state's at the
    same samples (their bias cancels), ``exact`` [m] the state's tip amplitude (at every
    step), ``deviation`` [m] the largest distance of a tip from the state's, ``nd_energy``
    ``(N // 2 + 1,)`` the shares of the NDs in that difference's tip ``y`` motion;
    ``seeded`` the NDs perturbed; ``growth`` ``(windows,)`` the largest tip distance at the
    end of each window [m]."""

    bounded: bool
    periods: int
    ratio: np.ndarray
    exact: float
    deviation: float
    nd_energy: np.ndarray
    seeded: list = field(default_factory=list)
    growth: np.ndarray = field(default_factory=lambda: np.zeros(0))
    wall_s: float = 0.0

    @property
    def largest(self) -> float:
        """The largest blade's tip amplitude [m]."""
        return float(self.ratio.max() * self.exact)

    @property
    def smallest(self) -> float:
        return float(self.ratio.min() * self.exact)

    @property
    def spread(self) -> float:
        """(largest - smallest) blade amplitude over the state's [-]."""
        return float(self.ratio.max() - self.ratio.min())

    @property
    def dominant_nd(self) -> int:
        return int(np.argmax(self.nd_energy)) if self.nd_energy.size else -1


class WholeWheel:
    """The whole wheel at the exact state ``orbit`` of ``problem``: its flat state ``x``
    (the pattern tiled), the units of its unknowns, the forced flow in the orbit's own steps
    (``orbit.steps_per_period``; ``cfg``'s step is not used); :meth:`destroy` frees it."""

    def __init__(self, model: ReducedModel, cfg: Config, problem: ForcedWave,
                 orbit: ForcedOrbit, angles_deg: dict | None = None):
        self.shooting = ForcedShooting(model, cfg, problem, orbit.frequency, angles_deg,
                                       whole=True)
        self.flow, self.model = self.shooting.flow, model
        self.N, self.m = model.blades, model.modes
        K = self.shooting.K if self.shooting.sliders else 0
        self.x = orbit.state[blade_indices(np.arange(self.N) % orbit.pattern, orbit.pattern,
                                           self.m, K)]
        self.scale = self.shooting._scale(self.x, orbit.tip_amplitude)
        self.period, self.steps = self.shooting.period, orbit.steps_per_period
        self.h = self.period / self.steps

    def destroy(self) -> None:
        self.shooting.destroy()

    def seeded(self, nds, size: float, seed: int = 0) -> np.ndarray:
        """The state with a wave of each ND of ``nds`` in every modal coordinate and
        velocity (random complex amplitudes per mode), the largest entry of the sum
        ``size`` in the unknowns' units."""
        rng = np.random.default_rng(seed)
        N, m = self.N, self.m
        wave = np.zeros(2 * N * m)
        for nd in nds:
            phase = np.exp(2j * math.pi * nd * np.arange(N) / N)[:, None]
            for part in range(2):
                c = rng.standard_normal(m) + 1j * rng.standard_normal(m)
                wave[part * N * m : (part + 1) * N * m] += (phase * c[None]).real.ravel()
        wave *= size / np.abs(wave).max()
        y = self.x.copy()
        y[: 2 * N * m] += wave * self.scale[: 2 * N * m]
        return y

    def distance(self, y: np.ndarray) -> float:
        """RMS distance of ``y`` from the state in the unknowns' units (``q, q'``)."""
        nq = 2 * self.N * self.m
        return float(np.sqrt(np.mean(((y[:nq] - self.x[:nq]) / self.scale[:nq]) ** 2)))

    def nd_energy(self, y: np.ndarray) -> np.ndarray:
        """``(N // 2 + 1,)`` shares of the NDs in ``y - x`` (scaled ``q, q'``, both waves
        of an ND counted together)."""
        N, m = self.N, self.m
        e = ((y - self.x)[: 2 * N * m] / self.scale[: 2 * N * m]).reshape(2, N, m)
        energy = (np.abs(np.fft.fft(e, axis=1)) ** 2).sum(axis=(0, 2))
        shares = np.zeros(N // 2 + 1)
        np.add.at(shares, np.minimum(np.arange(N), N - np.arange(N)), energy)
        return shares / max(shares.sum(), 1e-300)

    def period_map(self, y: np.ndarray) -> np.ndarray:
        """The state one period after ``y`` (the nozzle's time from 0)."""
        return self.flow.advance(y[None], self.period, self.steps)[0]

    def sampled_period(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(end, tips)``: the state one period after ``y`` and the tips ``(S, N, 3)`` [m]
        at ``S`` samples of it, the same steps every period (:data:`SAMPLES` a period)."""
        every = max(1, round(self.steps / SAMPLES))
        tips, done = [], 0
        while done < self.steps:
            n = min(every, self.steps - done)
            y = self.flow.advance(y[None], n * self.h, n, start=done * self.h)[0]
            done += n
            q = y[: self.N * self.m].reshape(self.N, self.m)
            tips.append(q @ self.model.tip.T)
        return y, np.array(tips)


def seeded_growth(model: ReducedModel, cfg: Config, problem: ForcedWave, orbit: ForcedOrbit,
                  nd: int, periods: int = 60, size: float = 1e-6,
                  angles_deg: dict | None = None, seed: int = 0, skip: int = SKIP,
                  limit: float = LIMIT) -> SeededGrowth:
    """A wave of ND ``nd`` seeded at the exact state ``orbit`` (its own steps) at
    ``size`` of the vibration and the whole wheel integrated ``periods`` periods; the fit
    from ``skip`` to the last period below ``limit`` (module docstring)."""
    t0 = time.perf_counter()
    wheel = WholeWheel(model, cfg, problem, orbit, angles_deg)
    try:
        y = wheel.seeded([nd], size, seed)
        deviation, states = [wheel.distance(y)], [y]
        for _ in range(periods):
            y = wheel.period_map(y)
            deviation.append(wheel.distance(y))
            states.append(y)
        deviation = np.array(deviation)
        beyond = np.flatnonzero(deviation[skip:] >= limit)
        last = skip + int(beyond[0]) - 1 if beyond.size else periods
        energy = wheel.nd_energy(states[max(last, skip)])
    finally:
        wheel.destroy()
    return SeededGrowth(int(nd), deviation, skip, max(last, skip), energy,
                        time.perf_counter() - t0)


def settle_forced(model: ReducedModel, cfg: Config, problem: ForcedWave, orbit: ForcedOrbit,
                  angles_deg: dict | None = None, size: float = 1e-6, window: int = 10,
                  max_periods: int = 400) -> SettledForced:
    """Where the wheel goes from the exact state ``orbit`` (its own steps) perturbed by
    ``size`` of the vibration in the NDs of its multipliers outside the unit circle (every
    ND's, :func:`~.forced_shooting.wheel_multipliers`, when computed; else the pattern's):
    windows of ``window`` periods until bounded or decayed, at most ``max_periods``
    (module docstring)."""
    t0 = time.perf_counter()
    values, nds = ((orbit.wheel_multipliers, orbit.wheel_nodal_diameters)
                   if orbit.wheel_multipliers.size else
                   (orbit.multipliers, orbit.nodal_diameters))
    growing = np.abs(values) > 1 + UNIT
    seeded = sorted({int(k) for k in nds[growing]})
    rate = float(np.abs(values).max()) ** window if values.size else 1.0
    wheel = WholeWheel(model, cfg, problem, orbit, angles_deg)
    try:
        _, reference = wheel.sampled_period(wheel.x)  # the state's tips at the samples
        y = wheel.seeded(seeded or [0], size)
        growth, calm, periods = [], 0, 0
        start = _largest_distance(wheel.sampled_period(y)[1], reference)
        while periods < max_periods:
            tips = []
            for _ in range(window):
                y, t = wheel.sampled_period(y)
                tips.append(t)
            periods += window
            tips = np.concatenate(tips)
            growth.append(_largest_distance(tips, np.tile(reference, (window, 1, 1))))
            before = growth[-2] if len(growth) > 1 else start
            # saturated: grown well beyond the seed, then slower than a quarter of the
            # linear rate (the other multipliers' transient can look calm at the start)
            slow = growth[-1] > GROWN * start and \
                growth[-1] < before * (1 + min(CALM, 0.25 * (rate - 1)))
            calm = calm + 1 if slow else 0
            if calm >= CONSECUTIVE or (growth[-1] < start and periods >= max_periods // 4):
                break
    finally:
        wheel.destroy()
    difference = tips - np.tile(reference, (window, 1, 1))
    energy = (nd_amplitudes(difference[:, :, 1]) ** 2).mean(axis=0)
    ratio = _amplitudes(tips) / _amplitudes(reference)
    return SettledForced(calm >= CONSECUTIVE or growth[-1] <= start, periods, ratio,
                         orbit.tip_amplitude, growth[-1], energy / max(energy.sum(), 1e-300),
                         seeded, np.array(growth), time.perf_counter() - t0)


def _amplitudes(tips: np.ndarray) -> np.ndarray:
    """``(N,)`` every blade's tip amplitude [m] about its mean over the samples ``tips``
    ``(S, N, 3)`` (the peak refined, :func:`~.settle.peak`)."""
    vibration = tips - tips.mean(axis=0)
    return peak(np.sqrt((vibration**2).sum(axis=2)))


def _largest_distance(tips: np.ndarray, reference: np.ndarray) -> float:
    """The largest distance [m] of a tip of ``tips`` from ``reference`` (both ``(S, N, 3)``)."""
    return float(np.sqrt(((tips - reference) ** 2).sum(axis=2)).max())


def settle_unstable(model: ReducedModel, cfg: Config, problem: ForcedWave, orbit: ForcedOrbit,
                    angles_deg: dict | None = None) -> None:
    """``orbit.settled``: :func:`settle_forced` when ``orbit`` is unstable (a flow that fails
    is said in ``orbit.reason``, the state kept)."""
    if not orbit.converged or orbit.stable is not False:
        return
    orbit.settled, failure = guarded(settle_forced, model, cfg, problem, orbit, angles_deg)
    if failure:
        orbit.reason += f"; where the wheel goes: {failure}"
