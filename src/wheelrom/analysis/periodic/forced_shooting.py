"""The forced response's exact periodic state by shooting at the known period, and its
stability from the period map (issue #45; docs/theory.md, "Nonlinear forced response: the
exact state").

The nozzle's travelling wave ``F_b cos(w t - phi_s)``, ``phi_s = 2 pi (1 - n_s / N) s``, is
wave ``k = n_s mod N``: blade ``s + j`` feels at ``t`` what blade ``s`` feels at ``t + g T /
N`` (``g = gcd(k, N)``, ``j k = g mod N``; :func:`~.flow.pattern_blades`). The steady
response has the symmetry of its force, so on the wave's pattern wheel of ``N' = N / g``
blades it satisfies::

    phi_tau(x0) = S^j x0,     tau = g T / N,   T = 2 pi / w

with the flow started at ``t = 0`` each time (the force repeats with the blades). The
unknowns are ``x0`` alone (every pattern blade's ``q, q'`` and, under the elastic law, its
sliders): the period is the excitation's and the force fixes the phase, so there is no
phase condition. Newton on the scaled shot, its Jacobian by central differences (all
perturbed shots one batch of the compiled kernel), from the harmonic balance's state.

The Jacobian at the solution is the pattern map's ``G``: its eigenvalues ``nu`` give the
Floquet multipliers ``mu = nu^{N'}`` of every perturbation that keeps the pattern (NDs that
are multiples of ``g``: for the paper wheel's ND-2 wave the even NDs), labelled by ND. A
real multiplier through +1 is a fold of the response curve, one through -1 a period
doubling, a complex pair leaving the unit circle the onset of a quasi-periodic state (a
self-excited wave beside the forced one). A contact kind that sticks the whole period leaves
its sliders free (any stuck position repeats): their rows of the Jacobian are unit rows, each
a multiplier ``mu = 1`` exactly, neutral, not unstable. They make the Jacobian singular, so
the Newton step is the least-squares one, and they are left out of the eigenproblem and
reported as exactly 1 (:meth:`ForcedShooting.locked`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from wheelrom.analysis.periodic.bloch import blade_indices, block_circulant_spectrum
from wheelrom.analysis.periodic.flow import (
    Nozzle,
    WheelFlow,
    pattern_blades,
    pattern_model,
    pattern_spectrum,
)
from wheelrom.analysis.periodic.forced_wave import ForcedWave
from wheelrom.analysis.periodic.newton import (
    EXTRAPOLATION_WINDOW,
    central_columns,
    newton_least_squares,
    reduced_rank_extrapolation,
)
from wheelrom.config import Config
from wheelrom.rom.model import ReducedModel, nodal_diameter
from wheelrom.runtime.environment import petsc

MAX_ITERATIONS = 20
#: the rounding floor of the static deflection in units of the vibration (converged there,
#: or at :data:`~.newton.TOLERANCE`, as the autonomous shot)
ROUNDOFF = 1e-12
DIFFERENCE = 1e-6  # central-difference step, relative to the vibration
#: the elastic law's start is marched period by period from the balance's sliders
#: until a period changes the state by less than ``MARCH_TOLERANCE`` of the vibration (at
#: most ``MARCH_PERIODS``; the best period kept): a contact in partial slip walks to its
#: shakedown loop over hundreds of periods, and Newton from a slider state off that loop
#: stalls (measured on the small wheel at 256 Hz: residual 0.06-0.09 after 20 iterations
#: from 3 marched periods, whatever the difference step or the time step; converged in two
#: from 300). Newton ends the march from 1e-4 (the autonomous shot's march too): on the
#: paper wheel's 1 N peak the march creeps below 3e-6 for over 1000 periods (111 s), while
#: Newton from 1e-4 (44 periods, 4 s) lands on the 1e-5 march's state to 2e-6 of the
#: vibration, 3e-7 in the tip amplitude
MARCH_PERIODS, MARCH_TOLERANCE = 2000, 1e-4
#: the march stops when this many periods have not found a smaller change (the paper wheel
#: under the elastic law at 3.2 kN, 135 Hz: 0.44 of the vibration a period for 600 periods,
#: its stuck modes damped by 2 zeta = beta_D w = 4e-5 ringing for a minute)
MARCH_STALL = 200
#: Newton keeps its Jacobian while the steps contract (:func:`~.newton.newton_least_squares`)
CHORD = True
#: a multiplier this close to the unit circle counts as on it (the differences' error, raised
#: to the pattern's power)
UNIT = 1e-6


@dataclass
class ForcedOrbit:
    """The exact forced state at ``frequency`` [rad/s]: ``state`` the pattern wheel's blades
    at ``t = 0`` (``q`` ``(N', m)`` [sqrt(kg) m], ``q'`` [sqrt(kg) m/s], then the sliders
    ``(K, N', 2)`` [m] under the elastic law, flat); ``residual`` the shot's, relative to
    the vibration (max norm, scaled units); ``multipliers`` ``mu`` (complex, largest
    modulus first) inside the pattern's symmetry and their ``nodal_diameters``;
    ``tip_amplitude`` [m] 0-peak about the mean from the orbit's every step;
    ``hb_tip_amplitude`` [m] the harmonic balance's at the same frequency; ``neutral``
    ``(K,)`` the contact kinds stuck all period, whose sliders' multipliers (exactly 1) are
    among ``multipliers``."""

    frequency: float
    state: np.ndarray
    pattern: int
    residual: float
    iterations: int
    converged: bool
    multipliers: np.ndarray = field(default_factory=lambda: np.zeros(0, complex))
    nodal_diameters: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    tip_amplitude: float = math.nan
    hb_tip_amplitude: float = math.nan
    wall_s: float = 0.0
    reason: str = ""
    #: the largest ``|mu|`` at twice the step (NaN: not refined), :func:`exact_forced`
    coarse_largest: float = math.nan
    steps_per_period: int = 0
    #: the multipliers in every ND (:func:`wheel_multipliers`), largest first, their NDs
    wheel_multipliers: np.ndarray = field(default_factory=lambda: np.zeros(0, complex))
    wheel_nodal_diameters: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    neutral: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    #: where the wheel goes from the state when it is unstable
    #: (:class:`~.forced_perturbed.SettledForced`; None: not asked or stable)
    settled: Any = None
    #: ``(G, scale)``: the map's Jacobian at ``state`` in the units ``scale`` ``(n,)``, the
    #: locked sliders' columns the identity's (:meth:`ForcedShooting.multipliers`); a finer
    #: step's Newton starts its chord on it (None: not computed)
    jacobian: Any = field(default=None, repr=False)

    @property
    def largest(self) -> float:
        """``|mu|`` of the dominant multiplier (NaN: none computed)."""
        return float(np.abs(self.multipliers[0])) if self.multipliers.size else math.nan

    @property
    def stable(self) -> bool | None:
        """No multiplier outside the unit circle (None: not computed): in every ND when
        :func:`wheel_multipliers` ran, else inside the pattern's symmetry."""
        if self.wheel_multipliers.size:
            return bool(abs(self.wheel_multipliers[0]) <= 1 + UNIT)
        return None if not self.multipliers.size else bool(self.largest <= 1 + UNIT)

    @property
    def relative_difference(self) -> float:
        """``(hb - exact) / exact`` of the tip amplitude."""
        return (self.hb_tip_amplitude - self.tip_amplitude) / self.tip_amplitude


class ForcedShooting:
    """Shooting for the forced state of one case at excitation frequency ``omega`` [rad/s]
    (the :class:`~.forced_wave.ForcedWave` ``problem``'s wave, force and self-excitation
    factor) on the configured transient scheme and step. :meth:`destroy` frees it."""

    def __init__(self, model: ReducedModel, cfg: Config, problem: ForcedWave, omega: float,
                 angles_deg: dict | None = None, whole: bool = False):
        params = problem.balance.params
        if params.follows_speed:  # the stiffness at this excitation's rotor speed
            model = model.at_speed(omega / (2 * math.pi * params.stator_vanes))
        self.wave = problem.wave
        if whole:  # the wave's map on every blade (its Jacobian holds every ND)
            pattern = model
            _, self.g, self.shift = pattern_blades(self.wave, model.blades)
        else:
            pattern, self.g, self.shift = pattern_model(model, self.wave,
                                                        cfg.flutter.model != "table")
        self.shots = model.blades // self.g  # shots a period: mu = nu^shots
        self.blades = model.blades
        self.N, self.m = pattern.blades, pattern.modes
        self.omega, self.period = float(omega), 2 * math.pi / float(omega)
        self.tau = self.g / model.blades * self.period
        # the balance's own parameters (its nozzle, contacts and law), cut to the pattern
        nozzle = Nozzle(self.omega, np.asarray(params.nozzle_phase)[: self.N])
        self.flow = WheelFlow(pattern, cfg, angles_deg, problem.lam, nozzle=nozzle,
                              params=params.first_blades(self.N))
        self.K = len(params.contacts.kinds)
        self.sliders = self.flow.sliders
        self.n = 2 * self.N * self.m + self.sliders
        self.tip = model.tip

    def destroy(self) -> None:
        self.flow.destroy()

    # ------------------------------------------------------------------ the map
    def shot(self, x: np.ndarray) -> np.ndarray:
        """``S^{-j} phi_tau(x)`` of states ``(B, n)``."""
        end = self.flow.advance(x, self.tau)
        return self.flow.shift(end, -self.shift)

    def start(self, problem: ForcedWave, X: np.ndarray) -> np.ndarray:
        """``(n,)``: the harmonic balance's state ``X`` at ``t = 0`` on the pattern; under
        the elastic law with the sliders of the balance's own closed loop
        (:meth:`balance_sliders`), then marched (:meth:`march`)."""
        q, v = problem.balance.wheel_state(X, self.omega)
        x = np.concatenate([q[: self.N].ravel(), v[: self.N].ravel()])
        if not self.sliders:
            return x
        x = np.concatenate([x, self.balance_sliders(problem, X).ravel()])
        return self.march(x, problem.tip_amplitude(X, self.omega))

    def balance_sliders(self, problem: ForcedWave, X: np.ndarray) -> np.ndarray:
        """``(K, N', 2)`` [m]: each pattern blade's sliders at ``t = 0`` from the balance's
        loop at ``X`` (the AFT's march, sampled ``n_t`` times a period for blade pair (0,
        1)): blade ``s`` at ``t = 0`` is blade 0 at phase ``s 2 pi k / N``, linearly
        interpolated between samples. Against the sliders at rest at the mean, the paper
        wheel's 1 N peak starts 3.4 times closer (the shot's residual 0.050 against 0.169)
        and its march takes 20.8 s instead of 48.5 s, to the same state."""
        problem.residual(X, self.omega)  # the AFT's march: its loop's sliders
        loop = problem.balance.sliders[:, :, 0, :]  # (n_t, K, 2): window blade 0's pair
        nt = loop.shape[0]
        phase = np.arange(self.N) * (self.wave % self.blades) / self.blades % 1.0
        position = phase * nt
        first = np.floor(position).astype(int) % nt
        share = (position - np.floor(position))[:, None, None]
        blades = (1 - share) * loop[first] + share * loop[(first + 1) % nt]  # (N', K, 2)
        return np.ascontiguousarray(blades.transpose(1, 0, 2))

    def march(self, x: np.ndarray, tip_amplitude: float) -> np.ndarray:
        """The state after the period (of up to :data:`MARCH_PERIODS`) that changed it
        least, stopping once one changes it by less than :data:`MARCH_TOLERANCE` (scaled
        max norm) or :data:`MARCH_STALL` periods found no smaller change: the transient's
        own approach to a stable state, which Newton then ends. Every
        :data:`~.newton.EXTRAPOLATION_WINDOW` periods the march jumps to the state its last
        periods approach (:func:`~.newton.reduced_rank_extrapolation`; the small wheel at
        256 Hz: 66 periods instead of 1547, 250 Hz: 80 instead of 1132, the orbits the
        same to 1e-10 and 1e-7 of the vibration; the stuck sliders' neutral positions
        differ), and the next period's change still decides."""
        scale = self._scale(x, tip_amplitude)
        best, smallest, found = x, math.inf, 0
        iterates = [x / scale]
        for period in range(MARCH_PERIODS):
            y = x[None]
            for _ in range(self.shots):
                y = self.shot(y)
            change = float(np.abs((y[0] - x) / scale).max())
            if not math.isfinite(change):
                break
            if change < smallest:
                best, smallest, found = y[0], change, period
            if change < MARCH_TOLERANCE or period - found > MARCH_STALL:
                break
            x = y[0]
            iterates.append(x / scale)
            if len(iterates) == EXTRAPOLATION_WINDOW + 2:  # the march goes on from there
                iterates = [reduced_rank_extrapolation(np.array(iterates))]
                x = iterates[0] * scale
        return best

    def _scale(self, x: np.ndarray, tip_amplitude: float) -> np.ndarray:
        """Units of the unknowns: ``a`` (the largest modal velocity over ``w``) for ``q``,
        ``w a`` for ``q'``, the tip amplitude [m] for the sliders."""
        nq = self.N * self.m
        a = max(float(np.abs(x[nq : 2 * nq]).max()) / self.omega, 1e-300)
        scale = np.full(self.n, a)
        scale[nq : 2 * nq] = self.omega * a
        scale[2 * nq :] = max(tip_amplitude, 1e-300)
        return scale

    def jacobian(self, x: np.ndarray, scale: np.ndarray,
                 columns: np.ndarray | None = None) -> np.ndarray:
        """``(n, c)`` columns ``columns`` (default all) of ``d(S^{-j} phi_tau)/dx`` in scaled
        units, central differences (one batch of ``2 c`` shots)."""
        return central_columns(self.shot, x, scale, DIFFERENCE, columns)

    # ------------------------------------------------------------------ Newton
    def solve(self, x0: np.ndarray, tip_amplitude: float, jacobian: tuple | None = None,
              multipliers: bool = True) -> ForcedOrbit:
        """Newton from ``x0`` ``(n,)``; ``tip_amplitude`` [m]: the start's (the sliders'
        unit); ``jacobian``: ``(G, scale)`` of a nearby state (:attr:`ForcedOrbit.jacobian`,
        the coarser step's) that Newton's chord starts on instead of a fresh one. The orbit
        with its multipliers (``multipliers``) and their Jacobian when converged."""
        t0 = time.perf_counter()
        x = np.array(x0, dtype=float)
        scale = self._scale(x, tip_amplitude)
        floor = ROUNDOFF * float(np.abs(x / scale).max())
        start = None
        if jacobian is not None:  # in this solve's units: D^-1 D_old G D_old^-1 D
            G, old = jacobian
            ratio = old / scale
            start = ratio[:, None] * G / ratio[None, :] - np.eye(self.n)
        z, _, size, reason, it = newton_least_squares(
            lambda z: (self.shot((z * scale)[None])[0] - z * scale) / scale,
            lambda z: self.jacobian(z * scale, scale) - np.eye(self.n),
            x / scale, floor, MAX_ITERATIONS, chord=CHORD, start=start)
        x = z * scale
        converged = reason.startswith("converged")
        orbit = ForcedOrbit(self.omega, x, self.N, size, it, converged, reason=reason,
                            steps_per_period=self.flow.steps_for(self.tau)[0] * self.shots)
        if converged:  # the multipliers from the Jacobian at the solution itself
            path = self.path(x)
            orbit.tip_amplitude = self.tip_amplitude(path)
            orbit.neutral = self.locked(path)
            if multipliers:
                orbit.multipliers, orbit.nodal_diameters, G = self.multipliers(
                    x, scale, orbit.neutral)
                orbit.jacobian = (G, scale)
        orbit.wall_s = time.perf_counter() - t0
        return orbit

    def multipliers(self, x: np.ndarray, scale: np.ndarray, neutral: np.ndarray):
        """``(mu, nd, G)`` of the pattern map at ``x`` (``scale``: the unknowns' units),
        largest first: the eigenvalues of its Jacobian without the sliders of the
        ``neutral`` kinds ``(K,)`` (:func:`~.flow.pattern_spectrum`; their columns are not
        shot), then those sliders' multipliers, exactly 1, labelled by the ND of their wave
        (:func:`neutral_nds`); ``G`` ``(n, n)`` that Jacobian, scaled, the locked sliders'
        columns the identity's (a chord on it leaves them where they are)."""
        keep = self.unlocked(neutral)
        columns = self.jacobian(x, scale, keep)
        mu, _, nd = pattern_spectrum(columns[keep], scale[keep], self.shots, self.N,
                                     self.blades, self.m)
        ones = neutral_nds(2 * self.N * int(np.sum(neutral)), self.N, self.g, self.blades)
        G = np.eye(self.n)
        G[:, keep] = columns
        mu, nd = largest_first(np.concatenate([mu, np.ones(ones.size)]),
                               np.concatenate([nd, ones]))
        return mu, nd, G

    def unlocked(self, neutral: np.ndarray) -> np.ndarray:
        """Flat indices of the unknowns other than the sliders of the ``neutral`` kinds
        ``(K,)``."""
        mask = np.ones(self.n, bool)
        if self.sliders:
            mask[2 * self.N * self.m :] = np.repeat(~np.asarray(neutral, bool), 2 * self.N)
        return np.flatnonzero(mask)

    def path(self, x: np.ndarray) -> np.ndarray:
        """``(n_tau, n)``: ``x`` and the state after each step of one shot but the last (the
        nozzle's time going on). Blade ``s`` is blade 0 a time ``k s T / N`` later, so the
        blades' rows together are every blade's whole period."""
        n_tau, h = self.flow.steps_for(self.tau)
        path = [x]
        for i in range(n_tau - 1):
            path.append(self.flow.advance(path[-1][None], h, 1, start=i * h)[0])
        return np.array(path)

    def tip_amplitude(self, path: np.ndarray) -> float:
        """0-peak tip amplitude [m] about the mean of the orbit whose shot is ``path``
        (:meth:`path`): blade 0's whole period at every step."""
        nq = self.N * self.m
        q = path[:, :nq].reshape(-1, self.m)  # (steps N', m)
        q = q - q.mean(axis=0)
        return float(np.linalg.norm(q @ self.tip.T, axis=1).max())

    def locked(self, path: np.ndarray) -> np.ndarray:
        """``(K,)`` bool: the contact kinds none of whose sliders moves over the shot
        ``path`` (:meth:`path`) and its last step, which is every blade's whole period: the
        kinds that stick all period (under the paper law none: no sliders)."""
        if not self.sliders:
            return np.zeros(self.K, bool)
        n_tau, h = self.flow.steps_for(self.tau)
        end = self.flow.advance(path[-1][None], h, 1, start=(n_tau - 1) * h)
        nq = 2 * self.N * self.m
        sliders = np.concatenate([path[:, nq:], end[:, nq:]]).reshape(-1, self.K, 2 * self.N)
        return np.all(sliders == sliders[:1], axis=(0, 2))


def neutral_nds(count: int, pattern: int, g: int, blades: int) -> np.ndarray:
    """``(count,)`` the NDs on the wheel of ``blades`` of ``count`` locked slider unknowns of
    a pattern of ``pattern`` blades repeating ``g`` times: per kind and component, one wave
    ``k' g`` (``k' = 0..N'-1``) over the pattern's blades each (their multipliers are the
    eigenvalue 1 of unit rows: any combination is an eigenvector's slider part)."""
    waves = np.arange(pattern) * g
    return np.tile(nodal_diameter(waves, blades), count // max(pattern, 1)).astype(int)


def largest_first(mu: np.ndarray, nd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(mu, nd)`` ordered by decreasing ``|mu|`` (ties in their given order)."""
    order = np.argsort(-np.abs(mu), kind="stable")
    return mu[order], np.asarray(nd, int)[order]


def exact_forced(model: ReducedModel, cfg: Config, problem: ForcedWave, X: np.ndarray,
                 omega: float, angles_deg: dict | None = None, refine: bool = True,
                 whole_wheel: bool = False) -> ForcedOrbit:
    """The exact forced state at ``omega`` [rad/s] by shooting from the harmonic balance's
    solution ``X`` ``(2H + 1, m)`` of ``problem``, with ``hb_tip_amplitude`` set;
    ``refine``: solved again at half the step from there, the multipliers (and the state)
    of the finer step reported and the coarse step's largest ``|mu|`` kept in
    ``coarse_largest`` (a contact opening or sticking within a step makes the multipliers
    converge with the step erratically: measured 1.45, 1.61, 1.59 at 5, 2.5, 1.25 us),
    its Newton's chord started on the coarse step's Jacobian at the state;
    ``whole_wheel``: also the whole wheel's multipliers (:func:`wheel_multipliers`), whose
    Bloch block ``p = 0`` gives the finer step's pattern multipliers (one Jacobian, not
    two; the pattern's own, :func:`pattern_multipliers`, where it fails)."""
    hb = problem.tip_amplitude(X, omega)
    orbit_cfg = cfg  # the configuration of the step the orbit is reported at
    orbit, failure = guarded(_shoot, model, cfg, problem, omega, angles_deg, X, None, hb)
    if failure:  # a step of the flow failed: said, and nothing else computed is lost
        return ForcedOrbit(float(omega), np.zeros(0), 0, math.inf, 0, False,
                           hb_tip_amplitude=hb, reason=failure)
    orbit.hb_tip_amplitude = hb
    if refine and orbit.converged:  # the fine step's multipliers: the wheel's p = 0 block
        finer = cfg.replace(**{"time.step": cfg.time.step / 2})
        fine, failure = guarded(_shoot, model, finer, problem, omega, angles_deg, None,
                                 orbit.state, hb, orbit.jacobian, not whole_wheel)
        if fine is not None and fine.converged:
            fine.hb_tip_amplitude, fine.coarse_largest = hb, orbit.largest
            fine.wall_s += orbit.wall_s
            orbit, orbit_cfg = fine, finer
        else:
            orbit.reason += f"; at half the step: {failure or fine.reason}"
    orbit.jacobian = None  # not kept: (n, n) floats
    t0 = time.perf_counter()
    if whole_wheel and orbit.converged:
        _, failure = guarded(wheel_multipliers, model, orbit_cfg, problem, orbit, angles_deg)
        if failure:
            orbit.reason += f"; every ND: {failure}"
    if orbit.converged and not orbit.multipliers.size:  # the wheel's failed: the pattern's
        _, failure = guarded(pattern_multipliers, model, orbit_cfg, problem, orbit,
                             angles_deg)
        if failure:
            orbit.reason += f"; multipliers: {failure}"
    orbit.wall_s += time.perf_counter() - t0
    return orbit


def pattern_multipliers(model: ReducedModel, cfg: Config, problem: ForcedWave,
                        orbit: ForcedOrbit, angles_deg: dict | None = None) -> None:
    """The multipliers inside the pattern's symmetry of the converged ``orbit`` (``cfg``:
    its step), set on it (:meth:`ForcedShooting.multipliers`)."""
    shooting = ForcedShooting(model, cfg, problem, orbit.frequency, angles_deg)
    try:
        scale = shooting._scale(orbit.state, orbit.tip_amplitude)
        orbit.multipliers, orbit.nodal_diameters, _ = shooting.multipliers(
            orbit.state, scale, orbit.neutral)
    finally:
        shooting.destroy()


def _shoot(model, cfg, problem, omega, angles_deg, X, x0, hb,
           jacobian: tuple | None = None, multipliers: bool = True) -> ForcedOrbit:
    """One shot's Newton solve, from the balance's ``X`` (marched) or from the state
    ``x0`` (its chord started on ``jacobian``, :meth:`ForcedShooting.solve`)."""
    shooting = ForcedShooting(model, cfg, problem, omega, angles_deg)
    try:
        return shooting.solve(shooting.start(problem, X) if x0 is None else x0, hb,
                              jacobian, multipliers)
    finally:
        shooting.destroy()


def guarded(function, *args):
    """``(result, "")`` or ``(None, what failed)``: a flow that diverges or a linear algebra
    failure on a NaN column ends this state's shot, not the caller's whole curve."""
    try:
        return function(*args), ""
    except (ValueError, RuntimeError, ArithmeticError, np.linalg.LinAlgError,
            petsc().Error) as exc:
        return None, f"{type(exc).__name__}: {exc}"


def wheel_multipliers(model: ReducedModel, cfg: Config, problem: ForcedWave,
                      orbit: ForcedOrbit, angles_deg: dict | None = None) -> None:
    """The Floquet multipliers of the forced state ``orbit`` in every ND (the pattern's miss
    the NDs that are no multiple of ``g``: where a self-excited wave of another ND would
    start beside the forced one), set on ``orbit`` with their NDs, largest first; ``cfg``:
    the orbit's step.

    The map ``F = S^{-j} phi_tau`` on the whole wheel has the orbit as its fixed point and
    commutes with the shift by ``N'`` blades (the force repeats every ``N'`` blades), so its
    Jacobian is block-circulant over the ``g`` super-blocks of ``N'`` blades: the columns of
    the first super-block (``2 N' m`` perturbed whole-wheel shots over ``tau``, plus the
    sliders) give every block ``C_r``, and the Bloch blocks ``B_p = sum_r C_{-r} w^{r p}``
    (``w = e^{2 pi i / g}``, ``p = 0..g-1``) hold the eigenvalues ``nu`` of the perturbations
    that change by ``w^p`` from one super-block to the next. ``F^{N'} = S^{-j N'} phi_T`` with
    ``S^{N'} v = w^p v``, so the monodromy's multiplier is ``mu = w^{p j} nu^{N'}``
    (``p = 0``: the pattern's own). No trivial multiplier: the force fixes the phase. The
    sliders of the kinds stuck all period (``orbit.neutral``) are left out of every block and
    their ``2 N`` multipliers reported as exactly 1 (:func:`neutral_nds`)."""
    N, m = model.blades, model.modes
    whole = ForcedShooting(model, cfg, problem, orbit.frequency, angles_deg, whole=True)
    neutral = np.asarray(orbit.neutral if orbit.neutral.size else np.zeros(whole.K, bool))
    try:
        K = whole.sliders // (2 * N)
        P = whole.shots  # the wave's pattern N' (the orbit may be on the whole wheel)
        g = N // P
        moving = np.isin(np.arange(whole.n), whole.unlocked(neutral))

        def block(r: int) -> np.ndarray:  # flat indices of super-block r's blades
            indices = blade_indices(np.arange(r * P, (r + 1) * P), N, m, K)
            return indices[moving[indices]]

        # blade s of the wheel is the orbit's blade s mod its blade count
        x_full = orbit.state[blade_indices(np.arange(N) % orbit.pattern, orbit.pattern,
                                            m, K)]
        scale = whole._scale(x_full, orbit.tip_amplitude)
        columns = whole.jacobian(x_full, scale, block(0))  # (n, 2 N' m (+ sliders))
    finally:
        whole.destroy()
    C = [columns[block(r)] for r in range(g)]  # C[r]: super-block r's response to block 0
    values, nds, _, _ = block_circulant_spectrum(C, [block(r) for r in range(g)], scale, N, m,
                                                 P, whole.shift)
    ones = neutral_nds(2 * N * int(neutral.sum()), N, 1, N)
    orbit.wheel_multipliers, orbit.wheel_nodal_diameters = largest_first(
        np.concatenate([values, np.ones(ones.size)]), np.concatenate([nds, ones]))
    if not orbit.multipliers.size and orbit.pattern == P:  # the pattern's own: block p = 0
        own = block(0).size
        ones = neutral_nds(2 * P * int(neutral.sum()), P, g, N)
        orbit.multipliers, orbit.nodal_diameters = largest_first(
            np.concatenate([values[:own], np.ones(ones.size)]),
            np.concatenate([nds[:own], ones]))
