"""The aerodynamic damping table as a linear operator in blade coordinates: influence
coefficients (docs/theory.md, "Aerodynamic damping table").

The force on blade ``s`` along its aerofoil's ``y`` direction (the Van der Pol direction
``p``, generalised force ``p F_s``) is::

    F_s = -sum_j ( a_j y_{s+j} + b_j y'_{s+j} ),   y_s = p^T q_s  [m]

with real ``a_j`` [N/m] and ``b_j`` [N s/m], ``j = 0..N-1`` (blade ``s`` feels blade
``s + j``). For the travelling wave ``y_s = Y e^{lambda t + i s sigma_k}`` this is
``F = -(A_k + lambda B_k) y`` with ``A_k = sum_j a_j e^{i j sigma_k}`` (likewise ``B_k``): the
inverse DFT of ``A_k``, ``B_k`` gives ``a_j``, ``b_j``. The table gives, per ND ``k`` (lead
convention, ``omega_k > 0``), the complex coefficient ``kappa_k = k_a(k) + i omega_k c_a(k)``
that ``A_k + i omega_k B_k`` must equal; real ``a_j``, ``b_j`` tie ND ``k`` to ND ``N - k``
(``A_{N-k} = conj A_k``), so each pair is solved together::

    B_k = (kappa_k - conj kappa_{N-k}) / (i (omega_k + omega_{N-k})),
    A_k = kappa_k - i omega_k B_k.

The operator is exact for harmonic motion at ``omega_k`` (what a flutter code computes) and
first-order accurate in the growth rate off it; a table symmetric in the two directions
(``kappa_{N-k} = conj kappa_k``) gives real ``A_k = k_a``, ``B_k = c_a``: exact at any
``lambda``. A damping ratio ``zeta_k`` of the selected segment mode ``j``'s family becomes
``c_a(k) = 2 zeta_k omega_k / p_j^2`` (modal mass 1: the family's modal equation gains
``2 zeta_k omega_k q_j'``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wheelrom.config.aero import AeroTable


@dataclass(frozen=True)
class AeroOperator:
    """The table as the wheel feels it, per ND ``k = 0..N-1``: ``kappa`` ``(N,)`` complex
    [N/m], ``omega`` ``(N,)`` reference frequencies [rad/s], and the influence coefficients
    ``a`` [N/m], ``b`` [N s/m] ``(N,)``; ``family``: the segment mode whose family it is."""

    family: int
    kappa: np.ndarray
    omega: np.ndarray
    a: np.ndarray
    b: np.ndarray


def aero_operator(table: AeroTable, model, family: int, p_family: float) -> AeroOperator:
    """The :class:`AeroOperator` of ``table`` on ``model`` (a ``ReducedModel``) for segment
    mode ``family``'s family, whose aero participation is ``p_family`` [1/sqrt(kg)]; the
    reference frequencies are the table's ``frequency_hz`` or the family's, contacts open."""
    if table.frequency_hz is not None:
        omega = 2 * np.pi * table.frequency_hz
    else:
        omega = family_frequencies(model, family)
    kappa = nd_coefficients(table, omega, p_family)
    a, b = influence_coefficients(kappa, omega)
    return AeroOperator(family, kappa, omega, a, b)


def family_frequencies(model, mode: int) -> np.ndarray:
    """``(N,)`` circular frequency [rad/s] of segment mode ``mode``'s family in every ND
    ``k = 0..N-1`` of the reduced wheel (contacts open): the eigenvalue of
    ``model.nd_stiffness(k)`` whose eigenvector has the largest share on ``mode``."""
    omega = np.empty(model.blades)
    for k in range(model.blades):
        w2, vectors = np.linalg.eigh(model.nd_stiffness(k))
        omega[k] = np.sqrt(max(w2[np.argmax(np.abs(vectors[mode]))], 0.0))
    return omega


def nd_coefficients(table: AeroTable, omega: np.ndarray, p_mode: float) -> np.ndarray:
    """``(N,)`` complex ``kappa_k = k_a + i omega_k c_a`` [N/m] of the table per ND at the
    reference frequencies ``omega`` ``(N,)`` [rad/s]; ``p_mode`` [1/sqrt(kg)]: the selected
    mode's aero participation (damping ratios only)."""
    if table.damping_ratio is not None:
        return 1j * omega * (2.0 * table.damping_ratio * omega / p_mode**2)
    return table.aero_stiffness + 1j * omega * table.aero_damping


def influence_coefficients(kappa: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(a, b)`` ``(N,)`` real influence coefficients [N/m], [N s/m] whose travelling-wave
    operator equals ``kappa`` ``(N,)`` at ``omega`` ``(N,)`` [rad/s] (module docstring)."""
    N = kappa.size
    partner = (-np.arange(N)) % N
    B = (kappa - np.conj(kappa[partner])) / (1j * (omega + omega[partner]))
    A = kappa - 1j * omega * B
    # a_j = (1/N) sum_k A_k e^{-i j sigma_k}
    a, b = np.fft.fft(A) / N, np.fft.fft(B) / N
    return np.ascontiguousarray(a.real), np.ascontiguousarray(b.real)
