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

from wheelrom.assembly import SegmentMatrices, phase_stiffness, spring_parts
from wheelrom.mesh import SegmentMesh
from wheelrom.modes import lowest_modes


def phase_modes(seg: SegmentMesh, mats: SegmentMatrices, parts, k: int, nev: int, comm=None):
    """The lowest ``nev`` sector modes of phase index ``k`` (exact cyclic symmetry).

    ``parts``: :func:`~wheelrom.assembly.spring_parts`. Returns ``(eigenvalues (nev,),
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
    comm=None,
    parts=None,
) -> np.ndarray:
    """Lowest ``nev`` wheel frequencies [Hz] with phase index ``k`` (nodal diameter
    ``min(k, N - k)``), exact cyclic symmetry on one sector."""
    parts = parts if parts is not None else spring_parts(seg, mats, c1)
    lam, _ = phase_modes(seg, mats, parts, k, nev, comm)
    return np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi)


def cyclic_table(seg, mats, c1: float, nev: int, comm=None, log=None) -> np.ndarray:
    """``(N // 2 + 1, nev)`` frequencies [Hz] per nodal diameter by (b)."""
    parts = spring_parts(seg, mats, c1)
    out = []
    t0 = time.perf_counter()
    for k in range(seg.sectors // 2 + 1):
        out.append(cyclic_modes(seg, mats, c1, k, nev, comm, parts))
        if log:
            log(f"cyclic FE: ND {k} done ({time.perf_counter() - t0:.1f} s)")
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


def assembled_wheel_modes(seg, mats, c1: float, nev: int, comm=None) -> np.ndarray:
    """Lowest ``nev`` frequencies [Hz] of the assembled wheel (a), SLEPc on ``comm``."""
    K, M = assembled_wheel(seg, mats, c1)
    res = lowest_modes(K, M, nev, comm, prefix="fullwheel_")
    return res.frequencies_hz


ENRICH_FAMILIES = 2


def enrichment_phases(blades: int) -> tuple[int, ...]:
    """Phase indices whose sector modes enrich the basis: ND 0, N/8, N/4 and N/2."""
    return tuple(sorted({0, round(blades / 8), round(blades / 4), blades // 2}))


def enriched_basis(seg, mats, c1: float, free_modes: np.ndarray, per_phase: int, comm=None,
                   phases=None):  # fmt: skip
    """Free-interface modes plus the lowest ``per_phase`` exact sector modes at ``phases``
    (default ND 0 and N/2; complex modes give their real and imaginary parts), made
    M-orthonormal and rotated to segment Ritz modes.

    ``free_modes``: ``(n_free, m)``. Returns ``(vectors (n_free, r), ritz_values (r,))`` with
    ``vectors^T M vectors = I`` and ``vectors^T K vectors = diag(ritz_values)``.
    """
    springs = spring_parts(seg, mats, c1)
    vectors = [free_modes]
    for k in sorted(set(phases) if phases is not None else {0, seg.sectors // 2}):
        vectors.append(phase_modes(seg, mats, springs, k, per_phase, comm)[1])
    V = np.hstack(vectors)
    Mr = V.T @ (mats.M @ V)
    Kr = V.T @ (mats.K @ V)
    # drop numerically dependent directions, then solve the small Ritz problem
    w, U = np.linalg.eigh(0.5 * (Mr + Mr.T))
    keep = w > 1e-13 * w.max()
    T = U[:, keep] / np.sqrt(w[keep])
    lam, Y = np.linalg.eigh(T.T @ (0.5 * (Kr + Kr.T)) @ T)
    return V @ (T @ Y), lam


def accuracy_table(cfg, modes=(10, 20, 40), enriched_modes=10, families=4, comm=None, log=None):
    """Reduced-model error against the exact cyclic FE, per basis, family and nodal diameter.

    Returns ``{"reference_hz": (ND, families), "bases": {label: {"vectors": r,
    "relative_error": (ND, families)}}}`` for the free-interface basis at each ``m`` in
    ``modes`` and the enriched basis built on ``enriched_modes``.
    """
    from wheelrom.cyclic import reduce
    from wheelrom.mesh import load_segment
    from wheelrom.modes import segment_modes
    from wheelrom.prestress import segment_matrices

    say = log or (lambda msg: None)
    seg = load_segment(cfg)
    mats = segment_matrices(cfg, seg, comm)
    c1 = cfg.wheel.coupling_stiffness
    eig = segment_modes(mats, max(max(modes), enriched_modes), comm)
    say(f"segment: {seg.n_dofs} DOFs, {eig.eigenvalues.size} modes in {eig.solve_s:.1f} s")
    reference = cyclic_table(seg, mats, c1, families, comm, log=None)
    say(f"exact cyclic FE: {reference.shape[0]} nodal diameters x {families} families")
    bases = {}
    for m in modes:
        model = reduce(seg, eig.vectors[:, :m], np.diag(eig.eigenvalues[:m]), cfg)
        rom = model.frequencies_by_nodal_diameter()[:, :families]
        bases[f"free m={m}"] = {"vectors": m, "relative_error": rom / reference - 1}
    X, lam = enriched_basis(seg, mats, c1, eig.vectors[mats.free, :enriched_modes],
                            ENRICH_FAMILIES, comm, enrichment_phases(seg.sectors))  # fmt: skip
    model = reduce(seg, mats.expand(X), np.diag(lam), cfg)
    rom = model.frequencies_by_nodal_diameter()[:, :families]
    bases[f"enriched m={enriched_modes}"] = {
        "vectors": int(X.shape[1]),
        "relative_error": rom / reference - 1,
    }
    return {"reference_hz": reference, "bases": bases}
