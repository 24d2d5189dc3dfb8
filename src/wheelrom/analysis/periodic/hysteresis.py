"""The harmonic balance's Jacobian under the elastic law: the tangent of the closed
hysteresis loop (docs/theory.md, "Harmonic balance").

The AFT marches each contact's slider through the period's samples until its loop closes
(:meth:`~wheelrom.analysis.periodic.harmonic_balance.WaveBalance._evaluate`): a sample's
force depends on the motion before it. With ``w_i`` the slider sample ``i`` uses in the
closed loop, its force is ``f(q_i, v_i, w_i)`` and the slider it returns ``g(q_i, w_i)``;
both are differenced at each sample with the sliders held, and the tangent ``dw_i / dX`` is
carried around the period and closed contact by contact (:func:`loop_tangent`). Units:
sliders [m], modal coordinates [sqrt(kg) m], forces [N].
"""

from __future__ import annotations

import numpy as np

#: differencing step of a held slider [m] (:meth:`WaveBalance._slider_derivatives`): a slip
#: step's return shrinks the slider's motion across its direction by ``mu F_n / |trial|``,
#: which a step of ``k_t dw`` beyond a grazed limit moves off 1 by ``k_t dw / (mu F_n)``
#: (1.7e-5 for 1e-10 m on the paper wheel's 3.2 kN shroud): far below :data:`NEUTRAL` at
#: this step, whose differences still carry 1e-8 of the slider's magnitude
SLIDER_STEP = 1e-13
#: a hysteresis loop's period map leaves its sliders unchanged along an eigenvector whose
#: eigenvalue lies within this of 1 (:func:`loop_tangent`)
NEUTRAL = 1e-6


class HysteresisLoop:
    """The loop-tangent methods of :class:`~wheelrom.analysis.periodic.harmonic_balance.
    WaveBalance` (its samples ``E``, projector ``P``, window forces and the differencing of
    its physical or modal inputs), under the elastic law: the sliders of blade 0's contacts
    ``loop`` (flat indices in ``(K, 3, 2)``), the last held evaluation's ``returned`` and
    ``_held`` sliders and the contacts ``_shaken`` on the way to their loop."""

    def _tiled(self, held: np.ndarray | None, copies: int) -> np.ndarray | None:
        """``held`` ``(n_t, K, 3, 2)`` sliders for ``copies`` periods of samples."""
        return None if held is None else np.tile(held, (copies, 1, 1, 1))

    def _same_branch(self, copies: int) -> np.ndarray | None:
        """``(copies, n_t)``: whether every contact of blade 0 sticks (or not) in each state
        of the last held evaluation as on its branch (None: no sliders held): the first
        copy's (the base), but the slip branch where a contact shaken down onto the
        Coulomb limit grazes it (:meth:`_loop_jacobian`'s ``_shaken``)."""
        if self.returned is None:
            return None
        stuck = (self._returned(copies) == self._held.reshape(copies, self.nt, -1)[:, :,
                 self.loop]).reshape(copies, self.nt, -1, 2).all(axis=3)
        branch = stuck[0].copy()  # (n_t, contacts)
        # a contact the march shook down onto the Coulomb limit (it slipped on its way to
        # the loop and sticks in it) grazes the limit where a perturbation slips it: its
        # slider is held there by the limit, the slip branch's
        branch[:, self._shaken] &= stuck[:, :, self._shaken].all(axis=0)
        return (stuck == branch).all(axis=2)

    @staticmethod
    def _differences(f: np.ndarray, step: np.ndarray, same: np.ndarray | None) -> np.ndarray:
        """``(k, n_t, ...)`` differences of ``f`` ``(1 + 2 k, n_t, ...)`` (the base, then
        each of ``k`` perturbations by ``+step`` and ``-step``, ``step`` ``(k, 1, 1)``):
        central, but one-sided where only one side sticks and slips as the base does
        (``same``, :meth:`_same_branch`): the Coulomb limit is a kink of the elastic law,
        and a central difference across it averages its two branches (a contact that
        grazes the limit then looks half-stuck, and the loop around it goes wrong)."""
        plus, minus, base = f[1::2], f[2::2], f[0]
        d = (plus - minus) / (2 * step)
        if same is not None:
            forward, backward = same[1::2] & ~same[2::2], same[2::2] & ~same[1::2]
            d[forward] = ((plus - base) / step)[forward]
            d[backward] = ((base - minus) / step)[backward]
        return d

    def _returned(self, copies: int) -> np.ndarray:
        """``(copies, n_t, s)`` the loop's slider components the last held evaluation
        returned."""
        return self.returned.reshape(copies, self.nt, -1)[:, :, self.loop]

    def _loop_jacobian(self, X: np.ndarray, omega: float, lam: float):
        """The elastic law's Jacobian: ``(lin, held, loop)``, the sample-local derivatives
        with each sample's slider held (``lin``), those sliders ``(n_t, K, 3, 2)`` [m] and
        the hysteresis' part of ``dR/dX`` ``(2H+1, m, 2H+1, m)``.

        A sample's force depends on the motion before it through the sliders: with ``w_i``
        the slider sample ``i`` uses in the march's converged loop, ``f_i = f(q_i, v_i,
        w_i)`` and ``w_(i+1) = g(q_i, w_i)``. Both are differenced at each sample with the
        others held (the physical inputs as under the paper law, and each slider component
        of blade 0's contacts), and the tangent ``dw_i / dX`` is carried around the period
        and closed per contact (:func:`loop_tangent`): one march and about 150 periods of
        unmarched samples instead of a march for each of the ``(2H+1) m`` unknowns."""
        n, m, nt = 2 * self.H + 1, self.modes, self.nt
        q, v = self.samples(X, omega)
        self._evaluate(q, v, lam)  # the march: its loop's sliders
        held = self.sliders.copy()
        start = self.forces.sliders_at_rest(np.ascontiguousarray(q.mean(axis=0)))
        # contacts that left their start on the way to the loop (the rest never slipped)
        self._shaken = (held.reshape(nt, -1)[:, self.loop] != start.ravel()[self.loop]).any(
            axis=0).reshape(-1, 2).any(axis=1)
        differenced = self._linearise_physical if self.inputs is not None else \
            self._linearise_modal
        lin = differenced(q, v, omega, lam, held)
        force_w, return_w = self._slider_derivatives(q, v, lam, held)
        through_q = np.einsum("wih,wisl->ishl", self.E, lin.dslider).reshape(nt, -1, n * m)
        dw = loop_tangent(return_w, through_q, ~self._shaken,
                          lambda: self._start_derivative(q))  # (n_t, s, n m)
        loop = np.einsum("pi,ijs,isk->pjk", self.P, force_w, dw, optimize=True)
        return lin, held, loop.reshape(n, m, n, m)

    def _slider_derivatives(self, q: np.ndarray, v: np.ndarray, lam: float,
                            held: np.ndarray):
        """``(d f_i / d w_i, d w_(i+1) / d w_i)`` ``(n_t, m, s)``, ``(n_t, s, s)``: central
        differences in each of the loop's ``s`` slider components, held at every sample."""
        nt, m, s = self.nt, self.modes, len(self.loop)
        copies = 2 * s + 1  # the base, then + and - of each component
        Q = np.broadcast_to(q, (copies, *q.shape)).reshape(-1, 3, m).copy()
        V = np.broadcast_to(v, (copies, *v.shape)).reshape(-1, 3, m).copy()
        sliders = self._tiled(held, copies).reshape(copies, nt, -1)
        for c, index in enumerate(self.loop):
            sliders[1 + 2 * c, :, index] += SLIDER_STEP
            sliders[2 + 2 * c, :, index] -= SLIDER_STEP
        f = self._evaluate(Q, V, lam, sliders.reshape(copies * nt, *held.shape[1:]))[0]
        same, step = self._same_branch(copies), np.full((s, 1, 1), SLIDER_STEP)
        d_force = self._differences(f.reshape(copies, nt, m), step, same)
        d_return = self._differences(self._returned(copies), step, same)
        return d_force.transpose(1, 2, 0), d_return.transpose(1, 2, 0)

    def _start_derivative(self, q: np.ndarray) -> np.ndarray:
        """``(s, (2H+1) m)`` d(the march's start, the sliders at rest at the period's mean
        motion)/dX: a contact that sticks throughout keeps it (central differences)."""
        mean = q.mean(axis=0)  # (3, m): every window blade's c_0
        d = np.empty((3, self.modes, len(self.loop)))
        for w in range(3):
            for j in range(self.modes):
                step = self.fd_step[j]
                ends = []
                for sign in (1.0, -1.0):
                    moved = mean.copy()
                    moved[w, j] += sign * step
                    ends.append(self.forces.sliders_at_rest(moved).ravel()[self.loop])
                d[w, j] = (ends[0] - ends[1]) / (2 * step)
        return np.einsum("wjs,wh->shj", d, self.E.mean(axis=1)).reshape(len(self.loop), -1)


def loop_tangent(return_w: np.ndarray, through_q: np.ndarray, stuck: np.ndarray,
                 start) -> np.ndarray:
    """``dw_i / dX`` ``(n_t, s, n)``: the tangent of the sliders the samples use around a
    closed hysteresis loop, from ``w_(i+1) = g(q_i, w_i)``'s derivatives ``return_w``
    ``(n_t, s, s)`` (d/dw_i) and ``through_q`` ``(n_t, s, n)`` (d/dX through ``q_i``).

    Around the period ``dw_n = Phi dw_0 + Gamma``; contacts (pairs of components) are
    independent, so ``Phi`` is 2 x 2 blocks. Along an eigenvector of ``Phi`` whose
    eigenvalue has shrunk (a slip returns the slider onto the Coulomb limit, an opening to
    the motion) the loop is the sliders' fixed point, ``(1 - lambda)^-1`` times
    ``Gamma``'s part; along one that the period leaves unchanged (``lambda`` within
    :data:`NEUTRAL` of 1: a contact that sticks throughout, ``stuck``, both; one that slips
    back and forth along one line, across it) the march keeps where it started, the
    sliders at rest at the mean motion, whose derivative ``start()`` gives ``(s, n)``."""
    nt, s, n = through_q.shape
    M, N = np.eye(s), np.zeros((s, n))
    Ms, Ns = np.empty((nt, s, s)), np.empty((nt, s, n))
    for i in range(nt):
        Ms[i], Ns[i] = M, N
        M, N = return_w[i] @ M, return_w[i] @ N + through_q[i]
    first, kept = np.empty((s, n)), None
    for c, held in enumerate(stuck):
        rows = slice(2 * c, 2 * c + 2)
        values, vectors = np.linalg.eig(np.eye(2) if held else M[rows, rows])
        neutral = np.abs(1.0 - values) < NEUTRAL
        if neutral.any() and kept is None:
            kept = start()
        parts = np.linalg.solve(vectors, N[rows])
        parts[~neutral] /= (1.0 - values[~neutral])[:, None]
        if neutral.any():
            parts[neutral] = np.linalg.solve(vectors, kept[rows])[neutral]
        first[rows] = (vectors @ parts).real
    dw = np.einsum("ist,tk->isk", Ms, first) + Ns
    for c in np.flatnonzero(stuck):  # its slider never moves (a graze's differences would)
        dw[:, 2 * c : 2 * c + 2] = kept[2 * c : 2 * c + 2]
    return dw
