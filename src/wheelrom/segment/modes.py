"""Segment modes with SLEPc: ``K x = lambda M x``, clamped bore, free cut faces.

Generalised Hermitian problem, shift-and-invert about 0 with a direct solver (MUMPS when
PETSc has it). Options prefix ``segment_`` (``-segment_eps_nev``, ``-segment_st_type``,
``-segment_st_pc_factor_mat_solver_type`` ...), ``setFromOptions()`` last. Runs on the
communicator it is given, so ``mpirun -n P`` distributes a large segment.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from wheelrom.runtime.environment import petsc, slepc
from wheelrom.segment.assembly import SegmentMatrices
from wheelrom.segment.petsc import to_petsc


@dataclass
class EigenResult:
    """Eigenpairs of ``K x = lambda M x``.

    Attributes:
        eigenvalues: ``(k,)`` lambda = omega^2 [1/s^2], ascending.
        vectors: ``(n, k)`` M-orthonormal eigenvectors (on every rank).
        residuals: ``(k,)`` relative residual ``|K x - lambda M x| / |K x|``.
        solve_s: wall time [s].
    """

    eigenvalues: np.ndarray
    vectors: np.ndarray
    residuals: np.ndarray
    solve_s: float

    @property
    def frequencies_hz(self) -> np.ndarray:
        return np.sqrt(np.maximum(self.eigenvalues, 0.0)) / (2 * np.pi)


def _has_mumps(PETSc) -> bool:
    try:
        return PETSc.Sys.hasExternalPackage("mumps")
    except AttributeError:  # pragma: no cover
        return False


def lowest_modes(
    K: sp.csr_matrix,
    M: sp.csr_matrix,
    nev: int,
    comm,
    prefix: str,
    target: float = 0.0,
) -> EigenResult:
    """The ``nev`` eigenpairs of ``K x = lambda M x`` nearest ``target`` (shift-and-invert)."""
    PETSc = petsc()
    SLEPc = slepc()
    t0 = time.perf_counter()
    A = to_petsc(K, comm)
    B = to_petsc(M, comm)
    eps = SLEPc.EPS().create(comm=comm)
    eps.setOptionsPrefix(prefix)
    eps.setOperators(A, B)
    eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
    eps.setDimensions(nev=nev)
    eps.setTarget(target)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
    eps.setTolerances(tol=1e-10, max_it=500)
    st = eps.getST()
    st.setType(SLEPc.ST.Type.SINVERT)
    ksp = st.getKSP()
    ksp.setType(PETSc.KSP.Type.PREONLY)
    pc = ksp.getPC()
    pc.setType(PETSc.PC.Type.CHOLESKY if comm.getSize() == 1 else PETSc.PC.Type.LU)
    if _has_mumps(PETSc):
        pc.setFactorSolverType("mumps")
    eps.setFromOptions()
    eps.solve()
    nconv = eps.getConverged()
    if nconv < nev:
        raise RuntimeError(f"{prefix}eps: only {nconv} of {nev} eigenpairs converged")
    xr = A.createVecRight()
    values, vectors = [], []
    scatter, full = PETSc.Scatter.toAll(xr)
    for i in range(nev):
        values.append(eps.getEigenpair(i, xr).real)
        scatter.scatter(xr, full, PETSc.InsertMode.INSERT, PETSc.ScatterMode.FORWARD)
        vectors.append(full.getArray().copy())
    for obj in (eps, A, B, xr, full, scatter):
        obj.destroy()
    lam = np.array(values)
    X = np.column_stack(vectors)
    order = np.argsort(lam)
    lam, X = lam[order], X[:, order]
    # M-normalise and fix the sign (largest component positive) so results are reproducible
    X /= np.sqrt(np.einsum("ij,ij->j", X, M @ X))
    big = np.argmax(abs(X), axis=0)
    X *= np.sign(X[big, np.arange(X.shape[1])])
    KX = K @ X
    res = np.linalg.norm(KX - (M @ X) * lam, axis=0) / np.linalg.norm(KX, axis=0)
    return EigenResult(lam, X, res, time.perf_counter() - t0)


def segment_modes(mats: SegmentMatrices, m: int, comm, prefix: str = "segment_") -> EigenResult:
    """First ``m`` modes of the clamped segment; vectors returned on the *full* DOFs."""
    res = lowest_modes(mats.K, mats.M, m, comm, prefix)
    res.vectors = mats.expand(res.vectors)
    return res
