"""Harmonic balance of one travelling wave of a tuned wheel, forces by alternating
frequency-time (AFT) evaluation (docs/theory.md, "Limit cycles").

Cyclic symmetry reduces the wheel to one blade: in a travelling wave of index ``k`` blade
``s + 1`` leads blade ``s`` by ``phi = 2 pi k / N`` of a period, so with ``tau = omega t``::

    q_s(tau) = c_0 + Re sum_{h=1..H} c_h exp(i h (tau + s phi))

and harmonic ``h`` lives on the wave ``h k`` (mod ``N``), whose stiffness is the ND block
``K_h = A0 + A1 e^{i h phi} + A1^T e^{-i h phi}``. The unknowns are blade 0's harmonics
``c_0`` (real) and ``c_1..c_H`` (complex) of its ``m`` modal coordinates, the frequency
``omega`` and the continuation parameter ``lam`` (the factor on the Van der Pol intensity
``mu``, or on the aerodynamic table). The equations, per harmonic::

    (K_h (1 + i h omega beta_D) - (h omega)^2) c_h - f_h(c, omega, lam) = 0

with ``f_h`` the harmonics of the nonlinear forces on blade 0 (contacts, Van der Pol), found by
synthesising ``n_t`` time samples of blades ``-1, 0, +1`` (blade ``b`` is blade 0 shifted by
``b phi``), evaluating the same force law as the transient at each sample
(:meth:`wheelrom.forces.reference.ReferenceForces.evaluate_samples` on a three-blade window) and
transforming back; plus a phase condition ``Im c_1[j*] = 0``.

The real packing of ``X`` ``(2H + 1, m)``: row 0 ``c_0``, rows ``2h - 1``, ``2h`` the real and
imaginary parts of ``c_h``. Units: ``c`` [sqrt(kg) m], ``omega`` [rad/s], ``lam`` [-].
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from wheelrom.analysis.periodic.hysteresis import HysteresisLoop, differences, tiled
from wheelrom.analysis.periodic.window import (
    FD_DISPLACEMENT,
    WINDOW,
    Linearisation,
    force_inputs,
    wave_state,
    window_parameters,
)
from wheelrom.forces.parameters import AERO_TABLE, ForceParameters
from wheelrom.forces.reference import ReferenceForces
from wheelrom.rom.model import ReducedModel

#: periods the AFT marches the elastic law's sliders (NLvib and pyHarm march 2-3): the loop
#: of a contact that slips in the first period is closed in the second
MARCH_PERIODS = 3
#: ... and on, up to this many, until what is left of every slider's walk to its loop (the
#: period's move over one minus the walk's shrink a period: a move alone stopped a walk
#: shrinking by 1e-4 a period 1e4 moves short of its loop, and the forces jumped where
#: that move crossed the tolerance) is within :data:`MARCH_TOLERANCE` [m] (the walk
#: closed by :func:`wheelrom.forces.reference._closed_loops` where it zig-zags between two
#: stick discs): a contact in partial slip whose normal force varies with its
#: tangential motion walks towards its shakedown loop over hundreds of periods (measured on
#: the small wheel's stuck resonance, shroud slipping 56 % of the period: the harmonic
#: forces after 3 periods 8.5e-5 of the harmonics' terms off the periodic loop's, 1.7e-6
#: after 100, 1e-8 once converged), above Newton's tolerance (1e-7); the walk is
#: extrapolated (:func:`wheelrom.forces.reference._extrapolated`: 20 periods there instead
#: of 269). The tolerance lies four decades below the Jacobian's differencing step
#: (:data:`FD_DISPLACEMENT`): a loop that grazes the Coulomb limit is approached so slowly
#: that a period's move of 1e-13 m left the march 1e-10 m from it (the paper wheel at 1.6 kN)
MARCH_MAX_PERIODS = 2000
MARCH_TOLERANCE = 1e-14
#: the elastic law's residual is known to ``k_t`` times the march's tolerance times a
#: contact's modal displacement (:attr:`WaveBalance.force_noise`) times this: Newton on the
#: paper wheel's 1.8 kN design case reached 0.4-1.2 of that and wandered there for 40
#: iterations (the static equations' 1e-9 of their terms, against their 1e-10 tolerance)
NOISE_FACTOR = 4.0


class WaveBalance:
    """The harmonic-balance residual and Jacobian of travelling wave ``wave`` (index ``k``,
    ``0 <= k < N``) of a tuned wheel about its configuration ``params`` (force parameters with
    the Van der Pol intensity at ``lam = 1``), ``harmonics`` ``H``, ``samples`` ``n_t`` per
    period (at least ``2 H + 1``; ``4 H + 4`` resolves the Jacobian's harmonics for Floquet).
    Under the elastic law its :attr:`hysteresis` (:class:`~wheelrom.analysis.periodic.
    hysteresis.HysteresisLoop`) gives the Jacobian's part through the sliders' loop."""

    def __init__(self, model: ReducedModel, params: ForceParameters, beta: float, wave: int,
                 harmonics: int, samples: int):
        if not model.tuned:
            raise ValueError("limit cycles need a tuned wheel (mistuning.* is set)")
        if samples < 2 * harmonics + 1:
            raise ValueError(f"limit_cycle.samples = {samples} < 2 H + 1 = {2 * harmonics + 1}")
        self.model, self.params, self.beta = model, params, beta
        self.blades, self.modes = model.blades, model.modes
        self.wave, self.H, self.nt = wave % model.blades, harmonics, samples
        self.phi = 2 * math.pi * self.wave / self.blades
        self.window = window_parameters(params)
        self._window_at = (1.0, self.window)
        self.forces = ReferenceForces(self.window)
        self.kinds = params.contacts.kinds
        # the elastic law's hysteresis: the AFT marches the sliders through the samples
        self.elastic = params.law.elastic
        self.sliders = None  # (n_t, K, 3, 2) the sliders of the last march's samples
        H, nt = harmonics, samples
        self.tau = 2 * math.pi * np.arange(nt) / nt
        self.h = np.arange(H + 1)
        self.stiffness = np.stack([self._wave_stiffness(h * self.phi) for h in range(H + 1)])
        # over the rotor speed (forced.over = "speed"): the stiffness follows the speed
        # w / n_s of the excitation w, [1/s^2 per (rad/s)^2] (None: fixed)
        self.speed_stiffness = model.stiffening_per_speed if params.follows_speed else None
        self.E = np.stack([self._synthesis(b, False) for b in WINDOW])  # (3, nt, 2H+1)
        self.D = np.stack([self._synthesis(b, True) for b in WINDOW])
        P = np.zeros((2 * H + 1, nt))
        P[0] = 1.0 / nt
        for h in range(1, H + 1):
            P[2 * h - 1] = 2.0 / nt * np.cos(h * self.tau)
            P[2 * h] = -2.0 / nt * np.sin(h * self.tau)
        self.P = P
        self._projectors = {}  # P (x) E and P (x) D for the Jacobian (:meth:`_projected`)
        points = np.abs(np.vstack([np.asarray(a) for a in model.contact_A.values()]
                                  + [np.asarray(b) for b in model.contact_B.values()]))
        reach = np.maximum(np.abs(model.tip).max(axis=0), points.max(axis=0))  # (m,) [m/unit]
        self.fd_step = FD_DISPLACEMENT / np.maximum(reach, 1e-30)
        # the record of the evaluations with held sliders (none under the paper law) and
        # the Jacobian's part through the elastic law's loop
        self.hysteresis = HysteresisLoop(len(self.kinds), nt, self.E, self.P, self.fd_step,
                                         self.forces.sliders_at_rest,
                                         lambda q, v, lam, held: self._evaluate(q, v, lam,
                                                                                held)[0])
        # the elastic law's force noise per modal coordinate: where the march leaves a
        # slider along the directions its loop does not fix is known to its tolerance
        self.force_noise = np.zeros(self.modes)
        if self.elastic:
            self.force_noise = (NOISE_FACTOR * MARCH_TOLERANCE
                                * float(np.max(params.contacts.tangential)) * points.max(axis=0))
        self.inputs = force_inputs(params)
        self.table = params.vdp_model == AERO_TABLE

    @property
    def size(self) -> int:
        """Real unknowns of the harmonics, ``(2 H + 1) m``."""
        return (2 * self.H + 1) * self.modes

    # ------------------------------------------------------------------ linear parts
    def _wave_stiffness(self, phase: float) -> np.ndarray:
        """``(m, m)`` Hermitian ``A0 + A1 e^{i phase} + A1^T e^{-i phase}`` (any real phase:
        Floquet perturbations use ``theta + h phi``) [1/s^2]."""
        z = np.exp(1j * phase)
        A0, A1 = self.model.A0, self.model.A1
        K = A0 + A1 * z + A1.T * np.conj(z)
        return 0.5 * (K + K.conj().T)

    def _synthesis(self, blade: int, derivative: bool) -> np.ndarray:
        """``(n_t, 2H + 1)``: samples (or their d/dtau) of blade ``blade`` from packed ``X``."""
        H = self.H
        E = np.zeros((self.nt, 2 * H + 1))
        if not derivative:
            E[:, 0] = 1.0
        for h in range(1, H + 1):
            arg = h * (self.tau + blade * self.phi)
            if derivative:
                E[:, 2 * h - 1], E[:, 2 * h] = -h * np.sin(arg), -h * np.cos(arg)
            else:
                E[:, 2 * h - 1], E[:, 2 * h] = np.cos(arg), -np.sin(arg)
        return E

    def complex_harmonics(self, X: np.ndarray) -> np.ndarray:
        """``(H + 1, m)`` complex ``c_h`` of packed ``X`` ``(2H + 1, m)``."""
        c = np.zeros((self.H + 1, self.modes), dtype=complex)
        c[0] = X[0]
        c[1:] = X[1::2] + 1j * X[2::2]
        return c

    def packed(self, c: np.ndarray) -> np.ndarray:
        """Packed ``X`` ``(2H + 1, m)`` of complex harmonics ``c`` ``(H + 1, m)``."""
        X = np.zeros((2 * self.H + 1, self.modes))
        X[0] = c[0].real
        X[1::2], X[2::2] = c[1:].real, c[1:].imag
        return X

    def _dynamic_stiffness(self, omega: float, lam: float) -> list[np.ndarray]:
        """``Z_h`` ``(m, m)`` complex per harmonic: stiffness, damping, inertia and the
        aerodynamic table's per-harmonic operator (``lam`` times the table)."""
        Z, moved = [], self.speed_term(omega)
        for h in range(self.H + 1):
            Kh = self.stiffness[h] + moved
            Zh = Kh * (1.0 + 1j * h * omega * self.beta) - (h * omega) ** 2 * np.eye(self.modes)
            if self.table:
                Zh = Zh + lam * self._table_operator(h * self.phi, h * omega)
            Z.append(Zh)
        return Z

    def speed_term(self, omega: float) -> np.ndarray | float:
        """``(m, m)`` [1/s^2] what every harmonic's stiffness gains at the excitation
        ``omega`` [rad/s] when it follows the rotor speed ``omega / n_s`` (0 when fixed):
        ``((omega / n_s)^2 - Omega_0^2) S``, :meth:`~wheelrom.rom.model.ReducedModel.
        at_speed` in the balance's terms."""
        if self.speed_stiffness is None:
            return 0.0
        speed = omega / self.params.stator_vanes
        return (speed**2 - (2 * math.pi * self.model.speed_hz) ** 2) * self.speed_stiffness

    def table_parts(self, phase: float) -> tuple[np.ndarray, np.ndarray]:
        """``(A, B)`` ``(m, m)``: minus the aerodynamic table's generalised force per unit
        displacement and per unit velocity of ``c`` on a wave of blade-to-blade ``phase``
        (``mu`` = the table factor): ``-mu sum_j (a_j, b_j) e^{i j phase} p p^T``."""
        pp = np.outer(self.params.aero, self.params.aero)
        z = np.exp(1j * np.arange(self.blades) * phase)
        mu = self.params.vdp_mu
        return (mu * np.sum(self.params.aero_displacement * z) * pp,
                mu * np.sum(self.params.aero_velocity * z) * pp)

    def _table_operator(self, phase: float, frequency: float) -> np.ndarray:
        """``A + i frequency B`` of :meth:`table_parts` (``frequency`` [rad/s])."""
        A, B = self.table_parts(phase)
        return A + 1j * frequency * B

    @staticmethod
    def _real_block(Z: np.ndarray) -> np.ndarray:
        """The real ``(2m, 2m)`` form of complex ``Z`` acting on ``(Re c, Im c)``."""
        return np.block([[Z.real, -Z.imag], [Z.imag, Z.real]])

    def linear_term(self, X: np.ndarray, omega: float, lam: float) -> np.ndarray:
        """``(2H + 1, m)`` packed ``Z_h c_h``."""
        c = self.complex_harmonics(X)
        Z = self._dynamic_stiffness(omega, lam)
        return self.packed(np.stack([Z[h] @ c[h] for h in range(self.H + 1)]))

    def wheel_state(self, X: np.ndarray, omega: float, tau: float = 0.0):
        """``(q, v)`` ``(N, m)`` of every blade at phase ``tau`` [rad] of the cycle ``X``,
        ``omega``: blade ``s`` is blade 0 at ``tau + s phi`` (the whole wheel's motion, to
        start a transient on the cycle or to check it with another code)."""
        return wave_state(self.complex_harmonics(X), self.wave, self.blades, omega, tau)

    # ------------------------------------------------------------------ AFT
    def samples(self, X: np.ndarray, omega: float) -> tuple[np.ndarray, np.ndarray]:
        """``q``, ``v`` ``(n_t, 3, m)``: the window's modal displacements and velocities."""
        q = np.einsum("wjh,hm->jwm", self.E, X)
        v = omega * np.einsum("wjh,hm->jwm", self.D, X)
        return np.ascontiguousarray(q), np.ascontiguousarray(v)

    def _evaluate(self, q: np.ndarray, v: np.ndarray, lam: float,
                  held: np.ndarray | None = None):
        """Forces on blade 0 ``(S, m)`` and pair-0 contact records of ``S`` window states.

        Elastic law: the states are periods of samples (``S / n_t`` of them, or one of ``S``)
        and the sliders are marched through each
        (:data:`MARCH_PERIODS` periods from rest at the period's mean state: a converged
        loop once every contact has slipped; a contact that never slips acts as its stuck
        spring about the mean, the stuck linearisation's limit), kept in ``self.sliders``;
        or, with ``held`` ``(S, K, 3, 2)`` [m], each state reads its own slider, unmarched,
        and the slider it returns is kept in :attr:`hysteresis`' ``returned``."""
        S, K = q.shape[0], len(self.kinds)
        self.forces.params = self._at(lam)
        force = np.empty((S, 3, self.modes))
        normal, power = np.empty((S, K)), np.empty((S, K))
        state = np.empty((S, K), dtype=np.int8)
        periods, block, sliders = 0, 0, None
        returned = self.hysteresis.hold(held)
        if held is not None:
            sliders = held
        elif self.elastic:  # S / n_t periods of samples, each marched
            block = self.nt if S % self.nt == 0 else S
            sliders = np.empty((S, *self.forces.slider.shape))
            for start in range(0, S, block):
                mean = np.ascontiguousarray(q[start : start + block].mean(axis=0))
                sliders[start] = self.forces.sliders_at_rest(mean)
            periods = MARCH_PERIODS
        self.march_drift = self.forces.evaluate_samples(
            q, v, force, normal, power, state, sliders, periods, block,
            MARCH_MAX_PERIODS if periods else 0, MARCH_TOLERANCE, returned)
        if periods:
            self.sliders = sliders
        return force[:, 0], normal, power, state

    def _at(self, lam: float) -> ForceParameters:
        """The window's parameters with the self-excitation at factor ``lam`` (kept for the
        last factor asked: a Newton solve asks for one many times)."""
        if self._window_at[0] != lam:
            self._window_at = (lam, dataclasses.replace(self.window,
                                                        vdp_mu=lam * self.window.vdp_mu))
        return self._window_at[1]

    def nonlinear_force(self, X: np.ndarray, omega: float, lam: float) -> np.ndarray:
        """``(n_t, m)`` the forces on blade 0 at the samples."""
        q, v = self.samples(X, omega)
        return self._evaluate(q, v, lam)[0]

    def residual(self, X: np.ndarray, omega: float, lam: float) -> np.ndarray:
        """``(2H + 1, m)`` packed ``Z_h c_h - f_h``."""
        return self.linear_term(X, omega, lam) - self.P @ self.nonlinear_force(X, omega, lam)

    def linearise(self, X: np.ndarray, omega: float, lam: float) -> Linearisation:
        """The forces at the samples and their derivatives by central differences, all
        samples and perturbations in one compiled call: over the blade-0 force's physical
        inputs (:func:`force_inputs`) when the basis resolves them, else over the window's
        ``6 m`` modal coordinates."""
        q, v = self.samples(X, omega)
        if self.elastic:  # no sample-local derivatives: the Jacobian comes from the march
            return Linearisation(self._evaluate(q, v, lam)[0], None, None)
        if self.inputs is not None:
            return self._linearise_physical(q, v, omega, lam)
        return self._linearise_modal(q, v, omega, lam)

    def _linearise_physical(self, q, v, omega: float, lam: float,
                            held: np.ndarray | None = None) -> Linearisation:
        """Central differences of the force on blade 0 along each physical input ``u_i =
        r_i . q_w`` (a contact point's displacement component, the Van der Pol ``y``), moved
        alone by ``FD_DISPLACEMENT`` through the modal direction ``d_i`` with ``r_j . d_i =
        delta_ij``; the chain rule ``d f / d q_w = sum_i (d f / d u_i) r_i`` gives the modal
        derivatives. The force depends on ``q`` through these inputs only, so this is the
        modal differencing's result on 2 x 33 inputs instead of 6 m (132: half the cost).
        ``held``: the elastic law's sliders per sample (:meth:`_loop_jacobian`)."""
        m, nt = self.modes, self.nt
        blades, rows, directions = self.inputs
        n_in = len(blades)
        steps = np.array([FD_DISPLACEMENT, FD_DISPLACEMENT * max(omega, 1.0)])
        Q = np.broadcast_to(q, (4 * n_in + 1, nt, 3, m)).copy()
        V = np.broadcast_to(v, (4 * n_in + 1, nt, 3, m)).copy()
        for kind, target in enumerate((Q, V)):
            for i in range(n_in):
                k = 1 + 2 * (kind * n_in + i)
                delta = steps[kind] * directions[i]
                target[k, :, blades[i]] += delta
                target[k + 1, :, blades[i]] -= delta
        f = self._evaluate(Q.reshape(-1, 3, m), V.reshape(-1, 3, m), lam,
                           tiled(held, 4 * n_in + 1))[0]
        f = f.reshape(4 * n_in + 1, nt, m)
        same = self.hysteresis.same_branch(4 * n_in + 1)
        by_input = np.repeat(steps, n_in)[:, None, None]

        def chain(f, kind):  # (nt, out) per window blade
            d = differences(f, by_input, same).reshape(2, n_in, nt, -1)[kind]
            return np.stack([np.einsum("itj,il->tjl", d[blades == w], rows[blades == w])
                             for w in range(3)])

        dslider = None if held is None else chain(
            self.hysteresis.returned_components(4 * n_in + 1), 0)
        return Linearisation(f[0], chain(f, 0), chain(f, 1), dslider)

    def _linearise_modal(self, q, v, omega: float, lam: float,
                         held: np.ndarray | None = None) -> Linearisation:
        """Central differences over the window's ``6 m`` modal inputs (``held``: as
        :meth:`_linearise_physical`)."""
        m, nt = self.modes, self.nt
        n_in = 6 * m  # (q, v) x 3 blades x m
        steps = np.concatenate([self.fd_step, self.fd_step * max(omega, 1.0)])
        Q = np.broadcast_to(q, (2 * n_in + 1, nt, 3, m)).copy()
        V = np.broadcast_to(v, (2 * n_in + 1, nt, 3, m)).copy()
        for i in range(n_in):
            kind, rest = divmod(i, 3 * m)
            w, j = divmod(rest, m)
            target = Q if kind == 0 else V
            step = steps[kind * m + j]
            target[1 + 2 * i, :, w, j] += step
            target[2 + 2 * i, :, w, j] -= step
        f = self._evaluate(Q.reshape(-1, 3, m), V.reshape(-1, 3, m), lam,
                           tiled(held, 2 * n_in + 1))[0]
        f = f.reshape(2 * n_in + 1, nt, m)
        same = self.hysteresis.same_branch(2 * n_in + 1)
        by_input = np.repeat(steps.reshape(2, 1, m), 3, axis=1).reshape(n_in)[:, None, None]

        def derivative(f):  # (kind, w, nt, out, m)
            d = differences(f, by_input, same)
            return d.reshape(2, 3, m, nt, -1).transpose(0, 1, 3, 4, 2)

        d = derivative(f)
        dslider = None if held is None else derivative(
            self.hysteresis.returned_components(2 * n_in + 1))[0]
        return Linearisation(f[0], d[0], d[1], dslider)

    def _loop_jacobian(self, X: np.ndarray, omega: float, lam: float):
        """The elastic law's Jacobian: ``(lin, marched, through_sliders)``, the sample-local
        derivatives with each sample's slider held (``lin``), those sliders ``(n_t, K, 3,
        2)`` [m] of the march's loop and the hysteresis' part of ``dR/dX`` ``(2H+1, m, 2H+1,
        m)`` (:meth:`HysteresisLoop.jacobian <wheelrom.analysis.periodic.hysteresis.
        HysteresisLoop.jacobian>`)."""
        q, v = self.samples(X, omega)
        self._evaluate(q, v, lam)  # the march: its loop's sliders
        marched = self.sliders.copy()
        self.hysteresis.find_shaken(q, marched)  # before the differences: their branches
        differenced = self._linearise_physical if self.inputs is not None else \
            self._linearise_modal
        lin = differenced(q, v, omega, lam, marched)
        return lin, marched, self.hysteresis.jacobian(q, v, lam, marched, lin.dslider)

    def jacobian(self, X: np.ndarray, omega: float, lam: float, lin: Linearisation | None = None):
        """``(R, dR/dX, dR/domega, dR/dlam)``: packed residual ``(2H+1, m)``, its derivative
        ``(2H+1, m, 2H+1, m)`` and the two parameter columns ``(2H+1, m)``."""
        held = None
        if self.elastic:  # the sliders' part through the closed loop (:meth:`_loop_jacobian`)
            lin, held, through_sliders = self._loop_jacobian(X, omega, lam)
        lin = lin or self.linearise(X, omega, lam)
        R = self.linear_term(X, omega, lam) - self.P @ lin.force
        dRdX, dRdw = self._linear_derivatives(X, omega, lam)
        dRdX -= self._projected(lin.dq, "E")
        dRdX -= omega * self._projected(lin.dv, "D")
        if held is not None:
            dRdX -= through_sliders
        # d/domega of the forces through the velocities
        DX = np.einsum("wjh,hm->wjm", self.D, X)
        dRdw -= self.P @ np.einsum("wjil,wjl->ji", lin.dv, DX)
        dRdlam = self._lambda_column(X, omega, lam, held)
        return R, dRdX, dRdw, dRdlam

    def _projected(self, derivative: np.ndarray, synthesis: str) -> np.ndarray:
        """``sum_(w, j) P[p, j] derivative[w, j, i, l] S[w, j, h]`` ``(2H+1, m, 2H+1, m)``
        with ``S`` the ``synthesis`` ``"E"`` or ``"D"``: the forces' derivative ``(3, n_t, m,
        m)`` over the window's samples taken to the harmonics, one matrix product with
        ``P (x) S`` formed once (0.5 ms instead of einsum's 42 ms at H = 11, 64 samples, 10
        modes)."""
        if synthesis not in self._projectors:
            S = getattr(self, synthesis)
            self._projectors[synthesis] = np.einsum("pj,wjh->phwj", self.P, S).reshape(
                self.P.shape[0] ** 2, -1)
        n, m = self.P.shape[0], self.modes
        flat = self._projectors[synthesis] @ derivative.reshape(-1, m * m)
        return flat.reshape(n, n, m, m).transpose(0, 2, 1, 3)

    def linear_jacobian(self, X: np.ndarray, omega: float, lam: float) -> np.ndarray:
        """``(n, n)`` the linear part's ``dR/dX`` (:meth:`_linear_derivatives`), flat."""
        return self._linear_derivatives(X, omega, lam)[0].reshape(self.size, self.size)

    def _linear_derivatives(self, X: np.ndarray, omega: float, lam: float):
        """``(dR/dX, dR/domega)`` of the linear part ``Z_h c_h``: ``(2H+1, m, 2H+1, m)`` (the
        real blocks of ``Z_h``) and ``(2H+1, m)`` (analytically)."""
        n, m = 2 * self.H + 1, self.modes
        Z = self._dynamic_stiffness(omega, lam)
        dRdX = np.zeros((n, m, n, m))
        dRdX[0, :, 0, :] = Z[0].real
        for h in range(1, self.H + 1):
            rows = slice(2 * h - 1, 2 * h + 1)
            dRdX[rows, :, rows, :] = self._real_block(Z[h]).reshape(2, m, 2, m)
        c = self.complex_harmonics(X)
        moved = self.speed_term(omega)
        dZ = [(self.stiffness[h] + moved) * (1j * h * self.beta) - 2 * h * h * omega * np.eye(m)
              + (lam * self._table_derivative(h) if self.table else 0) for h in range(self.H + 1)]
        if self.speed_stiffness is not None:  # d/domega of the stiffness that follows it
            dK = 2 * omega / self.params.stator_vanes**2 * self.speed_stiffness
            dZ = [dZ[h] + dK * (1.0 + 1j * h * omega * self.beta) for h in range(self.H + 1)]
        return dRdX, self.packed(np.stack([dZ[h] @ c[h] for h in range(self.H + 1)]))

    def _table_derivative(self, h: int) -> np.ndarray:
        """d(table operator of harmonic ``h``)/d omega."""
        return 1j * h * self.table_parts(h * self.phi)[1]

    def _lambda_column(self, X: np.ndarray, omega: float, lam: float,
                       held: np.ndarray | None = None) -> np.ndarray:
        """dR/dlam: the self-excitation is linear in ``lam`` (Van der Pol force and table;
        ``held``: the elastic law's loop, which does not depend on ``lam``)."""
        if self.table:
            c = self.complex_harmonics(X)
            ops = [self._table_operator(h * self.phi, h * omega) for h in range(self.H + 1)]
            return self.packed(np.stack([ops[h] @ c[h] for h in range(self.H + 1)]))
        q, v = self.samples(X, omega)
        f1 = self._evaluate(q, v, 1.0, held)[0]
        f0 = self._evaluate(q, v, 0.0, held)[0]
        return -(self.P @ (f1 - f0))

