"""Segment bases of the reduced model: the paper's free-interface modes (the segment modes,
:mod:`wheelrom.segment.modes`) and the enriched basis, which adds the sector parts of exact
cyclic wheel modes (docs/theory.md, docs/accuracy.md)."""

from __future__ import annotations

import numpy as np

from wheelrom.rom.references import phase_modes
from wheelrom.segment.springs import spring_parts

ENRICH_FAMILIES = 2


def enrichment_phases(blades: int) -> tuple[int, ...]:
    """Phase indices whose sector modes enrich the basis: ND 0, N/8, N/4 and N/2."""
    return tuple(sorted({0, round(blades / 8), round(blades / 4), blades // 2}))


def enriched_basis(seg, mats, c1: float, free_modes: np.ndarray, per_phase: int, comm,
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
