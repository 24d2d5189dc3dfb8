"""The context of the compiled right-hand side: one float64 array holding a header of scalars
and offsets, the model and force parameters, work arrays and the sample buffers of the current
window, with named numpy views into it (:class:`Context`), and the kernel's state layout.

**Batches.** One kernel call evaluates ``B`` cases of the same wheel at once (angle cases of a
sweep: they differ only in their contact frames and stiffnesses). The kernel's state layout
puts the case index innermost::

    u = ( q[j, s, b],  q'[j, s, b],  W[k, b],  w[c, a, s, b] )   mode j, blade s, case b

(``w``: the elastic contact law's sliders, contact kind ``c``, direction ``a`` = xi, zeta;
none under the paper law)

so every loop runs over the ``N B`` contiguous *columns* ``(s, b)``: the neighbouring blade of
column ``c`` is column ``c + B``, and the loops vectorise (AVX2) over blades and cases alike.
Every operation on a column reads and writes that column's case only, so a case's result does
not depend on the batch it runs in (the sweep tests hold batches of 1 and 3 bitwise equal).
``B = 1`` is a single case. :meth:`Context.pack` / :meth:`Context.unpack` convert from and to
the blade-major single-case state ``(q[s, j], q'[s, j], W[k], w[c, s, a])`` used everywhere
else (:func:`state_size`).
"""

from __future__ import annotations

import numba
import numpy as np

from wheelrom.forces.contact_law import LAW_SIZE
from wheelrom.forces.parameters import ForceParameters
from wheelrom.runtime.environment import petsc
from wheelrom.transient.stuck_shift import shift_stiffness, spring_matrix

H_LEN, H_N, H_M, H_K, H_VDP, H_NS, H_OMEGA, H_FB, H_MU, H_R, H_BETA = range(11)
H_SLIDERS = 11  # slider coordinates per case: 2 K N under the elastic law, else 0
H_USER_REASON, H_SAMPLE_DT, H_NEXT_SAMPLE = range(12, 15)
H_EXPONENTIAL = 15  # 1: leave A0 out of the force (the exponential scheme propagates it)
H_CAP, H_LIMIT, H_RHS_CALLS, H_SLOT_U, H_SLOT_F, H_OVERFLOW, H_NSTATE = range(16, 23)
H_SKIP_LINEAR = 23  # 1: leave out the K_R product (benchmarks of the force part alone)
H_B = 24  # cases in the batch
H_ACTIVE = 25  # cases still running (a diverged case is frozen)
H_STATE_EVERY = 26  # record the modal state at every k-th sample (0: never)
H_STATE_CAP = 27  # state samples one window can hold per case
H_MISTUNED = 28  # 1: blade s's diagonal block is A0 + delta_s K_seg (a mistuned wheel)
H_SHIFT = 29  # 1: A0_diag holds A0 + S, the force adds S w back (transient.stuck_shift)
H_OFFSETS = 30  # offsets of the arrays below start here

# arrays in the context, in order; shapes from (N, m, K, B, capacity)
_ARRAYS = (
    ("A0_diag", lambda N, m, K, B, c, c2: (m,)),  # the eigenvalues of A0 (+ S) [1/s^2]
    ("A1", lambda N, m, K, B, c, c2: (m, m)),
    ("A1T", lambda N, m, K, B, c, c2: (m, m)),
    ("p_exc", lambda N, m, K, B, c, c2: (m,)),
    ("cos_phase", lambda N, m, K, B, c, c2: (N * B,)),
    ("sin_phase", lambda N, m, K, B, c, c2: (N * B,)),
    ("p_aero", lambda N, m, K, B, c, c2: (m,)),
    ("R", lambda N, m, K, B, c, c2: (3, 3)),
    ("XA", lambda N, m, K, B, c, c2: (K, 3, m)),
    ("XB", lambda N, m, K, B, c, c2: (K, 3, m)),
    ("A_point", lambda N, m, K, B, c, c2: (K, 3)),
    ("B_point", lambda N, m, K, B, c, c2: (K, 3)),
    ("arm", lambda N, m, K, B, c, c2: (K,)),
    ("T", lambda N, m, K, B, c, c2: (K, 9, N * B)),  # local frame rows per column
    ("k_c", lambda N, m, K, B, c, c2: (K, N * B)),
    ("preload", lambda N, m, K, B, c, c2: (K,)),
    ("tip", lambda N, m, K, B, c, c2: (3, m)),
    ("active", lambda N, m, K, B, c, c2: (B,)),  # 1: running, 0: frozen (diverged)
    ("stop", lambda N, m, K, B, c, c2: (B,)),  # STOP_* reason per case
    ("stop_t", lambda N, m, K, B, c, c2: (B,)),
    ("count", lambda N, m, K, B, c, c2: (B,)),  # samples of the current window per case
    # work arrays: columns (s, b); one ghost blade (B columns) on each side where needed
    ("VT", lambda N, m, K, B, c, c2: (m, (N + 2) * B)),
    ("WT", lambda N, m, K, B, c, c2: (m, (N + 2) * B)),
    ("KW", lambda N, m, K, B, c, c2: (N * B,)),  # one row of K_R w
    ("DV", lambda N, m, K, B, c, c2: (N * B,)),  # one row of 2 A1 v_{s+1}
    ("nozzle", lambda N, m, K, B, c, c2: (N * B,)),
    ("y", lambda N, m, K, B, c, c2: ((N + 2) * B,)),
    ("yd", lambda N, m, K, B, c, c2: ((N + 2) * B,)),
    ("pair", lambda N, m, K, B, c, c2: ((N + 2) * B,)),
    ("g", lambda N, m, K, B, c, c2: (N * B,)),
    ("column", lambda N, m, K, B, c, c2: (N * B,)),  # per-column power before the case sums
    ("UA", lambda N, m, K, B, c, c2: (3, (N + 1) * B)),
    ("UB", lambda N, m, K, B, c, c2: (3, N * B)),
    ("VA", lambda N, m, K, B, c, c2: (3, (N + 1) * B)),
    ("VB", lambda N, m, K, B, c, c2: (3, N * B)),
    ("FA", lambda N, m, K, B, c, c2: (K, 3, N * B)),  # contact forces on A (and A from s-1) [N]
    ("FB", lambda N, m, K, B, c, c2: (K, 3, N * B)),  # and on B, per kind
    ("FN", lambda N, m, K, B, c, c2: (3, (N + 1) * B)),
    ("normal_force", lambda N, m, K, B, c, c2: (K, N * B)),
    ("contact_state", lambda N, m, K, B, c, c2: (K, N * B)),
    ("power", lambda N, m, K, B, c, c2: (4, B)),
    # samples of the current window
    ("sample_time", lambda N, m, K, B, c, c2: (B, c)),
    ("sample_tip", lambda N, m, K, B, c, c2: (B, c, N, 3)),
    ("sample_min_normal", lambda N, m, K, B, c, c2: (B, c, K)),
    ("sample_open", lambda N, m, K, B, c, c2: (B, c, K)),
    # the modal state history (output.state_rate_hz; c2 = 0: none), kernel basis
    ("sample_total", lambda N, m, K, B, c, c2: (B,)),  # samples since t = 0 per case
    ("state_count", lambda N, m, K, B, c, c2: (B,)),  # state samples of the current window
    ("state_time", lambda N, m, K, B, c, c2: (B, c2)),
    ("state", lambda N, m, K, B, c, c2: (B, c2, 2, m, N)),  # (z, z') per mode and blade
    # mistuning (H_MISTUNED): P^T K_seg P [1/s^2] and delta_s per column
    ("K_seg", lambda N, m, K, B, c, c2: (m, m)),
    ("delta", lambda N, m, K, B, c, c2: (N * B,)),
    # the aerodynamic table's influence coefficients a_j [N/m], b_j [N s/m] (H_VDP = 3)
    ("aero_a", lambda N, m, K, B, c, c2: (N,)),
    ("aero_b", lambda N, m, K, B, c, c2: (N,)),
    # the contact law's record (wheelrom.forces.contact_law, L_* indices), the elastic law's
    # tangential stiffness k_t [N/m] per column and the sliders returned onto the Coulomb
    # limit at the last contact evaluation (what the step's end keeps)
    ("law", lambda N, m, K, B, c, c2: (LAW_SIZE,)),
    ("k_t", lambda N, m, K, B, c, c2: (K, N * B)),
    ("slider_next", lambda N, m, K, B, c, c2: (K, 2, N * B)),
    # slipping contacts per kind at each sample of the current window
    ("sample_slip", lambda N, m, K, B, c, c2: (B, c, K)),
    # zeros: the sliders the contact loop reads under the paper law (which has none), apart
    # from the returned ones it writes (the loop promises LLVM its arrays do not overlap)
    ("slider_none", lambda N, m, K, B, c, c2: (K, 2, N * B)),
    # the isotropic spring per kind [N/m] moved into the exact propagator (H_SHIFT;
    # transient.stuck_shift) and its share of the damping power q'^T S q' per column
    ("shift_k", lambda N, m, K, B, c, c2: (K,)),
    ("shift_power", lambda N, m, K, B, c, c2: (N * B,)),
    # each contact's mode per column (wheelrom.forces.contact_law: 0 = FREE, the law as it
    # is; HELD_* keep one branch over a piece of an event-located step schedule)
    ("contact_mode", lambda N, m, K, B, c, c2: (K, N * B)),
)
_INDEX = {name: i for i, (name, _) in enumerate(_ARRAYS)}
(
    I_A0D, I_A1, I_A1T, I_PEXC, I_COS, I_SIN, I_PAERO, I_R, I_XA, I_XB, I_AP, I_BP, I_ARM, I_T,
    I_KC, I_PRELOAD, I_TIP, I_ACTIVE, I_STOP, I_STOPT, I_COUNT, I_VT, I_WT, I_KW, I_DV, I_NOZ,
    I_Y, I_YD, I_PAIR, I_G, I_COL, I_UA, I_UB, I_VA, I_VB, I_FA, I_FB, I_FN, I_NORMAL, I_STATE,
    I_POWER, I_STIME, I_STIP, I_SMIN, I_SOPEN, I_STOTAL, I_XCOUNT, I_XTIME, I_XSTATE, I_KSEG,
    I_DELTA, I_AEROA, I_AEROB, I_LAW, I_KT, I_WNEXT, I_SSLIP, I_WNONE, I_SHIFTK, I_SHIFTP,
    I_MODE,
) = range(len(_ARRAYS))

STOP_NONFINITE, STOP_AMPLITUDE = 1, 2

ALIGN = 8  # doubles: 64 bytes


def context_bytes(N: int, m: int, K: int, B: int, capacity: int, state_capacity: int = 0) -> int:
    """The bytes of a :class:`Context` (its one array) of ``B`` cases of ``N`` blades, ``m``
    modes and ``K`` contact kinds, ``capacity`` samples per window (``state_capacity`` modal
    states): known before it is allocated."""
    doubles = H_OFFSETS + len(_ARRAYS) + ALIGN
    for _, shape in _ARRAYS:
        doubles += int(np.prod(shape(N, m, K, B, capacity, state_capacity))) + ALIGN
    return 8 * doubles


def aligned_zeros(size: int) -> np.ndarray:
    """A zeroed float64 array whose data starts on a 64-byte boundary. Measured: shifting the
    context's arrays by 8 bytes made the right-hand side ~15 % slower."""
    raw = np.zeros(size + ALIGN)
    start = (-raw.ctypes.data // 8) % ALIGN
    return raw[start : start + size]


class Context:
    """The float64 context array of a batch of ``B`` cases and named numpy views into it.

    Built from one :class:`~wheelrom.forces.parameters.ForceParameters` per case (the cases
    may differ only in their contact frames ``T`` and stiffnesses ``k_c``) and the reduced
    model; ``capacity`` output samples per window and case.
    """

    def __init__(self, cases: list[ForceParameters], model, beta: float, sample_dt: float,
                 limit: float, capacity: int, state_every: int = 0,
                 state_capacity: int = 0):
        first = cases[0]
        N, m, K, B = first.blades, first.modes, len(first.contacts.kinds), len(cases)
        check_batchable(cases, model)
        self.N, self.m, self.K, self.B, self.capacity = N, m, K, B, capacity
        state_capacity = state_capacity if state_every > 0 else 0
        self.shapes = [fn(N, m, K, B, capacity, state_capacity) for _, fn in _ARRAYS]
        offsets, pos = [], H_OFFSETS + len(_ARRAYS)
        for shape in self.shapes:
            pos += -pos % ALIGN  # every array starts on a 64-byte boundary (AVX loads)
            offsets.append(pos)
            pos += int(np.prod(shape))
        self.array = aligned_zeros(pos)
        self._offsets = offsets
        self._fill_header(first, model, beta, sample_dt, limit, pos)
        self.array[H_STATE_EVERY] = state_every if state_capacity else 0
        self.array[H_STATE_CAP] = state_capacity
        # the kernel's modal basis: the segment modes rotated to diagonalise A0 (see
        # :func:`diagonal_basis`), under the elastic law A0 + S (the stuck springs' share
        # that the exponential scheme propagates exactly, :mod:`.stuck_shift`); every modal
        # vector and the state are rotated with it
        shift = shift_stiffness(model, first)
        self.array[H_SHIFT] = 1.0 if np.any(shift) else 0.0
        self.basis, A0_diag = diagonal_basis(model.A0 + spring_matrix(first, shift))
        for name, value in self._values(cases, model, A0_diag).items():
            self.view(name)[...] = value
        self.view("shift_k")[...] = shift

    def _fill_header(self, first: ForceParameters, model, beta, sample_dt, limit,
                     length) -> None:
        h = self.array
        N, m, K, B = self.N, self.m, self.K, self.B
        h[H_LEN], h[H_N], h[H_M], h[H_K], h[H_B], h[H_ACTIVE] = length, N, m, K, B, B
        h[H_VDP], h[H_NS], h[H_OMEGA] = first.vdp_model, first.stator_vanes, first.omega
        h[H_FB], h[H_MU], h[H_R], h[H_BETA] = first.nozzle_force, first.vdp_mu, first.vdp_r, beta
        h[H_SLIDERS] = first.sliders
        h[H_USER_REASON] = int(petsc().TS.ConvergedReason.CONVERGED_USER)
        h[H_SAMPLE_DT], h[H_CAP], h[H_LIMIT] = sample_dt, self.capacity, limit
        h[H_NSTATE] = B * state_size(first)
        h[H_MISTUNED] = 0.0 if model.tuned else 1.0
        h[H_OFFSETS : H_OFFSETS + len(_ARRAYS)] = self._offsets

    def _values(self, cases: list[ForceParameters], model, A0_diag) -> dict:
        """The parameter arrays of the context, in the kernel's basis and column layout."""
        N, K, B, P = self.N, self.K, self.B, self.basis
        first = cases[0]
        c = first.contacts
        A1 = P.T @ model.A1 @ P

        def columns(per_case):  # (B, ..., N) -> (..., N * B), case innermost
            a = np.asarray(per_case, dtype=float)
            return np.moveaxis(a, 0, -1).reshape(*a.shape[1:-1], N * B)

        return {
            "A0_diag": A0_diag,
            "A1": A1,
            "A1T": A1.T,
            "p_exc": P.T @ first.excitation,
            "cos_phase": np.repeat(np.cos(first.nozzle_phase), B),
            "sin_phase": np.repeat(np.sin(first.nozzle_phase), B),
            "p_aero": P.T @ first.aero,
            "R": first.rotation,
            "XA": c.shape_A @ P,
            "XB": c.shape_B @ P,
            "A_point": c.point_A,
            "B_point": c.point_B,
            "arm": c.arm_length,
            # (B, K, N, 3, 3) -> (K, 9, N, B)
            "T": columns([f.contacts.frame.reshape(K, N, 9).transpose(0, 2, 1) for f in cases]),
            "k_c": columns([f.contacts.stiffness for f in cases]),
            "preload": c.preload,
            "tip": model.tip @ P,
            "active": np.ones(B),
            "K_seg": P.T @ model.K_seg @ P,
            "delta": np.repeat(model.mistuning if not model.tuned else np.zeros(N), B),
            "aero_a": first.aero_displacement,
            "aero_b": first.aero_velocity,
            "law": first.friction,
            "k_t": columns([f.contacts.tangential for f in cases]),
        }

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

    @property
    def sliders(self) -> int:
        """Slider coordinates per case (``2 K N`` under the elastic law, else 0)."""
        return int(self.array[H_SLIDERS])

    def pack(self, states: np.ndarray) -> np.ndarray:
        """Kernel state (length ``B`` :func:`state_size`) from blade-major case states
        ``(B, state_size)`` (or ``(state_size,)`` when ``B = 1``)."""
        N, m, B, K = self.N, self.m, self.B, self.K
        s = np.asarray(states, dtype=float).reshape(B, -1)
        n = N * m
        P = self.basis  # z_s = P^T q_s, i.e. z_s^T = q_s^T P
        q = _times(s[:, :n].reshape(B, N, m), P).transpose(2, 1, 0)  # (m, N, B)
        v = _times(s[:, n : 2 * n].reshape(B, N, m), P).transpose(2, 1, 0)
        w = s[:, 2 * n : 2 * n + 4].T  # (4, B)
        # sliders: blade-major (c, s, a) per case -> (c, a, s, b)
        sliders = s[:, 2 * n + 4 :].reshape(B, K, N, 2).transpose(1, 3, 2, 0) if self.sliders \
            else np.zeros(0)
        return np.concatenate([q.ravel(), v.ravel(), w.ravel(), np.ravel(sliders)])

    def unpack_states(self, z: np.ndarray) -> np.ndarray:
        """Blade-major modal states ``(S, 2, N, m)`` (``q``, ``q'`` of every blade) from the
        recorded kernel-basis samples ``z`` ``(S, 2, m, N)`` (the same rotation as
        :meth:`unpack`, the same bits whatever the batch)."""
        return _times(np.swapaxes(np.asarray(z), 2, 3), self.basis.T)

    def unpack(self, u: np.ndarray) -> np.ndarray:
        """Blade-major case states ``(B, state_size)`` from a kernel state (inverse of
        :meth:`pack`)."""
        N, m, B, K = self.N, self.m, self.B, self.K
        n = N * m * B
        u = np.asarray(u)
        PT = self.basis.T  # q_s = P z_s
        q = _times(u[:n].reshape(m, N, B).transpose(2, 1, 0), PT).reshape(B, N * m)
        v = _times(u[n : 2 * n].reshape(m, N, B).transpose(2, 1, 0), PT).reshape(B, N * m)
        w = u[2 * n : 2 * n + 4 * B].reshape(4, B).T
        sliders = u[2 * n + 4 * B :].reshape(K, 2, N, B).transpose(3, 0, 2, 1).reshape(B, -1) \
            if self.sliders else np.zeros((B, 0))
        return np.concatenate([q, v, w, sliders], axis=1)


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


def state_size(params: ForceParameters) -> int:
    """Length of one case's blade-major state: ``q``, ``q'`` (``N m`` each), the four work
    integrals and the elastic law's sliders (``2 K N``, none under the paper law)."""
    return 2 * params.blades * params.modes + 4 + params.sliders


def check_batchable(cases: list[ForceParameters], model) -> None:
    """Cases of a batch share everything but the contact frames and stiffnesses, and the
    springs the exponential scheme propagates (:mod:`.stuck_shift`: one basis a batch)."""
    first = cases[0].shared()
    shift = shift_stiffness(model, cases[0])
    for f in cases[1:]:
        if not all(np.array_equal(a, b) for a, b in zip(f.shared(), first, strict=True)):
            raise ValueError("cases of one batch may differ only in contact angles and stiffnesses")
        if not np.array_equal(shift_stiffness(model, f), shift):
            raise ValueError("cases of one batch must share their smallest k_t per contact kind "
                             "(the springs the exponential scheme propagates exactly)")


@numba.njit(inline="always")
def get(ctx, index, size):
    """The context array ``index`` (of ``size`` doubles) as a 1-D view, in compiled code."""
    o = int(ctx[H_OFFSETS + index])
    return ctx[o : o + size]
