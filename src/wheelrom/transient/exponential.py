"""The exponential integrator of the transient: ETDRK4 (Cox & Matthews 2002) with the segment
block ``A0`` of ``K_R`` (and its ``beta_D`` damping) propagated exactly, as a PETSc TS of
type ``python`` (:class:`ExponentialStepper`; the compiled step is
:func:`wheelrom.transient.exponential_kernel.etd4_step`).

Why (issue #31, measured in docs/performance.md): the attachment vectors that resolve the
contacts make ``A0`` reach 60 and 69 kHz, which bounds an explicit RK step to 4.2 us, while
the coupling between blades (``A1``: 3.5 kHz equivalent) and the contacts (17.6 kHz for a
blade's own contact springs) are much softer and the wheel's stiff families are flat across
the nodal diameters. With ``A0`` exact the step is set by what stays explicit.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import expm

from wheelrom.runtime.errors import InputError
from wheelrom.transient.contact_kernel import slide_core
from wheelrom.transient.exponential_kernel import (
    C_F1,
    C_F2,
    C_F3,
    C_FULL,
    C_HALF,
    C_PHI_HALF,
    C_ROWS,
    etd4_step,
)
from wheelrom.transient.layout import H_BETA, H_EXPONENTIAL, H_NSTATE, H_SLIDERS
from wheelrom.transient.stuck_shift import shift_matrix

SCHEME = "etdrk4"
# steps refused: f_j h within this relative distance of a whole number of periods of an
# exactly propagated mode (measured: the 60 kHz attachment vector of the default wheel made
# 16.1-16.5 us unstable, f h = 0.97-0.99; 15.75 us and 17.25 us were fine)
RESONANCE_BAND = 0.07


def _phi_matrices(a: float, beta: float, tau: float) -> tuple[np.ndarray, np.ndarray]:
    """``(exp(tau L), [phi_1, phi_2, phi_3](tau L) e2)`` for ``L = [[0, 1], [-a, -beta a]]``
    (``(2, 2)`` and ``(3, 2)``), from one exponential of the augmented 5 x 5 matrix
    ``[[tau L, e2, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1], [0, 0, 0, 0]]`` (Sidje 1998): no
    cancellation for the slow modes (``tau sqrt(a)`` of 1e-3), unlike the closed forms."""
    M = np.zeros((5, 5))
    M[0, 1] = tau
    M[1, 0] = -a * tau
    M[1, 1] = -beta * a * tau
    M[1, 2] = 1.0
    M[2, 3] = 1.0
    M[3, 4] = 1.0
    X = expm(M)
    return X[:2, :2], X[:2, 2:5].T


def coefficients(A0_diag: np.ndarray, beta: float, h: float) -> np.ndarray:
    """``(C_ROWS, m)`` coefficients of :func:`etd4_step` for step ``h`` [s], the eigenvalues
    ``A0_diag`` [1/s^2] of ``A0`` and ``beta`` [s] (layout: ``exponential_kernel``)."""
    m = len(A0_diag)
    coef = np.zeros((C_ROWS, m))
    for j, a in enumerate(A0_diag):
        E, phi = _phi_matrices(float(a), beta, h)
        E_half, phi_half = _phi_matrices(float(a), beta, 0.5 * h)
        coef[C_FULL : C_FULL + 4, j] = E.ravel()
        coef[C_HALF : C_HALF + 4, j] = E_half.ravel()
        coef[C_PHI_HALF : C_PHI_HALF + 2, j] = phi_half[0]
        coef[C_F1 : C_F1 + 2, j] = phi[0] - 3 * phi[1] + 4 * phi[2]
        coef[C_F2 : C_F2 + 2, j] = phi[1] - 2 * phi[2]
        coef[C_F3 : C_F3 + 2, j] = -phi[1] + 4 * phi[2]
    return coef


class ExponentialStepper:
    """The ``python`` TS context of the exponential scheme: one :func:`etd4_step` per TS step
    on the TS's solution Vec (the kernel's state layout), the coefficients recomputed when the
    step changes. ``context``: the :class:`~wheelrom.transient.layout.Context` of the batch
    (None: a TS that only reads options, :func:`wheelrom.transient.ts.ts_settings`)."""

    def __init__(self, context=None):
        self.context = context
        self._coefficients: dict[float, np.ndarray] = {}  # per step: an event schedule's recur
        if context is not None:
            self._work = np.zeros((6, int(context.array[H_NSTATE])))
            self._A0 = context.view("A0_diag").copy()
            self._beta = float(context.array[H_BETA])

    def attach(self, active: bool) -> None:
        """Tell the kernel whether this scheme integrates (``A0`` left out of its force) or
        the user's options chose another TS type (the full right-hand side)."""
        if self.context is not None:
            self.context.array[H_EXPONENTIAL] = 1.0 if active else 0.0

    def step(self, ts) -> None:
        if self.context is None:
            raise RuntimeError("the exponential TS has no problem attached")
        t, h = ts.getTime(), ts.getTimeStep()
        coef = self._coefficients.get(h)
        if coef is None:
            if len(self._coefficients) > 256:
                self._coefficients.clear()
            coef = self._coefficients[h] = coefficients(self._A0, self._beta, h)
        x = ts.getSolution()
        with x as u:
            etd4_step(t, h, u, self.context.array, coef, self._work)
        ts.setTime(t + h)


def end_sliders(u, context) -> None:
    """The state ``u`` (a Vec, kernel layout) a solve of the exponential scheme left, with
    the elastic law's sliders returned onto the Coulomb limit: its step returns them in its
    first stage (:func:`etd4_step`), so the last step's are still the ones it held. Nothing
    under another scheme (its monitor returned them) or the paper law."""
    if context.array[H_EXPONENTIAL] != 0.0 and context.array[H_SLIDERS] > 0.0:
        with u as state:
            slide_core(state, context.array)


def segment_frequencies(model, shift: np.ndarray | None = None) -> np.ndarray:
    """The exactly propagated frequencies [Hz]: those of ``A0`` (plus ``shift``, the stuck
    springs' share under the elastic law, :mod:`.stuck_shift`), ascending."""
    A = model.A0 if shift is None else model.A0 + shift
    return np.sqrt(np.maximum(np.linalg.eigvalsh(A), 0.0)) / (2 * math.pi)


def _resonant(freqs: np.ndarray, step: float):
    """The first ``(f, k)`` with ``f step`` within ``RESONANCE_BAND k`` of a whole ``k >= 1``."""
    for f in freqs[::-1]:
        k = round(f * step)
        if k >= 1 and abs(f * step - k) <= RESONANCE_BAND * k:
            return f, k
    return None


def safe_step(model, step: float, shift: np.ndarray | None = None) -> tuple[float, str | None]:
    """The largest step ``<= step`` [s] at which no exactly propagated segment mode completes
    (nearly) a whole number of periods, and why it differs (None when ``step`` is safe).

    There (``f_j h`` within 7 % of an integer) the explicit contact coupling of that mode is
    not damped by the scheme: a resonance of exponential integrators (measured on the default
    wheel: 16.1-16.5 us, one period of the contact-stiffened 60 kHz vector, blow up; 15.75 and
    17.25 us are fine). Lowering the step past the band costs at most 7 %. ``shift``: see
    :func:`segment_frequencies`."""
    freqs = segment_frequencies(model, shift)
    h = step
    first = _resonant(freqs, h)
    hit = first
    while hit is not None:
        f, k = hit
        h = (k - RESONANCE_BAND * k) / f * (1.0 - 1e-9)
        hit = _resonant(freqs, h)
    if first is None:
        return step, None
    f, k = first
    return h, (f"time.step {step:g} s is {f * step:.3f} periods of the segment's "
               f"{f / 1e3:.4g} kHz mode, a resonance of the exponential scheme: "
               f"lowered to {h:.4g} s")


# --- the explicit contact coupling's stability ---------------------------------------------
# a step is refused when the scheme grows some ND faster than the wheel's linearisation does
# (a decaying one counted as not growing) by more than this [1/s] (measured on the default
# wheel: 0.0003-0.005 /s below the limit, 100-1700 /s beyond it; a mode decaying at -6.95 /s
# decays at -6.82 /s at 10 us: accuracy, not stability)
SPURIOUS_GROWTH = 0.1
RELATIVE_GROWTH = 0.05  # and by this share of a growing ND's own rate
STEP_FACTOR = 0.9  # a refused step is lowered by this factor until the scheme is stable


def _force_jacobian(model, params, q: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(d f / d q_0, d f / d q'_0)`` ``(N, m, m)`` [1/s^2, 1/s]: how blade 0's modal
    displacement and velocity move every blade's modal force (contacts, Van der Pol), by
    central differences at rest with every contact closed at its preload (and, under the
    elastic law, stuck: the sliders at rest): the stiffest explicit coupling a run meets. The
    contact forces are piecewise linear there, so a step that moves a contact point or the
    tip by 1 nm is exact to rounding. ``q`` ``(N, m)``: another state to linearise about
    (at rest; the sliders at rest there)."""
    from wheelrom.forces.reference import ReferenceForces

    N, m = model.blades, model.modes
    forces = ReferenceForces(params)
    rest = np.zeros((N, m)) if q is None else np.asarray(q, dtype=float)
    sliders = forces.sliders_at_rest(rest) if params.law.elastic else None
    shapes = [model.tip, *model.contact_A.values(), *model.contact_B.values()]
    reach = np.max(np.abs(np.concatenate([np.atleast_2d(s) for s in shapes])), axis=0)
    delta = 1e-9 / np.maximum(reach, 1e-300)  # (m,) modal steps of 1 nm (1 nm/s)
    jacobians = np.zeros((2, N, m, m))
    for which in range(2):
        for i in range(m):
            state = [rest.copy(), np.zeros((N, m)), rest.copy(), np.zeros((N, m))]
            state[which][0, i] += delta[i]
            state[2 + which][0, i] -= delta[i]
            up = forces.evaluate(0.0, state[0], state[1], sliders).copy()
            down = forces.evaluate(0.0, state[2], state[3], sliders).copy()
            jacobians[which, :, :, i] = (up - down) / (2 * delta[i])
    return jacobians[0], jacobians[1]


def _nd_explicit(model, jac_q, jac_v, beta: float, k: int, basis=None, delta: float = 0.0,
                 shift: np.ndarray | None = None):
    """``(L, N_k)`` ``(2m, 2m)`` in the kernel's basis (``A0 + S`` diagonal, ``S = shift``:
    the stuck springs' share the kernel propagates, :mod:`.stuck_shift`; None: 0): the exactly
    propagated part and the explicit part's Jacobian on ND ``k`` (``q_s = q_0 e^{i s phi_k}``):
    ``N_k = [[0, 0], [F_q - C, F_v - beta_D C]]``, ``C = A1 e^{i phi_k} + A1^T e^{-i phi_k}
    + delta K_seg - S`` (``delta``: a uniform mistuning, which the kernel adds explicitly and
    which keeps the wheel cyclic). ``basis``: ``eigh(A0 + S)`` when the caller has it (one
    per step size, not one per ND)."""
    N, m = model.blades, model.modes
    S = np.zeros((m, m)) if shift is None else shift
    a, V = np.linalg.eigh(model.A0 + S) if basis is None else basis
    # circulant: d f_0 / d x_d = d f_{-d} / d x_0, the blade-0 column's row -d
    rows = (-np.arange(N)) % N
    phase = np.exp(2j * math.pi * k * np.arange(N) / N)
    F_q = np.einsum("d,dji->ji", phase, jac_q[rows])
    F_v = np.einsum("d,dji->ji", phase, jac_v[rows])
    ph = np.exp(2j * math.pi * k / N)
    C = model.A1 * ph + model.A1.T * np.conj(ph) + delta * model.K_seg - S
    Z, I = np.zeros((m, m)), np.eye(m)
    explicit = np.block([[Z, Z], [V.T @ (F_q - C) @ V, V.T @ (F_v - beta * C) @ V]])
    linear = np.block([[Z, I], [-np.diag(a), -beta * np.diag(a)]])
    return linear, explicit


def step_matrix(coef: np.ndarray, explicit: np.ndarray, h: float) -> np.ndarray:
    """``(2m, 2m)``: one step of :func:`etd4_step` on the linear problem ``u' = L u + N u``
    (``coef``: :func:`coefficients` at ``h``; ``explicit``: ``N``, kernel basis)."""
    m = coef.shape[1]
    Z = np.zeros((m, m))

    def E(row):  # exp(tau L), per mode a 2 x 2 block
        return np.block([[np.diag(coef[row]), np.diag(coef[row + 1])],
                         [np.diag(coef[row + 2]), np.diag(coef[row + 3])]])

    def P(row):  # phi(tau L) e2 applied to a force on the velocity rows
        return np.block([[Z, np.diag(coef[row])], [Z, np.diag(coef[row + 1])]])

    I = np.eye(2 * m)
    E_half, kick = E(C_HALF), 0.5 * h * P(C_PHI_HALF) @ explicit
    A = E_half + kick
    B = E_half + kick @ A
    C = E_half @ A + kick @ (2 * B - I)
    return E(C_FULL) + h * (P(C_F1) @ explicit + 2 * P(C_F2) @ explicit @ (A + B)
                            + P(C_F3) @ explicit @ C)


def step_growth(model, jacobian, beta: float, h: float, delta: float = 0.0,
                shift: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(scheme, wheel)`` ``(N // 2 + 1,)`` [1/s] per ND: the largest growth rate of the
    scheme's step ``ln rho(R_k) / h`` and of the linearisation ``max Re eig(L + N_k)``
    (``delta``: every blade mistuned by it; ``shift``: the propagated springs,
    :func:`_nd_explicit`)."""
    basis = np.linalg.eigh(model.A0 if shift is None else model.A0 + shift)
    coef = coefficients(basis[0], beta, h)
    scheme, wheel = [], []
    for k in range(model.blades // 2 + 1):
        linear, explicit = _nd_explicit(model, *jacobian, beta, k, basis, delta, shift)
        rho = np.abs(np.linalg.eigvals(step_matrix(coef, explicit, h))).max()
        scheme.append(math.log(max(rho, 1e-300)) / h)
        wheel.append(np.linalg.eigvals(linear + explicit).real.max())
    return np.array(scheme), np.array(wheel)


_GROWTH_CACHE: dict = {}


def _cached_growth(model, jacobian, beta: float, h: float, delta: float = 0.0, shift=None):
    """:func:`step_growth`, kept per model, Jacobian, ``beta``, step and ``delta``: every
    window of a ``settle`` and every batch of a flow asks again (0.2 s a step on the default
    wheel)."""
    import hashlib

    digest = hashlib.sha1()
    S = np.zeros(0) if shift is None else shift
    for array in (model.A0, model.A1, model.K_seg, *jacobian, np.array([beta, h, delta]), S):
        digest.update(np.ascontiguousarray(array, dtype=float).tobytes())
    key = digest.hexdigest()
    if key not in _GROWTH_CACHE:
        if len(_GROWTH_CACHE) > 256:
            _GROWTH_CACHE.clear()
        _GROWTH_CACHE[key] = step_growth(model, jacobian, beta, h, delta, shift)
    return _GROWTH_CACHE[key]


def stable_step(model, params, beta: float, step: float) -> tuple[float, str | None]:
    """The largest step ``<= step`` [s] (lowered by ``STEP_FACTOR`` at a time, then off the
    resonances, :func:`safe_step`) at which the scheme grows no ND faster than the wheel's
    linearisation at rest with every contact closed (stuck), a decaying ND counted as not
    growing, by more than ``SPURIOUS_GROWTH``, and why it differs (None when ``step`` is
    stable and off the resonances).

    Why: the contacts are explicit; the elastic law's stuck tangential springs (``k_t`` in
    both tangential directions) stiffen that coupling beyond the scheme's reach at the
    default step (measured on the default wheel: stable to 6 us, at 7 us ND 0 grows at +100
    /s, at 10 us +1700 /s, where the linearisation decays; the paper law is stable to 20
    us). Blade 0's column of the tuned wheel; a mistuned wheel's explicit ``delta_s K_seg``
    is checked as the two uniformly mistuned wheels of its extreme ``delta_s`` (each cyclic:
    the largest explicit stiffness the kernel meets, on every blade at once). Under the
    elastic law the kernel propagates a share ``S`` of the stuck springs exactly
    (:mod:`.stuck_shift`: stable to 8 us there); an open contact then leaves ``+S``
    explicit, so the wheel with every contact open (the Van der Pol force alone) is checked
    as well."""
    shift = shift_matrix(model, params)
    shift = shift if np.any(shift) else None
    h, why = safe_step(model, step, shift)
    jacobians = [_force_jacobian(model, params)]
    if shift is not None:  # every contact open: no contact stiffness, the Van der Pol force
        jacobians.append((np.zeros_like(jacobians[0][0]), jacobians[0][1]))
    deltas = [0.0] if model.tuned else sorted({float(np.min(model.mistuning)),
                                               float(np.max(model.mistuning))})
    first = None
    for _ in range(60):
        # the state that limits: 0 closed and stuck, 1 every contact open
        excess, k, scheme, wheel, state = max((*_worst(model, jacobian, beta, h, deltas, shift), i)
                                              for i, jacobian in enumerate(jacobians))
        if excess <= SPURIOUS_GROWTH:
            if first is None:
                return h, why
            k, at, grows, exact, state = first
            law = "the contacts"
            if params.law.elastic:
                law = ("the elastic law's stuck springs" if state == 0 else
                       "the propagated springs' share with every contact open")
            if not model.tuned:
                law += " and the mistuning's delta_s K_seg"
            return h, (f"time.step {step:g} s: at {at:.3g} s the scheme grows ND {k} at "
                       f"{grows:.3g} /s (the wheel: {exact:.3g} /s), {law} explicit: "
                       f"lowered to {h:.4g} s")
        first = first or (k, h, scheme, wheel, state)
        h, _ = safe_step(model, STEP_FACTOR * h, shift)
    raise InputError(f"time.step {step:g} s: the exponential scheme found no stable step above "
                     f"{h:.3g} s for this model's explicit contact coupling")


def _worst(model, jacobian, beta: float, h: float, deltas: list[float], shift=None):
    """``(excess, ND, scheme's rate, wheel's rate)`` [1/s] of the ND whose step grows most
    beyond the wheel's own rate at step ``h`` over the uniform mistunings ``deltas``."""
    worst = (-math.inf, 0, 0.0, 0.0)
    for delta in deltas:
        scheme, wheel = _cached_growth(model, jacobian, beta, h, delta, shift)
        # a growing wheel's own rate is reproduced to the scheme's accuracy, not exactly
        excess = scheme - np.maximum(wheel, 0.0) * (1 + RELATIVE_GROWTH)
        k = int(np.argmax(excess))
        if excess[k] > worst[0]:
            worst = (float(excess[k]), k, float(scheme[k]), float(wheel[k]))
    return worst


def taken_step(model, cfg, step: float, angles_deg: dict | None = None) -> float:
    """The step [s] the exponential TS takes for one case of ``cfg`` (its contact angles
    ``angles_deg``, None: the configured ones): ``step`` off the resonances and within the
    scheme's stability (:func:`stable_step`)."""
    from wheelrom.forces.parameters import force_parameters

    params = force_parameters(model, cfg, angles_deg)
    return stable_step(model, params, cfg.wheel.damping_beta, step)[0]
