"""The Jacobian of the wheel's first-order system at a static equilibrium, analytic from the
force model of docs/theory.md ("Linear stability" there gives the formulas).

State ``x = (q, q')``, ``q`` blade-major (``q[s m + j]``, ``N m`` entries), as the TS state
without the work integrals. At a static state (``q' = 0``, nozzle excluded)::

    J = [[0, I], [-K_R + F_q, -beta_D K_R + F_v]]

- ``F_q``: the normal contact springs through the rigid-arm kinematics, with the geometric
  terms of the preload (the arm direction ``e`` and the force transfer ``L/|d|`` move with
  ``q``); friction and Van der Pol forces are proportional to ``q'`` and add nothing here;
- ``F_v``: micro-slip friction, the linear damper ``-(f_s F_n / v_k) (I - n n^T) v_c`` it is
  below ``v_k``, and the Van der Pol damping ``mu (1 - (y/r)^2)`` (absolute) or its relative
  form (neighbours coupled), on the aero direction ``p`` (one mode when ``flutter.mode`` is
  set: the force parameters carry that choice).

Contacts open at the equilibrium (``F_n <= 0``) contribute nothing. :class:`ContactLinearisation`
keeps, per contact kind and blade pair, the map from the two blades' modal coordinates to the
local relative displacement, which also tells what a mode does at the contacts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from wheelrom.forces.parameters import VDP_ABSOLUTE, VDP_RELATIVE, ForceParameters


@dataclass
class ContactLinearisation:
    """Contact kind ``c``, blade pair ``(s, s+1)`` at the equilibrium.

    ``gap_map``: ``(3, 2 m)`` d(local relative displacement xi, eta, zeta) / d(q_s, q_{s+1})
    [m / (sqrt(kg) m)]; ``normal_force`` [N] (0: open); ``margin`` [m]: how far the normal
    gap may still open before the contact lifts off (``F_n / k_c``; 0 when open);
    ``stiffness``, ``damping``: ``(2 m, 2 m)`` rows (force on s, force on s+1), columns
    (q_s, q_{s+1}) or (q'_s, q'_{s+1}) of ``F_q`` and ``F_v``.
    """

    gap_map: np.ndarray
    normal_force: float
    margin: float
    stiffness: np.ndarray
    damping: np.ndarray


def contact_linearisation(params: ForceParameters, q: np.ndarray, c: int,
                          s: int) -> ContactLinearisation:  # fmt: skip
    """Linearise contact kind ``c`` of pair ``(s, s+1)`` at the static state ``q`` ``(N, m)``."""
    cp, R = params.contacts, params.rotation
    N, m = q.shape
    sn = (s + 1) % N
    XA, XB = cp.shape_A[c], cp.shape_B[c]  # (3, m)
    D = XB - XA
    T = cp.frame[c, s]
    n = T[1]  # surface normal eta in sector s's frame
    L, k, preload = cp.arm_length[c], cp.stiffness[c, s], cp.preload[c]
    f_s, v_k = params.friction[0], params.friction[3]
    chord0 = cp.point_B[c] - cp.point_A[c]
    e0 = chord0 / np.linalg.norm(chord0)
    d = chord0 + D @ q[s]
    nd = np.linalg.norm(d)
    e = d / nd
    P = np.eye(3) - np.outer(e, e)
    uc = R @ (XA @ q[sn]) - XA @ q[s] - L * (e - e0)
    gap = float(n @ uc)
    normal_force = preload - k * gap
    # d(d)/dy and d(e)/dy over y = (q_s, q_{s+1})
    dd = np.hstack([D, np.zeros((3, m))])
    de = P @ dd / nd
    duc = np.hstack([-XA, R @ XA]) - L * de
    gap_map = T @ duc
    stiffness = np.zeros((2 * m, 2 * m))
    damping = np.zeros((2 * m, 2 * m))
    if normal_force > 0.0:
        F = normal_force * n  # the force on A_{s+1}, sector s's frame
        dF = np.outer(n, -k * (n @ duc))
        # the arm end's share moved onto B: F_B = -(L/|d|) P F, and its variation
        d_inv = -(e @ dd) / nd**2
        PF = P @ F
        # d(P F) = -(de (e.F) + e (F^T de)) + P dF, d(1/|d|) = d_inv
        dFB = -L * (np.outer(PF, d_inv) + (P @ dF - (e @ F) * de - np.outer(e, F @ de)) / nd)
        stiffness = _transfer(XA, D, R, dF, dFB)
        # micro-slip friction: a linear damper in the tangent plane
        tangent = np.eye(3) - np.outer(n, n)
        dvc = np.hstack([-XA - L * P @ D / nd, R @ XA])
        dF_v = -(f_s * normal_force / v_k) * tangent @ dvc
        damping = _transfer(XA, D, R, dF_v, -(L / nd) * P @ dF_v)
    return ContactLinearisation(gap_map, float(max(normal_force, 0.0)),
                                float(max(normal_force, 0.0) / k), stiffness, damping)  # fmt: skip


def _transfer(XA, D, R, dF, dFB) -> np.ndarray:
    """Generalised forces on (s, s+1) of a variation ``dF`` of the force on ``A_{s+1}`` and
    ``dFB`` of the arm end's share on ``B`` (``F_A = -F - F_B`` on blade s)."""
    on_s = -XA.T @ dF + D.T @ dFB
    on_next = XA.T @ R.T @ dF
    return np.vstack([on_s, on_next])


def van_der_pol_damping(params: ForceParameters, q: np.ndarray) -> sp.csr_matrix:
    """``(N m, N m)`` d(Van der Pol force)/dq' at the static state ``q`` ``(N, m)``."""
    N, m = q.shape
    p = params.aero
    ppT = np.outer(p, p)
    y = q @ p
    blocks = _BlockSum(N, m)
    if params.vdp_model == VDP_ABSOLUTE:
        for s, c in enumerate(params.vdp_mu * (1.0 - (y / params.vdp_r) ** 2)):
            blocks.add(s, s, c * ppT)
    elif params.vdp_model == VDP_RELATIVE:
        # g_s = c_s D'_s, D_s = y_s - y_{s-1}; blade s gets p (g_s - g_{s+1})
        c = params.vdp_mu * (1.0 - ((y - np.roll(y, 1)) / params.vdp_r) ** 2)
        for s in range(N):
            sn, sp_ = (s + 1) % N, (s - 1) % N
            blocks.add(s, s, (c[s] + c[sn]) * ppT)
            blocks.add(s, sp_, -c[s] * ppT)
            blocks.add(s, sn, -c[sn] * ppT)
    return blocks.matrix()


class _BlockSum:
    """A sparse ``(N m, N m)`` matrix summed from ``(m, m)`` blade blocks."""

    def __init__(self, N: int, m: int):
        self.N, self.m = N, m
        self.rows, self.cols, self.values = [], [], []

    def add(self, s: int, t: int, block: np.ndarray) -> None:
        m = self.m
        r, c = np.meshgrid(np.arange(m) + s * m, np.arange(m) + t * m, indexing="ij")
        self.rows.append(r.ravel())
        self.cols.append(c.ravel())
        self.values.append(np.asarray(block, float).ravel())

    def matrix(self) -> sp.csr_matrix:
        n = self.N * self.m
        if not self.values:
            return sp.csr_matrix((n, n))
        data = (np.concatenate(self.values), (np.concatenate(self.rows), np.concatenate(self.cols)))
        return sp.coo_matrix(data, shape=(n, n)).tocsr()  # duplicates are summed


def force_derivatives(params: ForceParameters, q: np.ndarray):
    """``(F_q, F_v, contacts)`` at the static state ``q`` ``(N, m)``: sparse ``(N m, N m)``
    derivatives of the generalised force and the :class:`ContactLinearisation` of every
    contact, ``contacts[c][s]``."""
    N, m = q.shape
    Fq, Fv = _BlockSum(N, m), _BlockSum(N, m)
    contacts = []
    for c in range(len(params.contacts.kinds)):
        row = []
        for s in range(N):
            lin = contact_linearisation(params, q, c, s)
            row.append(lin)
            if lin.normal_force > 0.0:
                for a, blade in enumerate((s, (s + 1) % N)):
                    for b, other in enumerate((s, (s + 1) % N)):
                        rows, cols = slice(a * m, (a + 1) * m), slice(b * m, (b + 1) * m)
                        Fq.add(blade, other, lin.stiffness[rows, cols])
                        Fv.add(blade, other, lin.damping[rows, cols])
        contacts.append(row)
    return Fq.matrix(), Fv.matrix() + van_der_pol_damping(params, q), contacts


def jacobian(K: np.ndarray | sp.spmatrix, beta: float, Fq, Fv) -> sp.csr_matrix:
    """``(2 N m, 2 N m)`` ``[[0, I], [-K + F_q, -beta K + F_v]]`` (``K``: ``K_R``)."""
    K = sp.csr_matrix(K)
    n = K.shape[0]
    return sp.bmat([[None, sp.identity(n)], [-K + Fq, -beta * K + Fv]], format="csr")
