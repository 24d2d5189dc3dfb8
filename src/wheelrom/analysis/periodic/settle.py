"""Where the flutter settles: the wheel integrated from an unstable state until its motion is
stationary, then the settled state classified (docs/theory.md, "Where the flutter settles").

**Stationarity.** The motion is integrated in windows of ``window_periods`` periods of the
start's frequency (a whole number of nozzle periods when the nozzle is on, so that a window
restarts exactly). After each window: the per-blade amplitude ``A_s`` (the largest tip
displacement about the blade's mean over the window, [m]) and the ND energy fractions ``e_k``
(the share of each nodal diameter in the window's mean square tip ``y`` motion). The window is
stationary against the one before when ``max_s |A_s - A'_s| / max_s A'_s <= tolerance`` and
``sum_k |e_k - e'_k| / 2 <= tolerance``; the motion has settled after ``consecutive`` such
windows in a row and at least ``min_time``. A motion that keeps changing from window to
window (energy moving between waves) may still stay within a band: it is **bounded** once
the trend of its largest amplitude over the last ``bounded_span`` seconds (all after
``min_time``), with its error adjusted for the windows' correlation (:func:`drift`), keeps it
within ``bounded_drift`` over that span (:func:`bounded`). At ``max_time`` without either the
case is reported "not settled" with how far it is from bounded, and no settled state is
claimed. The run is whole windows: it ends with the window whose end is nearest
``max_time``, up to half a window past it (so that a ``min_time`` equal to ``max_time`` is
reached).

**Classification** of the last window, from blade ``s*`` (the largest amplitude): its tip ``y``
history's envelope (the peak of every period, between successive zero crossings) and that
envelope's spectrum. *Periodic*: the envelope is flat (peak-to-peak below ``2 tolerance`` of
its mean) and the state returns to itself after one period (over the window's last period,
the largest distance of the state from its cubic-spline interpolant one period earlier,
relative to the motion, the period refined to bring them closest, below ``RETURN`` = 1 %).
*Quasi-periodic*: otherwise, when one line of the envelope's spectrum (its mean
removed, Hann window) holds at least ``LINE_SHARE`` of its power: its frequency is the
modulation frequency. *Chaotic*: neither; the line's share is reported as the test that
decided.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from wheelrom.runtime.errors import InputError
from wheelrom.transient.problem import nd_amplitudes

LINE_SHARE = 0.5  # of the envelope spectrum's power in its largest line: quasi-periodic
RETURN = 0.01  # relative return distance after one period below which the state is periodic
#: a motion that did not settle: the trend of its largest amplitude counts when it exceeds
#: this many of the slope's standard errors (adjusted for the windows' correlation,
#: :func:`drift`: about 95 %), from at least TREND_WINDOWS windows (the lag-1 correlation of
#: fewer residuals says nothing)
TREND_SIGNIFICANCE, TREND_WINDOWS = 2.0, 8
#: the largest lag-1 correlation of the residuals taken at its value (beyond it the effective
#: number of windows, ``n (1 - rho) / (1 + rho)``, is below 1 in 40 and no error is claimed)
MAX_CORRELATION = 0.95


@dataclass
class Settings:
    """The ``[settle]`` keys (docs/usage.md)."""

    window_periods: int = 20
    tolerance: float = 0.005
    consecutive: int = 2
    min_time: float = 1.0
    max_time: float = 20.0
    bounded_span: float = 3.0
    bounded_drift: float = 0.05


@dataclass
class Window:
    """One window's statistics: ``end`` [s], ``amplitude`` ``(N,)`` per blade [m],
    ``nd_energy`` ``(N // 2 + 1,)`` fractions, ``change`` (amplitude, ND) against the window
    before (nan for the first)."""

    end: float
    amplitude: np.ndarray
    nd_energy: np.ndarray
    change: tuple[float, float] = (math.nan, math.nan)


def window_statistics(time: np.ndarray, tip: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(amplitude (N,), nd_energy (N // 2 + 1,))`` of a window's tip history ``tip``
    ``(S, N, 3)`` [m] at times ``time`` ``(S,)``."""
    vibration = tip - tip.mean(axis=0)
    amplitude = peak(np.sqrt((vibration**2).sum(axis=2)))
    spectrum = nd_amplitudes(vibration[:, :, 1])  # (S, N // 2 + 1) [m]
    energy = (spectrum**2).mean(axis=0)
    total = energy.sum()
    return amplitude, energy / total if total > 0 else energy


def peak(distance: np.ndarray) -> np.ndarray:
    """``(N,)`` the largest value of each column of ``distance`` ``(S, N)`` (smooth samples
    in time), refined by the parabola through the largest sample and its neighbours: the
    largest sample of a motion sampled ``n`` times a period lies up to ``1 - cos(pi / n)``
    below its peak (0.9 % at 24), and that shortfall drifts with the phase of the samples
    against the motion, a ripple the trend would read as correlated scatter; the parabola's
    is ``O((pi / n)^4)``."""
    top = np.argmax(distance, axis=0)
    columns = np.arange(distance.shape[1])
    value = distance[top, columns]
    inside = (top > 0) & (top < distance.shape[0] - 1)
    before = distance[np.maximum(top - 1, 0), columns]
    after = distance[np.minimum(top + 1, distance.shape[0] - 1), columns]
    curvature = before - 2 * value + after
    ok = inside & (curvature < 0)
    offset = np.where(ok, 0.5 * (before - after) / np.where(ok, curvature, -1.0), 0.0)
    return np.where(ok, value - 0.25 * (before - after) * offset, value)


def changes(previous: Window, amplitude: np.ndarray, nd_energy: np.ndarray) -> tuple[float, float]:
    """``(amplitude change, ND distribution change)`` of a window against ``previous``."""
    scale = max(float(previous.amplitude.max()), 1e-300)
    return (float(np.abs(amplitude - previous.amplitude).max() / scale),
            float(0.5 * np.abs(nd_energy - previous.nd_energy).sum()))


def stationary(windows: list[Window], settings: Settings) -> bool:
    """Whether the last ``consecutive`` windows each changed by at most ``tolerance`` and the
    last one ends at or after ``min_time``."""
    last = windows[-settings.consecutive :]
    if len(last) < settings.consecutive or windows[-1].end < settings.min_time * (1 - 1e-9):
        return False
    return all(max(w.change) <= settings.tolerance for w in last)


@dataclass(frozen=True)
class Trend:
    """The drift of a motion's largest amplitude over a span of windows (:func:`drift`):
    ``rate`` [1/s] the least-squares slope of the amplitude's logarithm, ``error`` [1/s] its
    standard error adjusted for the residuals' lag-1 ``correlation``, over ``windows``
    windows ending within ``span`` [s]."""

    rate: float
    error: float
    correlation: float
    windows: int
    span: float

    @property
    def rising(self) -> bool:
        """Whether the amplitude rises beyond :data:`TREND_SIGNIFICANCE` errors."""
        return self.rate > TREND_SIGNIFICANCE * self.error

    def bound(self) -> float:
        """[1/s] the largest drift rate the windows allow at about 95 %: ``|rate| + 2 error``."""
        return abs(self.rate) + TREND_SIGNIFICANCE * self.error


def drift(ends: np.ndarray, amplitude: np.ndarray) -> Trend | None:
    """The :class:`Trend` of ``amplitude`` ``(n,)`` [m] at the window ends ``ends`` ``(n,)``
    [s] (None with fewer than :data:`TREND_WINDOWS` windows or no motion).

    The rate is the least-squares slope of ``ln A`` (exact for a growing or decaying
    oscillation, ``A0 exp(sigma t)``; the slope of ``A`` over its mean for a small drift).
    The ordinary error of that slope, ``sigma^2 = sum r_i^2 / (n - 2) / sum (t_i -
    t_mean)^2``, assumes independent residuals ``r_i``. Successive windows of a multi-wave
    state are not: energy moves between the waves over several windows. With the residuals'
    lag-1 correlation ``rho`` (an AR(1) model; its estimate from ``n`` residuals, biased low
    by about ``(1 + 3 rho) / n``, corrected, then clipped to ``[0, MAX_CORRELATION]``) the
    windows count as ``n_e = n (1 - rho) / (1 + rho)`` independent ones and the error is
    ``sigma sqrt((n - 2) / (n_e - 2))`` (Santer et al. 2000, J. Geophys. Res. 105, 7337),
    ``n_e`` counted as at least 3: residuals that are a smooth curve (an exactly exponential
    motion's rounding, ``rho`` at its clip) then get ``sqrt(n - 2)`` times their ordinary
    error, not an infinite one (measured on 2000 AR(1) series of 20 and 40 windows: the
    same coverage as without the floor; docs/theory.md "Where the flutter settles")."""
    n = ends.size
    if n < TREND_WINDOWS or not np.all(amplitude > 0):
        return None
    x = ends - ends.mean()
    if not x @ x > 0:
        return None
    y = np.log(amplitude)
    slope = float(x @ (y - y.mean()) / (x @ x))
    residual = y - y.mean() - slope * x
    power = float(residual @ residual)
    measured = float(residual[1:] @ residual[:-1]) / power if power > 0 else 0.0
    rho = min(max((n * measured + 1.0) / (n - 3.0), 0.0), MAX_CORRELATION)
    effective = n * (1.0 - rho) / (1.0 + rho)
    error = math.sqrt(power / (n - 2) / float(x @ x))
    error *= math.sqrt((n - 2) / (max(effective, 3.0) - 2))
    return Trend(slope, error, rho, n, float(ends[-1] - ends[0]))


def span_of(windows: list[Window], span: float) -> list[Window]:
    """The windows lying within the last ``span`` [s] of ``windows`` (all when shorter): those
    starting (a window's length before its end) at or after the span's start, to half a
    window."""
    if len(windows) < 2:
        return list(windows)
    length = windows[-1].end - windows[-2].end
    start = windows[-1].end - span + 0.5 * length
    return [w for w in windows if w.end - length >= start - length]


def bounded(windows: list[Window], settings: Settings) -> Trend | None:
    """The trend over the last ``bounded_span`` when it bounds the motion: the span lies
    after ``min_time`` and the largest amplitude drifts over it by at most ``bounded_drift``
    of itself at about 95 % (:meth:`Trend.bound` times the span); else None."""
    if not windows or windows[-1].end < (settings.min_time + settings.bounded_span) * (1 - 1e-9):
        return None
    last = span_of(windows, settings.bounded_span)
    trend = drift(np.array([w.end for w in last]), np.array([w.amplitude.max() for w in last]))
    if trend is None or trend.bound() * settings.bounded_span > settings.bounded_drift:
        return None
    return trend


@dataclass
class Classification:
    """``kind``: 'periodic', 'quasi-periodic' or 'chaotic'; ``frequency_hz`` of the motion
    (the tip signal's spectral peak); ``modulation_hz`` of the envelope (nan when flat);
    ``modulation_depth``: envelope peak-to-peak over its mean; ``line_share``: the largest
    envelope line's share of its power; ``return_distance``: relative; ``decided_by``: the
    test, in words."""

    kind: str
    frequency_hz: float
    modulation_hz: float
    modulation_depth: float
    line_share: float
    return_distance: float
    decided_by: str


def envelope(time: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(times, peaks)``: the largest ``|y - mean|`` between successive upward zero crossings
    of ``y - mean`` (one per period), at the time of the peak."""
    x = y - y.mean()
    up = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))
    times, peaks = [], []
    for a, b in zip(up[:-1], up[1:], strict=True):
        i = a + int(np.argmax(np.abs(x[a:b])))
        times.append(time[i])
        peaks.append(abs(x[i]))
    return np.array(times), np.array(peaks)


def dominant_frequency(time: np.ndarray, y: np.ndarray) -> float:
    """The frequency [Hz] of the largest line of ``y``'s spectrum (mean removed, Hann window,
    refined by a parabola through the peak's neighbours in log power)."""
    x = (y - y.mean()) * np.hanning(y.size)
    power = np.abs(np.fft.rfft(x)) ** 2
    dt = (time[-1] - time[0]) / (time.size - 1)
    k = int(np.argmax(power[1:])) + 1
    shift = 0.0
    if 1 <= k < power.size - 1 and np.all(power[k - 1 : k + 2] > 0):
        a, b, c = np.log(power[k - 1 : k + 2])
        shift = 0.5 * (a - c) / (a - 2 * b + c) if (a - 2 * b + c) != 0 else 0.0
    return (k + shift) / (time.size * dt)


def return_distance(time: np.ndarray, states: np.ndarray, period: float) -> tuple[float, float]:
    """``(distance, period)``: how far the state over the window's last period is from itself
    one period earlier (max over that period and the components, relative to the states'
    spread; ``states`` ``(S, n)`` at ``time``), the earlier states by cubic splines, the
    period the one within 2 % of ``period`` [s] that brings them closest."""
    from scipy.interpolate import CubicSpline

    if time[-1] - time[0] < 2.05 * period:
        return math.inf, period
    spread = max(float(np.abs(states - states.mean(axis=0)).max()), 1e-300)
    spline = CubicSpline(time, states, axis=0)
    last = time >= time[-1] - period

    def gap(T):
        return float(np.abs(states[last] - spline(time[last] - T)).max()) / spread

    grid = period * np.linspace(0.98, 1.02, 81)
    gaps = np.array([gap(T) for T in grid])
    i = int(np.argmin(gaps))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    for _ in range(30):  # golden section on the bracket
        m1, m2 = lo + 0.382 * (hi - lo), lo + 0.618 * (hi - lo)
        if gap(m1) < gap(m2):
            hi = m2
        else:
            lo = m1
    best = 0.5 * (lo + hi)
    return gap(best), best


def classify(time: np.ndarray, y: np.ndarray, states: np.ndarray | None = None,
             tolerance: float = 0.005) -> Classification:
    """The :class:`Classification` of a signal ``y`` ``(S,)`` at uniform ``time`` (the tip
    of the largest blade over the settled window; ``states`` ``(S, n)``: the whole state at
    the same samples, for the return test)."""
    frequency = dominant_frequency(time, y)
    t_env, peaks = envelope(time, y)
    if peaks.size < 8:
        return Classification("chaotic", frequency, math.nan, math.nan, 0.0, math.inf,
                              f"fewer than 8 periods in the window ({peaks.size})")
    depth = float((peaks.max() - peaks.min()) / peaks.mean())
    distance, period = return_distance(time, states if states is not None else y[:, None],
                                       1.0 / frequency)
    if depth <= 2 * tolerance and distance <= RETURN:
        return Classification("periodic", 1.0 / period, math.nan, depth, 1.0, distance,
                              f"flat envelope (peak-to-peak {depth:.2%} of its mean) and the "
                              f"state returns after one period to {distance:.1e}")
    # the envelope resampled uniformly (one sample per period) and its spectrum
    grid = np.linspace(t_env[0], t_env[-1], t_env.size)
    e = np.interp(grid, t_env, peaks)
    x = (e - e.mean()) * np.hanning(e.size)
    power = np.abs(np.fft.rfft(x))[1:] ** 2
    share = float(power.max() / power.sum()) if power.sum() > 0 else 0.0
    modulation = dominant_frequency(grid, e)
    if share >= LINE_SHARE:
        return Classification("quasi-periodic", frequency, modulation, depth, share, distance,
                              f"the envelope's spectrum has one line holding {share:.0%} of "
                              f"its power at {modulation:.4g} Hz")
    return Classification("chaotic", frequency, modulation, depth, share, distance,
                          f"the envelope's spectrum is broad (its largest line holds "
                          f"{share:.0%} of the power, below {LINE_SHARE:.0%})")


@dataclass
class Settled:
    """What :func:`wheelrom.studies.settle` finds for one case (arrays over blades, NDs and
    windows; see docs/output.md ``/settle``). ``settled``: stationary; ``bounded``: not
    stationary but bounded (:func:`bounded`); neither: stopped at ``max_time``. ``span``
    [s] and ``drift_limit`` [-]: the settings' ``bounded_span`` and ``bounded_drift``, the
    span the range and trend of a case that did not settle are read over."""

    settled: bool
    time: float  # [s] simulated
    windows: list[Window] = field(default_factory=list)
    classification: Classification | None = None
    amplitude: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (N,) last window
    nd_energy: np.ndarray = field(default_factory=lambda: np.zeros(0))
    fractions: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # (K, 3)
    normal_force_range: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    energy_balance: float = math.nan  # |sum of the works| / the self-excitation's, last window
    tip_time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    tip: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 3)))  # last window
    start: str = ""
    start_amplitude: float = math.nan
    wall_s: float = 0.0
    status: str = "done"
    bounded: bool = False
    span: float = Settings.bounded_span
    drift_limit: float = Settings.bounded_drift
    #: [s] the step the integration took (its TS's: the window's whole steps of at most
    #: ``settle.step``, lowered where the exponential scheme's stability check lowers it),
    #: and why it is below the window's step ("": it is not)
    step: float = math.nan
    step_lowered: str = ""

    def band(self) -> tuple[float, float, float] | None:
        """``(low, high, duration)``: the range [m] of the largest blade's amplitude over the
        windows of the last ``span`` (the trend's) and that duration [s] (None without two
        windows): how large a motion that does not settle stays."""
        if len(self.windows) < 2:
            return None
        last = span_of(self.windows, self.span)
        if len(last) < 2:
            last = self.windows[-2:]
        top = np.array([w.amplitude.max() for w in last])
        before = self.windows[len(self.windows) - len(last) - 1].end \
            if len(last) < len(self.windows) else 0.0
        return float(top.min()), float(top.max()), self.time - before

    def trend(self) -> Trend | None:
        """The :func:`drift` of the largest blade's amplitude over the windows of :meth:`band`
        (None when the case settled or with fewer than :data:`TREND_WINDOWS` windows)."""
        if self.settled:
            return None
        last = span_of(self.windows, self.span)
        return drift(np.array([w.end for w in last]),
                     np.array([w.amplitude.max() for w in last]))

    def still_growing(self) -> bool:
        """Whether the case is neither settled nor bounded and its :meth:`trend` rises beyond
        :data:`TREND_SIGNIFICANCE` errors: its range is a lower bound."""
        trend = self.trend()
        return not self.bounded and trend is not None and trend.rising

    def _trend_words(self) -> str:
        """The trend in words, with its bound against the drift allowed."""
        trend = self.trend()
        if trend is None:
            return ""
        words = f"trend {100 * trend.rate:+.2g} %/s +- {100 * trend.error:.2g}"
        if trend.correlation > 0:
            words += f" (windows correlated {trend.correlation:.2f})"
        return words

    def verdict(self) -> str:
        if self.status != "done":
            return self.status
        if not self.settled:
            span = self.band()
            if self.bounded:
                words = f"bounded after {self.time:.3g} s"
            else:
                state = ("still growing" if self.still_growing() else
                         "not bounded" if self.trend() is not None else "too short to say")
                words = f"not settled after {self.time:.3g} s (settle.max_time), {state}"
            if span is not None and self.nd_energy.size:
                nd = int(np.argmax(self.nd_energy))
                trend = self._trend_words()
                words += (f": the largest blade {span[0] * 1e6:.3g}-{span[1] * 1e6:.3g} um "
                          f"over the last {span[2]:.2g} s" + (f", {trend}" if trend else "")
                          + f", ND {nd} {self.nd_energy[nd]:.0%} of the energy in the last "
                          "window")
            return words
        c, A = self.classification, self.amplitude
        top = int(np.argmax(A))
        nd = int(np.argmax(self.nd_energy))
        words = [f"settles {c.kind} at {A.max() * 1e6:.3g} um tip (blade {top}; mean "
                 f"{A.mean() * 1e6:.3g}, min {A.min() * 1e6:.3g} um at blade "
                 f"{int(np.argmin(A))}), {c.frequency_hz:.4g} Hz, ND {nd} "
                 f"{self.nd_energy[nd]:.0%} of the energy"]
        if c.kind != "periodic" and math.isfinite(c.modulation_hz):
            words.append(f"modulated at {c.modulation_hz:.3g} Hz (depth {c.modulation_depth:.0%})")
        words.append(f"after {self.time:.3g} s")
        return ", ".join(words)


SAMPLES_PER_PERIOD = 24  # tip and state samples per period of the start's frequency


def window_config(cfg, frequency_hz, settings: Settings, nozzle: bool):
    """``(cfg of one window, window length [s])``: whole steps no longer than ``time.step``,
    samples (tips and states) about ``SAMPLES_PER_PERIOD`` per period on whole steps, no
    perturbation (the start carries it); with the nozzle on, a whole number of nozzle periods
    (a window restarts its time at 0). ``frequency_hz``: the start's [Hz], or a batch's
    starts' (a sequence): the window is ``window_periods`` periods of the lowest, the samples
    ``SAMPLES_PER_PERIOD`` per period of the highest."""
    frequencies = np.atleast_1d(np.asarray(frequency_hz, dtype=float))
    window = settings.window_periods / float(frequencies.min())
    if nozzle:
        nozzle_period = 1.0 / (cfg.wheel.stator_vanes * cfg.wheel.speed_hz)
        window = max(1, round(window / nozzle_period)) * nozzle_period
    steps = max(1, math.ceil(window / cfg.time.step * (1 - 1e-12)))
    h = window / steps
    every = max(1, round(1.0 / (SAMPLES_PER_PERIOD * float(frequencies.max()) * h)))
    rate = 1.0 / (every * h) * (1 + 1e-9)  # a sample at every every-th step, no round-off
    changes_ = {"time.step": h, "time.end": window, "time.window": window,
                "time.perturbation": 0.0, "time.perturbation_waves": [],
                "output.sample_rate_hz": rate, "output.history_rate_hz": rate,
                "output.state_rate_hz": rate}
    if not nozzle:
        changes_["excitation.force"] = 0.0
    return cfg.replace(**changes_), window


def settle_case(model, cfg, angles: dict | None, u0: np.ndarray, frequency_hz: float,
                settings: Settings, nozzle: bool = False, progress=None) -> Settled:
    """Integrate ``u0`` (``(2 N m,)`` modal ``q, q'``; the elastic law's sliders start at
    rest there and are carried from window to window) window by window until stationary
    (:func:`stationary`) or ``max_time``; classify the last window. One case of
    :func:`settle_cases`; ``progress(t, window)`` after every window."""
    return settle_cases(model, cfg, [angles], [u0], [frequency_hz], [settings], nozzle,
                        None if progress is None else (lambda _, t, w: progress(t, w)))[0]


def settle_cases(model, cfg, angles: list, u0: list, frequency_hz: list, settings: list,
                 nozzle: bool = False, progress=None) -> list[Settled]:
    """:func:`settle_case` for several cases at once, in one TS batch
    (:func:`~wheelrom.transient.run.run_cases`: the kernel vectorises across the cases, each
    case's arithmetic its own): ``angles``, ``u0``, ``frequency_hz``, ``settings`` one per
    case (the settings differ at most in ``min_time``). The batch shares its windows
    (:func:`window_config` of all its frequencies); a case leaves it once stationary,
    bounded or failed, the others go on. ``progress(case, t, window)`` after every window of a case.
    Each case's ``wall_s`` is its share of the batch's wall time."""
    import time as clock

    from wheelrom.transient.run import run_cases

    t0 = clock.perf_counter()
    first = settings[0]
    run_cfg, length = window_config(cfg, frequency_hz, first, nozzle)
    if length > first.max_time * (1 + 1e-9):  # not one window: "not settled after 0 s"
        raise InputError(f"settle.max_time = {first.max_time:g} s is shorter than one "
                         f"window: settle.window_periods = {first.window_periods} periods "
                         f"of the start's {min(frequency_hz):.4g} Hz last {length:.3g} s")
    outs = [Settled(False, 0.0, span=s.bounded_span, drift_limit=s.bounded_drift)
            for s in settings]
    states = [np.asarray(u, dtype=float).copy() for u in u0]
    last: list = [None] * len(angles)
    running = list(range(len(angles)))
    # whole windows, the last the one ending nearest max_time (up to half a window past it)
    while running and outs[running[0]].time < first.max_time - 0.5 * length:
        done = run_cases(model, run_cfg, [angles[i] for i in running],
                         u0=[states[i] for i in running])
        still = []
        for i, res in zip(running, done, strict=True):
            last[i], out = res, outs[i]
            out.step = float(res.options.get("ts_dt", run_cfg.time.step))
            out.step_lowered = str(res.options.get("ts_dt_lowered", ""))
            if not res.status.startswith("done"):
                out.status = f"failed at {out.time + res.window_end[-1:].sum():.3g} s: {res.status}"
                continue
            amplitude, nd_energy = window_statistics(res.sample_time + out.time, res.tip_history)
            out.time += length
            w = Window(out.time, amplitude, nd_energy)
            if out.windows:
                w.change = changes(out.windows[-1], amplitude, nd_energy)
            out.windows.append(w)
            # the whole state on: under the elastic law the sliders carry the contacts' history
            states[i] = res.final_state
            if progress:
                progress(i, out.time, w)
            if stationary(out.windows, settings[i]):
                out.settled = True
            elif bounded(out.windows, settings[i]) is not None:
                out.bounded = True
            else:
                still.append(i)
        running = still
    for i, out in enumerate(outs):
        if last[i] is not None and out.status == "done":
            _describe_last(out, last[i], model, run_cfg, angles[i], settings[i])
    wall = clock.perf_counter() - t0
    for out in outs:
        out.wall_s = wall / len(outs)
    return outs


def _describe_last(out: Settled, res, model, cfg, angles, settings: Settings) -> None:
    """The last window's amplitude, ND content, classification, contacts and energies."""
    from wheelrom.forces.parameters import force_parameters
    from wheelrom.forces.reference import ReferenceForces

    w = out.windows[-1]
    out.amplitude, out.nd_energy = w.amplitude, w.nd_energy
    out.tip_time = res.sample_time + out.time - res.window_end[-1]
    out.tip = res.tip_history
    top = int(np.argmax(w.amplitude))
    states = res.state_history.reshape(res.state_history.shape[0], -1)
    S = min(states.shape[0], out.tip.shape[0])
    if out.settled:  # a state still changing is not classified as a result
        out.classification = classify(out.tip_time[:S], out.tip[:S, top, 1], states[:S],
                                      settings.tolerance)
    forces = ReferenceForces(force_parameters(model, cfg, angles))
    K = len(forces.params.contacts.kinds)
    counts = np.zeros((K, 3))
    low, high = np.full(K, np.inf), np.full(K, -np.inf)
    for _ in forces.replay(np.zeros(len(res.state_history)), res.state_history):
        for k in range(K):
            counts[k] += np.bincount(forces.contact_state[k].astype(int), minlength=3)[:3]
        low = np.minimum(low, forces.normal_force.min(axis=1))
        high = np.maximum(high, forces.normal_force.max(axis=1))
    out.fractions = counts / np.maximum(counts.sum(axis=1, keepdims=True), 1)
    out.normal_force_range = np.stack([low, high], axis=1) if K else np.zeros((0, 2))
    work = res.work[-1]  # (nozzle, Van der Pol, friction, damping) over the window [J]
    out.energy_balance = float(abs(work.sum()) / max(abs(work[1]) + abs(work[0]), 1e-300))
