"""The Jacobian of the wheel's first-order system at a static equilibrium, analytic from the
force model of docs/theory.md ("Linear stability" there gives the formulas).

State ``x = (q, q')``, ``q`` blade-major (``q[s m + j]``, ``N m`` entries), as the TS state
without the work integrals. At a static state (``q' = 0``, nozzle excluded)::

    J = [[0, I], [-K_R + F_q, -beta_D K_R + F_v]]

- ``F_q``: the normal contact springs through the rigid-arm kinematics, with the geometric
  terms of the preload (the arm direction ``e`` and the force transfer ``L/|d|`` move with
  ``q``), and the aerodynamic table's stiffness part (``-mu a_j p p^T``); friction and Van der
  Pol forces are proportional to ``q'`` and add nothing here;
- under the elastic contact law (``contacts.law = "elastic"``) every closed contact sticks
  at the equilibrium (its slider at rest there, no tangential force): ``F_q`` gets its
  tangential spring ``-k_t (I - n n^T) u_c`` and friction adds no damping;
- ``F_v``: the paper law's micro-slip friction, the linear damper ``-(f_s F_n / v_k) (I -
  n n^T) v_c`` it is below ``v_k``, and the Van der Pol damping ``mu (1 - (y/r)^2)``
  (absolute) or its relative
  form (neighbours coupled), on the aero direction ``p`` (one mode when ``flutter.mode`` is
  set: the force parameters carry that choice), or the aerodynamic table's damping part
  (``-mu b_j p p^T`` at block ``(s, s + j)``).

Contacts open at the equilibrium (``F_n <= 0``) contribute nothing. :class:`ContactLinearisation`
keeps, per contact kind and blade pair, the map from the two blades' modal coordinates to the
local relative displacement, which also tells what a mode does at the contacts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from wheelrom.forces.parameters import AERO_TABLE, VDP_ABSOLUTE, VDP_RELATIVE, ForceParameters


@dataclass
class ContactLinearisation:
    """Contact kind ``c`` at the equilibrium, every blade pair ``(s, s+1)`` (``N`` of them).

    ``gap_map``: ``(N, 3, 2 m)`` d(local relative displacement xi, eta, zeta) / d(q_s,
    q_{s+1}) [m / (sqrt(kg) m)]; ``normal_force`` ``(N,)`` [N] (0: open); ``margin``
    ``(N,)`` [m]: how far the normal gap may still open before the contact lifts off
    (``F_n / k_c``; 0 when open); ``stiffness``, ``damping``: ``(N, 2 m, 2 m)`` rows (force on
    s, force on s+1), columns (q_s, q_{s+1}) or (q'_s, q'_{s+1}) of ``F_q`` and ``F_v``.
    """

    gap_map: np.ndarray
    normal_force: np.ndarray
    margin: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray


def contact_linearisation(params: ForceParameters, q: np.ndarray, c: int,
                          static: bool = False) -> ContactLinearisation:
    """Linearise contact kind ``c`` of every blade pair at the static state ``q`` ``(N, m)``
    (vectorised over the pairs; formulas in docs/theory.md, "Linear stability"). ``static``:
    the tangent of the static preload problem, where the elastic law's sliders follow the
    load (no tangential spring), as the paper law's friction at rest."""
    cp, R = params.contacts, params.rotation
    N, m = q.shape
    XA, XB = cp.shape_A[c], cp.shape_B[c]  # (3, m)
    D = XB - XA
    T = cp.frame[c]  # (N, 3, 3)
    n = T[:, 1]  # surface normal eta of each pair, sector s's frame
    L, k, preload = cp.arm_length[c], cp.stiffness[c], cp.preload[c]
    f_s, v_k = params.law.static, params.law.microslip_velocity
    chord0 = cp.point_B[c] - cp.point_A[c]
    e0 = chord0 / np.linalg.norm(chord0)
    d = chord0 + q @ D.T  # (N, 3)
    nd = np.linalg.norm(d, axis=1)[:, None, None]  # (N, 1, 1)
    e = d / nd[:, :, 0]
    P = np.eye(3) - e[:, :, None] * e[:, None, :]  # (N, 3, 3)
    uc = np.roll(q, -1, axis=0) @ XA.T @ R.T - q @ XA.T - L * (e - e0)
    normal_force = preload - k * np.einsum("ni,ni->n", n, uc)
    # variations over y = (q_s, q_{s+1}): d(d)/dy, d(e)/dy, d(u_c)/dy
    dd = np.hstack([D, np.zeros((3, m))])  # (3, 2m)
    de = P @ dd / nd  # (N, 3, 2m)
    duc = np.hstack([-XA, R @ XA]) - L * de
    gap_map = T @ duc
    closed = normal_force > 0.0
    F = normal_force[:, None] * n  # the force on A_{s+1}
    dF = n[:, :, None] * (-k[:, None] * np.einsum("ni,nij->nj", n, duc))[:, None, :]
    tangent = np.eye(3) - n[:, :, None] * n[:, None, :]
    elastic = params.law.elastic
    if elastic and not static:  # the stuck contact's spring (no force at rest: no geometric part)
        dF = dF - cp.tangential[c][:, None, None] * (tangent @ duc)
    # the arm end's share moved onto B: F_B = -(L/|d|) P F; d(1/|d|) = d_inv,
    # d(P F) = P dF - (e.F) de - e (F^T de)
    d_inv = -(e @ dd) / nd[:, :, 0] ** 2  # (N, 2m)
    eF = np.einsum("ni,ni->n", e, F)[:, None, None]
    FdE = np.einsum("ni,nij->nj", F, de)[:, None, :]
    dFB = -L * ((P @ F[:, :, None]) * d_inv[:, None, :]
                + (P @ dF - eF * de - e[:, :, None] * FdE) / nd)
    stiffness = _transfer(XA, D, R, dF, dFB)
    # micro-slip friction at rest: a linear damper in the tangent plane (the paper law; a
    # stuck elastic contact dissipates nothing)
    dvc = np.concatenate([-XA - L * P @ D / nd, np.broadcast_to(R @ XA, (N, 3, m))], axis=2)
    damper = 0.0 if elastic else f_s * normal_force / v_k
    dF_v = -np.broadcast_to(damper, (N,))[:, None, None] * (tangent @ dvc)
    damping = _transfer(XA, D, R, dF_v, -(L / nd) * (P @ dF_v))
    stiffness[~closed] = 0.0
    damping[~closed] = 0.0
    held = np.where(closed, normal_force, 0.0)
    return ContactLinearisation(gap_map, held, held / k, stiffness, damping)


def _transfer(XA, D, R, dF, dFB) -> np.ndarray:
    """``(N, 2m, 2m)`` generalised forces on (s, s+1) of variations ``dF`` ``(N, 3, 2m)`` of
    the force on ``A_{s+1}`` and ``dFB`` of the arm end's share on ``B`` (``F_A = -F - F_B``
    on blade s)."""
    on_s = -XA.T @ dF + D.T @ dFB
    on_next = XA.T @ R.T @ dF
    return np.concatenate([on_s, on_next], axis=1)


def van_der_pol_damping(params: ForceParameters, q: np.ndarray) -> sp.csr_matrix:
    """``(N m, N m)`` d(Van der Pol force)/dq' at the static state ``q`` ``(N, m)``."""
    N, m = q.shape
    p = params.aero
    ppT = np.outer(p, p)
    y = q @ p
    blocks = _BlockSum(N, m)
    blades = np.arange(N)
    if params.vdp_model == VDP_ABSOLUTE:
        c = params.vdp_mu * (1.0 - (y / params.vdp_r) ** 2)
        blocks.add(blades, blades, c[:, None, None] * ppT)
    elif params.vdp_model == VDP_RELATIVE:
        # g_s = c_s D'_s, D_s = y_s - y_{s-1}; blade s gets p (g_s - g_{s+1})
        c = params.vdp_mu * (1.0 - ((y - np.roll(y, 1)) / params.vdp_r) ** 2)
        c_next = np.roll(c, -1)
        blocks.add(blades, blades, (c + c_next)[:, None, None] * ppT)
        blocks.add(blades, (blades - 1) % N, -c[:, None, None] * ppT)
        blocks.add(blades, (blades + 1) % N, -c_next[:, None, None] * ppT)
    elif params.vdp_model == AERO_TABLE:
        return _influence(params, params.aero_velocity)
    return blocks.matrix()


def aero_stiffness(params: ForceParameters, N: int, m: int) -> sp.csr_matrix:
    """``(N m, N m)`` d(aerodynamic-table force)/dq: ``-mu a_j p p^T`` at block ``(s, s+j)``
    (zero for the Van der Pol models, whose force vanishes at rest)."""
    if params.vdp_model == AERO_TABLE:
        return _influence(params, params.aero_displacement)
    return sp.csr_matrix((N * m, N * m))


def _influence(params: ForceParameters, coefficients: np.ndarray) -> sp.csr_matrix:
    """``-mu c_j p p^T`` at every block ``(s, s + j)`` (the table's coefficients ``c``): the
    circulant of ``c`` times ``p p^T``, which has one entry when one mode carries the force
    (a Kronecker product keeps it so: ``N^2`` entries, not ``N^2 m^2``)."""
    N = params.blades
    blades = np.arange(N)
    circulant = -params.vdp_mu * coefficients[(blades[None, :] - blades[:, None]) % N]
    pp = sp.csr_matrix(np.outer(params.aero, params.aero))
    return sp.kron(sp.csr_matrix(circulant), pp, format="csr")


class _BlockSum:
    """A sparse ``(N m, N m)`` matrix summed from ``(m, m)`` blade blocks."""

    def __init__(self, N: int, m: int):
        self.N, self.m = N, m
        self.rows, self.cols, self.blocks = [], [], []

    def add(self, s, t, blocks: np.ndarray) -> None:
        """Add ``blocks`` ``(..., m, m)`` at block rows ``s`` (force on blade s) and block
        columns ``t`` (integers or arrays of them)."""
        blocks = np.asarray(blocks, float).reshape(-1, self.m, self.m)
        self.rows.append(np.broadcast_to(s, blocks.shape[:1]))
        self.cols.append(np.broadcast_to(t, blocks.shape[:1]))
        self.blocks.append(blocks)

    def matrix(self) -> sp.csr_matrix:
        N, m = self.N, self.m
        if not self.blocks:
            return sp.csr_matrix((N * m, N * m))
        s, t = np.concatenate(self.rows), np.concatenate(self.cols)
        local = np.arange(m)
        rows = np.broadcast_to(s[:, None, None] * m + local[None, :, None], (s.size, m, m))
        cols = np.broadcast_to(t[:, None, None] * m + local[None, None, :], (s.size, m, m))
        data = (np.concatenate(self.blocks).ravel(), (rows.ravel(), cols.ravel()))
        return sp.coo_matrix(data, shape=(N * m, N * m)).tocsr()  # duplicates are summed


def force_derivatives(params: ForceParameters, q: np.ndarray, stiffness_only: bool = False):
    """``(F_q, F_v, contacts)`` at the static state ``q`` ``(N, m)``: sparse ``(N m, N m)``
    derivatives of the generalised force and the :class:`ContactLinearisation` of every
    contact kind (``F_v`` is None with ``stiffness_only``: the static tangent)."""
    N, m = q.shape
    Fq, Fv = _BlockSum(N, m), _BlockSum(N, m)
    contacts = []
    pairs = np.arange(N)
    for c in range(len(params.contacts.kinds)):
        lin = contact_linearisation(params, q, c, static=stiffness_only)
        contacts.append(lin)
        for a, blade in enumerate((pairs, (pairs + 1) % N)):
            for b, other in enumerate((pairs, (pairs + 1) % N)):
                rows, cols = slice(a * m, (a + 1) * m), slice(b * m, (b + 1) * m)
                Fq.add(blade, other, lin.stiffness[:, rows, cols])
                if not stiffness_only:
                    Fv.add(blade, other, lin.damping[:, rows, cols])
    Fq = Fq.matrix() + aero_stiffness(params, N, m)
    if stiffness_only:
        return Fq, None, contacts
    return Fq, Fv.matrix() + van_der_pol_damping(params, q), contacts


def jacobian(K: np.ndarray | sp.spmatrix, beta: float, Fq, Fv) -> sp.csr_matrix:
    """``(2 N m, 2 N m)`` ``[[0, I], [-K + F_q, -beta K + F_v]]`` (``K``: ``K_R``)."""
    K = sp.csr_matrix(K)
    n = K.shape[0]
    return sp.bmat([[None, sp.identity(n)], [-K + Fq, -beta * K + Fv]], format="csr")
