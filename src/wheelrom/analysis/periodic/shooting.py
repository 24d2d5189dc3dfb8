"""The exact periodic orbit of a travelling wave by shooting on the project's TS, Newton by
PETSc SNES (docs/theory.md, "Limit cycles: shooting").

Cyclic symmetry makes a shorter shot exact: on the wave's pattern wheel of ``N'`` blades
(:func:`~wheelrom.analysis.periodic.flow.pattern_blades`) the orbit satisfies::

    phi_tau(x0) = S^j x0,     tau = g T / N

(its state a fraction ``g / N`` of the period later is its state at ``t = 0`` shifted by
``j`` blades). Applied ``N'`` times this gives ``phi_T(x0) = x0``; conversely a root of it is
a periodic orbit with that symmetry. The unknowns: ``x0`` (every pattern blade's ``q, q'``)
and ``T``; the equations: the shot and the phase condition ``q'_{0, j*}(0) = 0`` (blade 0's
largest modal coordinate at a turning point). Scaled: displacements in units of the
vibration amplitude ``a``, velocities of ``omega a``, ``T`` of the start period, equations
likewise. The Jacobian ``[S^{-j} dphi_tau/dx0 - I, dphi_tau/dT]`` by finite differences: all
``2 N' m`` perturbed shots are one batch of the compiled kernel (one TS), ``dphi/dT`` is
``(g / N)`` times the vector field at the end state (exact).

The shot's own Jacobian is the pattern map's: its eigenvalues ``nu`` give the multipliers
``mu = nu^{N'}`` of every perturbation that keeps the pattern (NDs that are multiples of
``g``: for ND ``N/2``, ND 0 and ``N/2``) at no extra cost: the multipliers "inside the
cycle's own symmetry".
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from wheelrom.analysis.periodic.events import Switches, orbit_switches
from wheelrom.analysis.periodic.flow import (
    WheelFlow,
    pattern_model,
    pattern_spectrum,
    shift_blades,
)
from wheelrom.config import Config
from wheelrom.rom.model import ReducedModel
from wheelrom.runtime.environment import petsc
from wheelrom.runtime.errors import InputError

PREFIX = "limitcycle_shooting_"
MAX_ITERATIONS = 40  # Newton iterations with backtracking
FULL_STEPS = 12  # full Newton steps first (quadratic where the shot is smooth)
STALL, STALL_ITERATIONS = 0.1, 6  # a solve that removes less than 10 % in 6 iterations stops
TOLERANCE = 1e-10  # scaled residual (relative to the vibration) at which Newton stops
#: reachable residual relative to the largest scaled unknown: the preload's static deflection
#: in units of a small vibration carries round-off into the shot (measured: 1e-9 for a 0.1 um
#: cycle on a 40 um static deflection)
ROUNDOFF = 1e-12
DIFFERENCE = 1e-6  # finite-difference step, relative to the vibration amplitude
#: full Newton steps that grow the residual this many times its start's have left Newton's
#: basin: the backtracking solve takes over at once (the paper wheel's 70 deg shots grew it
#: 1e3-1e4 times over the six iterations the stall test needed to stop them)
DIVERGED = 10.0
#: a Newton iteration keeps the last Jacobian (a chord step) while the residual falls at
#: least this factor an iteration (each Jacobian is 2 n shots; the orbit's multipliers are
#: taken from a fresh one at the solution)
CHORD = 0.25


def vibration_units(state: np.ndarray, period: float) -> np.ndarray:
    """``state``'s shape ``(2, ...)``: the units of a periodic state's unknowns, ``a`` for
    ``q`` and ``omega a`` for ``q'``, ``a`` the largest modal velocity over ``omega`` (the
    vibration, not the preload; ``period`` [s])."""
    omega = 2 * math.pi / period
    a = max(float(np.abs(state[1]).max()) / omega, 1e-300)
    units = np.empty_like(state, dtype=float)
    units[0], units[1] = a, omega * a
    return units


@dataclass
class Orbit:
    """A periodic orbit of wave ``wave``: ``period`` [s]; ``state`` ``(2, N', m)`` the pattern
    blades' ``q`` [sqrt(kg) m], ``q'`` [sqrt(kg) m/s] at ``t = 0`` (blade ``s`` of the wheel
    is pattern blade ``s mod N'``); ``shift`` ``j``, ``fraction`` ``g / N``; ``residual``:
    the shot's ``|phi_tau(x0) - S^j x0|`` relative to the vibration (max norm, scaled
    units); ``iterations`` (Newton), ``converged``; ``symmetric_multipliers``: ``mu = nu^{N'}``
    of the pattern map (complex, largest first) and ``symmetric_nd`` their NDs; ``steps``:
    TS steps per period; ``wall_s``."""

    wave: int
    period: float
    state: np.ndarray
    shift: int
    fraction: float
    residual: float
    iterations: int
    converged: bool
    symmetric_multipliers: np.ndarray = field(default_factory=lambda: np.zeros(0, complex))
    symmetric_nd: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    steps_per_period: int = 0
    wall_s: float = 0.0
    reason: str = ""
    #: the elastic law's sliders ``(K, N', 2)`` [m] at ``t = 0`` (None: the paper law)
    sliders: np.ndarray | None = None
    #: the contact switches over a shot from ``t = 0`` (:class:`~.events.Switches`; None:
    #: not located) on which the multipliers are taken
    switches: Switches | None = None

    @property
    def frequency_hz(self) -> float:
        return 1.0 / self.period

    @property
    def pattern(self) -> int:
        return self.state.shape[1]

    def wheel_state(self, blades: int) -> np.ndarray:
        """``(2, N, m)``: every blade's state at ``t = 0``."""
        return self.state[:, np.arange(blades) % self.pattern]

    def wheel_sliders(self, blades: int) -> np.ndarray | None:
        """``(K, N, 2)``: every blade's sliders at ``t = 0`` (None: the paper law)."""
        if self.sliders is None:
            return None
        return self.sliders[:, np.arange(blades) % self.pattern]

    def flat(self) -> np.ndarray:
        """``(2 N' m [+ 2 K N'],)``: the pattern's flat state at ``t = 0`` as the flow takes
        it (:meth:`~.flow.WheelFlow.advance`): ``q``, ``q'``, then the sliders when carried."""
        if self.sliders is None:
            return self.state.ravel()
        return np.concatenate([self.state.ravel(), self.sliders.ravel()])


class Shooting:
    """Shooting for the orbits of wave ``wave`` of one case at factor ``lam`` on the
    self-excitation (``flow``: on the pattern wheel; :meth:`destroy` frees it)."""

    def __init__(self, model: ReducedModel, cfg: Config, wave: int,
                 angles_deg: dict | None = None, lam: float = 1.0, comm=None,
                 options: dict | None = None):
        if cfg.contacts.elastic:  # this shot's state would drop the sliders
            raise InputError("this shot does not carry the elastic contact law's sliders: "
                             "under contacts.law = 'elastic' the exact orbit is marched and "
                             "shot by analysis/periodic/slider_shooting.py (limit-cycle does)")
        self.full_model, self.wave = model, int(wave)
        pattern, g, j = pattern_model(model, wave, cfg.flutter.model != "table")
        self.model, self.g, self.shift = pattern, g, j
        self.fraction = g / model.blades
        self.flow = WheelFlow(pattern, cfg, angles_deg, lam, options=options)
        self.comm = comm
        self.N, self.m = pattern.blades, pattern.modes
        self.n = 2 * self.N * self.m
        self.events = cfg.limit_cycle.events

    def destroy(self) -> None:
        self.flow.destroy()

    # ------------------------------------------------------------------ the shot
    def _shot(self, states: np.ndarray, period: float, schedule=None) -> np.ndarray:
        """``S^{-j} phi_tau(x)`` of states ``(B, 2, N', m)`` (``schedule``: on that
        :class:`~.events.Schedule` of ``tau``)."""
        end = self.flow.advance(states, self.fraction * period, schedule=schedule)
        return shift_blades(end, -self.shift)

    def solve(self, x0: np.ndarray, period: float) -> Orbit:
        """Newton (SNES, prefix ``limitcycle_shooting_``) from ``x0`` ``(2, N', m)`` and
        ``period`` [s]; the orbit (``converged`` False when Newton failed)."""
        t0 = time.perf_counter()
        x0 = np.asarray(x0, dtype=float).reshape(2, self.N, self.m)
        system = _ShotSystem(self, x0, period)
        z, reason, iterations = system.newton("basic", FULL_STEPS)
        if reason <= 0:  # full Newton steps wandered off: again with backtracking
            z, reason, more = system.newton("bt", MAX_ITERATIONS)
            iterations += more
        F, _ = system.residual(z)
        x, T = system.unpack(z)
        orbit = Orbit(self.wave, float(T), x, self.shift, self.fraction,
                      float(np.abs(F[: self.n]).max()), int(iterations),
                      bool(reason > 0 and np.all(np.isfinite(F))),
                      steps_per_period=self.flow.steps_for(self.fraction * T)[0]
                      * round(1 / self.fraction), reason=str(reason))
        if orbit.converged and self.events:  # on the orbit's switches (docs/theory.md)
            orbit.switches = orbit_switches(self.flow, orbit)
            orbit.symmetric_multipliers, orbit.symmetric_nd = self.multipliers_at(
                x, orbit.period, orbit.switches)
        elif orbit.converged:  # the multipliers from the Jacobian at the solution itself
            G = system.jacobian(z)[: self.n, : self.n] + np.eye(self.n)
            orbit.symmetric_multipliers, orbit.symmetric_nd = self._pattern_multipliers(
                G, system.scale)
        orbit.wall_s = time.perf_counter() - t0
        return orbit

    def samples(self, orbit: Orbit) -> OrbitSamples:
        """One period of ``orbit`` at every step (:func:`sample_orbit`)."""
        return sample_orbit(self, orbit)

    def multipliers_at(self, x0: np.ndarray, period: float,
                       switches: Switches | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(mu, nd)`` of the pattern map's Jacobian at ``x0`` ``(2, N', m)``, ``period``
        [s] without a Newton solve (one batch of ``2 n`` shots): an orbit of another step is
        a fixed point of this step's map to the integration error (the orbit converges at
        the scheme's order); ``switches``: the Jacobian on their schedule at this flow's step
        (:mod:`.events`; they are ``x0``'s own, located on it)."""
        schedule = None if switches is None else \
            switches.schedule(self.flow.steps_for(self.fraction * period)[1])
        system = _ShotSystem(self, np.asarray(x0, dtype=float), period, schedule)
        z = np.concatenate([system.z_start, [1.0]])
        G = system.jacobian(z)[: self.n, : self.n] + np.eye(self.n)
        return self._pattern_multipliers(G, system.scale)

    def _pattern_multipliers(self, G: np.ndarray, scale: np.ndarray):
        """``(mu, nd)``: the multipliers ``nu^{N'}`` of the pattern map's Jacobian ``G``
        ``(n, n)`` (scaled units ``scale``) and the NDs of their eigenvectors."""
        mu, _, nd = pattern_spectrum(G, np.ravel(scale), round(1 / self.fraction), self.N,
                                     self.full_model.blades, self.m)
        return mu, nd


@dataclass
class OrbitSamples:
    """One period of an orbit at every TS step: ``time`` ``(S,)`` [s] and ``states``
    ``(S, 2, N', m)`` (``t = 0`` included, ``t = T`` not: uniform samples of a periodic
    function); under the elastic law ``sliders`` ``(S, K, N', 2)`` [m], each step's start."""

    time: np.ndarray
    states: np.ndarray
    sliders: np.ndarray | None = None

    def tip_amplitude(self, tip: np.ndarray) -> float:
        """[m] the 0-peak tip amplitude of pattern blade 0 about its mean over the samples
        (``tip`` ``(3, m)``: the model's modal tip displacement): the orbit's reported
        amplitude."""
        q0 = self.states[:, 0, 0]  # (S, m)
        return float(np.linalg.norm((q0 - q0.mean(axis=0)) @ tip.T, axis=1).max())


def sample_orbit(shooting: Shooting, orbit: Orbit) -> OrbitSamples:
    """The orbit at every step of its period, with the shot's own steps (``N'`` shots of
    ``n_tau`` steps each: the same discrete map the orbit is a fixed point of)."""
    flow = shooting.flow
    n_tau, h = flow.steps_for(orbit.fraction * orbit.period)
    steps = n_tau * round(1 / orbit.fraction)
    path = flow.trajectory(orbit.state, steps * h, steps)
    return OrbitSamples(np.arange(steps) * h, path[:-1])


class _ShotSystem:
    """The scaled shooting equations of one solve and their SNES: unknowns ``z = (x0 / D,
    T / T_ref)`` (``D``: ``a`` for ``q``, ``omega a`` for ``q'``, ``a`` the vibration
    amplitude of the start), equations the shot in the same units and the phase condition
    ``f . (z - z_start) = 0``, ``f`` the unit vector field at the start (a Poincare section
    through it: any point of a nearby orbit lies on one)."""

    def __init__(self, shooting: Shooting, x0: np.ndarray, period: float, schedule=None):
        self.s = shooting
        self.schedule = schedule  # the shots' event schedule (at ``period`` only)
        self.n = shooting.n
        self.scale = vibration_units(x0, period)
        self.T_ref = period
        self.z_start = (x0 / self.scale).ravel()
        normal = (shooting.flow.vector_field(x0) / self.scale).ravel() * period
        self.normal = normal / np.linalg.norm(normal)
        self.floor = ROUNDOFF * float(np.abs(self.z_start).max())
        self._cache: tuple = (None, None)

    def unpack(self, z: np.ndarray):
        return z[: self.n].reshape(self.scale.shape) * self.scale, z[self.n] * self.T_ref

    def residual(self, z: np.ndarray):
        """``(F (n + 1,), end (2, N', m))``: the equations and the shot's end state."""
        key = z.tobytes()
        if self._cache[0] != key:
            x, T = self.unpack(z)
            if not (np.all(np.isfinite(z)) and T > 0):  # a Newton step off any orbit
                return np.full(self.n + 1, np.nan), np.full_like(x, np.nan)
            self._cache = (key, self.s._shot(x[None], T, self.schedule)[0])
        end = self._cache[1]
        x, _ = self.unpack(z)
        F = np.empty(self.n + 1)
        F[: self.n] = ((end - x) / self.scale).ravel()
        F[self.n] = self.normal @ (z[: self.n] - self.z_start)
        return F, end

    def jacobian(self, z: np.ndarray) -> np.ndarray:
        """``(n + 1, n + 1)``: finite-difference columns of the shot (all ``n`` perturbed
        states one batch), ``d/dT`` from the vector field at the end state."""
        n, s, scale = self.n, self.s, self.scale.ravel()
        x, T = self.unpack(z)
        _, end = self.residual(z)
        # central differences: all 2 n perturbed states one batch (the pattern wheel is
        # small), O(h^2) columns so that the multipliers of the pattern map hold to ~1e-10
        h = DIFFERENCE * scale
        perturbed = np.repeat(x.reshape(1, n), 2 * n, axis=0)
        perturbed[np.arange(n), np.arange(n)] += h
        perturbed[n + np.arange(n), np.arange(n)] -= h
        shots = s._shot(perturbed.reshape((2 * n,) + x.shape), T,
                        self.schedule).reshape(2 * n, n)
        columns = (shots[:n] - shots[n:]) / (2 * h[:, None])  # row i: d end / d x_i
        A = np.zeros((n + 1, n + 1))
        A[:n, :n] = columns.T * scale[None, :] / scale[:, None] - np.eye(n)
        at_end = shift_blades(end, s.shift)  # phi_tau(x) = S^j end
        field_ = shift_blades(s.flow.vector_field(at_end), -s.shift)
        A[:n, n] = s.fraction * field_.ravel() / scale * self.T_ref
        A[n, :n] = self.normal
        return A

    def _converged(self, snes, iteration, norms):
        atol, max_it = snes.getTolerances()[1], snes.getTolerances()[3]
        if iteration == 0:
            self._history = []
        self._history.append(norms[2])
        if norms[2] <= max(atol, self.floor):
            return 2  # SNES_CONVERGED_FNORM_ABS
        if not math.isfinite(norms[2]):
            return -4  # SNES_DIVERGED_FNORM_NAN
        if norms[2] > DIVERGED * self._history[0]:
            return -3  # diverged: full steps off the basin (the backtracking phase follows)
        # stalled: less than STALL of the residual gone over the last STALL_ITERATIONS
        # (Newton stuck at the kinks of a non-smooth shot: a finer step is the remedy)
        if len(self._history) > STALL_ITERATIONS and \
                norms[2] > (1 - STALL) * self._history[-1 - STALL_ITERATIONS]:
            return -5
        return -5 if iteration >= max_it else 0

    def newton(self, line_search: str = "basic",
               max_it: int = MAX_ITERATIONS) -> tuple[np.ndarray, int, int]:
        """``(z, SNES converged reason, iterations)`` from the start (``line_search``: the
        default when ``-limitcycle_shooting_snes_linesearch_type`` is not given)."""
        PETSc = petsc()
        n, self_ = self.n + 1, PETSc.COMM_SELF
        snes = PETSc.SNES().create(comm=self_)
        snes.setOptionsPrefix(PREFIX)
        J = PETSc.Mat().createDense((n, n), comm=self_)
        J.setUp()
        r, X = PETSc.Vec().createSeq(n, comm=self_), PETSc.Vec().createSeq(n, comm=self_)

        def function(snes, X, F):
            F.setArray(self.residual(X.getArray(readonly=True).copy())[0])

        built, chord = [False], line_search == "basic"  # a Jacobian in P; chord steps allowed

        def jacobian(snes, X, J, P):
            h = self._history
            # chord steps with full steps only: under a line search a stale direction can fail
            # the search and end the last phase where a fresh Jacobian would have gone on
            if chord and built[0] and len(h) >= 2 and h[-1] <= CHORD * h[-2]:
                return  # a chord step: P keeps the last Jacobian and its factors
            A = self.jacobian(X.getArray(readonly=True).copy())
            P.setValues(range(n), range(n), A.ravel())
            P.assemble()
            built[0] = True

        snes.setFunction(function, r)
        snes.setJacobian(jacobian, J, J)
        snes.setTolerances(rtol=1e-30, atol=TOLERANCE, stol=1e-14, max_it=max_it)
        snes.setConvergenceTest(self._converged)
        options = PETSc.Options(PREFIX)
        mine = not options.hasName("snes_linesearch_type")  # the user's choice stands
        if mine:
            options.setValue("snes_linesearch_type", line_search)
        snes.getKSP().setType("preonly")
        snes.getKSP().getPC().setType("lu")
        snes.setFromOptions()
        if mine:
            options.delValue("snes_linesearch_type")
        X.setArray(np.concatenate([self.z_start, [1.0]]))
        try:
            snes.solve(None, X)
            return (X.getArray(readonly=True).copy(), int(snes.getConvergedReason()),
                    int(snes.getIterationNumber()))
        finally:
            for obj in (snes, J, r, X):
                obj.destroy()
