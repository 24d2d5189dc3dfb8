"""The exact periodic orbit of a travelling wave under the elastic contact law: shooting with
the sliders in the state, started from a march of the wave's pattern wheel (issue #44;
docs/theory.md, "The exact orbit under the elastic law").

Why not from the harmonic balance, as under the paper law: the elastic law's balance stalls
where a contact starts to slip within the cycle (its hysteresis switches on with a kink in the
amplitude), and the friction-limited orbits lie beyond. The stuck wheel is linearly unstable,
so the orbit is the wave's own attractor inside its symmetry: the pattern wheel of ``N'``
blades (:func:`~.flow.pattern_model`) started from the wave's growing mode at half its slip
onset with every slider at rest at the equilibrium, integrated with the transient's steps
until its vibration energy stops changing (:meth:`SliderShooting.march`), ends next to it;
Newton then makes it exact.

The equations are those of :mod:`.shooting` with the state ``x`` flat (``q``, ``q'`` of every
pattern blade, then the sliders ``(K, N', 2)`` [m]): ``S^{-j} phi_tau(x) = x`` with
``tau = g T / N`` in a fixed number of steps (the discrete map smooth in ``T``) and the
Poincare section through the start. A contact that sticks the whole period leaves its slider
free (any stuck position repeats with its static offset): such directions are neutral
(``mu = 1``) and make the Jacobian singular, so the Newton step is the least-squares one
(as the forced shot's). The multipliers (:meth:`SliderShooting.multipliers`) leave those
sliders out: with them the eigenvalue 1 is multiple and its neighbours' differenced values
are not trusted; without them the map's multipliers converge with the step (at first order:
a stick-slip switch is a kink the fixed step meets anywhere; theory.md).
"""

from __future__ import annotations

import math
import time

import numpy as np

from wheelrom.analysis.periodic.events import orbit_switches
from wheelrom.analysis.periodic.flow import WheelFlow, pattern_model, pattern_spectrum
from wheelrom.analysis.periodic.hopf import tip_measure
from wheelrom.analysis.periodic.newton import central_columns, newton_least_squares
from wheelrom.analysis.periodic.shooting import Orbit, OrbitSamples, vibration_units
from wheelrom.config import Config
from wheelrom.rom.model import ReducedModel

MAX_ITERATIONS = 25
ROUNDOFF = 1e-12  # the rounding floor relative to the largest scaled unknown (as the shot's)
DIFFERENCE = 1e-6  # central-difference step, relative to the vibration
#: the march: chunks of ``MARCH_PERIODS`` periods until the vibration energy changes by less
#: than ``MARCH_TOLERANCE`` over one, at most ``MARCH_CHUNKS`` chunks (the paper wheel's ND 33
#: settles in 200-300 periods; its ND 31, whose pattern is the whole wheel, had not in 6000,
#: 15 min: every ND is free there)
MARCH_PERIODS, MARCH_TOLERANCE, MARCH_CHUNKS = 20, 1e-4, 100
#: the march starts at this fraction of the stuck mode's slip onset (:meth:`SliderShooting.
#: slip_onset`), from below: a flutter grows from small disturbances, and a start above the
#: orbit slips contacts that stick on it, locking a tangential prestress into them (a stuck
#: slider's offset is a neutral direction: another orbit of the family, measured 0.32 against
#: 0.48 um on the small wheel at 40 deg); when nothing slips or opens: :data:`SEED`
SEED_FRACTION, SEED = 0.5, 1e-9


class SliderShooting:
    """Shooting for the orbits of wave ``wave`` of one case at factor ``lam`` on the
    self-excitation, the sliders in the state (on the wave's pattern wheel; :meth:`destroy`
    frees the flow)."""

    def __init__(self, model: ReducedModel, cfg: Config, wave: int,
                 angles_deg: dict | None = None, lam: float = 1.0,
                 options: dict | None = None):
        self.full_model, self.wave = model, int(wave)
        pattern, g, j = pattern_model(model, wave, cfg.flutter.model != "table")
        self.model, self.g, self.shift = pattern, g, j
        self.fraction = g / model.blades
        self.shots = round(1 / self.fraction)  # shots a period: mu = nu^shots
        self.flow = WheelFlow(pattern, cfg, angles_deg, lam, options=options)
        self.N, self.m = pattern.blades, pattern.modes
        self.K = len(self.flow.params.contacts.kinds)
        self.sliders = self.flow.sliders
        self.nq = 2 * self.N * self.m
        self.n = self.nq + self.sliders
        self.events = cfg.limit_cycle.events

    def destroy(self) -> None:
        self.flow.destroy()

    # ------------------------------------------------------------------ the map
    def shot(self, x: np.ndarray, period: float, steps: int, schedule=None) -> np.ndarray:
        """``S^{-j} phi_tau(x)`` of states ``(B, n)`` in ``steps`` whole steps (``schedule``:
        on that :class:`~.events.Schedule` of ``tau`` instead)."""
        end = self.flow.advance(x, self.fraction * period, steps, schedule=schedule)
        return self.flow.shift(end, -self.shift)

    def unit_mode(self, vector: np.ndarray) -> np.ndarray:
        """``(N', 2 m)`` complex: the wave's mode ``vector`` ``(2 m,)`` (``q, q'`` of blade 0;
        blade ``s`` has ``e^{i 2 pi k s / N}``) on the pattern's blades, turned so that blade
        0's tip is at its largest at ``t = 0`` (the real part of an arbitrarily phased
        eigenvector can be at a zero of the displacement, its velocity then far larger) and
        scaled to a unit tip amplitude [m] (a mode that hardly moves the tip by its modal
        reach, as settle's seed)."""
        m, N = self.m, self.full_model.blades
        wave = np.exp(2j * math.pi * self.wave * np.arange(self.N) / N)
        state = wave[:, None] * np.asarray(vector)[None, :]
        tip = self.model.tip @ state[0, :m]
        state = state * np.exp(-1j * np.angle(tip[np.argmax(np.abs(tip))]))
        reach = np.linalg.norm(self.model.tip, 2)
        size = np.linalg.norm(state[:, :m] @ self.model.tip.T, axis=1).max()
        return state / tip_measure(size, np.abs(state[:, :m]), reach)

    def start(self, q_eq: np.ndarray, vector: np.ndarray, amplitude: float) -> np.ndarray:
        """``(n,)``: the equilibrium ``q_eq`` ``(N, m)`` plus the wave's mode ``vector``
        (:meth:`unit_mode`) at ``amplitude`` [m] of tip amplitude, the sliders at rest at
        the equilibrium."""
        m = self.m
        self.q_eq = np.array(q_eq[: self.N], dtype=float)
        state = (self.unit_mode(vector) * amplitude).real
        q = self.q_eq + state[:, :m]
        x = np.concatenate([q.ravel(), state[:, m:].ravel()])
        rest = np.concatenate([self.q_eq.ravel(), np.zeros(self.nq // 2)])
        if self.sliders:
            forces = self.flow.forces()
            sliders = forces.sliders_at_rest(np.ascontiguousarray(self.q_eq)).ravel()
            x, rest = np.concatenate([x, sliders]), np.concatenate([rest, sliders])
        self.rest_energy = self.energy(rest)  # the vibration's is measured from it
        return x

    def slip_onset(self, q_eq: np.ndarray, vector: np.ndarray) -> float:
        """The tip amplitude [m] at which the wave's stuck mode (:meth:`unit_mode`) first
        reaches a closed contact's stick range ``mu F_n / k_t`` in its tangential relative
        motion, opens a closed one (its normal relative motion reaching ``F_n / k_c``) or
        closes an open one (through its gap), every contact at its preloaded normal force
        ``F_n``; ``inf`` when it moves none. Below it the stuck wheel's linear growth is
        exact: the march starts there instead of growing to it."""
        forces = self.flow.forces()
        q0 = np.ascontiguousarray(q_eq[: self.N], dtype=float)
        zero = np.zeros_like(q0)
        forces.evaluate(0.0, q0, zero)
        base, normal = forces.relative_displacement.copy(), forces.normal_force.copy()
        mode, eps = self.unit_mode(vector)[:, : self.m], 1e-9
        parts = []
        for part in (mode.real, mode.imag):
            forces.evaluate(0.0, np.ascontiguousarray(q0 + eps * part), zero)
            parts.append((forces.relative_displacement - base) / eps)
        d = parts[0] + 1j * parts[1]  # (K, N', 3) per unit tip amplitude, complex
        tangential = d[:, :, ::2]
        # the largest |Re(c e^{i theta})| over the phase of a complex 2-vector c
        reach = np.sqrt(0.5 * (np.sum(np.abs(tangential) ** 2, axis=2)
                               + np.abs(np.sum(tangential**2, axis=2))))
        c = self.flow.params.contacts
        k_c = c.stiffness[:, : self.N]
        closed = normal > 0.0
        stick = self.flow.params.law.coulomb * normal / np.maximum(c.tangential[:, : self.N],
                                                                   1e-300)
        # a closed contact opens when its normal motion reaches F_n / k_c; an open one (its
        # preload taken by the static load) closes when it moves through its gap
        # u_eta - F_N0 / k_c (F_n = max(0, F_N0 - k_c u_eta)): neither slips nor sticks before
        normal_reach = np.where(closed, normal / k_c, base[:, :, 1] - c.preload[:, None] / k_c)
        with np.errstate(divide="ignore"):
            limits = np.concatenate([(stick / reach)[closed],
                                     (normal_reach / np.abs(d[:, :, 1])).ravel()])
        return float(limits.min(initial=math.inf))

    def energy(self, x: np.ndarray) -> float:
        """The pattern wheel's mechanical energy at state ``x`` (:meth:`~.flow.WheelFlow.
        energy`). Along a periodic orbit it changes within the period only by the
        self-excitation's and the friction's work, a fraction of the order of the damping
        ratio: the march's measure of settling."""
        return self.flow.energy(x)

    def tip_estimate(self, x: np.ndarray, period: float) -> float:
        """Blade 0's tip amplitude [m] at state ``x`` as a harmonic oscillator's of
        ``period`` [s]: ``sqrt(|tip u|^2 + |tip u'|^2 / w^2)`` about the equilibrium (the
        march's progress)."""
        omega = 2 * math.pi / period
        q = x[: self.m] - self.q_eq[0]
        v = x[self.nq // 2 : self.nq // 2 + self.m]
        tip = self.model.tip
        return float(np.sqrt(np.sum((tip @ q) ** 2) + np.sum((tip @ v) ** 2) / omega**2))

    def march(self, x: np.ndarray, period: float, tolerance: float = MARCH_TOLERANCE,
              progress=None):
        """``(x, period, periods)``: the state after marching ``x`` in chunks of
        :data:`MARCH_PERIODS` periods until its :meth:`energy` changes by less than
        ``tolerance`` from one chunk's end to the next (at most :data:`MARCH_CHUNKS`), the
        period measured after it (:meth:`measure_period`, the state there) and the periods
        marched."""
        energy, chunks = self.energy(x) - self.rest_energy, 0
        for chunks in range(1, MARCH_CHUNKS + 1):
            x = self.flow.advance(x[None], MARCH_PERIODS * period)[0]
            previous, energy = energy, self.energy(x) - self.rest_energy
            if not math.isfinite(energy):
                raise RuntimeError("the march diverged")
            if progress is not None:
                progress(chunks * MARCH_PERIODS, self.tip_estimate(x, period))
            if abs(energy - previous) <= tolerance * abs(energy):
                break
        # the section's coordinate: blade 0's largest modal displacement about the equilibrium
        # (a velocity carries the stiff families' ringing at kHz: crossings of that)
        coordinate = int(np.argmax(np.abs(x[: self.m] - self.q_eq[0])))
        x, period = self.measure_period(x, period, coordinate)
        return x, period, chunks * MARCH_PERIODS

    def measure_period(self, x: np.ndarray, period: float,
                       j: int) -> tuple[np.ndarray, float]:
        """``(x', T)``: the period [s] between the next two upward crossings of blade 0's
        modal displacement ``j`` through its equilibrium value (interpolated between steps)
        within three estimated periods ``period`` of ``x``, and the state ``x'`` at the step
        after the second."""
        n, h = self.flow.steps_for(period)
        rest = self.q_eq[0, j]
        crossings, state, previous = [], x, x[j] - rest
        for i in range(1, 3 * n + 1):
            state = self.flow.advance(state[None], h, 1)[0]
            value = state[j] - rest
            if previous < 0 <= value:
                crossings.append((i - value / (value - previous)) * h)
                if len(crossings) == 2:
                    return state, crossings[1] - crossings[0]
            previous = value
        return state, period  # not two crossings: the estimate stands

    def jacobian(self, x: np.ndarray, period: float, steps: int, scale: np.ndarray,
                 columns: np.ndarray | None = None, schedule=None) -> np.ndarray:
        """``(n, c)`` columns ``columns`` (default all) of ``d(S^{-j} phi_tau)/dx`` in scaled
        units, central differences (one batch of ``2 c`` shots: the held or locked sliders'
        columns, which the callers drop, are not shot; ``schedule``: on that event
        schedule)."""
        return central_columns(lambda states: self.shot(states, period, steps, schedule), x,
                               scale, DIFFERENCE, columns)

    def _scale(self, x: np.ndarray, period: float, tip_amplitude: float) -> np.ndarray:
        """Units of the unknowns: ``a`` (the largest modal velocity over ``w``) for ``q``,
        ``w a`` for ``q'``, the tip amplitude [m] for the sliders."""
        scale = np.empty(self.n)
        scale[: self.nq] = vibration_units(x[: self.nq].reshape(2, -1), period).ravel()
        scale[self.nq :] = max(tip_amplitude, 1e-300)
        return scale

    # ------------------------------------------------------------------ Newton
    def solve(self, x0: np.ndarray, period: float, tip_amplitude: float,
              fixed: np.ndarray | None = None, chord: dict | None = None,
              iterations: int = MAX_ITERATIONS) -> Orbit:
        """Newton from ``x0`` ``(n,)`` and ``period`` [s] (``tip_amplitude`` [m]: the
        sliders' unit); the orbit (``converged`` False when Newton failed). ``fixed``
        ``(n,)`` bool: unknowns held at ``x0``'s values (the sliders of contacts stuck all
        period: an orbit of the family at that offset, :mod:`.family`); their equations
        stay, so a held slider that the period would move leaves a residual. ``chord``: a
        dict whose ``"matrix"`` (the bordered Jacobian of a neighbouring solve, kept there by
        the last fresh one) is used for every iteration while ``"reuse"`` is true (the
        family's members lie close together: one Jacobian, ``2 n`` shots, serves them);
        ``iterations``: Newton's at most."""
        t0 = time.perf_counter()
        x, period = np.array(x0, dtype=float), float(period)
        free = np.ones(self.n, bool) if fixed is None else ~np.asarray(fixed, bool)
        steps = self.flow.steps_for(self.fraction * period)[0]  # fixed: the map smooth in T
        scale = self._scale(x, period, tip_amplitude)
        one = self.flow.steps_for(self.fraction * period / steps)  # one step along the flow
        normal = (self.flow.advance(x[None], one[1], 1)[0] - x) / scale
        normal /= max(np.linalg.norm(normal), 1e-300)
        start = x / scale
        floor = ROUNDOFF * float(np.abs(start).max())

        n = self.n
        columns = np.flatnonzero(free)

        def unknowns(z):  # z: the free x in its units, then T over the start's period
            full = start.copy()
            full[columns] = z[:-1]
            return full * scale, period * z[-1]

        def residual(z):
            x, T = unknowns(z)
            if not T > 0:
                return np.full(n + 1, np.nan)
            F = np.empty(n + 1)
            F[:n] = (self.shot(x[None], T, steps)[0] - x) / scale
            F[n] = normal @ (x / scale - start)
            return F

        def jacobian(z):
            if chord is not None and chord.get("reuse") and chord.get("matrix") is not None \
                    and chord["matrix"].shape == (n + 1, columns.size + 1):
                return chord["matrix"]
            x, T = unknowns(z)
            c = columns.size  # the free unknowns' columns, then the period's
            A = np.zeros((n + 1, c + 1))
            A[:n, :c] = self.jacobian(x, T, steps, scale, columns) - np.eye(n)[:, columns]
            dT = DIFFERENCE * T
            later = self.shot(x[None], T + dT, steps)[0] - self.shot(x[None], T - dT, steps)[0]
            A[:n, c] = later / (2 * dT) / scale * period
            A[n, :c] = normal[columns]
            if chord is not None:
                chord["matrix"] = A
            return A

        z, _, size, reason, it = newton_least_squares(
            residual, jacobian, np.append(start[columns], 1.0), floor, iterations)
        x, T = unknowns(z)
        converged = reason.startswith("converged")
        q_v = x[: self.nq].reshape(2, self.N, self.m)
        orbit = Orbit(self.wave, T, q_v, self.shift, self.fraction, size, it, converged,
                      steps_per_period=steps * self.shots, reason=reason,
                      sliders=x[self.nq :].reshape(self.K, self.N, 2) if self.sliders
                      else None)
        orbit.wall_s = time.perf_counter() - t0
        return orbit

    # ------------------------------------------------------------------ stability
    def locked(self, orbit: Orbit) -> np.ndarray:
        """``(n,)`` bool: the unknowns of the sliders that do not move over ``orbit``'s period
        (a contact stuck all of it keeps its slider exactly where it is). Each is a neutral
        direction of the map (its offset selects another orbit of the family: a multiplier
        exactly 1), left out of :meth:`multipliers`."""
        mask = np.zeros(self.n, bool)
        if self.sliders:
            path = self.samples(orbit).sliders  # (S, K, N', 2)
            still = np.all(path == path[:1], axis=(0, 3))  # (K, N')
            mask[self.nq :] = np.repeat(still.ravel(), 2)
        return mask

    def multipliers(self, orbit: Orbit, tip_amplitude: float) -> dict:
        """The multipliers ``mu = nu^{N'}`` of the pattern map's Jacobian at ``orbit`` in its
        own steps (central differences, :meth:`jacobian`; ``tip_amplitude`` [m] the sliders'
        unit) without the :meth:`locked` sliders: ``values`` (complex, largest modulus
        first), ``nd`` of their eigenvectors on the whole wheel, ``vectors`` ``(n, E)`` those
        of the pattern map in the state's units (0 at the locked unknowns), ``trivial`` the
        index of the phase shift's (the eigenvector most aligned with the flow), ``neutral``
        the locked unknowns left out (each a multiplier exactly 1), ``scale`` ``(n,)`` the
        unknowns' units and ``keep`` the indices of those not locked."""
        x = orbit.flat()
        steps = orbit.steps_per_period // self.shots
        scale = self._scale(x, orbit.period, tip_amplitude)
        locked = self.locked(orbit)
        keep = np.flatnonzero(~locked)
        schedule = None
        if self.events:  # on the orbit's switches (docs/theory.md "Events in the step")
            if orbit.switches is None:
                orbit.switches = orbit_switches(self.flow, orbit)
            schedule = orbit.switches.schedule(self.fraction * orbit.period / steps)
        G = self.jacobian(x, orbit.period, steps, scale, keep, schedule)[keep]
        along = (self.flow.advance(x[None], self.fraction * orbit.period / steps, 1)[0] - x)
        along = along[keep] / scale[keep]
        # the locked unknowns are sliders, after q and q': keep's first N' m rows are q
        values, vectors, nd = pattern_spectrum(G, scale[keep], self.shots, self.N,
                                               self.full_model.blades, self.m)
        scaled = vectors / scale[keep, None]
        alignment = np.abs(scaled.conj().T @ along) / np.maximum(
            np.linalg.norm(scaled, axis=0) * np.linalg.norm(along), 1e-300)
        full = np.zeros((self.n, values.size), complex)  # in the state's units
        full[keep] = vectors
        return {"values": values, "nd": nd, "trivial": int(np.argmax(alignment)),
                "neutral": int(locked.sum()), "vectors": full, "scale": scale, "keep": keep}

    def samples(self, orbit: Orbit) -> OrbitSamples:
        """One period of ``orbit`` at every step of its shots (``q, q'`` and the sliders each
        step starts from)."""
        n_tau = orbit.steps_per_period // self.shots
        h = self.fraction * orbit.period / n_tau
        path = [orbit.flat()]
        for _ in range(orbit.steps_per_period - 1):
            path.append(self.flow.advance(path[-1][None], h, 1)[0])
        path = np.array(path)
        S = path.shape[0]
        states = path[:, : self.nq].reshape(S, 2, self.N, self.m)
        sliders = path[:, self.nq :].reshape(S, self.K, self.N, 2) if self.sliders else None
        return OrbitSamples(np.arange(S) * h, states, sliders)
