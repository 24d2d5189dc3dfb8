"""The compiled right-hand side of the reduced wheel (numba): ``rhs_core`` evaluates
``(q', q'', W')`` -- block-circulant ``K_R`` product, nozzle, Van der Pol, contacts, the four
powers -- for a batch of cases in one fused pass over the context (:mod:`.layout`);
``sample_core`` records the output samples and freezes a diverging case. Both are called by
PETSc TS as C callbacks (:mod:`.bridge`) and from Python for tests and benchmarks.

The kernel is a second, independent implementation of the reference force model
(:class:`wheelrom.forces.reference.ReferenceForces`); the tests hold the two equal to
round-off. Measured on the 2-core test machine: ``docs/performance.md``.
"""

from __future__ import annotations

import math

import numba

from wheelrom.runtime import kernel_cache as _kernel_cache
from wheelrom.transient.contact_kernel import contacts, shift_forces, slider_rows
from wheelrom.transient.layout import (
    H_ACTIVE,
    H_B,
    H_BETA,
    H_CAP,
    H_EXPONENTIAL,
    H_FB,
    H_K,
    H_LIMIT,
    H_M,
    H_MISTUNED,
    H_MU,
    H_N,
    H_NEXT_SAMPLE,
    H_NS,
    H_OMEGA,
    H_OVERFLOW,
    H_R,
    H_SAMPLE_DT,
    H_SHIFT,
    H_SKIP_LINEAR,
    H_STATE_CAP,
    H_STATE_EVERY,
    H_VDP,
    I_A0D,
    I_A1,
    I_A1T,
    I_ACTIVE,
    I_AEROA,
    I_AEROB,
    I_COL,
    I_COS,
    I_COUNT,
    I_DELTA,
    I_DV,
    I_FA,
    I_FB,
    I_G,
    I_KSEG,
    I_KW,
    I_NORMAL,
    I_NOZ,
    I_PAERO,
    I_PAIR,
    I_PEXC,
    I_POWER,
    I_SHIFTP,
    I_SIN,
    I_SMIN,
    I_SOPEN,
    I_SSLIP,
    I_STATE,
    I_STIME,
    I_STIP,
    I_STOP,
    I_STOPT,
    I_STOTAL,
    I_TIP,
    I_UB,
    I_VT,
    I_WT,
    I_XA,
    I_XB,
    I_XCOUNT,
    I_XSTATE,
    I_XTIME,
    I_Y,
    I_YD,
    STOP_AMPLITUDE,
    STOP_NONFINITE,
    get,
)


@numba.njit(inline="always")
def _load_state(u, ctx, N, m, B, beta):
    """``(Q, V, VT, WT)``: ``Q``, ``V`` the rows ``q[j]``, ``q'[j]`` of ``u`` (views, for what
    reads them blade by blade) and column copies with one ghost blade (B columns) on each side:
    ``VT[j, B + c] = q'[j, c]``, ``VT[j, :B]`` = blade ``N-1``, ``VT[j, (N+1) B:]`` = blade 0;
    likewise ``WT`` for ``w = q + beta_D q'`` (one ``K_R`` product gives the elastic and the
    damping force)."""
    NB = N * B
    n = m * NB
    W = (N + 2) * B
    VT = get(ctx, I_VT, m * W).reshape((m, W))
    WT = get(ctx, I_WT, m * W).reshape((m, W))
    for j in range(m):
        # slices instead of offset indices: numba adds a negative-index wrap-around to
        # ``a[i + B]`` (B is not known to be >= 0), which keeps LLVM from vectorising
        vt = VT[j]
        wt = WT[j]
        vs = vt[B:]
        ws = wt[B:]
        uq = u[j * NB : (j + 1) * NB]
        uv = u[n + j * NB : n + (j + 1) * NB]
        for c in range(NB):
            vs[c] = uv[c]
            ws[c] = uq[c] + beta * uv[c]
        for b in range(B):
            vt[b] = vt[NB + b]
            vt[NB + B + b] = vt[B + b]
            wt[b] = wt[NB + b]
            wt[NB + B + b] = wt[B + b]
    return u[:n].reshape((m, NB)), u[n : 2 * n].reshape((m, NB)), VT, WT


@numba.njit(inline="always")
def _case_sums(column, out, N, B):
    """``out[b] = sum_s column[s B + b]`` (blades in order: the same sum for any ``B``)."""
    for b in range(B):
        out[b] = 0.0
    for s in range(N):
        part = column[s * B : (s + 1) * B]
        for b in range(B):
            out[b] += part[b]


@_kernel_cache.njit(fastmath={"contract"}, error_model="numpy")
def rhs_core(t, u, f, ctx):  # noqa: PLR0915 - one fused pass is the point
    """``f = (q', q'', W', w')`` for the batch state ``u = (q, q', W, w)`` at ``t`` [s]
    (kernel layout, :mod:`.layout`; ``w'`` = 0: the elastic law's sliders move only between
    steps, :func:`slide_core`, or from the exponential step's first stage)."""
    N = int(ctx[H_N])
    m = int(ctx[H_M])
    K = int(ctx[H_K])
    B = int(ctx[H_B])
    NB = N * B
    n = m * NB
    beta = ctx[H_BETA]
    A0_diag = get(ctx, I_A0D, m)
    A1 = get(ctx, I_A1, m * m).reshape((m, m))
    A1T = get(ctx, I_A1T, m * m).reshape((m, m))
    Q, V, VT, WT = _load_state(u, ctx, N, m, B, beta)
    column = get(ctx, I_COL, NB)
    power = get(ctx, I_POWER, 4 * B).reshape((4, B))
    # nozzle (eq. 13) and Van der Pol displacements y_s = p^T q_s (y, yd with ghost blades)
    p_exc = get(ctx, I_PEXC, m)
    p_aero = get(ctx, I_PAERO, m)
    cos_phase = get(ctx, I_COS, NB)
    sin_phase = get(ctx, I_SIN, NB)
    nozzle = get(ctx, I_NOZ, NB)
    y = get(ctx, I_Y, NB + 2 * B)
    yd = get(ctx, I_YD, NB + 2 * B)
    pair = get(ctx, I_PAIR, NB + 2 * B)
    g = get(ctx, I_G, NB)
    # F_b cos(n_s Omega t - phi_s) by the angle-difference formula: one cos and sin per call
    w_exc = ctx[H_NS] * ctx[H_OMEGA] * t
    Fc = ctx[H_FB] * math.cos(w_exc)
    Fs = ctx[H_FB] * math.sin(w_exc)
    y_this = y[B:]
    yd_this = yd[B:]
    for c in range(NB):
        nozzle[c] = Fc * cos_phase[c] + Fs * sin_phase[c]
        y_this[c] = 0.0
        yd_this[c] = 0.0
        column[c] = 0.0  # p_exc^T q'
    for j in range(m):
        pe = p_exc[j]
        pa = p_aero[j]
        qj = Q[j]
        vj = V[j]
        for c in range(NB):
            y_this[c] += pa * qj[c]
            yd_this[c] += pa * vj[c]
            column[c] += pe * vj[c]
    for c in range(NB):
        column[c] *= nozzle[c]
    _case_sums(column, power[0], N, B)
    vdp = int(ctx[H_VDP])
    mu = ctx[H_MU]
    inv_r = 1.0 / ctx[H_R]
    if vdp == 1:  # absolute (eq. 1): force on blade s is -F_s = g_s along the aero direction
        for c in range(NB):
            ys = y_this[c] * inv_r
            g[c] = mu * (1.0 - ys * ys) * yd_this[c]
            column[c] = g[c] * yd_this[c]
    elif vdp == 2:  # relative (eq. 2/14): D_s = y_s - y_{s-1}, force g_s - g_{s+1}
        for b in range(B):
            y[b] = y[NB + b]
            yd[b] = yd[NB + b]
        for c in range(NB):
            D = (y_this[c] - y[c]) * inv_r
            pair[c] = mu * (1.0 - D * D) * (yd_this[c] - yd[c])
        for b in range(B):
            pair[NB + b] = pair[b]
        pair_next = pair[B:]
        for c in range(NB):
            g[c] = pair[c] - pair_next[c]
            column[c] = g[c] * yd_this[c]
    elif vdp == 3:  # table: g_s = -mu sum_j (a_j y_{s+j} + b_j y'_{s+j}), one shift j at a
        # time in two contiguous runs (s + j < N and s + j >= N): no modulo in the inner loop
        aero_a = get(ctx, I_AEROA, N)
        aero_b = get(ctx, I_AEROB, N)
        for c in range(NB):
            g[c] = 0.0
        for j in range(N):
            aj = -mu * aero_a[j]
            bj = -mu * aero_b[j]
            split = (N - j) * B
            y_ahead = y_this[j * B :]
            yd_ahead = yd_this[j * B :]
            for c in range(split):
                g[c] += aj * y_ahead[c] + bj * yd_ahead[c]
            g_wrap = g[split:]
            for c in range(j * B):
                g_wrap[c] += aj * y_this[c] + bj * yd_this[c]
        for c in range(NB):
            column[c] = g[c] * yd_this[c]
    else:
        for c in range(NB):
            g[c] = 0.0
            column[c] = 0.0
    _case_sums(column, power[1], N, B)
    # contacts: the arm of blade s (A_s, B_s, end C_s) against A_{s+1}
    shift_power = get(ctx, I_SHIFTP, NB)  # shift_forces adds q'^T S q' into it
    for c in range(NB):
        column[c] = 0.0
        shift_power[c] = 0.0
    sliders = slider_rows(u, ctx, n, K, NB, B)
    linear = ctx[H_SKIP_LINEAR] == 0.0
    shifted = linear and ctx[H_SHIFT] != 0.0
    for kind in range(K):
        contacts(ctx, kind, N, m, K, B, Q, V, column, sliders)
        if shifted:  # A0_diag is A0 + S: S w back with the forces (transient.stuck_shift)
            shift_forces(ctx, kind, K, N, B, beta)
    _case_sums(column, power[2], N, B)
    # K_R w row by row (row s = A0 w_s + A1 w_{s+1} + A1^T w_{s-1}; A0 diagonal in the
    # kernel's basis), written straight into f with the forces: the contact forces are
    # projected back to the modes in the same row scratch (one row stays in L1; a whole
    # m x NB force array would not), XA^T (F_A + F_N) + XB^T F_B; for the damping power
    # q'^T K_R q' = sum_s v_s^T (A0 v_s + 2 A1 v_{s+1}) the row of 2 A1 v_{s+1} is dotted with
    # v at once (two row scratches, no m x NB temporaries: the batch's arrays do not fit in
    # L1). Modes j in pairs: one pass over the columns serves two modes (fewer loads and
    # stores per multiply-add). A mistuned wheel adds delta_s K_seg w_s to row s (and
    # delta_s K_seg v_s to the power row): K_seg is dense in the kernel's basis.
    exponential = ctx[H_EXPONENTIAL] != 0.0
    B2 = 2 * B
    kw = get(ctx, I_KW, NB)
    dv = get(ctx, I_DV, NB)
    XA = get(ctx, I_XA, K * 3 * m).reshape((K, 3, m))
    XB = get(ctx, I_XB, K * 3 * m).reshape((K, 3, m))
    FA = get(ctx, I_FA, K * 3 * NB).reshape((K, 3, NB))
    FB = get(ctx, I_FB, K * 3 * NB).reshape((K, 3, NB))
    for c in range(NB):
        column[c] = 0.0
    mistuned = linear and ctx[H_MISTUNED] != 0.0
    K_seg = get(ctx, I_KSEG, m * m).reshape((m, m))
    delta = get(ctx, I_DELTA, NB)
    pairs = (m // 2) if linear else 0
    single = (m % 2 == 1) and linear
    for i in range(m):
        for c in range(NB):
            kw[c] = 0.0
            dv[c] = 0.0
        for jp in range(pairs):
            j = 2 * jp
            a1, b1 = A1[i, j], A1[i, j + 1]
            a1t, b1t = A1T[i, j], A1T[i, j + 1]
            a1x2, b1x2 = 2.0 * a1, 2.0 * b1
            w_prev = WT[j]
            w_next = w_prev[B2:]
            x_prev = WT[j + 1]
            x_next = x_prev[B2:]
            v_next = VT[j, B2:]
            y_next = VT[j + 1, B2:]
            for c in range(NB):
                kw[c] += a1 * w_next[c] + a1t * w_prev[c] + b1 * x_next[c] + b1t * x_prev[c]
                dv[c] += a1x2 * v_next[c] + b1x2 * y_next[c]
        if single:
            j = m - 1
            a1, a1t = A1[i, j], A1T[i, j]
            a1x2 = 2.0 * a1
            w_prev = WT[j]
            w_next = w_prev[B2:]
            v_next = VT[j, B2:]
            for c in range(NB):
                kw[c] += a1 * w_next[c] + a1t * w_prev[c]
                dv[c] += a1x2 * v_next[c]
        if mistuned:  # + delta_s K_seg on the diagonal block: m^2 more per column
            for jp in range(m // 2):  # modes in pairs, as the A1 product: one delta per pair
                j = 2 * jp
                ks0, ks1 = K_seg[i, j], K_seg[i, j + 1]
                w0, w1 = WT[j, B:], WT[j + 1, B:]
                v0, v1 = VT[j, B:], VT[j + 1, B:]
                for c in range(NB):
                    kw[c] += delta[c] * (ks0 * w0[c] + ks1 * w1[c])
                    dv[c] += delta[c] * (ks0 * v0[c] + ks1 * v1[c])
            if m % 2 == 1:
                ks0 = K_seg[i, m - 1]
                w0, v0 = WT[m - 1, B:], VT[m - 1, B:]
                for c in range(NB):
                    kw[c] += delta[c] * ks0 * w0[c]
                    dv[c] += delta[c] * ks0 * v0[c]
        for kind in range(K):
            xa0, xa1, xa2 = XA[kind, 0, i], XA[kind, 1, i], XA[kind, 2, i]
            xb0, xb1, xb2 = XB[kind, 0, i], XB[kind, 1, i], XB[kind, 2, i]
            fa0, fa1, fa2 = FA[kind, 0], FA[kind, 1], FA[kind, 2]
            fb0, fb1, fb2 = FB[kind, 0], FB[kind, 1], FB[kind, 2]
            for c in range(NB):
                kw[c] -= (xa0 * fa0[c] + xa1 * fa1[c] + xa2 * fa2[c]
                          + xb0 * fb0[c] + xb1 * fb1[c] + xb2 * fb2[c])
        a0 = A0_diag[i] if linear else 0.0
        a0_force = 0.0 if exponential else a0  # the power keeps a0: it is the whole q'^T K q'
        pe = p_exc[i]
        pa = p_aero[i]
        wi = WT[i, B:]
        vi = VT[i, B:]
        fq = f[i * NB : (i + 1) * NB]
        fv = f[n + i * NB : n + (i + 1) * NB]
        for c in range(NB):
            fq[c] = vi[c]
            fv[c] = pe * nozzle[c] + pa * g[c] - (a0_force * wi[c] + kw[c])
            column[c] += vi[c] * (a0 * vi[c] + dv[c])
    if shifted:  # a0 held q'^T S q' too
        for c in range(NB):
            column[c] -= shift_power[c]
    _case_sums(column, power[3], N, B)
    for b in range(B):
        f[2 * n + b] = power[0, b]
        f[2 * n + B + b] = power[1, b]
        f[2 * n + 2 * B + b] = power[2, b]
        f[2 * n + 3 * B + b] = -beta * power[3, b]
    for k in range(2 * n + 4 * B, f.size):
        f[k] = 0.0
    if ctx[H_ACTIVE] < B:  # frozen (diverged) cases stay where they stopped
        active = get(ctx, I_ACTIVE, B)
        for b in range(B):
            if active[b] == 0.0:
                for i in range(2 * m * N):
                    f[i * B + b] = 0.0
                for k in range(4):
                    f[2 * n + k * B + b] = 0.0


@numba.njit(inline="always")
def _freeze(ctx, b, reason, t):
    active = get(ctx, I_ACTIVE, int(ctx[H_B]))
    if active[b] != 0.0:
        active[b] = 0.0
        ctx[H_ACTIVE] -= 1.0
        B = int(ctx[H_B])
        get(ctx, I_STOP, B)[b] = reason
        get(ctx, I_STOPT, B)[b] = t


@numba.njit(inline="always")
def _record_state(ctx, u, b, t, N, m, B):
    """Case ``b``'s modal state ``(z, z')`` (kernel basis) into the state history when this
    sample is one of every ``H_STATE_EVERY`` since ``t = 0``; counts the case's samples."""
    total = get(ctx, I_STOTAL, B)
    every = int(ctx[H_STATE_EVERY])
    index = int(total[b])
    total[b] = index + 1
    if every <= 0 or index % every != 0:
        return
    cap = int(ctx[H_STATE_CAP])
    count = get(ctx, I_XCOUNT, B)
    k = int(count[b])
    if k >= cap:
        ctx[H_OVERFLOW] = 1.0
        return
    NB = N * B
    n = m * NB
    get(ctx, I_XTIME, B * cap)[b * cap + k] = t
    state = get(ctx, I_XSTATE, B * cap * 2 * m * N).reshape((B, cap, 2, m, N))
    for j in range(m):
        o = j * NB + b
        for s in range(N):
            state[b, k, 0, j, s] = u[o + s * B]
            state[b, k, 1, j, s] = u[n + o + s * B]
    count[b] = k + 1


@_kernel_cache.njit(fastmath={"contract"}, error_model="numpy")
def sample_core(t, u, ctx):
    """Output samples at ``t`` when due, for every running case: tip displacements, minimum
    normal force and open contacts per kind. A case whose tips are non-finite or too large is
    frozen (its right-hand side is zero from then on); returns 1 when no case is left."""
    if t < ctx[H_NEXT_SAMPLE] - 1e-12:
        return 0
    N = int(ctx[H_N])
    m = int(ctx[H_M])
    K = int(ctx[H_K])
    B = int(ctx[H_B])
    NB = N * B
    cap = int(ctx[H_CAP])
    ctx[H_NEXT_SAMPLE] += ctx[H_SAMPLE_DT]
    tipm = get(ctx, I_TIP, 3 * m).reshape((3, m))
    active = get(ctx, I_ACTIVE, B)
    count = get(ctx, I_COUNT, B)
    times = get(ctx, I_STIME, B * cap).reshape((B, cap))
    tips = get(ctx, I_STIP, B * cap * N * 3).reshape((B, cap, N, 3))
    smin = get(ctx, I_SMIN, B * cap * K).reshape((B, cap, K))
    sopen = get(ctx, I_SOPEN, B * cap * K).reshape((B, cap, K))
    sslip = get(ctx, I_SSLIP, B * cap * K).reshape((B, cap, K))
    UB = get(ctx, I_UB, 3 * NB).reshape((3, NB))  # scratch: tip displacement per column
    for a in range(3):
        x = UB[a]
        for c in range(NB):
            x[c] = 0.0
        for j in range(m):
            coef = tipm[a, j]
            o = j * NB
            for c in range(NB):
                x[c] += coef * u[o + c]
    recorded = 0
    for b in range(B):
        if active[b] == 0.0:
            continue
        k = int(count[b])
        if k >= cap:
            ctx[H_OVERFLOW] = 1.0
            continue
        times[b, k] = t
        amp = 0.0
        finite = True
        for s in range(N):
            a2 = 0.0
            for a in range(3):
                x = UB[a, s * B + b]
                tips[b, k, s, a] = x
                a2 += x * x
            if not math.isfinite(a2):
                finite = False
            elif a2 > amp:
                amp = a2
        count[b] = k + 1
        recorded += 1
        _record_state(ctx, u, b, t, N, m, B)
        if not finite:
            _freeze(ctx, b, STOP_NONFINITE, t)
        elif math.sqrt(amp) > ctx[H_LIMIT]:
            _freeze(ctx, b, STOP_AMPLITUDE, t)
    if K > 0 and recorded > 0:
        # the contact forces at this state (no K_R product, nozzle or Van der Pol needed;
        # column is scratch here: the next rhs_core overwrites it)
        n = m * NB  # the state's rows as they are: no ghost copies needed here
        Q = u[:n].reshape((m, NB))
        V = u[n : 2 * n].reshape((m, NB))
        column = get(ctx, I_COL, NB)
        sliders = slider_rows(u, ctx, n, K, NB, B)
        for kind in range(K):
            contacts(ctx, kind, N, m, K, B, Q, V, column, sliders)
        normal = get(ctx, I_NORMAL, K * NB).reshape((K, NB))
        state = get(ctx, I_STATE, K * NB).reshape((K, NB))
        for b in range(B):
            k = int(count[b]) - 1
            if k < 0 or times[b, k] != t:  # not sampled now (frozen earlier or overflow)
                continue
            for c in range(K):
                low = normal[c, b]
                opened = 0.0
                slipping = 0.0
                for s in range(N):
                    low = min(low, normal[c, s * B + b])
                    if state[c, s * B + b] == 0.0:
                        opened += 1.0
                    elif state[c, s * B + b] == 2.0:
                        slipping += 1.0
                smin[b, k, c] = low
                sopen[b, k, c] = opened
                sslip[b, k, c] = slipping
    return 1 if ctx[H_ACTIVE] <= 0.0 else 0


def multiply_adds(N: int, m: int, K: int) -> int:
    """Multiply-adds of one :func:`rhs_core` evaluation of one case in its modal loops
    (everything that scales with the mode count ``m``), per column (blade):

    - ``3 m``: ``y = p_aero^T q``, ``y' = p_aero^T q'``, ``p_exc^T q'``;
    - ``3 m^2 + 5 m``: the ``K_R`` rows (``A1``, ``A1^T`` on ``w``: ``2 m^2``; ``2 A1`` on
      ``q'`` for the damping power: ``m^2``; ``A0``, nozzle, Van der Pol, power: ``5 m``);
    - ``18 K m``: per contact kind, ``A`` and ``B`` of ``q`` and ``q'`` in 3 directions
      (``12 m``) and the forces back to the modes (``6 m``).

    The contact laws themselves (~60 flops, 2 square roots, 2 divisions and an ``exp`` per
    contact) are not counted: a lower bound of the work.
    """
    return N * (3 * m * m + 8 * m + 18 * K * m)
