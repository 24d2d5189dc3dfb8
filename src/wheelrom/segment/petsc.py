"""PETSc-side of the segment: scipy CSR matrices as PETSc AIJ on a communicator, and direct
solves with MUMPS (every PETSc-specific call of the segment stage lives here and in
:mod:`wheelrom.segment.modes`)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from wheelrom.runtime.environment import petsc


def to_petsc(A: sp.csr_matrix, comm, prefix: str | None = None):
    """A scipy CSR matrix as a PETSc AIJ matrix on ``comm`` (rows split by PETSc's layout).

    Every rank holds the full CSR (the segment is built redundantly); each inserts its rows.
    """
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


def direct_solve(A: sp.csr_matrix, B: np.ndarray, comm, prefix: str):
    """``X = A^-1 B`` for the columns of ``B`` ``(n, k)`` with one factorisation: PETSc KSP
    ``preonly`` + Cholesky (LU in parallel) with MUMPS, options prefix ``prefix``.

    Every rank holds ``A`` and ``B`` (built redundantly) and gets the whole ``X``.
    """
    PETSc = petsc()
    K = to_petsc(A, comm)
    ksp = PETSc.KSP().create(comm=comm)
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
