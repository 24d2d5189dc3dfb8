"""The autonomous flow ``phi_t`` of the tuned wheel on the project's own PETSc TS (the
configured scheme, whole fixed steps no longer than ``time.step``) for a batch of states:
the function that shooting and the monodromy evaluate.

Autonomous: the nozzle is off and the self-excitation is scaled by ``lam`` (the factor on
``flutter.mu`` or ``flutter.table_scale``), as for the harmonic balance; or forced
(``nozzle``: the nozzle's travelling wave at a given frequency, :class:`Nozzle`, for the
forced response's exact orbit). Every state of a
batch is one case of the compiled kernel's batch dimension, so a batch of perturbed states
is one compiled call per step. No output samples are taken (the monitor's next sample time
is set beyond the end): the flow returns end states only.

A travelling wave of index ``k`` repeats every ``N' = N / gcd(k, N)`` blades, so its orbit
lives on the pattern wheel of ``N'`` blades (:func:`pattern_model`): the same blade blocks
``A0``, ``A1`` and contact geometry, closed after ``N'`` blades. Its dynamics on patterns of
period ``N'`` is the full wheel's exactly (the coupling and the contacts act between
neighbours only), at ``N' / N`` of the cost.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from wheelrom.config import Config
from wheelrom.forces.parameters import ForceParameters, force_parameters
from wheelrom.rom.model import ReducedModel
from wheelrom.runtime.environment import petsc
from wheelrom.runtime.errors import InputError
from wheelrom.transient import exponential
from wheelrom.transient.layout import H_NEXT_SAMPLE
from wheelrom.transient.problem import WheelProblem
from wheelrom.transient.run import load_kernels
from wheelrom.transient.stuck_shift import shift_matrix
from wheelrom.transient.ts import PREFIX, make_ts

#: most states integrated in one TS (memory: ~ 60 doubles per modal coordinate and state)
MAX_BATCH = 256


def autonomous(cfg: Config) -> Config:
    """``cfg`` with the nozzle off and no stored histories."""
    return cfg.replace(**{"excitation.force": 0.0, "output.history_rate_hz": 0.0,
                          "output.state_rate_hz": 0.0})


@dataclass(frozen=True)
class Nozzle:
    """The nozzle force of a forced flow: ``frequency`` [rad/s] of the excitation (the rotor
    speed set to ``frequency / n_s``) and ``phases`` ``(N,)`` [rad] per blade of the flow's
    wheel (a pattern wheel takes the whole wheel's first ``N'`` phases)."""

    frequency: float
    phases: np.ndarray


def pattern_blades(wave: int, blades: int) -> tuple[int, int, int]:
    """``(N', g, j)`` of travelling wave ``wave`` on ``blades`` = N: the pattern period
    ``N' = N / g``, ``g = gcd(k, N)``, and the blade shift ``j`` (``0 <= j < N'``) with
    ``j k = g (mod N)``: the wave's state a fraction ``g / N`` of a period later is its state
    at ``t = 0`` shifted by ``j`` blades, ``x_s(g T / N) = x_{s + j}(0)`` (blade ``s + 1``
    leads blade ``s`` by ``2 pi k / N``, so it is blade ``s`` a time ``k T / N`` later)."""
    g = math.gcd(int(wave) % blades, blades)
    n = blades // g
    j = pow((int(wave) % blades) // g, -1, n) % n if n > 1 else 0
    return n, g, j


def pattern_model(model: ReducedModel, wave: int, use_pattern: bool = True):
    """``(model', g, j)``: the pattern wheel of ``wave`` (:func:`pattern_blades`) and the
    blade shift on it; with ``use_pattern = False`` (an aerodynamic table couples every
    blade pair) the whole wheel over a whole period without a shift, ``(model, N, 0)``: the
    wave's shift over ``g T / N`` on the whole wheel would make the shot's ``N'``-th power
    ``S^{-j N'} phi_T``, whose eigenvalues carry the shift's phases (a ``g`` = 2 wave's
    multipliers came out squared)."""
    if not model.tuned:
        raise InputError("periodic orbits by shooting need a tuned wheel (mistuning off)")
    if not use_pattern:
        return model, model.blades, 0
    # j k' = 1 (mod N') with k = g k' gives j k = g (mod N): the shift holds on the whole
    # wheel as on the pattern
    n, g, j = pattern_blades(wave, model.blades)
    if n == model.blades:
        return model, g, j
    return dataclasses.replace(model, blades=n, mistuning=None), g, j


def pattern_nd(q: np.ndarray, g: int, blades: int) -> np.ndarray:
    """NDs on the whole wheel of ``blades`` of pattern vectors ``q`` ``(E, N', m)`` (modal
    displacements of a pattern of ``N'`` blades repeating ``g = blades / N'`` times): the
    DFT over the pattern's blades, its index of largest energy times ``g``."""
    if q.shape[1] == 1:
        return np.zeros(q.shape[0], int)
    energy = (np.abs(np.fft.fft(q, axis=1)) ** 2).sum(axis=2)  # (E, N')
    k = np.argmax(energy, axis=1) * g
    return np.minimum(k % blades, (-k) % blades)


def pattern_spectrum(G: np.ndarray, scale: np.ndarray, shots: int, pattern: int,
                     blades: int, modes: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(mu, vectors, nd)``: the multipliers ``mu = nu^shots`` of a pattern map's Jacobian
    ``G`` ``(n, n)`` in scaled units ``scale`` ``(n,)`` (``G^shots`` is the monodromy on the
    pattern), largest modulus first; its eigenvectors ``(n, E)`` in the state's units, in
    that order; the NDs on the wheel of ``blades`` of their ``q`` parts (the first
    ``pattern * modes`` rows: :func:`pattern_nd`)."""
    nu, vectors = np.linalg.eig(G)
    mu = nu**shots
    order = np.argsort(-np.abs(mu))
    vectors = (vectors * scale[:, None])[:, order]
    q = vectors[: pattern * modes].T.reshape(-1, pattern, modes)
    return mu[order], vectors, pattern_nd(q, blades // pattern, blades)


def shift_blades(states: np.ndarray, j: int) -> np.ndarray:
    """``(..., 2, N, m)`` states with blade ``s`` replaced by blade ``s + j``."""
    return np.roll(states, -j, axis=-2)


class WheelFlow:
    """``phi_t`` of one case for batches of states ``(B, 2, N, m)`` (``q`` [sqrt(kg) m],
    ``q'`` [sqrt(kg) m/s] of every blade of ``model``). ``lam``: factor on the
    self-excitation; ``nozzle``: the forced flow's nozzle (None: off, autonomous). The TS has
    the options prefix ``prefix`` (``wheel_``: the transient's ``-wheel_ts_*`` options act
    here too); ``params``: the case's force parameters on ``model`` instead of ``cfg``'s
    (the nozzle's on or off as in them). :meth:`destroy` frees the PETSc objects."""

    def __init__(self, model: ReducedModel, cfg: Config, angles_deg: dict | None = None,
                 lam: float = 1.0, prefix: str = PREFIX, options: dict | None = None,
                 nozzle: Nozzle | None = None,
                 params: ForceParameters | None = None):
        self.model, self.prefix, self.options = model, prefix, options
        self.cfg = autonomous(cfg) if nozzle is None else \
            cfg.replace(**{"output.history_rate_hz": 0.0, "output.state_rate_hz": 0.0})
        # the factor on the intensity (or the table's scale) on the parameters: a reversed
        # self-excitation (lam < 0) is no configuration, but an unstable cycle to test on
        if params is None:
            params = force_parameters(model, self.cfg, angles_deg)
        self.params = dataclasses.replace(params, vdp_mu=params.vdp_mu * lam)
        if nozzle is not None:  # the kernel's nozzle runs at n_s times the rotor speed
            self.params = dataclasses.replace(
                self.params, omega=nozzle.frequency / params.stator_vanes,
                nozzle_phase=np.ascontiguousarray(nozzle.phases, dtype=float))
        self.N, self.m = model.blades, model.modes
        self.n = self.N * self.m
        #: the elastic law's slider coordinates of a state (``2 K N``; 0 under the paper law)
        self.sliders = self.params.sliders
        load_kernels(self.params)
        self._batches: dict[int, tuple] = {}
        self.max_step = float(self.cfg.time.step)
        self.used: dict = {}
        self.steps_taken = 0  # TS steps of all calls times their batch size

    def _batch(self, B: int):
        if B not in self._batches:
            problem = WheelProblem(self.model, self.cfg, [self.params] * B,
                                   petsc().COMM_SELF, capacity=4)
            ts, f, used = make_ts(problem, self.cfg, self.prefix, self.options)
            self.used = used
            self.max_step = float(used["ts_dt"])
            self._batches[B] = (problem, ts, f, f.duplicate())
        return self._batches[B]

    def shift(self, states: np.ndarray, j: int) -> np.ndarray:
        """Flat states ``(B, 2 N m + sliders)`` (:meth:`advance`'s) with blade ``s`` replaced
        by blade ``s + j``: ``q``, ``q'`` and the elastic law's sliders ``(K, N, 2)``, whose
        blades are on the same axis."""
        B, nq = states.shape[0], 2 * self.n
        parts = [shift_blades(states[:, :nq].reshape(B, 2, self.N, self.m), j)]
        if self.sliders:
            K = self.sliders // (2 * self.N)
            parts.append(shift_blades(states[:, nq:].reshape(B, K, self.N, 2), j))
        return np.concatenate([p.reshape(B, -1) for p in parts], axis=1)

    def forces(self):
        """The case's :class:`~wheelrom.forces.reference.ReferenceForces` on the flow's wheel
        (its contact laws, sliders and equilibrium checks)."""
        return self._batch(1)[0].forces[0]

    def energy(self, state: np.ndarray, tangential: bool = True) -> float:
        """The flow's wheel's mechanical energy [J on the modal masses] at the flat ``state``
        (``q, q'`` then, under the elastic law, the sliders ``(K, N, 2)``): kinetic, the
        wheel's elastic ``q K_R q / 2``, the normal contact springs' and (``tangential``) the
        tangential springs' ``|F_t|^2 / (2 k_t)`` (a slider on or inside its Coulomb limit
        at a step's end: ``F_t = k_t (u_t - w)``). Without the tangential springs its change
        over a time is the works of :meth:`works` over it (the friction's work is the
        tangential force's on the wheel: the springs' release and the slip's loss): the
        energy balance."""
        x = np.asarray(state, dtype=float).ravel()
        q = x[: self.n].reshape(self.N, self.m)
        v = x[self.n : 2 * self.n].reshape(self.N, self.m)
        forces = self.forces()
        K = len(self.params.contacts.kinds)
        slider = x[2 * self.n :].reshape(K, self.N, 2) if x.size > 2 * self.n else None
        forces.evaluate(0.0, np.ascontiguousarray(q), np.ascontiguousarray(v), slider)
        if getattr(self, "_stiffness", None) is None:
            self._stiffness = self.model.sparse_stiffness()
        stored = 0.0
        if slider is not None and tangential:
            k_t = np.maximum(self.params.contacts.tangential[:, : self.N], 1e-300)
            stored = 0.5 * float(np.sum(np.sum(forces.friction_force**2, axis=2) / k_t))
        flat = q.ravel()
        return (0.5 * float(v.ravel() @ v.ravel() + flat @ (self._stiffness @ flat))
                + forces.contact_energy() + stored)

    def steps_for(self, duration: float) -> tuple[int, float]:
        """``(n, h)``: whole steps ``h = duration / n <= time.step`` [s] (off the exponential
        scheme's resonances)."""
        if self.max_step <= 0 or not math.isfinite(duration) or duration <= 0:
            raise ValueError(f"a flow over {duration!r} s with a step of {self.max_step!r} s")
        n = max(1, math.ceil(duration / self.max_step * (1 - 1e-12)))
        if self.cfg.time.scheme == "exponential" and \
                self.used.get("ts_type", "python") == "python":
            shift = shift_matrix(self.model, self.params)
            while exponential.safe_step(self.model, duration / n, shift)[1] is not None:
                n += 1
        return n, duration / n

    def works(self, state: np.ndarray, duration: float, steps: int) -> tuple[np.ndarray,
                                                                            np.ndarray]:
        """``(end, works)``: one state's end (as :meth:`advance`, flat ``q, q'`` and the
        sliders when carried) and the four work integrals over the ``steps`` steps of
        ``duration`` [s], ``(nozzle, self-excitation, friction, damping)`` [J on the modal
        masses] (friction and damping negative: taken out), integrated by the scheme along
        the state (:mod:`wheelrom.transient.kernel`)."""
        flat = np.asarray(state, dtype=float).reshape(1, -1)
        end, works = self._advance(flat, duration, steps, 0.0, works=True)
        return end[0], works[0]

    def advance(self, states: np.ndarray, duration: float, steps: int = 0,
                start: float = 0.0, schedule=None) -> np.ndarray:
        """``phi_duration`` of every state ``(B, 2, N, m)`` -> ``(B, 2, N, m)``, or of flat
        states ``(B, 2 N m + sliders)`` that carry the elastic law's sliders after ``q, q'``
        (blade-major ``(K, N, 2)`` [m], as the transient's state), in ``steps`` whole steps
        (0: :meth:`steps_for`), from time ``start`` [s] (the forced flow's nozzle phase).
        ``schedule``: an event-located :class:`~.events.Schedule` of ``duration`` instead
        (its pieces' steps and contact modes; ``steps`` unread)."""
        states = np.asarray(states, dtype=float)
        out = np.empty_like(states)
        for lo in range(0, states.shape[0], MAX_BATCH):
            chunk = states[lo : lo + MAX_BATCH]
            out[lo : lo + len(chunk)] = self._advance(chunk, duration, steps, start,
                                                      schedule=schedule)
        return out

    def _advance(self, states: np.ndarray, duration: float, steps: int,
                 start: float, works: bool = False, schedule=None):
        """End states of ``states`` ``(B, ...)`` from time ``start`` [s]: ``q, q'`` and, when
        given (``2 n + sliders`` per state), the sliders; sliders not given start at 0.
        ``works``: also the four work integrals ``(B, 4)`` over the steps; ``schedule``: an
        event-located :class:`~.events.Schedule` (:meth:`advance`)."""
        B = states.shape[0]
        problem, ts, f, u = self._batch(B)
        if schedule is not None and abs(schedule.duration - duration) > 1e-9 * duration:
            raise ValueError(f"a schedule of {schedule.duration!r} s for a flow over "
                             f"{duration!r} s")
        n = schedule.steps if schedule is not None else \
            steps if steps else self.steps_for(duration)[0]
        full = np.zeros((B, problem.size()))
        flat = states.reshape(B, -1)
        full[:, : 2 * self.n] = flat[:, : 2 * self.n]
        if flat.shape[1] > 2 * self.n:  # the sliders follow the four work integrals
            full[:, 2 * self.n + 4 :] = flat[:, 2 * self.n :]
        ctx = problem.context
        ctx.set_header(H_NEXT_SAMPLE, math.inf)  # no output samples: end states only
        u.setArray(ctx.pack(full))
        pieces = [(duration, n, None)] if schedule is None else schedule.pieces
        mode = ctx.view("contact_mode").reshape(-1, self.N, B)
        try:
            for length, count, modes in pieces:
                mode[...] = 0.0 if modes is None else modes[:, :, None]
                self._solve(ts, u, ctx, start, length, count)
                start += length
        finally:
            mode[...] = 0.0
        self.steps_taken += n * B
        end = ctx.unpack(u.getArray(readonly=True))
        integrals = end[:, 2 * self.n : 2 * self.n + 4].copy()
        if flat.shape[1] > 2 * self.n:
            end = np.concatenate([end[:, : 2 * self.n], end[:, 2 * self.n + 4 :]], axis=1)
        end = end[:, : flat.shape[1]].reshape(states.shape)
        return (end, integrals) if works else end

    def _solve(self, ts, u, ctx, start: float, duration: float, n: int) -> None:
        """``n`` steps of ``ts`` on ``u`` from ``start`` over ``duration`` [s], the sliders
        returned at the end under the contact modes the steps held."""
        h = duration / n
        ts.setTime(start)
        ts.setStepNumber(0)
        ts.setTimeStep(h)
        ts.setMaxSteps(n)
        ts.setMaxTime(start + duration + 0.5 * h)
        ts.setExactFinalTime(petsc().TS.ExactFinalTime.STEPOVER)
        ts.solve(u)
        exponential.end_sliders(u, ctx)
        if ts.getStepNumber() != n:
            raise RuntimeError(f"the flow took {ts.getStepNumber()} of {n} steps")

    def trajectory(self, state: np.ndarray, duration: float, steps: int,
                   stride: int = 1) -> np.ndarray:
        """``(steps // stride + 1, 2, N, m)``: ``state`` and every ``stride``-th of ``steps``
        whole steps over ``duration`` [s] (the same steps as one :meth:`advance`). States
        without sliders: the paper law's (under the elastic law each piece would start its
        sliders at zero; :mod:`.slider_shooting` samples its orbits itself)."""
        h = duration / steps
        out = [np.asarray(state, dtype=float)]
        for _ in range(steps // stride):
            out.append(self.advance(out[-1][None], stride * h, stride)[0])
        return np.array(out)

    def vector_field(self, state: np.ndarray) -> np.ndarray:
        """``d/dt (q, q')`` ``(2, N, m)`` of one state (the reference forces, dense ``K_R``)."""
        problem = self._batch(1)[0]
        u = np.zeros(problem.size())
        u[: 2 * self.n] = np.asarray(state, dtype=float).ravel()
        return problem.rhs_numpy(0.0, u)[: 2 * self.n].reshape(2, self.N, self.m)

    def destroy(self) -> None:
        for problem, ts, f, u in self._batches.values():
            for obj in (ts, f, u):
                obj.destroy()
            problem.destroy()
        self._batches = {}
