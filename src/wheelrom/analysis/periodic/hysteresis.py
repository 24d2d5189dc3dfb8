"""The harmonic balance's Jacobian under the elastic law: the tangent of the closed
hysteresis loop (docs/theory.md, "Harmonic balance").

The AFT marches each contact's slider through the period's samples until its loop closes
(:meth:`~wheelrom.analysis.periodic.harmonic_balance.WaveBalance._evaluate`): a sample's
force depends on the motion before it. With ``w_i`` the slider sample ``i`` uses in the
closed loop, its force is ``f(q_i, v_i, w_i)`` and the slider it returns ``g(q_i, w_i)``;
both are differenced at each sample with the sliders held
(:meth:`HysteresisLoop.slider_derivatives`, :func:`differences`), and the tangent ``dw_i /
dX`` is carried around the period and closed contact by contact (:func:`loop_tangent`).
Units: sliders [m], modal coordinates [sqrt(kg) m], forces [N].
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

#: differencing step of a held slider [m] (:meth:`HysteresisLoop.slider_derivatives`): a
#: slip step's return shrinks the slider's motion across its direction by ``mu F_n /
#: |trial|``, which a step of ``k_t dw`` beyond a grazed limit moves off 1 by ``k_t dw / (mu
#: F_n)`` (1.7e-5 for 1e-10 m on the paper wheel's 3.2 kN shroud): far below
#: :data:`NEUTRAL` at this step, whose differences still carry 1e-8 of the slider's magnitude
SLIDER_STEP = 1e-13
#: a hysteresis loop's period map leaves its sliders unchanged along an eigenvector whose
#: eigenvalue lies within this of 1 (:func:`loop_tangent`)
NEUTRAL = 1e-6


class HysteresisLoop:
    """The closed hysteresis loop of blade 0's contacts in a wave's harmonic balance: the
    record of the balance's last evaluation with held sliders and the loop's part of the
    Jacobian.

    Inputs (the balance's, :class:`~wheelrom.analysis.periodic.harmonic_balance.
    WaveBalance`): ``contacts`` ``K`` contact kinds; ``samples`` ``n_t`` per period; the
    window's synthesis ``E`` ``(3, n_t, 2H+1)`` and the projector ``P`` ``(2H+1, n_t)`` onto
    the harmonics; ``fd_step`` ``(m,)`` the modal differencing steps [sqrt(kg) m];
    ``sliders_at_rest(q)`` the sliders ``(K, 3, 2)`` [m] at rest at the window state ``q``
    ``(3, m)`` (the march's start); ``evaluate(q, v, lam, held)`` the forces on blade 0
    ``(S, m)`` of ``S`` window states ``(S, 3, m)`` with their sliders ``held`` ``(S, K, 3,
    2)`` (which calls :meth:`hold`).

    State: ``held`` and ``returned`` ``(S, K, 3, 2)``, the sliders the last held evaluation
    read and those it returned (``returned`` None after an evaluation without held sliders:
    the differences are then central); ``shaken`` ``(2 K,)``, which of the loop's contacts
    left their start on the way to the loop (:meth:`find_shaken`)."""

    def __init__(self, contacts: int, samples: int, synthesis: np.ndarray,
                 projector: np.ndarray, fd_step: np.ndarray,
                 sliders_at_rest: Callable[[np.ndarray], np.ndarray],
                 evaluate: Callable[..., np.ndarray]):
        self.nt, self.E, self.P, self.fd_step = samples, synthesis, projector, fd_step
        self.modes = len(fd_step)
        self.sliders_at_rest, self.evaluate = sliders_at_rest, evaluate
        # the sliders of blade 0's contacts (pairs 0 and 2 of the window; pair 1 acts on the
        # neighbours only), flat in (K, 3, 2): a contact's two components side by side
        self.components = np.array([(k * 3 + pair) * 2 + j for k in range(contacts)
                                    for pair in (0, 2) for j in (0, 1)])
        self.held = None
        self.returned = None
        self.shaken = None

    def hold(self, held: np.ndarray | None) -> np.ndarray | None:
        """Record an evaluation with the sliders ``held`` ``(S, K, 3, 2)`` (None: a march or
        the paper law, no record): the array ``(S, K, 3, 2)`` it is to fill with the sliders
        it returns."""
        if held is None:
            self.returned = None
        else:
            self.held, self.returned = held, np.empty_like(held)
        return self.returned

    def find_shaken(self, q: np.ndarray, marched: np.ndarray) -> None:
        """Mark the loop's contacts whose sliders in the march's loop, ``marched`` ``(n_t, K,
        3, 2)`` [m] at the samples ``q`` ``(n_t, 3, m)``, left their start (the rest never
        slipped): the branch they take in :meth:`same_branch`."""
        start = self.sliders_at_rest(np.ascontiguousarray(q.mean(axis=0)))
        moved = marched.reshape(self.nt, -1)[:, self.components] != start.ravel()[
            self.components]
        self.shaken = moved.any(axis=0).reshape(-1, 2).any(axis=1)

    def same_branch(self, copies: int) -> np.ndarray | None:
        """``(copies, n_t)``: whether every contact of blade 0 sticks (or not) in each state
        of the last held evaluation as on its branch (None: no sliders held): the first
        copy's (the base), but the slip branch where a contact shaken down onto the
        Coulomb limit grazes it (:attr:`shaken`)."""
        if self.returned is None:
            return None
        held = self.held.reshape(copies, self.nt, -1)[:, :, self.components]
        stuck = (self.returned_components(copies) == held).reshape(
            copies, self.nt, -1, 2).all(axis=3)
        branch = stuck[0].copy()  # (n_t, contacts)
        # a contact the march shook down onto the Coulomb limit (it slipped on its way to
        # the loop and sticks in it) grazes the limit where a perturbation slips it: its
        # slider is held there by the limit, the slip branch's
        branch[:, self.shaken] &= stuck[:, :, self.shaken].all(axis=0)
        return (stuck == branch).all(axis=2)

    def returned_components(self, copies: int) -> np.ndarray:
        """``(copies, n_t, s)`` the loop's ``s`` slider components the last held evaluation
        returned."""
        return self.returned.reshape(copies, self.nt, -1)[:, :, self.components]

    def jacobian(self, q: np.ndarray, v: np.ndarray, lam: float, marched: np.ndarray,
                 dslider: np.ndarray) -> np.ndarray:
        """The hysteresis' part of the balance's ``dR/dX`` ``(2H+1, m, 2H+1, m)`` at the
        samples ``q``, ``v`` ``(n_t, 3, m)`` of the march's loop ``marched`` ``(n_t, K, 3,
        2)``, from the sample-local derivatives of the returned sliders in the window's
        displacements ``dslider`` ``(3, n_t, s, m)`` (those sliders held, after
        :meth:`find_shaken`).

        With ``w_i`` the slider sample ``i`` uses in the march's converged loop, ``f_i =
        f(q_i, v_i, w_i)`` and ``w_(i+1) = g(q_i, w_i)``. Both are differenced at each sample
        with the others held (in the physical inputs by the balance, in each slider
        component of blade 0's contacts here), and the tangent ``dw_i / dX`` is carried
        around the period and closed per contact (:func:`loop_tangent`): one march and
        about 150 periods of unmarched samples instead of a march for each of the ``(2H+1)
        m`` unknowns."""
        harmonics, m, nt = self.P.shape[0], self.modes, self.nt
        force_w, return_w = self.slider_derivatives(q, v, lam, marched)
        through_q = np.einsum("wih,wisl->ishl", self.E, dslider).reshape(
            nt, -1, harmonics * m)
        dw = loop_tangent(return_w, through_q, ~self.shaken,
                          lambda: self.start_derivative(q))  # (n_t, s, n m)
        part = np.einsum("pi,ijs,isk->pjk", self.P, force_w, dw, optimize=True)
        return part.reshape(harmonics, m, harmonics, m)

    def slider_derivatives(self, q: np.ndarray, v: np.ndarray, lam: float,
                           marched: np.ndarray):
        """``(d f_i / d w_i, d w_(i+1) / d w_i)`` ``(n_t, m, s)``, ``(n_t, s, s)``: central
        differences in each of the loop's ``s`` slider components, held at every sample."""
        nt, m, s = self.nt, self.modes, len(self.components)
        copies = 2 * s + 1  # the base, then + and - of each component
        Q = np.broadcast_to(q, (copies, *q.shape)).reshape(-1, 3, m).copy()
        V = np.broadcast_to(v, (copies, *v.shape)).reshape(-1, 3, m).copy()
        sliders = tiled(marched, copies).reshape(copies, nt, -1)
        for c, index in enumerate(self.components):
            sliders[1 + 2 * c, :, index] += SLIDER_STEP
            sliders[2 + 2 * c, :, index] -= SLIDER_STEP
        f = self.evaluate(Q, V, lam, sliders.reshape(copies * nt, *marched.shape[1:]))
        same, step = self.same_branch(copies), np.full((s, 1, 1), SLIDER_STEP)
        d_force = differences(f.reshape(copies, nt, m), step, same)
        d_return = differences(self.returned_components(copies), step, same)
        return d_force.transpose(1, 2, 0), d_return.transpose(1, 2, 0)

    def start_derivative(self, q: np.ndarray) -> np.ndarray:
        """``(s, (2H+1) m)`` d(the march's start, the sliders at rest at the period's mean
        motion)/dX: a contact that sticks throughout keeps it (central differences)."""
        mean = q.mean(axis=0)  # (3, m): every window blade's c_0
        s = len(self.components)
        d = np.empty((3, self.modes, s))
        for w in range(3):
            for j in range(self.modes):
                step = self.fd_step[j]
                ends = []
                for sign in (1.0, -1.0):
                    moved = mean.copy()
                    moved[w, j] += sign * step
                    ends.append(self.sliders_at_rest(moved).ravel()[self.components])
                d[w, j] = (ends[0] - ends[1]) / (2 * step)
        return np.einsum("wjs,wh->shj", d, self.E.mean(axis=1)).reshape(s, -1)


def tiled(held: np.ndarray | None, copies: int) -> np.ndarray | None:
    """``held`` ``(n_t, K, 3, 2)`` sliders for ``copies`` periods of samples (None: none)."""
    return None if held is None else np.tile(held, (copies, 1, 1, 1))


def differences(f: np.ndarray, step: np.ndarray, same: np.ndarray | None) -> np.ndarray:
    """``(k, n_t, ...)`` differences of ``f`` ``(1 + 2 k, n_t, ...)`` (the base, then each of
    ``k`` perturbations by ``+step`` and ``-step``, ``step`` ``(k, 1, 1)``): central, but
    one-sided where only one side sticks and slips as the base does (``same`` ``(1 + 2 k,
    n_t)``, :meth:`HysteresisLoop.same_branch`; None: central throughout): the Coulomb limit
    is a kink of the elastic law, and a central difference across it averages its two
    branches (a contact that grazes the limit then looks half-stuck, and the loop around it
    goes wrong)."""
    plus, minus, base = f[1::2], f[2::2], f[0]
    d = (plus - minus) / (2 * step)
    if same is not None:
        forward, backward = same[1::2] & ~same[2::2], same[2::2] & ~same[1::2]
        d[forward] = ((plus - base) / step)[forward]
        d[backward] = ((base - minus) / step)[backward]
    return d


def loop_tangent(return_w: np.ndarray, through_q: np.ndarray, stuck: np.ndarray,
                 start: Callable[[], np.ndarray]) -> np.ndarray:
    """``dw_i / dX`` ``(n_t, s, n)``: the tangent of the sliders the samples use around a
    closed hysteresis loop, from ``w_(i+1) = g(q_i, w_i)``'s derivatives ``return_w``
    ``(n_t, s, s)`` (d/dw_i) and ``through_q`` ``(n_t, s, n)`` (d/dX through ``q_i``), for
    ``s`` slider components (two per contact) and ``n`` unknowns.

    Carried from the period's start, ``dw_i = gain_i dw_0 + offset_i``; around the period
    ``dw_(n_t) = Phi dw_0 + Gamma`` (docs/theory.md's names for the last ``gain`` and
    ``offset``). Contacts (pairs of components) are independent, so ``Phi`` is 2 x 2 blocks.
    Along an eigenvector of ``Phi`` whose eigenvalue has shrunk (a slip returns the slider
    onto the Coulomb limit, an opening to the motion) the loop is the sliders' fixed point,
    ``(1 - eigenvalue)^-1`` times ``Gamma``'s part; along one that the period leaves
    unchanged (the eigenvalue within :data:`NEUTRAL` of 1: a contact that sticks throughout,
    ``stuck`` ``(s / 2,)``, both; one that slips back and forth along one line, across it)
    the march keeps where it started, the sliders at rest at the mean motion, whose
    derivative ``start()`` gives ``(s, n)``."""
    nt, s, unknowns = through_q.shape
    gain, offset = np.eye(s), np.zeros((s, unknowns))
    gains, offsets = np.empty((nt, s, s)), np.empty((nt, s, unknowns))
    for i in range(nt):
        gains[i], offsets[i] = gain, offset
        gain, offset = return_w[i] @ gain, return_w[i] @ offset + through_q[i]
    first, kept = np.empty((s, unknowns)), None
    for c, sticks in enumerate(stuck):
        rows = slice(2 * c, 2 * c + 2)
        values, vectors = np.linalg.eig(np.eye(2) if sticks else gain[rows, rows])
        neutral = np.abs(1.0 - values) < NEUTRAL
        if neutral.any() and kept is None:
            kept = start()
        parts = np.linalg.solve(vectors, offset[rows])
        parts[~neutral] /= (1.0 - values[~neutral])[:, None]
        if neutral.any():
            parts[neutral] = np.linalg.solve(vectors, kept[rows])[neutral]
        first[rows] = (vectors @ parts).real
    dw = np.einsum("ist,tk->isk", gains, first) + offsets
    for c in np.flatnonzero(stuck):  # its slider never moves (a graze's differences would)
        dw[:, 2 * c : 2 * c + 2] = kept[2 * c : 2 * c + 2]
    return dw
