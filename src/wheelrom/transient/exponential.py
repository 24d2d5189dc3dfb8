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
from wheelrom.transient.layout import H_BETA, H_EXPONENTIAL, H_NSTATE

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
        self._step = None
        self._coef = None
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
        if h != self._step:
            self._coef = coefficients(self._A0, self._beta, h)
            self._step = h
        x = ts.getSolution()
        with x as u:
            etd4_step(t, h, u, self.context.array, self._coef, self._work)
        ts.setTime(t + h)


def segment_frequencies(model) -> np.ndarray:
    """The exactly propagated frequencies [Hz]: those of ``A0`` (ascending)."""
    return np.sqrt(np.maximum(np.linalg.eigvalsh(model.A0), 0.0)) / (2 * math.pi)


def _resonant(freqs: np.ndarray, step: float):
    """The first ``(f, k)`` with ``f step`` within ``RESONANCE_BAND k`` of a whole ``k >= 1``."""
    for f in freqs[::-1]:
        k = round(f * step)
        if k >= 1 and abs(f * step - k) <= RESONANCE_BAND * k:
            return f, k
    return None


def safe_step(model, step: float) -> tuple[float, str | None]:
    """The largest step ``<= step`` [s] at which no exactly propagated segment mode completes
    (nearly) a whole number of periods, and why it differs (None when ``step`` is safe).

    There (``f_j h`` within 7 % of an integer) the explicit contact coupling of that mode is
    not damped by the scheme: a resonance of exponential integrators (measured on the default
    wheel: 16.1-16.5 us, one period of the contact-stiffened 60 kHz vector, blow up; 15.75 and
    17.25 us are fine). Lowering the step past the band costs at most 7 %."""
    freqs = segment_frequencies(model)
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
