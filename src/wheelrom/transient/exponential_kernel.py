"""One step of the exponential Runge-Kutta scheme (ETDRK4, Cox & Matthews 2002) on the
kernel's state, compiled: four :func:`~wheelrom.transient.kernel.rhs_core` evaluations with
``A0`` left out of the force (``H_EXPONENTIAL``) and the exact per-mode propagators of
``q'' + beta_D a_j q' + a_j q = 0`` (``a_j`` the eigenvalues of ``A0``, the kernel's basis).
The coefficients come from :func:`wheelrom.transient.exponential.coefficients`; the theory is
in docs/theory.md ("The exponential integrator").

Coefficient rows (``(C_ROWS, m)``), per mode ``j`` with ``L_j = [[0, 1], [-a_j, -beta_D a_j]]``
and ``e2 = (0, 1)`` (the explicit part acts on the velocity only):
``E(h)`` (4 rows: 00, 01, 10, 11), ``E(h/2)`` (4), ``phi_1(h L / 2) e2`` (2: q, v),
``f_1 e2``, ``f_2 e2``, ``f_3 e2`` (2 each) with ``f_1 = phi_1 - 3 phi_2 + 4 phi_3``,
``f_2 = phi_2 - 2 phi_3``, ``f_3 = -phi_2 + 4 phi_3`` at ``h L``.
"""

from __future__ import annotations

from wheelrom.runtime import kernel_cache as _kernel_cache
from wheelrom.transient.contact_kernel import take_returned
from wheelrom.transient.kernel import rhs_core
from wheelrom.transient.layout import H_ACTIVE, H_B, H_M, H_N, H_RHS_CALLS, I_ACTIVE, get

C_FULL, C_HALF, C_PHI_HALF, C_F1, C_F2, C_F3 = 0, 4, 8, 10, 12, 14
C_ROWS = 16


@_kernel_cache.njit(fastmath={"contract"}, error_model="numpy")
def _propagate(E, j, u, out, NB, n):
    """Mode ``j`` of ``out`` (``q``, ``q'`` rows) = the 2 x 2 propagator ``E[:, j]`` applied to
    mode ``j`` of ``u``."""
    e00, e01, e10, e11 = E[0, j], E[1, j], E[2, j], E[3, j]
    uq = u[j * NB : (j + 1) * NB]
    uv = u[n + j * NB : n + (j + 1) * NB]
    oq = out[j * NB : (j + 1) * NB]
    ov = out[n + j * NB : n + (j + 1) * NB]
    for c in range(NB):
        q = uq[c]
        v = uv[c]
        oq[c] = e00 * q + e01 * v
        ov[c] = e10 * q + e11 * v


@_kernel_cache.njit(fastmath={"contract"}, error_model="numpy")
def etd4_step(t, h, u, ctx, coef, work):
    """Advance the kernel state ``u`` (kernel layout, :mod:`.layout`) from ``t`` by ``h``
    [s] in place. The elastic law's sliders are returned onto the Coulomb limit at the
    step's start, from the first stage's contact evaluation (:func:`take_returned`: the
    return at the previous step's end without evaluating the contacts twice); the state left
    carries the sliders the step held, :func:`~wheelrom.transient.exponential.end_sliders`
    returns them when a solve ends.
    ``coef``: ``(C_ROWS, m)`` for this ``h``; ``work``: ``(6, len(u))`` scratch (the four
    stage derivatives, two stage states). Frozen (diverged) cases keep their state.
    """
    N = int(ctx[H_N])
    m = int(ctx[H_M])
    B = int(ctx[H_B])
    NB = N * B
    n = m * NB
    size = u.size
    Nu, Na, Nb, Nc, a, c = work[0], work[1], work[2], work[3], work[4], work[5]
    half = 0.5 * h
    E_full = coef[C_FULL : C_FULL + 4]
    E_half = coef[C_HALF : C_HALF + 4]
    # stage 1: N(u); a = E(h/2) u + h/2 phi1(hL/2) N_u
    rhs_core(t, u, Nu, ctx)
    take_returned(u, ctx)  # before any stage state copies u's sliders (none: nothing)
    _half_stage(E_half, u, a, Nu, coef, half, u, Nu, half, m, NB, n, size)
    # stage 2: N(a); b = E(h/2) u + h/2 phi1 N_a (b kept in c's scratch until stage 3)
    rhs_core(t + half, a, Na, ctx)
    _half_stage(E_half, u, c, Na, coef, half, u, Na, half, m, NB, n, size)
    rhs_core(t + half, c, Nb, ctx)
    # stage 3: c = E(h/2) a + h/2 phi1 (2 N_b - N_u); Na's scratch is still needed, so the
    # combination 2 N_b - N_u goes into Nc until N(c) overwrites it
    for k in range(n, 2 * n):
        Nc[k] = 2.0 * Nb[k] - Nu[k]
    _half_stage(E_half, a, c, Nc, coef, half, u, Nb, h, m, NB, n, size)
    rhs_core(t + h, c, Nc, ctx)
    # u+ = E(h) u + h (f1 N_u + 2 f2 (N_a + N_b) + f3 N_c); W by the classical RK4 weights
    for k in range(n, 2 * n):
        Na[k] += Nb[k]
    for j in range(m):
        _propagate(E_full, j, u, a, NB, n)
    _add_phi(a, Nu, coef, C_F1, h, m, NB, n)
    _add_phi(a, Na, coef, C_F2, 2.0 * h, m, NB, n)
    _add_phi(a, Nc, coef, C_F3, h, m, NB, n)
    sixth = h / 6.0
    for k in range(2 * n, size):
        a[k] = u[k] + sixth * (Nu[k] + 2.0 * (Na[k] + Nb[k]) + Nc[k])
    ctx[H_RHS_CALLS] += 4.0
    if ctx[H_ACTIVE] < B:  # frozen cases stay where they stopped
        active = get(ctx, I_ACTIVE, B)
        for k in range(size):
            col = k % B
            if active[col] != 0.0:
                u[k] = a[k]
    else:
        for k in range(size):
            u[k] = a[k]


@_kernel_cache.njit(fastmath={"contract"}, error_model="numpy")
def _half_stage(E_half, src, out, f, coef, half, u, w, w_scale, m, NB, n, size):
    """One stage state: ``out = E(h/2) src + h/2 phi1(hL/2) f`` on the modes, and the work
    integrals ``out_W = u_W + w_scale w_W`` (explicit, the classical RK4 stages)."""
    for j in range(m):
        _propagate(E_half, j, src, out, NB, n)
    _add_phi(out, f, coef, C_PHI_HALF, half, m, NB, n)
    for k in range(2 * n, size):
        out[k] = u[k] + w_scale * w[k]


@_kernel_cache.njit(fastmath={"contract"}, error_model="numpy")
def _add_phi(out, f, coef, row, scale, m, NB, n):
    """``out[mode j] += scale * coef[row:row+2, j] * f's velocity rows of mode j`` (the
    explicit force acts on q'' only: ``(q, v) += scale phi(hL) e2 f_v``)."""
    for j in range(m):
        cq = scale * coef[row, j]
        cv = scale * coef[row + 1, j]
        fv = f[n + j * NB : n + (j + 1) * NB]
        oq = out[j * NB : (j + 1) * NB]
        ov = out[n + j * NB : n + (j + 1) * NB]
        for c in range(NB):
            oq[c] += cq * fv[c]
            ov[c] += cv * fv[c]
