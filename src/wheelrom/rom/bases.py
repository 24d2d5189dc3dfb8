"""Segment bases of the reduced model: the paper's free-interface modes (the segment modes,
:mod:`wheelrom.segment.modes`), the enriched basis, which adds the sector parts of exact
cyclic wheel modes, and attachment vectors, the static responses to unit forces at the
contact nodes (docs/theory.md, docs/accuracy.md). Any of them combined are made M-orthonormal
and rotated to segment Ritz vectors (:func:`ritz_basis`)."""

from __future__ import annotations

import numpy as np

from wheelrom.rom.references import phase_modes
from wheelrom.segment.petsc import direct_solve
from wheelrom.segment.springs import spring_parts

ENRICH_FAMILIES = 2


def enrichment_phases(blades: int) -> tuple[int, ...]:
    """Phase indices whose sector modes enrich the basis: ND 0, N/8, N/4 and N/2."""
    return tuple(sorted({0, round(blades / 8), round(blades / 4), blades // 2}))


def basis_size(cfg) -> int:
    """The basis vectors per blade ``cfg`` builds at most, known from its keys alone (before
    the segment is solved): ``wheel.modes_per_segment``, plus the sector modes of the
    enrichment (:data:`ENRICH_FAMILIES` per phase, complex ones twice) and 6 attachment
    vectors per enabled contact kind. For the memory a model will take up front."""
    parts = set(cfg.wheel.basis.split("+"))
    size = cfg.wheel.modes_per_segment
    if "enriched" in parts:
        size += 2 * ENRICH_FAMILIES * len(enrichment_phases(cfg.wheel.blades))
    if "attachment" in parts:
        size += 6 * len(cfg.contacts.enabled_kinds())
    return size


def enrichment_vectors(seg, mats, c1: float, per_phase: int, comm, phases=None) -> np.ndarray:
    """``(n_free, r)`` the lowest ``per_phase`` exact sector modes at ``phases`` (default ND 0
    and N/2; complex modes give their real and imaginary parts)."""
    springs = spring_parts(seg, mats, c1)
    chosen = sorted(set(phases) if phases is not None else {0, seg.sectors // 2})
    return np.hstack([phase_modes(seg, mats, springs, k, per_phase, comm)[1] for k in chosen])


def attachment_vectors(seg, mats, kinds, comm, prefix: str = "attachment_") -> np.ndarray:
    """``(n_free, 6 K)`` static responses ``K^-1 f`` of the segment (the model's stiffness:
    prestressed when configured, bore clamped, cut faces free) to unit forces in x, y, z at
    the contact nodes ``<kind>_A`` and ``<kind>_B`` of every kind in ``kinds``. With them in
    the basis the reduced model has the FE's exact static flexibility at those nodes, which
    the contact springs load (PETSc KSP, MUMPS, options prefix ``attachment_``)."""
    columns = []
    for kind in kinds:
        for end in ("A", "B"):
            node = int(seg.node_sets[f"{kind}_{end}"][0])
            for c in range(3):
                force = np.zeros(seg.n_dofs)
                force[3 * node + c] = 1.0
                columns.append(force[mats.free])
    return direct_solve(mats.K, np.array(columns).T, comm, prefix)


def ritz_basis(mats, parts: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The columns of ``parts`` (each ``(n_free, r_i)``), numerically dependent directions
    dropped, made M-orthonormal and rotated to segment Ritz vectors: ``(vectors, values)``
    with ``vectors^T M vectors = I``, ``vectors^T K vectors = diag(values)``."""
    V = np.hstack(parts)
    # unit M-norm columns first: static responses [m/N] are ~1e-7 of a modal column's scale
    # and would otherwise be dropped below as "dependent"
    V = V / np.sqrt(np.einsum("ij,ij->j", V, mats.M @ V))
    for _ in range(2):  # M-orthonormalise twice: one pass keeps ~cond * eps of the overlap
        Mr = V.T @ (mats.M @ V)
        w, U = np.linalg.eigh(0.5 * (Mr + Mr.T))
        keep = w > 1e-13 * w.max()  # drop numerically dependent directions
        V = V @ (U[:, keep] / np.sqrt(w[keep]))
    Kr = V.T @ (mats.K @ V)
    lam, Y = np.linalg.eigh(0.5 * (Kr + Kr.T))
    return V @ Y, lam


def enriched_basis(seg, mats, c1: float, free_modes: np.ndarray, per_phase: int, comm,
                   phases=None):
    """Free-interface modes plus the lowest ``per_phase`` exact sector modes at ``phases``
    (:func:`enrichment_vectors`), as segment Ritz vectors (:func:`ritz_basis`).

    ``free_modes``: ``(n_free, m)``. Returns ``(vectors (n_free, r), ritz_values (r,))``.
    """
    return ritz_basis(mats, [free_modes, enrichment_vectors(seg, mats, c1, per_phase, comm,
                                                            phases)])
