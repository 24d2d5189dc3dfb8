"""The elastic law's stuck springs, in part, inside the exponential scheme's exact propagator.

Why (issue #44, measured in docs/performance.md): the exponential scheme propagates the
segment block ``A0`` of ``K_R`` exactly and the contacts explicitly. Under the elastic law a
stuck contact is a spring ``k_t`` in both tangential directions, and that explicit coupling
bounds the step at 5.9 us on the default wheel (the paper law: 20 us). Each blade's own share
of the springs (the motion of its arm end and of its point A, the other blade held) is a
constant matrix ``S`` of the blade's modes, so ``A0 + S`` can be propagated exactly instead,
the explicit part then carrying ``+S w`` (``w = q + beta_D q'``): the same equations. Moving
all of ``S`` leaves an open contact with ``+S`` explicit, an explicit negative stiffness the
scheme does not hold at the larger step; half of it holds both ends (stuck and open) to 8 us
(:data:`FRACTION`).

The shift must not depend on the contact angle: the cases of one batch (a sweep's angles)
share the kernel's basis, which diagonalises ``A0 + S``. So ``S`` is that of an isotropic
spring ``k`` (the same in the normal and both tangential directions) between the arm end of
blade ``s`` and the point A of blade ``s + 1``: ``k = FRACTION min_s k_t``, per contact kind.

The shift pays where the stuck springs stiffen a segment that is already stiff (the default
wheel: ``S`` up to 0.06 of ``A0``'s largest eigenvalue). A contact far stiffer than its blade
(Den Hartog's ring of one-mode blades, ``k_t`` 5e4 times the blade's stiffness) sets the
propagator's fastest frequency itself, and an open contact's explicit ``+S`` then needs a
smaller step than the unshifted scheme's (measured: 2.3 us against 9.5 us), and the step
check finds spurious stable islands far above it. So ``k`` is scaled down until the largest
eigenvalue of ``S`` is at most :data:`CAP` times ``A0``'s.
"""

from __future__ import annotations

import numpy as np

# the share of the smallest stuck tangential stiffness moved into the propagator (measured on
# the default wheel, 0 and 90 deg: 0.3-0.4 are stuck-limited at 7 us, 0.6 open-limited at 7-8
# us; 0.5 holds both to 8 us; docs/performance.md)
FRACTION = 0.5
# the largest eigenvalue of S against A0's (measured on Den Hartog's one-mode ring: 1090 still
# gains, 1e4 loses; the small test wheel is at 1.8, the default wheel at 0.06)
CAP = 2.0


def shift_stiffness(model, params) -> np.ndarray:
    """``(K,)`` [N/m]: the isotropic spring per contact kind moved into the propagator of
    ``model``'s segment block ``A0`` (zeros under the paper law, whose contacts stay
    explicit): ``FRACTION min_s k_t``, scaled down to :data:`CAP`."""
    c = params.contacts
    if not params.law.elastic or c.tangential.size == 0:
        return np.zeros(len(c.kinds))
    k = FRACTION * np.min(c.tangential, axis=1)
    largest = np.linalg.eigvalsh(spring_matrix(params, k))[-1]
    cap = CAP * max(np.linalg.eigvalsh(model.A0)[-1], 0.0)
    return k * (cap / largest) if largest > cap else k


def arm_maps(point_A: np.ndarray, point_B: np.ndarray, arm: float) -> tuple[float, np.ndarray]:
    """``(L / l0, e0)``: the arm end moves by ``u_C = u_A + (L / l0) Pi (u_B - u_A)`` to first
    order, ``Pi = I - e0 e0^T`` (``e0``: the undeformed direction A -> B, ``l0`` its length;
    :mod:`wheelrom.transient.contact_kernel`'s ``L (e - e0)`` linearised)."""
    d0 = np.asarray(point_B, dtype=float) - np.asarray(point_A, dtype=float)
    l0 = float(np.linalg.norm(d0))
    return float(arm) / l0, d0 / l0


def shift_matrix(model, params) -> np.ndarray:
    """``(m, m)`` [1/s^2]: the springs ``S`` the kernel propagates with ``model.A0``
    (:func:`spring_matrix` of :func:`shift_stiffness`)."""
    return spring_matrix(params, shift_stiffness(model, params))


def spring_matrix(params, stiffness: np.ndarray) -> np.ndarray:
    """``(m, m)`` [1/s^2] in the segment modes: ``S = sum_kinds k (X_C^T X_C + X_A^T X_A)``,
    ``X_C = P_A X_A + P_B X_B`` the arm end's displacement per mode (``P_A = I - (L/l0) Pi``,
    ``P_B = (L/l0) Pi``), ``X_A`` blade ``s + 1``'s point A (its rotation into blade ``s``'s
    frame drops out of an isotropic spring). ``stiffness``: ``k`` ``(K,)`` [N/m]."""
    c = params.contacts
    k = np.asarray(stiffness, dtype=float)
    S = np.zeros((params.modes, params.modes))
    for kind in range(len(c.kinds)):
        if k[kind] == 0.0:
            continue
        scale, e0 = arm_maps(c.point_A[kind], c.point_B[kind], c.arm_length[kind])
        Pi = np.eye(3) - np.outer(e0, e0)
        XA, XB = c.shape_A[kind], c.shape_B[kind]
        XC = XA + scale * Pi @ (XB - XA)
        S += k[kind] * (XC.T @ XC + XA.T @ XA)
    return 0.5 * (S + S.T)
