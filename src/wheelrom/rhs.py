"""Compiled right-hand side of the reduced wheel, called by PETSc TS without Python.

Why: a petsc4py Python callback costs several microseconds per call (wrapping the Vecs, numpy
views, the numba dispatch of ~30 arguments); the paper case needs ~900,000 evaluations. Here
the whole right-hand side ``(q', q'', W')`` -- block-circulant ``K_R`` product, nozzle, Van der
Pol, contacts, the four powers -- is one numba kernel, registered with ``TSSetRHSFunction`` as
a C function (a numba ``cfunc`` calling PETSc through ctypes). A second C callback
(``TSMonitorSet``) records the output samples and freezes a diverging case.

**Batches.** One kernel call evaluates ``B`` cases of the same wheel at once (angle cases of a
sweep: they differ only in their contact frames and stiffnesses). The kernel's state layout
puts the case index innermost::

    u = ( q[j, s, b],  q'[j, s, b],  W[k, b] )      mode j, blade s, case b

so every loop runs over the ``N B`` contiguous *columns* ``(s, b)``: the neighbouring blade of
column ``c`` is column ``c + B``, and the loops vectorise (AVX2) over blades and cases alike.
Every operation on a column reads and writes that column's case only, so a case's result does
not depend on the batch it runs in (the sweep tests hold batches of 1 and 3 bitwise equal).
``B = 1`` is a single case. :meth:`Context.pack` / :meth:`Context.unpack` convert from and to
the blade-major single-case state ``(q[s, j], q'[s, j], W[k])`` used everywhere else.

Everything the kernel needs lives in one float64 *context* array: a header of scalars and
offsets, the model and force parameters, work arrays, and the sample buffers of the current
window (see :class:`Context`). The kernel is a second, independent implementation of
:class:`wheelrom.forces.ForceModel`; the tests hold the two equal to round-off.

Measured on the 2-core test machine: ``docs/performance.md``.
"""

from __future__ import annotations

import ctypes
import functools
import math

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from wheelrom._environment import petsc

# header slots (float64; integers stored exactly)
H_LEN, H_N, H_M, H_K, H_VDP, H_NS, H_OMEGA, H_FB, H_MU, H_R, H_BETA = range(11)
H_FS, H_FD, H_DECAY, H_VK, H_USER_REASON, H_SAMPLE_DT, H_NEXT_SAMPLE = range(11, 18)
H_CAP, H_LIMIT, H_RHS_CALLS, H_SLOT_U, H_SLOT_F, H_OVERFLOW, H_NSTATE = range(19, 26)
H_SKIP_LINEAR = 26  # 1: leave out the K_R product (benchmarks of the force part alone)
H_B = 27  # cases in the batch
H_ACTIVE = 28  # cases still running (a diverged case is frozen)
H_OFFSETS = 32  # offsets of the arrays below start here

# arrays in the context, in order; shapes from (N, m, K, B, capacity)
_ARRAYS = (
    ("A0_diag", lambda N, m, K, B, c: (m,)),  # the eigenvalues of A0 [1/s^2]
    ("A1", lambda N, m, K, B, c: (m, m)),
    ("A1T", lambda N, m, K, B, c: (m, m)),
    ("p_exc", lambda N, m, K, B, c: (m,)),
    ("cos_phase", lambda N, m, K, B, c: (N * B,)),
    ("sin_phase", lambda N, m, K, B, c: (N * B,)),
    ("p_aero", lambda N, m, K, B, c: (m,)),
    ("R", lambda N, m, K, B, c: (3, 3)),
    ("XA", lambda N, m, K, B, c: (K, 3, m)),
    ("XB", lambda N, m, K, B, c: (K, 3, m)),
    ("A_point", lambda N, m, K, B, c: (K, 3)),
    ("B_point", lambda N, m, K, B, c: (K, 3)),
    ("arm", lambda N, m, K, B, c: (K,)),
    ("T", lambda N, m, K, B, c: (K, 9, N * B)),  # local frame rows per column
    ("k_c", lambda N, m, K, B, c: (K, N * B)),
    ("preload", lambda N, m, K, B, c: (K,)),
    ("tip", lambda N, m, K, B, c: (3, m)),
    ("active", lambda N, m, K, B, c: (B,)),  # 1: running, 0: frozen (diverged)
    ("stop", lambda N, m, K, B, c: (B,)),  # STOP_* reason per case
    ("stop_t", lambda N, m, K, B, c: (B,)),
    ("count", lambda N, m, K, B, c: (B,)),  # samples of the current window per case
    # work arrays: columns (s, b); one ghost blade (B columns) on each side where needed
    ("VT", lambda N, m, K, B, c: (m, (N + 2) * B)),
    ("WT", lambda N, m, K, B, c: (m, (N + 2) * B)),
    ("KW", lambda N, m, K, B, c: (N * B,)),  # one row of K_R w
    ("DV", lambda N, m, K, B, c: (N * B,)),  # one row of 2 A1 v_{s+1}
    ("nozzle", lambda N, m, K, B, c: (N * B,)),
    ("y", lambda N, m, K, B, c: ((N + 2) * B,)),
    ("yd", lambda N, m, K, B, c: ((N + 2) * B,)),
    ("pair", lambda N, m, K, B, c: ((N + 2) * B,)),
    ("g", lambda N, m, K, B, c: (N * B,)),
    ("column", lambda N, m, K, B, c: (N * B,)),  # per-column power before the case sums
    ("UA", lambda N, m, K, B, c: (3, (N + 1) * B)),
    ("UB", lambda N, m, K, B, c: (3, N * B)),
    ("VA", lambda N, m, K, B, c: (3, (N + 1) * B)),
    ("VB", lambda N, m, K, B, c: (3, N * B)),
    ("FA", lambda N, m, K, B, c: (K, 3, N * B)),  # contact forces on A (and A from s-1) [N]
    ("FB", lambda N, m, K, B, c: (K, 3, N * B)),  # and on B, per kind
    ("FN", lambda N, m, K, B, c: (3, (N + 1) * B)),
    ("normal_force", lambda N, m, K, B, c: (K, N * B)),
    ("contact_state", lambda N, m, K, B, c: (K, N * B)),
    ("power", lambda N, m, K, B, c: (4, B)),
    # samples of the current window
    ("sample_time", lambda N, m, K, B, c: (B, c)),
    ("sample_tip", lambda N, m, K, B, c: (B, c, N, 3)),
    ("sample_min_normal", lambda N, m, K, B, c: (B, c, K)),
    ("sample_open", lambda N, m, K, B, c: (B, c, K)),
)
_INDEX = {name: i for i, (name, _) in enumerate(_ARRAYS)}
(
    I_A0D, I_A1, I_A1T, I_PEXC, I_COS, I_SIN, I_PAERO, I_R, I_XA, I_XB, I_AP, I_BP, I_ARM, I_T,
    I_KC, I_PRELOAD, I_TIP, I_ACTIVE, I_STOP, I_STOPT, I_COUNT, I_VT, I_WT, I_KW, I_DV, I_NOZ,
    I_Y, I_YD, I_PAIR, I_G, I_COL, I_UA, I_UB, I_VA, I_VB, I_FA, I_FB, I_FN, I_NORMAL, I_STATE,
    I_POWER, I_STIME, I_STIP, I_SMIN, I_SOPEN,
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
    """The float64 context array of a batch of ``B`` cases and named numpy views into it.

    Built from one :class:`~wheelrom.forces.ForceModel` per case (the single source of the
    force parameters; the cases may differ only in their contact frames ``T`` and stiffnesses
    ``k_c``) and the reduced model; ``capacity`` output samples per window and case.
    """

    def __init__(self, forces, model, beta: float, sample_dt: float, limit: float, capacity: int):
        PETSc = petsc()
        forces = list(forces) if isinstance(forces, list | tuple) else [forces]
        first = forces[0]
        N, m, K, B = first.N, first.m, len(first.contacts.kinds), len(forces)
        _check_batchable(forces)
        self.N, self.m, self.K, self.B, self.capacity = N, m, K, B, capacity
        self.shapes = [fn(N, m, K, B, capacity) for _, fn in _ARRAYS]
        offsets, pos = [], H_OFFSETS + len(_ARRAYS)
        for shape in self.shapes:
            pos += -pos % ALIGN  # every array starts on a 64-byte boundary (AVX loads)
            offsets.append(pos)
            pos += int(np.prod(shape))
        self.array = aligned_zeros(pos)
        h = self.array
        h[H_LEN], h[H_N], h[H_M], h[H_K], h[H_B], h[H_ACTIVE] = pos, N, m, K, B, B
        h[H_VDP], h[H_NS], h[H_OMEGA] = first.vdp_model, first.stator_vanes, first.omega
        h[H_FB], h[H_MU], h[H_R], h[H_BETA] = first.nozzle_force, first.vdp_mu, first.vdp_r, beta
        h[H_FS : H_VK + 1] = first.friction
        h[H_USER_REASON] = int(PETSc.TS.ConvergedReason.CONVERGED_USER)
        h[H_SAMPLE_DT], h[H_CAP], h[H_LIMIT] = sample_dt, capacity, limit
        h[H_NSTATE] = B * (2 * N * m + 4)
        h[H_OFFSETS : H_OFFSETS + len(_ARRAYS)] = offsets
        self._offsets = offsets
        c = first.contacts
        # the kernel's modal basis: the segment modes rotated to diagonalise A0 (see
        # :func:`diagonal_basis`); every modal vector and the state are rotated with it
        self.basis, A0_diag = diagonal_basis(model.A0)
        P = self.basis
        A1 = P.T @ model.A1 @ P

        def columns(per_case):  # (B, ..., N) -> (..., N * B), case innermost
            a = np.asarray(per_case, dtype=float)
            return np.moveaxis(a, 0, -1).reshape(*a.shape[1:-1], N * B)

        values = {
            "A0_diag": A0_diag,
            "A1": A1,
            "A1T": A1.T,
            "p_exc": P.T @ first.p_exc,
            "cos_phase": np.repeat(np.cos(first.nozzle_phase), B),
            "sin_phase": np.repeat(np.sin(first.nozzle_phase), B),
            "p_aero": P.T @ first.p_aero,
            "R": first.R,
            "XA": c.XA @ P,
            "XB": c.XB @ P,
            "A_point": c.A0,
            "B_point": c.B0,
            "arm": c.arm,
            # (B, K, N, 3, 3) -> (K, 9, N, B)
            "T": columns([f.contacts.T.reshape(K, N, 9).transpose(0, 2, 1) for f in forces]),
            "k_c": columns([f.contacts.k for f in forces]),
            "preload": c.preload,
            "tip": model.tip @ P,
            "active": np.ones(B),
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

    def pack(self, states: np.ndarray) -> np.ndarray:
        """Kernel state (length ``B (2 N m + 4)``) from blade-major case states
        ``(B, 2 N m + 4)`` (or ``(2 N m + 4,)`` when ``B = 1``)."""
        N, m, B = self.N, self.m, self.B
        s = np.asarray(states, dtype=float).reshape(B, -1)
        n = N * m
        P = self.basis  # z_s = P^T q_s, i.e. z_s^T = q_s^T P
        q = _times(s[:, :n].reshape(B, N, m), P).transpose(2, 1, 0)  # (m, N, B)
        v = _times(s[:, n : 2 * n].reshape(B, N, m), P).transpose(2, 1, 0)
        w = s[:, 2 * n :].T  # (4, B)
        return np.concatenate([q.ravel(), v.ravel(), w.ravel()])

    def unpack(self, u: np.ndarray) -> np.ndarray:
        """Blade-major case states ``(B, 2 N m + 4)`` from a kernel state (inverse of
        :meth:`pack`)."""
        N, m, B = self.N, self.m, self.B
        n = N * m * B
        u = np.asarray(u)
        PT = self.basis.T  # q_s = P z_s
        q = _times(u[:n].reshape(m, N, B).transpose(2, 1, 0), PT).reshape(B, N * m)
        v = _times(u[n : 2 * n].reshape(m, N, B).transpose(2, 1, 0), PT).reshape(B, N * m)
        w = u[2 * n :].reshape(4, B).T
        return np.concatenate([q, v, w], axis=1)


def _times(x: np.ndarray, M: np.ndarray) -> np.ndarray:
    """``x @ M`` over the last axis, summed in a fixed order by elementwise operations: the
    same bits for a case whatever the batch (a BLAS product may block differently by shape,
    which would break the batch independence of the results)."""
    out = x[..., :1] * M[0]
    for j in range(1, M.shape[0]):
        out = out + x[..., j : j + 1] * M[j]
    return out


def diagonal_basis(A0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(P, lam)``: the orthogonal ``P`` (m, m) with ``P^T A0 P = diag(lam)`` [1/s^2].

    Why: the kernel works in the segment modes rotated by ``P`` (``q_s = P z_s``). The mass
    stays the identity, the diagonal block of ``K_R`` becomes ``diag(lam)`` and the row of
    ``K_R`` costs ``2 m^2 + m`` multiply-adds instead of ``3 m^2``, the damping power
    ``m^2 + m`` instead of ``2 m^2``: a third of the linear work. The same wheel, only
    rounded differently (``pack``/``unpack`` rotate the state; the samples are physical).
    """
    A0 = np.asarray(A0, dtype=float)
    scale = max(float(np.abs(A0).max()), np.finfo(float).tiny)
    if not np.allclose(A0, A0.T, rtol=0.0, atol=1e-12 * scale):
        raise ValueError("the reduced model's A0 (diagonal block of K_R) must be symmetric")
    lam, P = np.linalg.eigh(0.5 * (A0 + A0.T))
    return P, lam


def _shared(f) -> tuple:
    """What :class:`Context` takes from the first case for the whole batch."""
    c = f.contacts
    return (f.N, f.m, c.kinds, f.vdp_model, f.stator_vanes, f.omega, f.nozzle_force, f.vdp_mu,
            f.vdp_r, f.friction, f.p_exc, f.p_aero, f.nozzle_phase, f.R, c.preload, c.arm,
            c.XA, c.XB, c.A0, c.B0)  # fmt: skip


def _check_batchable(forces) -> None:
    """Cases of a batch share everything but the contact frames and stiffnesses."""
    first = _shared(forces[0])
    for f in forces[1:]:
        if not all(np.array_equal(a, b) for a, b in zip(_shared(f), first, strict=True)):
            raise ValueError("cases of one batch may differ only in contact angles and stiffnesses")


@numba.njit(inline="always")
def _get(ctx, index, size):
    o = int(ctx[H_OFFSETS + index])
    return ctx[o : o + size]


@intrinsic
def _float_bits(typingctx, x):
    """The IEEE bits of a float64 as int64 (LLVM ``bitcast``: vectorises)."""

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(64))

    return types.int64(types.float64), codegen


@intrinsic
def _bits_float(typingctx, x):
    """The float64 with the IEEE bits of an int64 (inverse of :func:`_float_bits`)."""

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return types.float64(types.int64), codegen


def _noalias_option() -> dict:
    """``{"noalias": True}`` for ``numba.njit`` where numba has the flag (it marks every
    array argument ``noalias`` in LLVM); numba 0.68 has the compiler flag but no decorator
    option for it, so the option is added here. Without it the contact loop is still correct,
    only slower (LLVM then needs runtime overlap checks across ~20 arrays and gives up)."""
    from numba.core import compiler, cpu
    from numba.core.options import TargetOptions

    if not hasattr(compiler.Flags, "noalias"):
        return {}
    if not hasattr(cpu.CPUTargetOptions, "noalias"):
        cpu.CPUTargetOptions.noalias = TargetOptions.Mapping("noalias")
    return {"noalias": True}


_NOALIAS = _noalias_option()

_SHIFTER = 6755399441055744.0  # 1.5 * 2**52: adding it rounds to an integer in the low bits
_SHIFTER_BITS = 0x4338000000000000


@numba.njit(inline="always", fastmath={"contract"}, error_model="numpy")
def fexp(x):
    """``exp(x)`` within 2 ulp for ``x`` in [-708, 709] (clamped outside), branch-free (tested).

    Why: ``math.exp`` is a libm call, which keeps LLVM from vectorising the contact loop
    (there is no vector math library in numba's LLVM here). Cody-Waite reduction
    ``x = k ln 2 + r``, ``|r| <= ln 2 / 2``, Taylor polynomial of degree 13 (truncation
    < 1e-17 relative), ``2^k`` built in the exponent bits.
    """
    x = min(max(x, -708.0), 709.0)
    shifted = x * 1.4426950408889634 + _SHIFTER
    k = _float_bits(shifted) - _SHIFTER_BITS
    kd = shifted - _SHIFTER
    r = x - kd * 6.93147180369123816490e-01  # ln 2, high part (exact product)
    r = r - kd * 1.90821492927058770002e-10  # ln 2, low part
    # Estrin's scheme: the same polynomial as Horner's but a dependency chain of ~5
    # operations instead of 14 (the chain, not the operation count, bounds the long
    # vectorised contact loop: measured 25 % of it with Horner)
    r2 = r * r
    r4 = r2 * r2
    r8 = r4 * r4
    p01 = 1.0 + r
    p23 = 0.5 + r * (1.0 / 6.0)
    p45 = 1.0 / 24.0 + r * (1.0 / 120.0)
    p67 = 1.0 / 720.0 + r * (1.0 / 5040.0)
    p89 = 1.0 / 40320.0 + r * (1.0 / 362880.0)
    p1011 = 1.0 / 3628800.0 + r * (1.0 / 39916800.0)
    p1213 = 1.0 / 479001600.0 + r * (1.0 / 6227020800.0)
    p03 = p01 + r2 * p23
    p47 = p45 + r2 * p67
    p811 = p89 + r2 * p1011
    p07 = p03 + r4 * p47
    p813 = p811 + r4 * p1213
    p = p07 + r8 * p813
    return p * _bits_float((k + 1023) << 52)


@numba.njit(cache=True, inline="always")
def _load_state(u, ctx, N, m, B, beta):
    """``(Q, V, VT, WT)``: ``Q``, ``V`` the rows ``q[j]``, ``q'[j]`` of ``u`` (views, for what
    reads them blade by blade) and column copies with one ghost blade (B columns) on each side:
    ``VT[j, B + c] = q'[j, c]``, ``VT[j, :B]`` = blade ``N-1``, ``VT[j, (N+1) B:]`` = blade 0;
    likewise ``WT`` for ``w = q + beta_D q'`` (one ``K_R`` product gives the elastic and the
    damping force)."""
    NB = N * B
    n = m * NB
    W = (N + 2) * B
    VT = _get(ctx, I_VT, m * W).reshape((m, W))
    WT = _get(ctx, I_WT, m * W).reshape((m, W))
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


@numba.njit(cache=True, fastmath={"contract"}, error_model="numpy")
def rhs_core(t, u, f, ctx):  # noqa: PLR0915 - one fused pass is the point
    """``f = (q', q'', W')`` for the batch state ``u = (q, q', W)`` at ``t`` [s] (kernel
    layout, length ``B (2 N m + 4)``; see the module docstring)."""
    N = int(ctx[H_N])
    m = int(ctx[H_M])
    K = int(ctx[H_K])
    B = int(ctx[H_B])
    NB = N * B
    n = m * NB
    beta = ctx[H_BETA]
    A0_diag = _get(ctx, I_A0D, m)
    A1 = _get(ctx, I_A1, m * m).reshape((m, m))
    A1T = _get(ctx, I_A1T, m * m).reshape((m, m))
    Q, V, VT, WT = _load_state(u, ctx, N, m, B, beta)
    column = _get(ctx, I_COL, NB)
    power = _get(ctx, I_POWER, 4 * B).reshape((4, B))
    # nozzle (eq. 13) and Van der Pol displacements y_s = p^T q_s (y, yd with ghost blades)
    p_exc = _get(ctx, I_PEXC, m)
    p_aero = _get(ctx, I_PAERO, m)
    cos_phase = _get(ctx, I_COS, NB)
    sin_phase = _get(ctx, I_SIN, NB)
    nozzle = _get(ctx, I_NOZ, NB)
    y = _get(ctx, I_Y, NB + 2 * B)
    yd = _get(ctx, I_YD, NB + 2 * B)
    pair = _get(ctx, I_PAIR, NB + 2 * B)
    g = _get(ctx, I_G, NB)
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
    else:
        for c in range(NB):
            g[c] = 0.0
            column[c] = 0.0
    _case_sums(column, power[1], N, B)
    # contacts: the arm of blade s (A_s, B_s, end C_s) against A_{s+1}
    for c in range(NB):
        column[c] = 0.0
    for kind in range(K):
        _contacts(ctx, kind, N, m, K, B, Q, V, column)
    _case_sums(column, power[2], N, B)
    # K_R w row by row (row s = A0 w_s + A1 w_{s+1} + A1^T w_{s-1}; A0 diagonal in the
    # kernel's basis), written straight into f with the forces: the contact forces are
    # projected back to the modes in the same row scratch (one row stays in L1; a whole
    # m x NB force array would not), XA^T (F_A + F_N) + XB^T F_B; for the damping power
    # q'^T K_R q' = sum_s v_s^T (A0 v_s + 2 A1 v_{s+1}) the row of 2 A1 v_{s+1} is dotted with
    # v at once (two row scratches, no m x NB temporaries: the batch's arrays do not fit in
    # L1). Modes j in pairs: one pass over the columns serves two modes (fewer loads and
    # stores per multiply-add).
    linear = ctx[H_SKIP_LINEAR] == 0.0
    B2 = 2 * B
    kw = _get(ctx, I_KW, NB)
    dv = _get(ctx, I_DV, NB)
    XA = _get(ctx, I_XA, K * 3 * m).reshape((K, 3, m))
    XB = _get(ctx, I_XB, K * 3 * m).reshape((K, 3, m))
    FA = _get(ctx, I_FA, K * 3 * NB).reshape((K, 3, NB))
    FB = _get(ctx, I_FB, K * 3 * NB).reshape((K, 3, NB))
    for c in range(NB):
        column[c] = 0.0
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
        for kind in range(K):
            xa0, xa1, xa2 = XA[kind, 0, i], XA[kind, 1, i], XA[kind, 2, i]
            xb0, xb1, xb2 = XB[kind, 0, i], XB[kind, 1, i], XB[kind, 2, i]
            fa0, fa1, fa2 = FA[kind, 0], FA[kind, 1], FA[kind, 2]
            fb0, fb1, fb2 = FB[kind, 0], FB[kind, 1], FB[kind, 2]
            for c in range(NB):
                kw[c] -= (xa0 * fa0[c] + xa1 * fa1[c] + xa2 * fa2[c]
                          + xb0 * fb0[c] + xb1 * fb1[c] + xb2 * fb2[c])  # fmt: skip
        a0 = A0_diag[i] if linear else 0.0
        pe = p_exc[i]
        pa = p_aero[i]
        wi = WT[i, B:]
        vi = VT[i, B:]
        fq = f[i * NB : (i + 1) * NB]
        fv = f[n + i * NB : n + (i + 1) * NB]
        for c in range(NB):
            fq[c] = vi[c]
            fv[c] = pe * nozzle[c] + pa * g[c] - (a0 * wi[c] + kw[c])
            column[c] += vi[c] * (a0 * vi[c] + dv[c])
    _case_sums(column, power[3], N, B)
    for b in range(B):
        f[2 * n + b] = power[0, b]
        f[2 * n + B + b] = power[1, b]
        f[2 * n + 2 * B + b] = power[2, b]
        f[2 * n + 3 * B + b] = -beta * power[3, b]
    if ctx[H_ACTIVE] < B:  # frozen (diverged) cases stay where they stopped
        active = _get(ctx, I_ACTIVE, B)
        for b in range(B):
            if active[b] == 0.0:
                for i in range(2 * m * N):
                    f[i * B + b] = 0.0
                for k in range(4):
                    f[2 * n + k * B + b] = 0.0


@numba.njit(cache=True, fastmath={"contract"}, error_model="numpy")
def _contacts(ctx, kind, N, m, K, B, Q, V, column):
    """Contact forces of contact ``kind`` at A (with the neighbour's push on it) and B of
    every column left in ``FA[kind]``, ``FB[kind]`` [N], its friction power per column added
    to ``column`` [W]; normal forces and states left in the context."""
    NB = N * B
    W = (N + 1) * B
    c = kind
    XA = _get(ctx, I_XA, K * 3 * m).reshape((K, 3, m))
    XB = _get(ctx, I_XB, K * 3 * m).reshape((K, 3, m))
    UA = _get(ctx, I_UA, 3 * W).reshape((3, W))
    UB = _get(ctx, I_UB, 3 * NB).reshape((3, NB))
    VA = _get(ctx, I_VA, 3 * W).reshape((3, W))
    VB = _get(ctx, I_VB, 3 * NB).reshape((3, NB))
    FA = _get(ctx, I_FA, K * 3 * NB).reshape((K, 3, NB))[c]
    FB = _get(ctx, I_FB, K * 3 * NB).reshape((K, 3, NB))[c]
    FN = _get(ctx, I_FN, 3 * W).reshape((3, W))
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
    Apt = _get(ctx, I_AP, K * 3).reshape((K, 3))
    Bpt = _get(ctx, I_BP, K * 3).reshape((K, 3))
    T = _get(ctx, I_T, K * 9 * NB).reshape((K, 9, NB))
    kc = _get(ctx, I_KC, K * NB).reshape((K, NB))
    normal = _get(ctx, I_NORMAL, K * NB).reshape((K, NB))
    state = _get(ctx, I_STATE, K * NB).reshape((K, NB))
    R = _get(ctx, I_R, 9).reshape((3, 3))
    law = (ctx[H_FS], ctx[H_FD], ctx[H_DECAY], ctx[H_VK])
    geometry = (Apt[c, 0], Apt[c, 1], Apt[c, 2], Bpt[c, 0], Bpt[c, 1], Bpt[c, 2],
                _get(ctx, I_ARM, K)[c], _get(ctx, I_PRELOAD, K)[c])  # fmt: skip
    # the next blade's rows as 1-D views (a 2-D view UA[:, B:] would not be contiguous)
    next_a = (UA[0, B:], UA[1, B:], UA[2, B:], VA[0, B:], VA[1, B:], VA[2, B:])
    next_f = (FN[0, B:], FN[1, B:], FN[2, B:])
    _contact_columns(NB, UA, UB, VA, VB, *next_a, T[c], kc[c], R, geometry, law,
                     FA, FB, *next_f, normal[c], state[c], column)  # fmt: skip
    # the force on A_{s+1} of the last blade's arm went to the ghost column: blade 0
    for a in range(3):
        fa = FA[a]
        fn = FN[a]
        for b in range(B):
            fn[b] = fn[NB + b]
        for col in range(NB):
            fa[col] += fn[col]


@numba.njit(cache=True, fastmath={"contract"}, error_model="numpy", **_NOALIAS)
def _contact_columns(NB, UA, UB, VA, VB, uax, uay, uaz, vax, vay, vaz, T, kc, R, geometry, law,
                     FA, FB, fnx, fny, fnz, normal, state, column):  # fmt: skip
    """The contact law of every column (eqs. 16-20), branch-free so that it vectorises.

    ``uax ... vaz``, ``fnx ... fnz``: the rows of ``UA``, ``VA``, ``FN`` from the next blade
    on (entry ``c`` is blade ``s + 1``), as views: see :func:`_load_state` on offset indices.

    ``noalias``: the arrays are disjoint parts of the context; telling LLVM so removes the
    runtime overlap checks that otherwise keep this loop scalar.
    """
    ax, ay, az, bx, by, bz, L, preload = geometry
    f_s, f_d, decay, v_k = law
    d0x, d0y, d0z = bx - ax, by - ay, bz - az
    l0 = math.sqrt(d0x * d0x + d0y * d0y + d0z * d0z)
    e0x, e0y, e0z = d0x / l0, d0y / l0, d0z / l0
    inv_vk = 1.0 / v_k
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
        v_xi = t00 * vcx + t01 * vcy + t02 * vcz
        v_zeta = t20 * vcx + t21 * vcy + t22 * vcz
        trial = preload - kc[col] * gap  # eq. 19; open when <= 0
        Fn = max(trial, 0.0)
        vt = math.sqrt(v_xi * v_xi + v_zeta * v_zeta)
        micro = vt <= v_k  # micro-slip branch (Fig. 4)
        coef_slip = f_d + (f_s - f_d) * fexp(-decay * (vt - v_k))
        coef = f_s * vt * inv_vk if micro else coef_slip
        # vt = 0 gives coef = 0 and zero force, as the law's limit
        scale = -coef * Fn / max(vt, 1e-300)
        F_xi = scale * v_xi
        F_zeta = scale * v_zeta
        column[col] += F_xi * v_xi + F_zeta * v_zeta
        normal[col] = Fn
        state[col] = 0.0 if trial <= 0.0 else (1.0 if micro else 2.0)
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
def _freeze(ctx, b, reason, t):
    active = _get(ctx, I_ACTIVE, int(ctx[H_B]))
    if active[b] != 0.0:
        active[b] = 0.0
        ctx[H_ACTIVE] -= 1.0
        B = int(ctx[H_B])
        _get(ctx, I_STOP, B)[b] = reason
        _get(ctx, I_STOPT, B)[b] = t


@numba.njit(cache=True, fastmath={"contract"}, error_model="numpy")
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
    tipm = _get(ctx, I_TIP, 3 * m).reshape((3, m))
    active = _get(ctx, I_ACTIVE, B)
    count = _get(ctx, I_COUNT, B)
    times = _get(ctx, I_STIME, B * cap).reshape((B, cap))
    tips = _get(ctx, I_STIP, B * cap * N * 3).reshape((B, cap, N, 3))
    smin = _get(ctx, I_SMIN, B * cap * K).reshape((B, cap, K))
    sopen = _get(ctx, I_SOPEN, B * cap * K).reshape((B, cap, K))
    UB = _get(ctx, I_UB, 3 * NB).reshape((3, NB))  # scratch: tip displacement per column
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
        column = _get(ctx, I_COL, NB)
        for kind in range(K):
            _contacts(ctx, kind, N, m, K, B, Q, V, column)
        normal = _get(ctx, I_NORMAL, K * NB).reshape((K, NB))
        state = _get(ctx, I_STATE, K * NB).reshape((K, NB))
        for b in range(B):
            k = int(count[b]) - 1
            if k < 0 or times[b, k] != t:  # not sampled now (frozen earlier or overflow)
                continue
            for c in range(K):
                low = normal[c, b]
                opened = 0.0
                for s in range(N):
                    low = min(low, normal[c, s * B + b])
                    if state[c, s * B + b] == 0.0:
                        opened += 1.0
                smin[b, k, c] = low
                sopen[b, k, c] = opened
    return 1 if ctx[H_ACTIVE] <= 0.0 else 0


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
    """A PETSc state Vec's array (``B (2 N m + 4)`` doubles) at ``address``."""
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


@functools.cache
def _null_rhs():
    @numba.cfunc(types.int32(types.int64, types.float64, types.int64, types.int64, types.int64))
    def nothing(ts, t, U, F, ctx_addr):
        return 0

    return nothing


def attach_null(ts, f) -> None:
    """Register a compiled right-hand side that does nothing (``F`` keeps its values) and no
    monitor: what the integrator costs by itself (``wheelrom bench``'s floor figures)."""
    set_rhs = callbacks()[2]
    ts.cancelMonitor()
    if set_rhs(ts.handle, f.handle, _null_rhs().address, 0):
        raise RuntimeError("PETSc error while registering the no-op right-hand side")


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


def attach(ts, f, context: Context) -> None:
    """Register the compiled RHS (residual Vec ``f``) and sampling monitor on ``ts``.

    ``context`` must outlive ``ts``: PETSc keeps its address.
    """
    rhs, monitor, set_rhs, set_monitor = callbacks()
    err = set_rhs(ts.handle, f.handle, rhs.address, context.address)
    err = err or set_monitor(ts.handle, monitor.address, context.address, 0)
    if err:
        raise RuntimeError(f"PETSc error {err} while registering the compiled callbacks")


def evaluate(context: Context, t: float, states: np.ndarray) -> np.ndarray:
    """The compiled RHS from Python (tests, benchmarks) for blade-major case states
    ``(B, 2 N m + 4)`` (or one state when ``B = 1``); returns the same shape."""
    states = np.asarray(states, dtype=float)
    u = context.pack(states)
    f = np.empty_like(u)
    rhs_core(t, u, f, context.array)
    return context.unpack(f).reshape(states.shape)
