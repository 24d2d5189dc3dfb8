"""Compiled right-hand side of the reduced wheel, called by PETSc TS without Python.

Why: a petsc4py Python callback costs several microseconds per call (wrapping the Vecs, numpy
views, the numba dispatch of ~30 arguments); the paper case needs ~900,000 evaluations. Here
the whole right-hand side ``(q', q'', W')`` -- block-circulant ``K_R`` product for ``q`` and
``q'``, nozzle, Van der Pol, contacts, the four powers -- is one numba kernel, registered with
``TSSetRHSFunction`` as a C function (a numba ``cfunc`` calling PETSc through ctypes). A second
C callback (``TSMonitorSet``) records the output samples and stops a diverging case.

Everything the kernel needs lives in one float64 *context* array: a header of scalars and
offsets, the model and force parameters, work arrays, and the sample buffers of the current
window (see :class:`Context`). The kernel is a second, independent implementation of
:class:`wheelrom.forces.ForceModel` (vectorised over blades, mode-major work arrays); the tests
hold the two equal to round-off.

Measured on the 2-core test machine (66 blades x 10 modes, both contacts): ``K_R`` product
of ``q`` and ``q'`` as a numba loop 7 us, as two PETSc BAIJ ``MatMult`` 2 x 26 us, as one BLAS
``dgemm`` 11 us -- hence the loop (``docs/performance.md``).
"""

from __future__ import annotations

import ctypes
import functools
import math

import numba
import numpy as np
from numba import types
from numba.extending import intrinsic

from wheelrom._environment import petsc

# header slots (float64; integers stored exactly)
H_LEN, H_N, H_M, H_K, H_VDP, H_NS, H_OMEGA, H_FB, H_MU, H_R, H_BETA = range(11)
H_FS, H_FD, H_DECAY, H_VK, H_USER_REASON, H_SAMPLE_DT, H_NEXT_SAMPLE, H_COUNT = range(11, 19)
H_CAP, H_LIMIT, H_STOP, H_STOP_T, H_RHS_CALLS, H_SLOT_U, H_SLOT_F, H_OVERFLOW = range(19, 27)
H_NSTATE = 27
H_SKIP_LINEAR = 28  # 1: leave out the K_R product (benchmarks of the force part alone)
H_OFFSETS = 32  # offsets of the arrays below start here

# arrays in the context, in order; shapes from (N, m, K, capacity)
_ARRAYS = (
    ("A0", lambda N, m, K, c: (m, m)),
    ("A1", lambda N, m, K, c: (m, m)),
    ("A1T", lambda N, m, K, c: (m, m)),
    ("p_exc", lambda N, m, K, c: (m,)),
    ("cos_phase", lambda N, m, K, c: (N,)),
    ("sin_phase", lambda N, m, K, c: (N,)),
    ("p_aero", lambda N, m, K, c: (m,)),
    ("R", lambda N, m, K, c: (3, 3)),
    ("XA", lambda N, m, K, c: (K, 3, m)),
    ("XB", lambda N, m, K, c: (K, 3, m)),
    ("A_point", lambda N, m, K, c: (K, 3)),
    ("B_point", lambda N, m, K, c: (K, 3)),
    ("arm", lambda N, m, K, c: (K,)),
    ("T", lambda N, m, K, c: (K, N, 3, 3)),
    ("k_c", lambda N, m, K, c: (K, N)),
    ("preload", lambda N, m, K, c: (K,)),
    ("tip", lambda N, m, K, c: (3, m)),
    # work arrays (mode-major: the blade index is innermost, so loops over blades vectorise)
    ("QT", lambda N, m, K, c: (m, N + 2)),  # q with one periodic ghost blade on each side
    ("VT", lambda N, m, K, c: (m, N + 2)),
    ("WT", lambda N, m, K, c: (m, N + 2)),
    ("KW", lambda N, m, K, c: (m, N)),
    ("DV", lambda N, m, K, c: (m, N)),
    ("FT", lambda N, m, K, c: (m, N)),  # generalised nonlinear force
    ("nozzle", lambda N, m, K, c: (N,)),
    ("y", lambda N, m, K, c: (N,)),
    ("yd", lambda N, m, K, c: (N,)),
    ("g", lambda N, m, K, c: (N,)),
    ("UA", lambda N, m, K, c: (3, N)),
    ("UB", lambda N, m, K, c: (3, N)),
    ("VA", lambda N, m, K, c: (3, N)),
    ("VB", lambda N, m, K, c: (3, N)),
    ("FA", lambda N, m, K, c: (3, N)),
    ("FB", lambda N, m, K, c: (3, N)),
    ("FN", lambda N, m, K, c: (3, N)),
    ("normal_force", lambda N, m, K, c: (K, N)),
    ("contact_state", lambda N, m, K, c: (K, N)),
    # samples of the current window
    ("sample_time", lambda N, m, K, c: (c,)),
    ("sample_tip", lambda N, m, K, c: (c, N, 3)),
    ("sample_min_normal", lambda N, m, K, c: (c, K)),
    ("sample_open", lambda N, m, K, c: (c, K)),
)
_INDEX = {name: i for i, (name, _) in enumerate(_ARRAYS)}
(
    I_A0, I_A1, I_A1T, I_PEXC, I_COS, I_SIN, I_PAERO, I_R, I_XA, I_XB, I_AP, I_BP, I_ARM, I_T, I_KC,
    I_PRELOAD, I_TIP, I_QT, I_VT, I_WT, I_KW, I_DV, I_FT, I_NOZ, I_Y, I_YD, I_G, I_UA, I_UB, I_VA,
    I_VB, I_FA, I_FB, I_FN, I_NORMAL, I_STATE, I_STIME, I_STIP, I_SMIN, I_SOPEN,
) = range(len(_ARRAYS))  # fmt: skip

STOP_NONFINITE, STOP_AMPLITUDE = 1, 2


ALIGN = 8  # doubles: 64 bytes


def aligned_zeros(size: int) -> np.ndarray:
    """A zeroed float64 array whose data starts on a 64-byte boundary. Measured: shifting the
    context's arrays by 8 bytes made the right-hand side ~15 % slower."""
    raw = np.zeros(size + ALIGN)
    start = (-raw.ctypes.data // 8) % ALIGN
    return raw[start : start + size]


class Context:
    """The float64 context array of one case and named numpy views into it.

    Built from a :class:`~wheelrom.forces.ForceModel` (the single source of the force
    parameters) and the reduced model; ``capacity`` output samples per window.
    """

    def __init__(self, forces, model, beta: float, sample_dt: float, limit: float, capacity: int):
        PETSc = petsc()
        N, m, K = forces.N, forces.m, len(forces.contacts.kinds)
        self.N, self.m, self.K, self.capacity = N, m, K, capacity
        self.shapes = [fn(N, m, K, capacity) for _, fn in _ARRAYS]
        offsets, pos = [], H_OFFSETS + len(_ARRAYS)
        for shape in self.shapes:
            pos += -pos % ALIGN  # every array starts on a 64-byte boundary (AVX loads)
            offsets.append(pos)
            pos += int(np.prod(shape))
        self.array = aligned_zeros(pos)
        h = self.array
        h[H_LEN], h[H_N], h[H_M], h[H_K] = pos, N, m, K
        h[H_VDP], h[H_NS], h[H_OMEGA] = forces.vdp_model, forces.stator_vanes, forces.omega
        h[H_FB], h[H_MU], h[H_R], h[H_BETA] = forces.nozzle_force, forces.vdp_mu, forces.vdp_r, beta
        h[H_FS : H_VK + 1] = forces.friction
        h[H_USER_REASON] = int(PETSc.TS.ConvergedReason.CONVERGED_USER)
        h[H_SAMPLE_DT], h[H_CAP], h[H_LIMIT] = sample_dt, capacity, limit
        h[H_NSTATE] = 2 * N * m + 4
        h[H_OFFSETS : H_OFFSETS + len(_ARRAYS)] = offsets
        self._offsets = offsets
        c = forces.contacts
        values = {
            "A0": model.A0,
            "A1": model.A1,
            "A1T": model.A1.T,
            "p_exc": forces.p_exc,
            "cos_phase": np.cos(forces.nozzle_phase),
            "sin_phase": np.sin(forces.nozzle_phase),
            "p_aero": forces.p_aero,
            "R": forces.R,
            "XA": c.XA,
            "XB": c.XB,
            "A_point": c.A0,
            "B_point": c.B0,
            "arm": c.arm,
            "T": c.T,
            "k_c": c.k,
            "preload": c.preload,
            "tip": model.tip,
        }
        for name, value in values.items():
            self.view(name)[...] = value

    @property
    def address(self) -> int:
        return self.array.ctypes.data

    def view(self, name: str) -> np.ndarray:
        i = _INDEX[name]
        o = self._offsets[i]
        return self.array[o : o + int(np.prod(self.shapes[i]))].reshape(self.shapes[i])

    def header(self, slot: int) -> float:
        return float(self.array[slot])

    def set_header(self, slot: int, value: float) -> None:
        self.array[slot] = value


@numba.njit(inline="always")
def _get(ctx, index, size):
    o = int(ctx[H_OFFSETS + index])
    return ctx[o : o + size]


@numba.njit(cache=True, inline="always")
def _load_state(u, ctx, N, m, beta):
    """Mode-major copies of the state with one periodic ghost blade on each side:
    ``QT[:, s+1] = q_s``, ``QT[:, 0] = q_{N-1}``, ``QT[:, N+1] = q_0``; likewise ``VT`` for
    ``q'`` and ``WT`` for ``w = q + beta_D q'`` (one product gives elastic + damping force)."""
    n = N * m
    QT = _get(ctx, I_QT, m * (N + 2)).reshape((m, N + 2))
    VT = _get(ctx, I_VT, m * (N + 2)).reshape((m, N + 2))
    WT = _get(ctx, I_WT, m * (N + 2)).reshape((m, N + 2))
    for s in range(N):
        for j in range(m):
            QT[j, s + 1] = u[s * m + j]
            VT[j, s + 1] = u[n + s * m + j]
            WT[j, s + 1] = u[s * m + j] + beta * u[n + s * m + j]
    for j in range(m):
        QT[j, 0] = QT[j, N]
        QT[j, N + 1] = QT[j, 1]
        VT[j, 0] = VT[j, N]
        VT[j, N + 1] = VT[j, 1]
        WT[j, 0] = WT[j, N]
        WT[j, N + 1] = WT[j, 1]
    return QT, VT, WT


@numba.njit(cache=True, fastmath={"contract"})
def rhs_core(t, u, f, ctx):  # noqa: PLR0915 - one fused pass is the point
    """``f = (q', q'', W')`` for state ``u = (q, q', W)`` (lengths ``2 N m + 4``) at ``t`` [s]."""
    N = int(ctx[H_N])
    m = int(ctx[H_M])
    K = int(ctx[H_K])
    n = N * m
    beta = ctx[H_BETA]
    A0 = _get(ctx, I_A0, m * m).reshape((m, m))
    A1 = _get(ctx, I_A1, m * m).reshape((m, m))
    A1T = _get(ctx, I_A1T, m * m).reshape((m, m))
    QT, VT, WT = _load_state(u, ctx, N, m, beta)
    KW = _get(ctx, I_KW, m * N).reshape((m, N))
    DV = _get(ctx, I_DV, m * N).reshape((m, N))
    FT = _get(ctx, I_FT, m * N).reshape((m, N))
    # KW = K_R w, row s = A0 w_s + A1 w_{s+1} + A1^T w_{s-1}; and for the damping power
    # q'^T K_R q' = sum_s v_s^T (A0 v_s + 2 A1 v_{s+1}) the vectors DV_s = A0 v_s + 2 A1 v_{s+1}
    linear = ctx[H_SKIP_LINEAR] == 0.0
    for i in range(m):
        kw = KW[i]
        dv = DV[i]
        for s in range(N):
            kw[s] = 0.0
            dv[s] = 0.0
        for j in range(m if linear else 0):
            a0 = A0[i, j]
            a1 = A1[i, j]
            a1t = A1T[i, j]
            a1x2 = 2.0 * a1
            wj = WT[j]
            vj = VT[j]
            for s in range(N):
                kw[s] += a0 * wj[s + 1] + a1 * wj[s + 2] + a1t * wj[s]
                dv[s] += a0 * vj[s + 1] + a1x2 * vj[s + 2]
    # nozzle (eq. 13) and Van der Pol displacements y_s = p^T q_s
    p_exc = _get(ctx, I_PEXC, m)
    p_aero = _get(ctx, I_PAERO, m)
    cos_phase = _get(ctx, I_COS, N)
    sin_phase = _get(ctx, I_SIN, N)
    nozzle = _get(ctx, I_NOZ, N)
    y = _get(ctx, I_Y, N)
    yd = _get(ctx, I_YD, N)
    g = _get(ctx, I_G, N)
    # F_b cos(n_s Omega t - phi_s) by the angle-difference formula: one cos and sin per call
    w_exc = ctx[H_NS] * ctx[H_OMEGA] * t
    Fc = ctx[H_FB] * math.cos(w_exc)
    Fs = ctx[H_FB] * math.sin(w_exc)
    for s in range(N):
        nozzle[s] = Fc * cos_phase[s] + Fs * sin_phase[s]
        y[s] = 0.0
        yd[s] = 0.0
        g[s] = 0.0
    p_noz = 0.0
    for j in range(m):
        pe = p_exc[j]
        pa = p_aero[j]
        for s in range(N):
            FT[j, s] = pe * nozzle[s]
            y[s] += pa * QT[j, s + 1]
            yd[s] += pa * VT[j, s + 1]
            p_noz += pe * nozzle[s] * VT[j, s + 1]
    p_vdp = 0.0
    vdp = int(ctx[H_VDP])
    mu = ctx[H_MU]
    r = ctx[H_R]
    if vdp == 1:  # absolute (eq. 1): force on blade s is -F_s = g_s along the aero direction
        for s in range(N):
            g[s] = mu * (1.0 - (y[s] / r) ** 2) * yd[s]
            p_vdp += g[s] * yd[s]
    elif vdp == 2:  # relative (eq. 2/14): D_s = y_s - y_{s-1}, force g_s - g_{s+1}
        for s in range(N):
            sp = s - 1 if s > 0 else N - 1
            D = y[s] - y[sp]
            Dd = yd[s] - yd[sp]
            nozzle[s] = mu * (1.0 - (D / r) ** 2) * Dd  # reuse as the pair term
        for s in range(N):
            sn = s + 1 if s + 1 < N else 0
            g[s] = nozzle[s] - nozzle[sn]
            p_vdp += g[s] * yd[s]
    if vdp != 0:
        for j in range(m):
            pa = p_aero[j]
            for s in range(N):
                FT[j, s] += pa * g[s]
    # contacts: the arm of blade s (A_s, B_s, end C_s) against A_{s+1}
    p_fric = 0.0
    if K > 0:
        p_fric = _contacts(ctx, N, m, K, QT, VT, FT)
    # assemble f
    p_damp = 0.0
    for s in range(N):
        for j in range(m):
            f[s * m + j] = VT[j, s + 1]
            f[n + s * m + j] = FT[j, s] - KW[j, s]
            p_damp += VT[j, s + 1] * DV[j, s]
    f[2 * n] = p_noz
    f[2 * n + 1] = p_vdp
    f[2 * n + 2] = p_fric
    f[2 * n + 3] = -beta * p_damp


@numba.njit(cache=True, fastmath={"contract"})
def _contacts(ctx, N, m, K, QT, VT, FT):
    """Contact forces of every kind added to ``FT``; returns the friction power [W]."""
    XA = _get(ctx, I_XA, K * 3 * m).reshape((K, 3, m))
    XB = _get(ctx, I_XB, K * 3 * m).reshape((K, 3, m))
    Apt = _get(ctx, I_AP, K * 3).reshape((K, 3))
    Bpt = _get(ctx, I_BP, K * 3).reshape((K, 3))
    arm = _get(ctx, I_ARM, K)
    T = _get(ctx, I_T, K * N * 9).reshape((K, N, 3, 3))
    kc = _get(ctx, I_KC, K * N).reshape((K, N))
    preload = _get(ctx, I_PRELOAD, K)
    R = _get(ctx, I_R, 9).reshape((3, 3))
    UA = _get(ctx, I_UA, 3 * N).reshape((3, N))
    UB = _get(ctx, I_UB, 3 * N).reshape((3, N))
    VA = _get(ctx, I_VA, 3 * N).reshape((3, N))
    VB = _get(ctx, I_VB, 3 * N).reshape((3, N))
    FA = _get(ctx, I_FA, 3 * N).reshape((3, N))
    FB = _get(ctx, I_FB, 3 * N).reshape((3, N))
    FN = _get(ctx, I_FN, 3 * N).reshape((3, N))
    normal = _get(ctx, I_NORMAL, K * N).reshape((K, N))
    state = _get(ctx, I_STATE, K * N).reshape((K, N))
    f_s, f_d, decay, v_k = ctx[H_FS], ctx[H_FD], ctx[H_DECAY], ctx[H_VK]
    p_fric = 0.0
    for c in range(K):
        # displacements and velocities of A and B of every blade (blades innermost)
        for a in range(3):
            for s in range(N):
                UA[a, s] = 0.0
                UB[a, s] = 0.0
                VA[a, s] = 0.0
                VB[a, s] = 0.0
            for j in range(m):
                xa = XA[c, a, j]
                xb = XB[c, a, j]
                qj = QT[j]
                vj = VT[j]
                ua = UA[a]
                ub = UB[a]
                va = VA[a]
                vb = VB[a]
                for s in range(N):
                    ua[s] += xa * qj[s + 1]
                    ub[s] += xb * qj[s + 1]
                    va[s] += xa * vj[s + 1]
                    vb[s] += xb * vj[s + 1]
        L = arm[c]
        d0x = Bpt[c, 0] - Apt[c, 0]
        d0y = Bpt[c, 1] - Apt[c, 1]
        d0z = Bpt[c, 2] - Apt[c, 2]
        l0 = math.sqrt(d0x * d0x + d0y * d0y + d0z * d0z)
        e0x, e0y, e0z = d0x / l0, d0y / l0, d0z / l0
        inv_vk = 1.0 / v_k
        for s in range(N):
            sn = s + 1 if s + 1 < N else 0
            # deformed arm direction e and its rate (eq. 16)
            dx = d0x + UB[0, s] - UA[0, s]
            dy = d0y + UB[1, s] - UA[1, s]
            dz = d0z + UB[2, s] - UA[2, s]
            ddx = VB[0, s] - VA[0, s]
            ddy = VB[1, s] - VA[1, s]
            ddz = VB[2, s] - VA[2, s]
            inv_nd = 1.0 / math.sqrt(dx * dx + dy * dy + dz * dz)
            ex, ey, ez = dx * inv_nd, dy * inv_nd, dz * inv_nd
            edd = ex * ddx + ey * ddy + ez * ddz
            edx = (ddx - ex * edd) * inv_nd
            edy = (ddy - ey * edd) * inv_nd
            edz = (ddz - ez * edd) * inv_nd
            # gap change in sector s's frame (eq. 17): R u_A(s+1) - u_A(s) - L (e - e0)
            ucx = R[0, 0] * UA[0, sn] + R[0, 1] * UA[1, sn] + R[0, 2] * UA[2, sn]
            ucy = R[1, 0] * UA[0, sn] + R[1, 1] * UA[1, sn] + R[1, 2] * UA[2, sn]
            ucz = R[2, 0] * UA[0, sn] + R[2, 1] * UA[1, sn] + R[2, 2] * UA[2, sn]
            vcx = R[0, 0] * VA[0, sn] + R[0, 1] * VA[1, sn] + R[0, 2] * VA[2, sn]
            vcy = R[1, 0] * VA[0, sn] + R[1, 1] * VA[1, sn] + R[1, 2] * VA[2, sn]
            vcz = R[2, 0] * VA[0, sn] + R[2, 1] * VA[1, sn] + R[2, 2] * VA[2, sn]
            ucx -= UA[0, s] + L * (ex - e0x)
            ucy -= UA[1, s] + L * (ey - e0y)
            ucz -= UA[2, s] + L * (ez - e0z)
            vcx -= VA[0, s] + L * edx
            vcy -= VA[1, s] + L * edy
            vcz -= VA[2, s] + L * edz
            Tc = T[c, s]
            gap = Tc[1, 0] * ucx + Tc[1, 1] * ucy + Tc[1, 2] * ucz  # local eta (eq. 18)
            v_xi = Tc[0, 0] * vcx + Tc[0, 1] * vcy + Tc[0, 2] * vcz
            v_zeta = Tc[2, 0] * vcx + Tc[2, 1] * vcy + Tc[2, 2] * vcz
            Fn = preload[c] - kc[c, s] * gap  # eq. 19
            vt = math.sqrt(v_xi * v_xi + v_zeta * v_zeta)
            F_xi = 0.0
            F_zeta = 0.0
            if Fn <= 0.0:
                Fn = 0.0
                state[c, s] = 0.0
            else:
                if vt <= v_k:  # micro-slip branch (Fig. 4)
                    coef = f_s * vt * inv_vk
                    state[c, s] = 1.0
                else:
                    coef = f_d + (f_s - f_d) * math.exp(-decay * (vt - v_k))
                    state[c, s] = 2.0
                if vt > 0.0:
                    scale = -coef * Fn / vt
                    F_xi = scale * v_xi
                    F_zeta = scale * v_zeta
                p_fric += F_xi * v_xi + F_zeta * v_zeta
            normal[c, s] = Fn
            # force on A_{s+1} in sector s's frame: T^T (F_xi, F_n, F_zeta)
            Fx = Tc[0, 0] * F_xi + Tc[1, 0] * Fn + Tc[2, 0] * F_zeta
            Fy = Tc[0, 1] * F_xi + Tc[1, 1] * Fn + Tc[2, 1] * F_zeta
            Fz = Tc[0, 2] * F_xi + Tc[1, 2] * Fn + Tc[2, 2] * F_zeta
            # blade s+1 in its own frame: R^T F
            FN[0, sn] = R[0, 0] * Fx + R[1, 0] * Fy + R[2, 0] * Fz
            FN[1, sn] = R[0, 1] * Fx + R[1, 1] * Fy + R[2, 1] * Fz
            FN[2, sn] = R[0, 2] * Fx + R[1, 2] * Fy + R[2, 2] * Fz
            # -F at the arm end moved exactly onto A and B: F_B = (L/|d|) F_perp
            Fe = -(Fx * ex + Fy * ey + Fz * ez)
            scale = L * inv_nd
            FB[0, s] = scale * (-Fx - Fe * ex)
            FB[1, s] = scale * (-Fy - Fe * ey)
            FB[2, s] = scale * (-Fz - Fe * ez)
            FA[0, s] = -Fx - FB[0, s]
            FA[1, s] = -Fy - FB[1, s]
            FA[2, s] = -Fz - FB[2, s]
        # back to the modes: FT[j, s] += XA[:, j] . (F_A + F_N) + XB[:, j] . F_B
        for a in range(3):
            for s in range(N):
                FA[a, s] += FN[a, s]
        fa0, fa1, fa2 = FA[0], FA[1], FA[2]
        fb0, fb1, fb2 = FB[0], FB[1], FB[2]
        for j in range(m):
            xa0, xa1, xa2 = XA[c, 0, j], XA[c, 1, j], XA[c, 2, j]
            xb0, xb1, xb2 = XB[c, 0, j], XB[c, 1, j], XB[c, 2, j]
            ft = FT[j]
            for s in range(N):
                ft[s] += (xa0 * fa0[s] + xa1 * fa1[s] + xa2 * fa2[s]
                          + xb0 * fb0[s] + xb1 * fb1[s] + xb2 * fb2[s])  # fmt: skip
    return p_fric


@numba.njit(cache=True)
def sample_core(t, u, ctx):
    """Output sample at ``t`` when due: tip displacements, minimum normal force and open
    contacts per kind; returns 1 when the case must stop (non-finite or too large)."""
    if t < ctx[H_NEXT_SAMPLE] - 1e-12:
        return 0
    N = int(ctx[H_N])
    m = int(ctx[H_M])
    K = int(ctx[H_K])
    cap = int(ctx[H_CAP])
    k = int(ctx[H_COUNT])
    ctx[H_NEXT_SAMPLE] += ctx[H_SAMPLE_DT]
    tipm = _get(ctx, I_TIP, 3 * m).reshape((3, m))
    amp = 0.0
    finite = True
    if k >= cap:
        ctx[H_OVERFLOW] = 1.0
    else:
        times = _get(ctx, I_STIME, cap)
        tips = _get(ctx, I_STIP, cap * N * 3).reshape((cap, N, 3))
        times[k] = t
        for s in range(N):
            a2 = 0.0
            for a in range(3):
                x = 0.0
                for j in range(m):
                    x += tipm[a, j] * u[s * m + j]
                tips[k, s, a] = x
                a2 += x * x
            if not math.isfinite(a2):
                finite = False
            elif a2 > amp:
                amp = a2
        if K > 0 and finite:
            # the contact forces at this state (no K_R product, nozzle or Van der Pol needed;
            # FT is scratch here: the next rhs_core overwrites it)
            QT, VT, _ = _load_state(u, ctx, N, m, ctx[H_BETA])
            FT = _get(ctx, I_FT, m * N).reshape((m, N))
            _contacts(ctx, N, m, K, QT, VT, FT)
            normal = _get(ctx, I_NORMAL, K * N).reshape((K, N))
            state = _get(ctx, I_STATE, K * N).reshape((K, N))
            smin = _get(ctx, I_SMIN, cap * K).reshape((cap, K))
            sopen = _get(ctx, I_SOPEN, cap * K).reshape((cap, K))
            for c in range(K):
                low = normal[c, 0]
                count = 0.0
                for s in range(N):
                    low = min(low, normal[c, s])
                    if state[c, s] == 0.0:
                        count += 1.0
                smin[k, c] = low
                sopen[k, c] = count
        ctx[H_COUNT] = k + 1
    if not finite:
        ctx[H_STOP] = STOP_NONFINITE
        ctx[H_STOP_T] = t
        return 1
    if math.sqrt(amp) > ctx[H_LIMIT]:
        ctx[H_STOP] = STOP_AMPLITUDE
        ctx[H_STOP_T] = t
        return 1
    return 0


def _address_cast(element):
    """A numba intrinsic turning an int64 address into ``element *`` (for ``numba.carray``
    over PETSc and context memory)."""

    @intrinsic
    def cast(typingctx, address):
        sig = types.CPointer(element)(types.int64)

        def codegen(context, builder, signature, args):
            return builder.inttoptr(args[0], context.get_value_type(signature.return_type))

        return sig, codegen

    return cast


_double_ptr = _address_cast(types.float64)
_long_ptr = _address_cast(types.int64)


@numba.njit
def _context_at(ctx_addr):
    """The context array at ``ctx_addr`` and its header viewed as int64 (pointer slots)."""
    header = numba.carray(_double_ptr(ctx_addr), H_OFFSETS)
    ctx = numba.carray(_double_ptr(ctx_addr), int(header[H_LEN]))
    return ctx, numba.carray(_long_ptr(ctx_addr), H_OFFSETS)


@numba.njit
def _state_at(address, ctx):
    """A PETSc state Vec's array (``2 N m + 4`` doubles) at ``address``."""
    return numba.carray(_double_ptr(address), int(ctx[H_NSTATE]))


def _petsc_function(lib, name, *argtypes):
    fn = getattr(lib, name)
    fn.argtypes = argtypes
    fn.restype = ctypes.c_int
    return fn


@functools.cache
def callbacks():
    """``(rhs, monitor, TSSetRHSFunction, TSMonitorSet)``: C callbacks compiled once per
    process (~1 s) and the PETSc setters. Pointers travel as int64 (same ABI on x86-64)."""
    PETSc = petsc()
    lib = ctypes.CDLL(PETSc.__file__)  # dlsym also searches its libpetsc dependency
    i64, i32 = ctypes.c_int64, ctypes.c_int32
    get_read = _petsc_function(lib, "VecGetArrayRead", i64, i64)
    restore_read = _petsc_function(lib, "VecRestoreArrayRead", i64, i64)
    get_write = _petsc_function(lib, "VecGetArray", i64, i64)
    restore_write = _petsc_function(lib, "VecRestoreArray", i64, i64)
    set_reason = _petsc_function(lib, "TSSetConvergedReason", i64, i32)

    @numba.cfunc(types.int32(types.int64, types.float64, types.int64, types.int64, types.int64))
    def rhs(ts, t, U, F, ctx_addr):
        ctx, slots = _context_at(ctx_addr)
        slot_u = ctx_addr + 8 * H_SLOT_U
        slot_f = ctx_addr + 8 * H_SLOT_F
        err = get_read(U, slot_u)
        if err:
            return err
        err = get_write(F, slot_f)
        if err:
            return err
        u = _state_at(slots[H_SLOT_U], ctx)
        f = _state_at(slots[H_SLOT_F], ctx)
        rhs_core(t, u, f, ctx)
        ctx[H_RHS_CALLS] += 1.0
        err = restore_read(U, slot_u)
        if err:
            return err
        return restore_write(F, slot_f)

    @numba.cfunc(types.int32(types.int64, types.int32, types.float64, types.int64, types.int64))
    def monitor(ts, step, t, U, ctx_addr):
        ctx, slots = _context_at(ctx_addr)
        slot_u = ctx_addr + 8 * H_SLOT_U
        err = get_read(U, slot_u)
        if err:
            return err
        u = _state_at(slots[H_SLOT_U], ctx)
        stop = sample_core(t, u, ctx)
        err = restore_read(U, slot_u)
        if err:
            return err
        if stop:
            return set_reason(ts, int(ctx[H_USER_REASON]))
        return 0

    set_rhs = _petsc_function(lib, "TSSetRHSFunction", i64, i64, i64, i64)
    set_monitor = _petsc_function(lib, "TSMonitorSet", i64, i64, i64, i64)
    return rhs, monitor, set_rhs, set_monitor


def attach(ts, f, context: Context) -> None:
    """Register the compiled RHS (residual Vec ``f``) and sampling monitor on ``ts``.

    ``context`` must outlive ``ts``: PETSc keeps its address.
    """
    rhs, monitor, set_rhs, set_monitor = callbacks()
    err = set_rhs(ts.handle, f.handle, rhs.address, context.address)
    err = err or set_monitor(ts.handle, monitor.address, context.address, 0)
    if err:
        raise RuntimeError(f"PETSc error {err} while registering the compiled callbacks")


def evaluate(context: Context, t: float, u: np.ndarray) -> np.ndarray:
    """The compiled RHS from Python (tests, benchmarks): returns a new array."""
    f = np.empty_like(u)
    rhs_core(t, np.ascontiguousarray(u, dtype=float), f, context.array)
    return f
