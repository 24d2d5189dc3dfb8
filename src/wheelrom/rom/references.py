"""Full-wheel finite-element references for the reduced model (paper Fig. 8, "full 3D FE").

Two independent ways to the modes of the whole wheel built from the segment FE with the same
coupling springs ``c1`` (on all DOFs of every ``right(s)``/``left(s+1)`` node pair, with the
sector rotation ``R``) as the reduced model:

(a) :func:`assembled_wheel_modes`: ``N`` copies of the segment joined by the springs, one
    sparse matrix of ``N n`` DOFs distributed over the communicator, lowest modes by SLEPc
    (prefix ``fullwheel_``). Practical with the ``coarse`` preset and a few ranks.
(b) :func:`cyclic_modes`: exact cyclic symmetry on one sector. For phase ``phi = 2 pi k/N``
    the Bloch condition ``u(s+1) = e^{i phi} u(s)`` turns the springs into a Hermitian
    sector stiffness ``K + c1 (Pl^T Pl + Pr^T Pr) - c1 (e^{i phi} X + e^{-i phi} X^T)``,
    ``X = Pr^T R Pl``; PETSc here is real, so it is solved in the real ``2n`` form
    ``[[A, -B], [B, A]]`` (``A``, ``B`` its real and imaginary parts) whose eigenvalues come in
    equal pairs (prefix ``cyclic_``). Cheap for any preset.

The reduced model is a Ritz projection of (b) onto the segment basis for every ``k``, so its
frequencies per nodal diameter are upper bounds of (b)'s, family by family.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from wheelrom.segment.assembly import SegmentMatrices
from wheelrom.segment.mesh import SegmentMesh
from wheelrom.segment.modes import lowest_modes
from wheelrom.segment.springs import phase_stiffness, spring_parts


def phase_modes(seg: SegmentMesh, mats: SegmentMatrices, parts, k: int, nev: int, comm):
    """The lowest ``nev`` sector modes of phase index ``k`` (exact cyclic symmetry).

    ``parts``: :func:`~wheelrom.segment.springs.spring_parts`. Returns ``(eigenvalues (nev,),
    vectors)``; ``vectors`` are real and span the modes: ``(n_free, nev)`` for a real phase
    (``k`` = 0, N/2), else ``(n_free, 2 nev)`` with the real and imaginary parts.
    """
    A, B = phase_stiffness(mats, parts, 2 * np.pi * k / seg.sectors)
    if B is None:
        res = lowest_modes(A, mats.M, nev, comm, prefix="cyclic_")
        return res.eigenvalues, res.vectors
    A2 = sp.bmat([[A, -B], [B, A]], format="csr")
    M2 = sp.block_diag([mats.M, mats.M], format="csr")
    res = lowest_modes(A2, M2, 2 * nev, comm, prefix="cyclic_")
    lam = 0.5 * (res.eigenvalues[0::2] + res.eigenvalues[1::2])  # equal pairs
    V = res.vectors[:, 0::2]  # one member of each pair: x + i y as [x; y]
    n = mats.free.size
    return lam, np.hstack([V[:n], V[n:]])


def cyclic_modes(
    seg: SegmentMesh,
    mats: SegmentMatrices,
    c1: float,
    k: int,
    nev: int,
    comm,
    parts=None,
) -> np.ndarray:
    """Lowest ``nev`` wheel frequencies [Hz] with phase index ``k`` (nodal diameter
    ``min(k, N - k)``), exact cyclic symmetry on one sector."""
    parts = parts if parts is not None else spring_parts(seg, mats, c1)
    lam, _ = phase_modes(seg, mats, parts, k, nev, comm)
    return np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi)


def time_left(seconds: float) -> str:
    """``about 40 s left`` / ``about 5.5 min left``."""
    if seconds < 1:
        return "less than 1 s left"
    if seconds < 120:
        return f"about {seconds:.0f} s left"
    return f"about {seconds / 60:.1f} min left"


def phase_weight(k: int, sectors: int) -> float:
    """Relative cost of the sector eigenproblem of phase ``k``: 0.25 for the real phases
    (ND 0 and N/2, ``n`` DOFs), 1 for the complex ones (``2 n`` DOFs, and the sparse
    factorisation grows faster than its size: on the default segment ND 0 took 3.0 s and every
    complex phase 13.8 s; with 0.5 the estimate after ND 0 was 3.3 min for 7.4)."""
    return 0.25 if 2 * k in (0, sectors) else 1.0


def cyclic_table(seg, mats, c1: float, nev: int, comm, log=None) -> np.ndarray:
    """``(N // 2 + 1, nev)`` frequencies [Hz] per nodal diameter by (b).

    ``log``: called after every ND with the elapsed time, the count done and the time left,
    estimated from the time per phase so far (ND 0 and N/2 are real problems of half the
    size: counted as a quarter of a phase, :func:`phase_weight`)."""
    parts = spring_parts(seg, mats, c1)
    count = seg.sectors // 2 + 1
    weight = [phase_weight(k, seg.sectors) for k in range(count)]
    out = []
    t0 = time.perf_counter()
    for k in range(count):
        out.append(cyclic_modes(seg, mats, c1, k, nev, comm, parts))
        if log:
            elapsed = time.perf_counter() - t0
            left = sum(weight[k + 1 :]) * elapsed / sum(weight[: k + 1])
            eta = f", {time_left(left)}" if k + 1 < count else ""
            log(f"cyclic FE: ND {k} done ({elapsed:.1f} s), {k + 1} of {count}{eta}")
    return np.array(out)


def assembled_wheel(seg: SegmentMesh, mats: SegmentMatrices, c1: float):
    """``(K, M)`` of ``N`` segment copies joined by the springs, sparse ``(N n, N n)``."""
    N = seg.sectors
    D, X = spring_parts(seg, mats, c1)
    eye = sp.identity(N, format="csr")
    # spring (s, s+1): 1/2 c1 |R Pl u_{s+1} - Pr u_s|^2 -> (s,s) c1 Pr^T Pr, (s+1,s+1)
    # c1 Pl^T Pl (together D on every diagonal block), (s, s+1) -X, (s+1, s) -X^T
    shift = sp.csr_matrix((np.ones(N), (np.arange(N), (np.arange(N) + 1) % N)), shape=(N, N))
    K = sp.kron(eye, mats.K + D) - sp.kron(shift, X) - sp.kron(shift.T, X.T)
    M = sp.kron(eye, mats.M)
    return K.tocsr(), M.tocsr()


def assembled_wheel_modes(seg, mats, c1: float, nev: int, comm) -> np.ndarray:
    """Lowest ``nev`` frequencies [Hz] of the assembled wheel (a), SLEPc on ``comm``."""
    K, M = assembled_wheel(seg, mats, c1)
    res = lowest_modes(K, M, nev, comm, prefix="fullwheel_")
    return res.frequencies_hz
