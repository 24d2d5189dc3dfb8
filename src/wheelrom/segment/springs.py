"""Cut-face coupling springs ``c1`` of the wheel on the segment's free DOFs: every
``right(s)``/``left(s+1)`` node pair, with the sector rotation ``R`` (docs/theory.md)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from wheelrom.segment.assembly import SegmentMatrices
from wheelrom.segment.mesh import SegmentMesh


def selection(seg: SegmentMesh, mats: SegmentMatrices, name: str) -> sp.csr_matrix:
    """``(3 p, n_free)`` picking the DOFs of node set ``name`` (clamped DOFs give zero rows)."""
    dofs = seg.dofs(name).ravel()
    where = np.full(mats.n_full, -1)
    where[mats.free] = np.arange(mats.free.size)
    cols = where[dofs]
    rows = np.arange(dofs.size)
    keep = cols >= 0
    return sp.csr_matrix(
        (np.ones(keep.sum()), (rows[keep], cols[keep])), shape=(dofs.size, mats.free.size)
    )


def spring_parts(seg: SegmentMesh, mats: SegmentMatrices, c1: float):
    """``(D, X)``: ``D = c1 (Pl^T Pl + Pr^T Pr)`` and ``X = c1 Pr^T R Pl`` on the free DOFs."""
    Pr = selection(seg, mats, "right")
    Pl = selection(seg, mats, "left")
    pairs = Pr.shape[0] // 3
    Rb = sp.block_diag([seg.rotation] * pairs, format="csr")
    D = c1 * (Pl.T @ Pl + Pr.T @ Pr)
    X = c1 * (Pr.T @ Rb @ Pl)
    return D.tocsr(), X.tocsr()


def phase_stiffness(mats: SegmentMatrices, parts, phi: float):
    """The sector stiffness of the wheel modes with phase ``phi`` between neighbours
    (``u(s+1) = e^{i phi} u(s)``): ``K + D - (e^{i phi} X + e^{-i phi} X^T) = A + i B``.

    ``parts = (D, X)`` from :func:`spring_parts`. Returns ``(A, B)``, ``B = None`` when the
    problem is real (``phi`` = 0 or pi).
    """
    D, X = parts
    A = (mats.K + D - np.cos(phi) * (X + X.T)).tocsr()
    if abs(np.sin(phi)) < 1e-12:
        return A, None
    return A, (-np.sin(phi) * (X - X.T)).tocsr()
