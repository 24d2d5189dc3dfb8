"""The contact part of the compiled kernel: per contact kind, the displacements and velocities
of the profile points of every column (blade, case), the kinematics of eqs. 16-20 and the
tangential law of :mod:`wheelrom.forces.contact_law` (the record every consumer reads),
branch-free so that it vectorises (docs/theory.md, docs/performance.md)."""

from __future__ import annotations

import math

import numba

from wheelrom.forces.contact_law import FREE, HELD_OPEN, LAW_SIZE, tangential_force
from wheelrom.forces.fastmath import NOALIAS
from wheelrom.runtime import kernel_cache as _kernel_cache
from wheelrom.transient.layout import (
    H_B,
    H_K,
    H_M,
    H_N,
    H_SLIDERS,
    I_ACTIVE,
    I_AP,
    I_ARM,
    I_BP,
    I_COL,
    I_FA,
    I_FB,
    I_FN,
    I_KC,
    I_KT,
    I_LAW,
    I_MODE,
    I_NORMAL,
    I_PRELOAD,
    I_R,
    I_SHIFTK,
    I_SHIFTP,
    I_STATE,
    I_T,
    I_UA,
    I_UB,
    I_VA,
    I_VB,
    I_WNEXT,
    I_WNONE,
    I_XA,
    I_XB,
    get,
)


@_kernel_cache.njit(fastmath={"contract"}, error_model="numpy")
def contacts(ctx, kind, N, m, K, B, Q, V, column, sliders):
    """Contact forces of contact ``kind`` at A (with the neighbour's push on it) and B of
    every column left in ``FA[kind]``, ``FB[kind]`` [N], its friction power per column added
    to ``column`` [W]; normal forces, states and the returned sliders left in the context.
    ``sliders``: ``(K, 2, N B)`` the elastic law's sliders of the state (unread under the
    paper law)."""
    NB = N * B
    W = (N + 1) * B
    c = kind
    XA = get(ctx, I_XA, K * 3 * m).reshape((K, 3, m))
    XB = get(ctx, I_XB, K * 3 * m).reshape((K, 3, m))
    UA = get(ctx, I_UA, 3 * W).reshape((3, W))
    UB = get(ctx, I_UB, 3 * NB).reshape((3, NB))
    VA = get(ctx, I_VA, 3 * W).reshape((3, W))
    VB = get(ctx, I_VB, 3 * NB).reshape((3, NB))
    FA = get(ctx, I_FA, K * 3 * NB).reshape((K, 3, NB))[c]
    FB = get(ctx, I_FB, K * 3 * NB).reshape((K, 3, NB))[c]
    FN = get(ctx, I_FN, 3 * W).reshape((3, W))
    # displacements and velocities of A and B of every column (ghost blade N = blade 0 for A):
    # five modes per pass over the columns (a pass of one mode is bound by the four
    # read-modify-writes of the sums; with five, by the multiply-adds)
    for a in range(3):
        ua = UA[a]
        ub = UB[a]
        va = VA[a]
        vb = VB[a]
        for col in range(NB):
            ua[col] = 0.0
            ub[col] = 0.0
            va[col] = 0.0
            vb[col] = 0.0
        j = 0
        while j + 5 <= m:
            xa = XA[c, a]
            xb = XB[c, a]
            xa0, xa1, xa2, xa3, xa4 = xa[j], xa[j + 1], xa[j + 2], xa[j + 3], xa[j + 4]
            xb0, xb1, xb2, xb3, xb4 = xb[j], xb[j + 1], xb[j + 2], xb[j + 3], xb[j + 4]
            q0, q1, q2, q3, q4 = Q[j], Q[j + 1], Q[j + 2], Q[j + 3], Q[j + 4]
            v0, v1, v2, v3, v4 = V[j], V[j + 1], V[j + 2], V[j + 3], V[j + 4]
            for col in range(NB):
                ua[col] += (
                    xa0 * q0[col] + xa1 * q1[col] + xa2 * q2[col] + xa3 * q3[col] + xa4 * q4[col]
                )
                ub[col] += (
                    xb0 * q0[col] + xb1 * q1[col] + xb2 * q2[col] + xb3 * q3[col] + xb4 * q4[col]
                )
                va[col] += (
                    xa0 * v0[col] + xa1 * v1[col] + xa2 * v2[col] + xa3 * v3[col] + xa4 * v4[col]
                )
                vb[col] += (
                    xb0 * v0[col] + xb1 * v1[col] + xb2 * v2[col] + xb3 * v3[col] + xb4 * v4[col]
                )
            j += 5
        while j < m:
            xa = XA[c, a, j]
            xb = XB[c, a, j]
            qj = Q[j]
            vj = V[j]
            for col in range(NB):
                ua[col] += xa * qj[col]
                ub[col] += xb * qj[col]
                va[col] += xa * vj[col]
                vb[col] += xb * vj[col]
            j += 1
        for b in range(B):
            ua[NB + b] = ua[b]
            va[NB + b] = va[b]
    Apt = get(ctx, I_AP, K * 3).reshape((K, 3))
    Bpt = get(ctx, I_BP, K * 3).reshape((K, 3))
    T = get(ctx, I_T, K * 9 * NB).reshape((K, 9, NB))
    kc = get(ctx, I_KC, K * NB).reshape((K, NB))
    normal = get(ctx, I_NORMAL, K * NB).reshape((K, NB))
    state = get(ctx, I_STATE, K * NB).reshape((K, NB))
    R = get(ctx, I_R, 9).reshape((3, 3))
    law = get(ctx, I_LAW, LAW_SIZE)
    k_t = get(ctx, I_KT, K * NB).reshape((K, NB))
    slider_next = get(ctx, I_WNEXT, K * 2 * NB).reshape((K, 2, NB))
    mode = get(ctx, I_MODE, K * NB).reshape((K, NB))
    geometry = (Apt[c, 0], Apt[c, 1], Apt[c, 2], Bpt[c, 0], Bpt[c, 1], Bpt[c, 2],
                get(ctx, I_ARM, K)[c], get(ctx, I_PRELOAD, K)[c])
    # the next blade's rows as 1-D views (a 2-D view UA[:, B:] would not be contiguous)
    next_a = (UA[0, B:], UA[1, B:], UA[2, B:], VA[0, B:], VA[1, B:], VA[2, B:])
    next_f = (FN[0, B:], FN[1, B:], FN[2, B:])
    _contact_columns(NB, UA, UB, VA, VB, *next_a, T[c], kc[c], R, geometry, law, k_t[c],
                     sliders[c, 0], sliders[c, 1], slider_next[c, 0], slider_next[c, 1],
                     FA, FB, *next_f, normal[c], state[c], column, mode[c])
    # the force on A_{s+1} of the last blade's arm went to the ghost column: blade 0
    for a in range(3):
        fa = FA[a]
        fn = FN[a]
        for b in range(B):
            fn[b] = fn[NB + b]
        for col in range(NB):
            fa[col] += fn[col]


@_kernel_cache.njit(fastmath={"contract"}, error_model="numpy", **NOALIAS)
def _contact_columns(NB, UA, UB, VA, VB, uax, uay, uaz, vax, vay, vaz, T, kc, R, geometry, law,
                     k_t, w_xi, w_zeta, wn_xi, wn_zeta, FA, FB, fnx, fny, fnz, normal, state,
                     column, mode):
    """The contact law of every column (eqs. 16-20), branch-free so that it vectorises (the
    law's choice is the same for every column: LLVM unswitches it out of the loop).

    ``uax ... vaz``, ``fnx ... fnz``: the rows of ``UA``, ``VA``, ``FN`` from the next blade
    on (entry ``c`` is blade ``s + 1``), as views: see :func:`_load_state` on offset indices.

    ``noalias``: the arrays are disjoint parts of the context; telling LLVM so removes the
    runtime overlap checks that otherwise keep this loop scalar.

    ``mode``: each column's contact mode (``FREE``: the law; ``HELD_OPEN``: no normal force;
    ``HELD_STICK``, ``HELD_SLIP``: closed, the normal spring past its lift-off, the elastic
    law's slider on that branch).
    """
    ax, ay, az, bx, by, bz, L, preload = geometry
    d0x, d0y, d0z = bx - ax, by - ay, bz - az
    l0 = math.sqrt(d0x * d0x + d0y * d0y + d0z * d0z)
    e0x, e0y, e0z = d0x / l0, d0y / l0, d0z / l0
    r00, r01, r02 = R[0, 0], R[0, 1], R[0, 2]
    r10, r11, r12 = R[1, 0], R[1, 1], R[1, 2]
    r20, r21, r22 = R[2, 0], R[2, 1], R[2, 2]
    for col in range(NB):
        # deformed arm direction e and its rate (eq. 16)
        dx = d0x + UB[0, col] - UA[0, col]
        dy = d0y + UB[1, col] - UA[1, col]
        dz = d0z + UB[2, col] - UA[2, col]
        ddx = VB[0, col] - VA[0, col]
        ddy = VB[1, col] - VA[1, col]
        ddz = VB[2, col] - VA[2, col]
        inv_nd = 1.0 / math.sqrt(dx * dx + dy * dy + dz * dz)
        ex, ey, ez = dx * inv_nd, dy * inv_nd, dz * inv_nd
        edd = ex * ddx + ey * ddy + ez * ddz
        edx = (ddx - ex * edd) * inv_nd
        edy = (ddy - ey * edd) * inv_nd
        edz = (ddz - ez * edd) * inv_nd
        # gap change in sector s's frame (eq. 17): R u_A(s+1) - u_A(s) - L (e - e0)
        ucx = r00 * uax[col] + r01 * uay[col] + r02 * uaz[col]
        ucy = r10 * uax[col] + r11 * uay[col] + r12 * uaz[col]
        ucz = r20 * uax[col] + r21 * uay[col] + r22 * uaz[col]
        vcx = r00 * vax[col] + r01 * vay[col] + r02 * vaz[col]
        vcy = r10 * vax[col] + r11 * vay[col] + r12 * vaz[col]
        vcz = r20 * vax[col] + r21 * vay[col] + r22 * vaz[col]
        ucx -= UA[0, col] + L * (ex - e0x)
        ucy -= UA[1, col] + L * (ey - e0y)
        ucz -= UA[2, col] + L * (ez - e0z)
        vcx -= VA[0, col] + L * edx
        vcy -= VA[1, col] + L * edy
        vcz -= VA[2, col] + L * edz
        t00, t01, t02 = T[0, col], T[1, col], T[2, col]
        t10, t11, t12 = T[3, col], T[4, col], T[5, col]
        t20, t21, t22 = T[6, col], T[7, col], T[8, col]
        gap = t10 * ucx + t11 * ucy + t12 * ucz  # local eta (eq. 18)
        u_xi = t00 * ucx + t01 * ucy + t02 * ucz
        u_zeta = t20 * ucx + t21 * ucy + t22 * ucz
        v_xi = t00 * vcx + t01 * vcy + t02 * vcz
        v_zeta = t20 * vcx + t21 * vcy + t22 * vcz
        held = mode[col]
        closed = preload - kc[col] * gap
        Fn = max(closed, 0.0) if held == FREE else (0.0 if held == HELD_OPEN else closed)
        F_xi, F_zeta, st, w0, w2 = tangential_force(law, u_xi, u_zeta, v_xi, v_zeta, w_xi[col],
                                                    w_zeta[col], Fn, k_t[col], held)
        wn_xi[col] = w0
        wn_zeta[col] = w2
        column[col] += F_xi * v_xi + F_zeta * v_zeta
        normal[col] = Fn
        state[col] = st
        # force on A_{s+1} in sector s's frame: T^T (F_xi, F_n, F_zeta)
        Fx = t00 * F_xi + t10 * Fn + t20 * F_zeta
        Fy = t01 * F_xi + t11 * Fn + t21 * F_zeta
        Fz = t02 * F_xi + t12 * Fn + t22 * F_zeta
        # blade s+1 in its own frame: R^T F (column nxt; the last blade's lands in the ghost)
        fnx[col] = r00 * Fx + r10 * Fy + r20 * Fz
        fny[col] = r01 * Fx + r11 * Fy + r21 * Fz
        fnz[col] = r02 * Fx + r12 * Fy + r22 * Fz
        # -F at the arm end moved exactly onto A and B: F_B = (L/|d|) F_perp
        Fe = -(Fx * ex + Fy * ey + Fz * ez)
        arm_scale = L * inv_nd
        fbx = arm_scale * (-Fx - Fe * ex)
        fby = arm_scale * (-Fy - Fe * ey)
        fbz = arm_scale * (-Fz - Fe * ez)
        FB[0, col] = fbx
        FB[1, col] = fby
        FB[2, col] = fbz
        FA[0, col] = -Fx - fbx
        FA[1, col] = -Fy - fby
        FA[2, col] = -Fz - fbz


@numba.njit(inline="always")
def slider_rows(u, ctx, n, K, NB, B):
    """``(K, 2, N B)`` the elastic law's sliders of the state ``u`` (a view); under the paper
    law, which has none, the context's zeros (``slider_none``, never written)."""
    if ctx[H_SLIDERS] > 0.0:
        start = 2 * n + 4 * B
        return u[start : start + K * 2 * NB].reshape((K, 2, NB))
    return get(ctx, I_WNONE, K * 2 * NB).reshape((K, 2, NB))


@_kernel_cache.njit(fastmath={"contract"}, error_model="numpy")
def slide_core(u, ctx):
    """The end of a step under the elastic law: every running case's sliders in ``u``
    returned onto the Coulomb limit at the state ``u`` (the contact law's return map,
    :func:`wheelrom.forces.contact_law.elastic_friction`); returns 1 when one moved (the
    integrator must then restart: the force at the step's end changed with it), 0 when none
    did or the law has none."""
    if ctx[H_SLIDERS] <= 0.0:
        return 0
    N = int(ctx[H_N])
    m = int(ctx[H_M])
    K = int(ctx[H_K])
    B = int(ctx[H_B])
    NB = N * B
    n = m * NB
    Q = u[:n].reshape((m, NB))
    V = u[n : 2 * n].reshape((m, NB))
    column = get(ctx, I_COL, NB)  # scratch: the next rhs_core overwrites it
    sliders = slider_rows(u, ctx, n, K, NB, B)
    for kind in range(K):
        contacts(ctx, kind, N, m, K, B, Q, V, column, sliders)
    return take_returned(u, ctx)


@_kernel_cache.njit(fastmath={"contract"}, error_model="numpy")
def take_returned(u, ctx):
    """The sliders the last contact evaluation of the state ``u`` returned (``slider_next``)
    into ``u``'s slider rows, for every running case: the return map without evaluating the
    contacts again (the exponential step takes them from its first stage's evaluation);
    1 when one moved, 0 when none did or the law has none."""
    if ctx[H_SLIDERS] <= 0.0:
        return 0
    K = int(ctx[H_K])
    B = int(ctx[H_B])
    NB = int(ctx[H_N]) * B
    sliders = slider_rows(u, ctx, int(ctx[H_M]) * NB, K, NB, B)
    returned = get(ctx, I_WNEXT, K * 2 * NB).reshape((K, 2, NB))
    active = get(ctx, I_ACTIVE, B)
    moved = 0
    for c in range(K):
        for a in range(2):
            w = sliders[c, a]
            w_new = returned[c, a]
            for col in range(NB):
                if w_new[col] != w[col] and active[col % B] != 0.0:
                    w[col] = w_new[col]
                    moved = 1
    return moved


@_kernel_cache.njit(fastmath={"contract"}, error_model="numpy")
def shift_forces(ctx, kind, K, N, B, beta):
    """``+S w`` of contact ``kind`` back onto its forces of every column (``A0_diag`` holds
    ``A0 + S``, :mod:`wheelrom.transient.stuck_shift`), ``w = q + beta_D q'`` of the blade's
    own points (``UA``, ``UB``, ``VA``, ``VB`` as :func:`contacts` left them for this kind):
    the isotropic spring ``k`` on its arm end ``c = a + (L/l0) Pi (b - a)`` and on its point
    ``a`` (as the next arm's partner), ``F_A += k (P_A^T c + a)``, ``F_B += k P_B^T c`` [N];
    ``q'^T S q'`` per column added to ``shift_power`` [1/s^2 (m/s)^2 per unit modal mass]
    (the damping power's correction; the caller zeroes it)."""
    NB = N * B
    W = (N + 1) * B
    UA = get(ctx, I_UA, 3 * W).reshape((3, W))
    UB = get(ctx, I_UB, 3 * NB).reshape((3, NB))
    VA = get(ctx, I_VA, 3 * W).reshape((3, W))
    VB = get(ctx, I_VB, 3 * NB).reshape((3, NB))
    FA = get(ctx, I_FA, K * 3 * NB).reshape((K, 3, NB))
    FB = get(ctx, I_FB, K * 3 * NB).reshape((K, 3, NB))
    Apt = get(ctx, I_AP, K * 3).reshape((K, 3))
    Bpt = get(ctx, I_BP, K * 3).reshape((K, 3))
    arm = get(ctx, I_ARM, K)
    power = get(ctx, I_SHIFTP, NB)
    k = get(ctx, I_SHIFTK, K)[kind]
    if k != 0.0:
        d0x = Bpt[kind, 0] - Apt[kind, 0]
        d0y = Bpt[kind, 1] - Apt[kind, 1]
        d0z = Bpt[kind, 2] - Apt[kind, 2]
        l0 = math.sqrt(d0x * d0x + d0y * d0y + d0z * d0z)
        ex, ey, ez = d0x / l0, d0y / l0, d0z / l0
        s = arm[kind] / l0
        fa, fb = FA[kind], FB[kind]
        for col in range(NB):
            ax = UA[0, col] + beta * VA[0, col]
            ay = UA[1, col] + beta * VA[1, col]
            az = UA[2, col] + beta * VA[2, col]
            dx = UB[0, col] + beta * VB[0, col] - ax
            dy = UB[1, col] + beta * VB[1, col] - ay
            dz = UB[2, col] + beta * VB[2, col] - az
            de = ex * dx + ey * dy + ez * dz
            cx, cy, cz = ax + s * (dx - ex * de), ay + s * (dy - ey * de), az + s * (dz - ez * de)
            ce = ex * cx + ey * cy + ez * cz
            px, py, pz = s * (cx - ex * ce), s * (cy - ey * ce), s * (cz - ez * ce)
            fa[0, col] += k * (cx - px + ax)
            fa[1, col] += k * (cy - py + ay)
            fa[2, col] += k * (cz - pz + az)
            fb[0, col] += k * px
            fb[1, col] += k * py
            fb[2, col] += k * pz
            # the velocities' arm end, for q'^T S q'
            avx, avy, avz = VA[0, col], VA[1, col], VA[2, col]
            dvx, dvy, dvz = VB[0, col] - avx, VB[1, col] - avy, VB[2, col] - avz
            dve = ex * dvx + ey * dvy + ez * dvz
            cvx = avx + s * (dvx - ex * dve)
            cvy = avy + s * (dvy - ey * dve)
            cvz = avz + s * (dvz - ez * dve)
            power[col] += k * (cvx * cvx + cvy * cvy + cvz * cvz
                               + avx * avx + avy * avy + avz * avz)
