"""Stability of a travelling-wave limit cycle: Floquet exponents by Hill's method on the
harmonic-balance linearisation (docs/theory.md, "Limit cycles").

A perturbation of the whole wheel about the wave splits, by cyclic symmetry, into Bloch
families ``p = 0..N-1`` (blade-to-blade phase ``theta = 2 pi p / N`` on top of the wave's)::

    dq_s(t) = e^{sigma t} e^{i theta s} sum_{h=-H..H} d_h e^{i h (omega t + s phi)}

and for each family the Floquet exponents ``sigma`` are the eigenvalues of the Hill matrix
(first-order form, ``w_h = (sigma + i h omega) d_h``)::

    sigma [d; w] = [[-i Omega, I], [-K + J_q, -i Omega - beta_D K + J_v]] [d; w]

``K = diag_h K(theta + h phi)``, ``Omega = diag_h(h omega)``, ``J_q``, ``J_v`` the Toeplitz
blocks of the force derivatives' Fourier coefficients, each window blade ``b`` weighted by
``e^{i b (theta + h' phi)}``. Harmonic ``h`` of family ``p`` lives on the wave ``p + h k``:
the slot ``h`` of family ``p`` describes the same perturbation as slot 0 of family
``p + h k`` (its exponent shifted by ``i h omega``, the same real part). An eigenvector
spread over two slots (a real perturbation of a travelling wave: slots ``h`` and ``-h``) sits
between them, so "the ``2 m`` most centred per family" misses exponents for ``k != 0``;
instead every eigenvalue centred within ``max(1, H / 3)`` slots of harmonic 0 is kept (copies
included: they repeat a real part, which is all stability needs; the slots near ``+-H``,
which truncation corrupts, are left out; a stiff Ritz vector far above ``H omega`` is
represented by its slot-0 copy). The trivial exponent of the phase shift (multiplier 1)
lives in family 0 and family ``k``; a cycle is stable when every other exponent has a
negative real part. Multipliers are ``exp(sigma T)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wheelrom.analysis.periodic.harmonic_balance import WaveBalance
from wheelrom.analysis.periodic.window import WINDOW, Linearisation

#: growth rate [1/s] up to which an exponent counts as neutral (as the linear verdict)
TOLERANCE = 1e-6
#: ``|mu_0 - 1|`` of the phase shift's multiplier above which the analysis is not trusted: a
#: contact that opens within the cycle makes the force derivatives jump, their Fourier
#: series converge slowly and Hill's exponents drift with ``H`` (measured: 7..38 /s for the
#: same vibro-impact cycle at H = 3..15, its trivial multiplier off by 1-5 %)
TRUSTED = 1e-3


@dataclass(frozen=True)
class FloquetResult:
    """``families``: the Bloch families checked (``p``); ``growth`` ``(len(families),)`` the
    largest non-trivial Floquet exponent's real part [1/s] of each; ``multiplier``: the
    largest non-trivial ``|exp(sigma T)|``; ``trivial``: ``|exp(sigma_0 T) - 1|`` of the
    phase-shift exponent (it should be ~0); ``stable``: every non-trivial growth
    <= :data:`TOLERANCE`; ``trusted``: ``trivial`` <= :data:`TRUSTED` (else the verdict is
    reported as uncertain)."""

    families: np.ndarray
    growth: np.ndarray
    multiplier: float
    trivial: float
    stable: bool
    by: str = "Floquet: family"  # what decided, and what a family is (the transient: "ND")
    trust: float = TRUSTED  # the largest ``trivial`` at which the verdict holds

    @property
    def trusted(self) -> bool:
        # infinite trust: a verdict that needs no phase-shift check (a proof of instability)
        return bool(self.trust == math.inf or self.trivial <= self.trust)

    @property
    def worst_family(self) -> int:
        """The family of the largest growth (-1: none computed)."""
        if not len(self.growth):
            return -1
        return int(self.families[int(np.argmax(self.growth))])


def hill_matrix(balance: WaveBalance, lin: Linearisation, omega: float, lam: float,
                theta: float) -> np.ndarray:
    """``(2 m (2H + 1), 2 m (2H + 1))`` complex Hill matrix of Bloch phase ``theta`` [rad]."""
    b, m, H = balance, balance.modes, balance.H
    harmonics = np.arange(-H, H + 1)
    n = harmonics.size
    orders = np.arange(-2 * H, 2 * H + 1)
    basis = np.exp(-1j * np.outer(orders, b.tau)) / b.nt  # (4H + 1, n_t)
    Jq = np.einsum("nj,wjil->wnil", basis, lin.dq)  # (3, 4H + 1, m, m)
    Jv = np.einsum("nj,wjil->wnil", basis, lin.dv)
    Aq = np.zeros((n, m, n, m), dtype=complex)
    Av = np.zeros((n, m, n, m), dtype=complex)
    for w, blade in enumerate(WINDOW):
        weight = np.exp(1j * blade * (theta + harmonics * b.phi))  # (n,) over h'
        difference = harmonics[:, None] - harmonics[None, :] + 2 * H  # index of h - h'
        Aq += (Jq[w][difference] * weight[None, :, None, None]).transpose(0, 2, 1, 3)
        Av += (Jv[w][difference] * weight[None, :, None, None]).transpose(0, 2, 1, 3)
    K = np.zeros((n, m, n, m), dtype=complex)
    for i, h in enumerate(harmonics):
        phase = theta + h * b.phi
        K[i, :, i, :] = b._wave_stiffness(phase) + b.speed_term(omega)
        if b.table:  # the table's displacement and velocity parts
            A, B = b.table_parts(phase)
            Aq[i, :, i, :] -= lam * A
            Av[i, :, i, :] -= lam * B
    size = n * m
    K, Aq, Av = K.reshape(size, size), Aq.reshape(size, size), Av.reshape(size, size)
    Omega = np.diag(np.repeat(harmonics * omega, m)).astype(complex)
    return np.block([[-1j * Omega, np.eye(size)],
                     [-K + Aq, -1j * Omega - b.beta * K + Av]])


def exponents(balance: WaveBalance, lin: Linearisation, omega: float, lam: float,
              theta: float) -> np.ndarray:
    """The Floquet exponents [1/s] of Bloch phase ``theta``: the eigenvalues of the Hill
    matrix whose eigenvectors are centred within ``max(1, H / 3)`` slots of harmonic 0 (copies
    of one exponent in neighbouring slots included: they have its real part; the slots near
    ``+-H``, which truncation corrupts, left out)."""
    m, H = balance.modes, balance.H
    values, vectors = np.linalg.eig(hill_matrix(balance, lin, omega, lam, theta))
    n = 2 * H + 1
    d = np.abs(vectors[: n * m].reshape(n, m, -1)) ** 2
    energy = d.sum(axis=1)  # (n, eigenvalues)
    centroid = (np.arange(-H, H + 1)[:, None] * energy).sum(axis=0) / energy.sum(axis=0)
    return values[np.abs(centroid) <= max(1.0, H / 3)]


def floquet(balance: WaveBalance, lin: Linearisation, omega: float, lam: float,
            families=None) -> FloquetResult:
    """Floquet analysis of a solved cycle; ``families``: the Bloch families ``p`` to check
    (default: the wave's own, ``p = k``, where its amplitude and phase perturbations live).
    Family ``N - p`` is the complex conjugate of family ``p`` (a real system: the same
    exponents, conjugated), so each pair is computed once.

    The phase shift's exponent (multiplier 1) appears in family 0 (slots ``+-1``: the real
    perturbation ``dq/dt``) and in family ``k`` (slot 0, ``+i omega``) and their copies; both
    families are always analysed, ``trivial`` is the distance to 1 of the multiplier closest
    to it there, and that exponent with its slot copies (the same multiplier) is removed
    before the growth rates are taken."""
    N, k = balance.blades, balance.wave
    families = np.array([k] if families is None else list(families), dtype=int)

    def mirror(p: int) -> int:
        return int(min(p % N, (N - p) % N))

    period = 2 * math.pi / omega
    computed = {p: exponents(balance, lin, omega, lam, 2 * math.pi * p / N)
                for p in sorted({mirror(p) for p in families} | {0, mirror(k)})}
    distance = {p: np.abs(np.exp(sigma * period) - 1.0) for p, sigma in computed.items()}
    holder = min((0, mirror(k)), key=lambda p: distance[p].min(initial=math.inf))
    trivial = float(distance[holder].min(initial=math.inf))
    mu_0 = np.exp(computed[holder][int(np.argmin(distance[holder]))] * period)
    growth_of = {}
    for p, sigma in computed.items():
        # the phase shift's exponent and its slot copies (the same multiplier) only: an
        # amplitude exponent near 0 (a fold, a subcritical branch) must stay
        copy = np.abs(np.exp(sigma * period) - mu_0) <= trivial + 1e-9
        rest = sigma[~copy] if p in (0, mirror(k)) else sigma
        growth_of[p] = float(rest.real.max()) if rest.size else -math.inf
    growth = np.array([growth_of[mirror(p)] for p in families])
    worst = float(growth.max())
    return FloquetResult(families, growth, math.exp(worst * period), trivial,
                         bool(worst <= TOLERANCE))
