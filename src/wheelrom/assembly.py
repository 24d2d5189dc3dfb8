"""Segment matrices: consistent mass and linear-elastic stiffness (scikit-fem), PETSc AIJ.

The ``clamped`` DOFs are removed: the returned matrices act on the *free* DOFs only, listed in
``SegmentMatrices.free`` (indices into the full DOF vector ``3 * node + component``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from wheelrom.mesh import SegmentMesh

# 3x3x3 Gauss points on a hexahedron, 11 points (degree 4) on a tetrahedron: the usual
# rules for quadratic solid elements (scikit-fem's default is exact for the full degree).
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
    """scikit-fem vector basis of the segment's quadratic element."""
    from skfem import Basis, ElementHexS2, ElementTetP2, ElementVector

    elem = ElementHexS2() if seg.element == "hex20" else ElementTetP2()
    return Basis(seg.mesh, ElementVector(elem), intorder=INTORDER)


def scalar_basis(seg: SegmentMesh):
    """scikit-fem scalar basis of the segment's quadratic element (one DOF per node)."""
    from skfem import Basis, ElementHexS2, ElementTetP2

    elem = ElementHexS2() if seg.element == "hex20" else ElementTetP2()
    return Basis(seg.mesh, elem, intorder=INTORDER)


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


def to_petsc(A: sp.csr_matrix, comm, prefix: str | None = None):
    """A scipy CSR matrix as a PETSc AIJ matrix on ``comm`` (rows split by PETSc's layout).

    Every rank holds the full CSR (the segment is built redundantly); each inserts its rows.
    """
    from wheelrom._environment import petsc

    PETSc = petsc()
    n = A.shape[0]
    M = PETSc.Mat().create(comm=comm)
    M.setSizes(((PETSc.DECIDE, n), (PETSc.DECIDE, n)))
    M.setType(PETSc.Mat.Type.AIJ)
    if prefix:
        M.setOptionsPrefix(prefix)
    rlo, rhi = _ownership(n, comm)
    local = A[rlo:rhi]
    M.setPreallocationCSR((local.indptr, local.indices))
    M.setValuesCSR(local.indptr, local.indices, local.data)
    M.assemble()
    return M


def direct_solve(A: sp.csr_matrix, B: np.ndarray, comm=None, prefix: str | None = None):
    """``X = A^-1 B`` for the columns of ``B`` ``(n, k)`` with one factorisation: PETSc KSP
    ``preonly`` + Cholesky (LU in parallel) with MUMPS, options prefix ``prefix``.

    Every rank holds ``A`` and ``B`` (built redundantly) and gets the whole ``X``.
    """
    from wheelrom._environment import petsc

    PETSc = petsc()
    comm = comm or PETSc.COMM_SELF
    K = to_petsc(A, comm)
    ksp = PETSc.KSP().create(comm=comm)
    if prefix:
        ksp.setOptionsPrefix(prefix)
    ksp.setOperators(K)
    ksp.setType("preonly")
    pc = ksp.getPC()
    pc.setType("cholesky" if comm.getSize() == 1 else "lu")
    pc.setFactorSolverType("mumps")
    ksp.setFromOptions()
    x, b = K.createVecs()
    lo, hi = b.getOwnershipRange()
    B = np.asarray(B, dtype=float).reshape(A.shape[0], -1)
    X = np.zeros_like(B)
    for j in range(B.shape[1]):
        b.setArray(B[lo:hi, j])
        ksp.solve(b, x)
        X[lo:hi, j] = x.getArray(readonly=True)
    if comm.getSize() > 1:
        from mpi4py import MPI

        X = comm.tompi4py().allreduce(X, op=MPI.SUM)
    for obj in (ksp, K, x, b):
        obj.destroy()
    return X


def _ownership(n: int, comm) -> tuple[int, int]:
    """PETSc's default row split of ``n`` rows over ``comm``."""
    size, rank = comm.getSize(), comm.getRank()
    base, extra = divmod(n, size)
    lo = rank * base + min(rank, extra)
    return lo, lo + base + (1 if rank < extra else 0)


# cut-face coupling springs (c1 on every right(s)/left(s+1) node pair, sector rotation R)


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
