"""Segment matrices: consistent mass and linear-elastic stiffness (scikit-fem quadrature).

The ``clamped`` DOFs are removed: the returned matrices act on the *free* DOFs only, listed in
``SegmentMatrices.free`` (indices into the full DOF vector ``3 * node + component``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from wheelrom.segment.mesh import SegmentMesh

# 3x3x3 Gauss points on the 20-node hexahedron: the usual rule for quadratic solid elements
# (scikit-fem's default is exact for the full polynomial degree: 343 points, ~30x slower).
INTORDER = 4


@dataclass
class SegmentMatrices:
    """Mass ``M`` [kg] and stiffness ``K`` [N/m] on the free DOFs (scipy CSR, symmetric).

    Attributes:
        free: ``(n_free,)`` full DOF index of every row.
        n_full: number of DOFs including the clamped ones.
        assembly_s: wall time of the assembly [s].
    """

    K: sp.csr_matrix
    M: sp.csr_matrix
    free: np.ndarray
    n_full: int
    assembly_s: float

    def expand(self, x: np.ndarray) -> np.ndarray:
        """Free-DOF vectors ``(n_free, ...)`` -> full DOF vectors with zeros at the clamp."""
        out = np.zeros((self.n_full,) + x.shape[1:], dtype=x.dtype)
        out[self.free] = x
        return out


def vector_basis(seg: SegmentMesh):
    """scikit-fem vector basis of the segment's 20-node hexahedra."""
    from skfem import Basis, ElementHexS2, ElementVector

    return Basis(seg.mesh, ElementVector(ElementHexS2()), intorder=INTORDER)


def scalar_basis(seg: SegmentMesh):
    """scikit-fem scalar basis of the segment's 20-node hexahedra (one DOF per node)."""
    from skfem import Basis, ElementHexS2

    return Basis(seg.mesh, ElementHexS2(), intorder=INTORDER)


def basis_arrays(seg: SegmentMesh):
    """The segment's scalar basis at its Gauss points, as arrays for ``einsum`` assembly.

    Returns ``(values (nb, nel, nq), grads (nb, 3, nel, nq), dx (nel, nq), element_dofs
    (nel, 3 nb), basis)``: shape functions, their gradients, quadrature weight x |det J|, the
    vector DOFs ``3 node + component`` of every element, and the scikit-fem basis.
    """
    bs = scalar_basis(seg)
    nb = bs.Nbfun
    values = np.array([bs.basis[i][0].value for i in range(nb)])
    grads = np.array([bs.basis[i][0].grad for i in range(nb)])
    nodes = bs.element_dofs.T  # (nel, nb): scalar DOF = node index
    dofs = (3 * nodes[:, :, None] + np.arange(3)).reshape(len(nodes), 3 * nb)
    return values, grads, bs.dx, dofs, bs


def scatter(local: np.ndarray, dofs: np.ndarray, n: int) -> sp.csr_matrix:
    """Sum element matrices ``local`` (``(nel, k, k)`` or any shape of that size) into an
    ``(n, n)`` CSR matrix at the element DOFs ``dofs`` ``(nel, k)``."""
    nel, k = dofs.shape
    rows = np.broadcast_to(dofs[:, :, None], (nel, k, k)).ravel()
    cols = np.broadcast_to(dofs[:, None, :], (nel, k, k)).ravel()
    return sp.csr_matrix((local.reshape(nel, k, k).ravel(), (rows, cols)), shape=(n, n))


def scalar_to_vector(local: np.ndarray, components=(1.0, 1.0, 1.0)) -> np.ndarray:
    """``(nel, nb, nb)`` scalar element matrices -> ``(nel, 3 nb, 3 nb)`` acting on the listed
    displacement components (node-major DOF order)."""
    nel, nb, _ = local.shape
    return np.einsum("eab,ij->eaibj", local, np.diag(components)).reshape(nel, 3 * nb, 3 * nb)


def assemble_full(seg: SegmentMesh, young: float, poisson: float, density: float):
    """Full (unconstrained) K and M as scipy CSR, DOF ``3 * node + component``.

    Shape functions, their gradients and the quadrature come from scikit-fem; the isotropic
    elasticity form ``lambda div u div v + 2 mu eps(u):eps(v)`` is contracted for all
    elements at once with ``einsum`` (scikit-fem's generic ``asm`` loops over the 60 x 60
    basis pairs in Python and is ~30x slower; :func:`assemble_full_skfem` keeps it as the
    reference the tests compare against).
    """
    lam = young * poisson / ((1 + poisson) * (1 - 2 * poisson))
    mu = young / (2 * (1 + poisson))
    values, grads, dx, dofs, _ = basis_arrays(seg)
    gw = grads * dx[None, None]
    # T[e, i, a, j, b] = sum_q dphi_i/dx_a dphi_j/dx_b dx
    T = np.einsum("iaeq,jbeq->eiajb", gw, grads, optimize=True)
    K_loc = lam * T + mu * T.transpose(0, 1, 4, 3, 2)
    lap = np.einsum("eikjk->eij", T)
    for a in range(3):
        K_loc[:, :, a, :, a] += mu * lap
    m_loc = density * np.einsum("ieq,jeq->eij", values * dx[None], values, optimize=True)
    n = seg.n_dofs
    return scatter(K_loc, dofs, n), scatter(scalar_to_vector(m_loc), dofs, n)


def assemble_full_skfem(seg: SegmentMesh, young: float, poisson: float, density: float):
    """Reference assembly with scikit-fem's ``asm`` and its elasticity model (slow)."""
    from skfem import BilinearForm, asm
    from skfem.helpers import dot
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    basis = vector_basis(seg)

    @BilinearForm
    def mass(u, v, w):
        return density * dot(u, v)

    K = asm(linear_elasticity(*lame_parameters(young, poisson)), basis).tocsr()
    M = asm(mass, basis).tocsr()
    return K, M


def assemble(
    seg: SegmentMesh, young: float, poisson: float, density: float, clamp: bool = True
) -> SegmentMatrices:
    """Assemble the segment and remove the ``clamped`` DOFs (``clamp=False``: free-free)."""
    t0 = time.perf_counter()
    K, M = assemble_full(seg, young, poisson, density)
    fixed = seg.dofs("clamped").ravel() if clamp else np.zeros(0, int)
    keep = np.ones(seg.n_dofs, bool)
    keep[fixed] = False
    free = np.flatnonzero(keep)
    K = K[free][:, free].tocsr()
    M = M[free][:, free].tocsr()
    # symmetric to round-off: average away the assembly's last-bit asymmetry
    K = ((K + K.T) * 0.5).tocsr()
    M = ((M + M.T) * 0.5).tocsr()
    return SegmentMatrices(K, M, free, seg.n_dofs, time.perf_counter() - t0)
