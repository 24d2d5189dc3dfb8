"""The static equilibrium under the contact preloads (``time.start = "preload"``): PETSc SNES
on ``K_R q = f(q, 0, t = 0)``, so the accelerations vanish at ``t = 0``."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from wheelrom.runtime.environment import petsc
from wheelrom.transient.problem import WheelProblem


def static_preload(problem: WheelProblem, case: int = 0,
                   prefix: str = "preload_") -> tuple[np.ndarray, float]:
    """Solve ``K_R q = f(q, 0, t=0)`` for one case; returns ``q`` and ``|residual|``.

    Jacobian by finite differences of the residual (dense, ``N m`` unknowns). Options prefix
    ``preload_`` (``-preload_snes_rtol`` ...), ``setFromOptions`` last.
    """
    return static_equilibrium(problem.forces[case], problem.Kd, problem.comm,
                              problem.cases[case].nozzle_force, prefix)


def _static_residual(forces, K):
    """``q -> K q - f(q, 0, t = 0)`` (``(N m,)``). Under the elastic law the sliders follow
    the static load (no tangential force), as the paper law's friction at rest: both laws
    share the preloaded equilibrium."""
    N, m = forces.params.blades, forces.params.modes
    zeros_v = np.zeros((N, m))
    elastic = forces.params.law.elastic

    def residual(q):
        slider = forces.sliders_at_rest(q.reshape(N, m)) if elastic else None
        return K @ q - forces.evaluate(0.0, q.reshape(N, m), zeros_v, slider).ravel()

    return residual


def static_equilibrium(forces, K: np.ndarray, comm, force_scale: float, prefix: str = "preload_",
                       tangent=None) -> tuple[np.ndarray, float]:
    """``K q = f(q, 0, t=0)`` for the :class:`~wheelrom.forces.reference.ReferenceForces`
    ``forces`` and ``K`` ``(N m, N m)`` (dense, or scipy sparse when ``tangent`` is given).
    ``tangent(q)``: the analytic ``df/dq`` (sparse, blocks of neighbouring blades only) if
    known, then the Jacobian is a sparse AIJ (PETSc LU), else dense by finite differences.
    ``force_scale`` [N] sets the absolute tolerance. Returns ``q`` and ``|residual|``."""
    PETSc = petsc()
    n = K.shape[0]
    N, m = forces.params.blades, forces.params.modes
    residual_np = _static_residual(forces, K)

    def residual(snes, x, r):
        # a writable copy: the compiled force model has one specialisation (writable arrays)
        r.setArray(residual_np(x.getArray(readonly=True).copy()))

    if tangent is not None:  # the AIJ structure, and K once as CSR
        structure, K_sparse = _blade_pattern(N, m), sp.csr_matrix(K)
        # forces that couple more than neighbours (the aerodynamic table's influence
        # coefficients) widen it: the tangent's stored entries at rest, which is also where
        # Newton starts (x = 0), so the first Jacobian reuses it
        at_rest = [sp.csr_matrix(tangent(np.zeros((N, m))))]
        pattern = at_rest[0].copy()
        pattern.data[:] = 1.0
        structure = (structure + pattern).tocsr()
        structure.data[:] = 1.0

    def jacobian(snes, x, J, P):
        q = x.getArray(readonly=True).copy()
        if tangent is not None:  # sparse: K_R and the contacts couple neighbours only
            T = at_rest.pop() if at_rest and not q.any() else tangent(q.reshape(N, m))
            A = (K_sparse - T).tocsr()  # within the structure
            A.sort_indices()
            P.zeroEntries()  # entries A leaves out (an exact zero) must not keep old values
            P.setValuesCSR(A.indptr, A.indices, A.data)
            P.assemble()
            return
        else:
            base = residual_np(q)
            h = 1e-9 * max(1.0, np.abs(q).max())
            Jd = np.empty((n, n))
            for j in range(n):
                qj = q.copy()
                qj[j] += h
                Jd[:, j] = (residual_np(qj) - base) / h
        P.setValues(range(n), range(n), Jd)
        P.assemble()

    snes = PETSc.SNES().create(comm=comm)
    snes.setOptionsPrefix(prefix)
    if tangent is not None:
        J = PETSc.Mat().createAIJ((n, n), csr=(structure.indptr, structure.indices), comm=comm)
    else:
        J = PETSc.Mat().createDense((n, n), comm=comm)
        J.setUp()
    r = PETSc.Vec().createSeq(n, comm=comm)
    x = PETSc.Vec().createSeq(n, comm=comm)
    snes.setFunction(residual, r)
    snes.setJacobian(jacobian, J, J)
    snes.setTolerances(rtol=1e-12, atol=1e-12 * max(1.0, force_scale), max_it=50)
    snes.getKSP().setType("preonly")
    snes.getKSP().getPC().setType("lu")
    snes.setFromOptions()
    x.set(0.0)
    snes.solve(None, x)
    q = x.getArray().copy()
    res = float(np.linalg.norm(residual_np(q)))
    reason = snes.getConvergedReason()
    for obj in (snes, J, r, x):
        obj.destroy()
    if reason <= 0:
        raise RuntimeError(f"{prefix}snes did not converge (reason {reason}, |F| = {res:.3g})")
    return q, res


def _blade_pattern(N: int, m: int) -> sp.csr_matrix:
    """Ones on every ``(m, m)`` block of a blade and its two neighbours: the nonzero structure
    of ``K_R`` and of the contact tangent (so their values fit a fixed AIJ)."""
    neighbours = (np.arange(N)[:, None] + [-1, 0, 1]).ravel() % N
    ring = sp.csr_matrix((np.ones(3 * N), (np.repeat(np.arange(N), 3), neighbours)), shape=(N, N))
    structure = sp.kron(ring, np.ones((m, m)), format="csr")
    structure.sort_indices()
    return structure


def initial_state(problem: WheelProblem, case: int = 0) -> tuple[np.ndarray, float | None]:
    """One case's blade-major state at ``t = 0`` per ``time.start``: zero, or the static
    equilibrium under the preloads (and the t = 0 nozzle force); plus the start perturbation
    (:func:`start_perturbation`). Returns ``(u0, preload residual or None)``."""
    u0 = np.zeros(problem.size())
    residual = None
    if problem.cfg.time.start == "preload":
        q, residual = static_preload(problem, case=case)
        u0[: problem.n] = q
    problem.rest_sliders(u0, case)  # elastic law: stuck where the preload left them
    u0[: problem.n] += start_perturbation(problem.model, problem.cfg).ravel()
    problem.slide(u0, case)  # a perturbation beyond the stick range starts slipping
    return u0, residual


def start_perturbation(model, cfg) -> np.ndarray:
    """``(N, m)`` modal displacement of the start perturbation, defined physically so that a
    "1 nm" seed means the same motion in every basis: the lowest mode of every nodal diameter
    ``k = 0..N-1`` of the tuned wheel with the contacts open (``A0 + A1 e^{i sigma_k} + A1^T
    e^{-i sigma_k}``, ``sigma_k = 2 pi k / N``: both travelling directions), each scaled to a
    unit tip displacement with its phase fixed by the tip (blade 0's tangential tip
    displacement real and positive), turned by a random phase ``theta_k`` (numpy
    ``default_rng(time.seed)``, identical for every case and rank count) and summed::

        q_s = Re sum_k phi_k e^{i (theta_k + s sigma_k)},

    then scaled so that the largest tip displacement is ``time.perturbation`` [m]; zeros when 0.
    ``time.perturbation_waves`` restricts the sum to the listed ``k`` (a seed of one travelling
    wave, e.g. to follow it to its limit cycle).

    Why not random modal coordinates: a standard normal on every Ritz vector puts most of the
    seed into the stiff attachment vectors of a converged basis, and which motion it is
    depends on the basis (re-signing the vectors changed the paper's 90 deg transient from
    +1.64 to +2.19 /s). The lowest mode of each ND is what flutters and what every basis
    resolves."""
    N, m = model.blades, model.modes
    amplitude = cfg.time.perturbation
    if amplitude <= 0.0:
        return np.zeros((N, m))
    theta = np.random.default_rng(cfg.time.seed).uniform(0.0, 2 * np.pi, N)
    blades = np.arange(N)
    q = np.zeros((N, m))
    waves = [k % N for k in cfg.time.perturbation_waves] or range(N)
    for k in waves:
        phi = np.linalg.eigh(model.nd_stiffness(k))[1][:, 0]
        tip = model.tip @ phi  # (3,) complex tip displacement of blade 0
        size = np.linalg.norm(tip)
        ref = tip[1] if abs(tip[1]) > 1e-3 * size else tip[np.argmax(np.abs(tip))]
        phi = phi * (np.conj(ref) / abs(ref)) / size
        wave = np.exp(1j * (theta[k] + 2 * np.pi * k * blades / N))  # (N,)
        q += (wave[:, None] * phi[None, :]).real
    tip = np.linalg.norm(q @ model.tip.T, axis=1).max()
    return q * (amplitude / tip)
