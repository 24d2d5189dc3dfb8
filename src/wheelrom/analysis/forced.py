"""Linear forced response to the nozzle (issue #22): the steady harmonic state of the wheel
linearised at its preloaded equilibrium, tuned or mistuned.

The nozzle force on blade ``s`` at engine order ``n_s`` (``wheel.stator_vanes``),
``F_b cos(w t - phi_s)``, ``phi_s = 2 pi (1 - n_s / N) s`` (docs/theory.md, eq. 13), is the
real part of ``F_s e^{i w t}`` with the complex amplitude ``F_s = excitation F_b e^{-i phi_s}``
(``(N, m)`` [N/sqrt(kg)]). The steady state ``q = Re(Q e^{i w t})`` ([sqrt(kg) m])
solves

    (K - w^2 I + i w C) Q = F,    K = K_R - F_q,  C = beta_D K_R - F_v,

with ``F_q``, ``F_v`` the contact (and Van der Pol) force derivatives at the preloaded
equilibrium (:func:`wheelrom.analysis.stability.linearise`: ``K`` and ``C`` are minus the
lower blocks of its Jacobian), or ``K = K_R``, ``C = beta_D K_R`` without contacts. PETSc
KSP (options prefix ``forced_``; defaults ``preonly`` + LU, MUMPS when PETSc has it,
``setFromOptions`` last) solves the real form

    [[K - w^2 I, -w C], [w C, K - w^2 I]] [Re Q; Im Q] = [Re F; Im F].

Over the rotor speed (``forced.over = "speed"``, :class:`SpeedFollowing`) the stiffness
follows the speed ``w / n_s`` of each excitation frequency: ``K(w) = K + ((w / n_s)^2 -
Omega_0^2) S`` and ``C(w)`` gains ``beta_D`` times the same change.

Per frequency the tip amplitude of blade ``s`` is ``sqrt(sum_k |tip_k . Q_s|^2)`` [m]. The
amplification factor of a mistuned wheel is the peak over the frequency range of its
largest blade amplitude over the same peak of the tuned wheel.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from wheelrom.config import Config
from wheelrom.rom.model import ReducedModel, nodal_diameter
from wheelrom.runtime.environment import petsc

PREFIX = "forced_"


@dataclass
class ForcedResponse:
    """The steady response over ``F`` excitation frequencies (``N`` blades).

    ``frequency``: ``(F,)`` excitation frequencies ``w`` [rad/s]; ``blade_amplitude``:
    ``(F, N)`` tip amplitude of every blade [m]; ``stator_vanes``: engine order ``n_s``;
    ``nodal_diameter``: the ND the nozzle excites; ``contacts``: linearised contacts
    included; ``wall_s``: total time, ``solve_s``: time in the linear solves [s];
    ``solver``: the KSP's settings (:func:`ksp_settings`; empty for the scipy solver).
    """

    frequency: np.ndarray
    blade_amplitude: np.ndarray
    stator_vanes: int
    nodal_diameter: int
    contacts: bool
    wall_s: float = 0.0
    solve_s: float = 0.0
    solver: dict = dataclasses.field(default_factory=dict)

    @property
    def max_amplitude(self) -> np.ndarray:
        """``(F,)`` the largest blade tip amplitude per frequency [m]."""
        return self.blade_amplitude.max(axis=1)

    @property
    def peak(self) -> float:
        """The largest blade tip amplitude over the whole range [m]."""
        return float(self.max_amplitude.max())


def amplification_factor(mistuned: ForcedResponse, tuned: ForcedResponse) -> float:
    """Peak max-blade amplitude of ``mistuned`` over that of ``tuned`` (each over its range)."""
    return mistuned.peak / tuned.peak


def tuned_copy(model: ReducedModel) -> ReducedModel:
    """``model`` with every blade the same (mistuning removed)."""
    return dataclasses.replace(model, mistuning=None)


def nozzle_amplitude(model: ReducedModel, stator_vanes: int, force: float) -> np.ndarray:
    """``(N, m)`` complex generalised force amplitudes ``F_s = excitation F_b e^{-i phi_s}``,
    ``phi_s = 2 pi (1 - n_s / N) s``: a travelling wave of index ``n_s mod N``."""
    N = model.blades
    phase = 2 * math.pi * (1 - stator_vanes / N) * np.arange(N)
    return force * np.exp(-1j * phase)[:, None] * model.excitation[None, :]


@dataclass(frozen=True)
class SpeedFollowing:
    """The wheel's stiffness following the rotor speed ``w / n_s`` of the excitation ``w``
    [rad/s] (``forced.over = "speed"``): ``K(w) = K + shift(w) S``, ``shift(w) = (w /
    n_s)^2 - Omega_0^2``, the damping ``beta_D`` times the same change. ``S`` ``(N m, N m)``
    CSR [1/s^2 per (rad/s)^2]: every blade's centrifugal stiffening less spin softening per
    ``Omega^2`` (:attr:`~wheelrom.rom.model.ReducedModel.speed_stiffness`), ``speed``
    ``Omega_0`` [rad/s] the model's own, ``engine_order`` ``n_s``."""

    S: sp.csr_matrix
    beta: float
    engine_order: int
    speed: float

    def shift(self, w: float) -> float:
        """``(w / n_s)^2 - Omega_0^2`` [(rad/s)^2]."""
        return (w / self.engine_order) ** 2 - self.speed**2

    def crossing_problem(self, K, S: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(A, B)`` dense: ``K(w) x = w^2 x`` as ``A x = w^2 B x``, ``A = K - Omega_0^2 S``,
        ``B = I - S / n_s^2``: its eigenvalues are the Campbell crossings of the engine
        order with the wheel's modes (``K`` at the model's speed; ``S`` dense when given,
        e.g. one ND block's, else :attr:`S`)."""
        S = self.S.toarray() if S is None else S
        K = K.toarray() if sp.issparse(K) else np.asarray(K)
        return K - self.speed**2 * S, np.eye(S.shape[0]) - S / self.engine_order**2


def speed_following(model: ReducedModel, cfg: Config) -> SpeedFollowing | None:
    """The :class:`SpeedFollowing` of ``forced.over = "speed"`` (None: over the frequency,
    or a model without prestress, whose stiffness does not depend on the speed). A mistuned
    blade's block ``A0 + delta_s K_seg`` moves by ``(1 + delta_s)`` times the shift."""
    per_speed = model.stiffening_per_speed
    if cfg.forced.over != "speed" or per_speed is None:
        return None
    factors = np.ones(model.blades) if model.tuned else 1.0 + model.mistuning
    S = sp.block_diag([f * per_speed for f in factors], format="csr")
    return SpeedFollowing(S, cfg.wheel.damping_beta, cfg.wheel.stator_vanes,
                          2 * math.pi * model.speed_hz)


def operators(model: ReducedModel, cfg: Config, contacts: bool = True,
              angles_deg: dict | None = None, comm=None, prefix: str = PREFIX,
              jacobian=None):
    """``(K, C)`` scipy CSR ``(N m, N m)`` [1/s^2], [1/s]: stiffness and damping of the
    linearised wheel (contacts at the preloaded equilibrium, SNES prefix
    ``<prefix>preload_``; ``jacobian``: the Jacobian there when already computed, as
    :func:`stability.linearise` returns it) or of ``K_R`` alone (``contacts=False``)."""
    beta = cfg.wheel.damping_beta
    if not contacts:
        K = model.sparse_stiffness()
        return K, (beta * K).tocsr()
    from wheelrom.analysis.stability import linearise

    J = jacobian if jacobian is not None else linearise(model, cfg, angles_deg, comm,
                                                        prefix=prefix)[3]
    n = model.size
    J = sp.csr_matrix(J)
    return (-J[n:, :n]).tocsr(), (-J[n:, n:]).tocsr()


def direct_solve(K, C, F: np.ndarray, w: float) -> np.ndarray:
    """``(N m,)`` complex ``Q`` of ``(K - w^2 I + i w C) Q = F``, scipy sparse direct."""
    import scipy.sparse.linalg as spla

    A = (K - w**2 * sp.identity(K.shape[0]) + 1j * w * C).tocsc()
    return spla.spsolve(A, np.asarray(F, dtype=complex).ravel())


class HarmonicSolver:
    """The real ``2 N m`` block system of one wheel on ``comm`` (every rank holds ``K``,
    ``C``), refactorised per frequency by a KSP with options prefix ``prefix``.

    The matrix keeps one sparsity pattern (``K`` and ``I`` in the diagonal blocks, ``C`` in
    the off-diagonal ones); per frequency only its values change: ``K - w^2 I + w C``.
    """

    def __init__(self, K, C, comm=None, prefix: str = PREFIX,
                 speed: SpeedFollowing | None = None):
        from wheelrom.segment.petsc import to_petsc

        PETSc = petsc()
        self.comm = comm or PETSc.COMM_SELF
        n = K.shape[0]
        self.size = n
        eye = sp.identity(n, format="csr")
        block_K = sp.block_diag([K, K], format="csr")
        block_I = sp.block_diag([eye, eye], format="csr")
        block_C = sp.bmat([[None, -C], [C, None]], format="csr")
        blocks = [block_K, block_I, block_C]
        self.speed = speed
        if speed is not None:  # the stiffness's and the damping's share of the speed's shift
            blocks += [sp.block_diag([speed.S, speed.S], format="csr"),
                       speed.beta * sp.bmat([[None, -speed.S], [speed.S, None]], format="csr")]
        pattern = sum(abs(M) for M in blocks).tocsr()
        pattern.data[:] = 1.0
        pattern.sort_indices()
        self.indptr, self.indices = pattern.indptr, pattern.indices
        self.values = [self._aligned(M, pattern) for M in blocks]
        self.A = to_petsc(pattern, self.comm, prefix=prefix)
        self.rows = self.A.getOwnershipRange()
        self.ksp = PETSc.KSP().create(comm=self.comm)
        self.ksp.setOptionsPrefix(prefix)
        self.ksp.setType(PETSc.KSP.Type.PREONLY)
        pc = self.ksp.getPC()
        pc.setType(PETSc.PC.Type.LU)
        if PETSc.Sys.hasExternalPackage("mumps"):
            pc.setFactorSolverType("mumps")
        self.ksp.setOperators(self.A)
        self.ksp.setFromOptions()
        self.settings = ksp_settings(self.ksp)
        self.x, self.b = self.A.createVecs()
        self.solves = 0

    @staticmethod
    def _aligned(M, pattern) -> np.ndarray:
        """``M``'s entries in the order of ``pattern``'s stored entries (zeros elsewhere)."""
        index = pattern.copy()
        index.data = np.arange(1, pattern.nnz + 1, dtype=float)
        M = M.tocoo()
        keep = M.data != 0  # explicit zeros may be missing from the pattern
        M = sp.coo_matrix((M.data[keep], (M.row[keep], M.col[keep])), shape=M.shape)
        where = np.asarray(index[M.row, M.col]).ravel().astype(np.int64) - 1
        out = np.zeros(pattern.nnz)
        np.add.at(out, where, M.data)
        return out

    def solve(self, F: np.ndarray, w: float) -> np.ndarray:
        """``(N m,)`` complex ``Q`` at excitation frequency ``w`` [rad/s]."""
        lo, hi = self.rows
        data = self.values[0] - w**2 * self.values[1] + w * self.values[2]
        if self.speed is not None:
            data = data + self.speed.shift(w) * (self.values[3] + w * self.values[4])
        start, stop = self.indptr[lo], self.indptr[hi]
        self.A.setValuesCSR(self.indptr[lo : hi + 1] - start, self.indices[start:stop],
                            data[start:stop])
        self.A.assemble()
        self.ksp.setOperators(self.A)
        F = np.asarray(F, dtype=complex).ravel()
        rhs = np.concatenate([F.real, F.imag])
        self.b.setArray(rhs[lo:hi])
        self.ksp.solve(self.b, self.x)
        reason = self.ksp.getConvergedReason()
        if reason < 0:
            raise RuntimeError(f"{self.ksp.getOptionsPrefix()}ksp: diverged ({reason}) at "
                               f"w = {w:.6g} rad/s")
        self.solves += 1
        full = np.concatenate(self.comm.tompi4py().allgather(self.x.getArray().copy()))
        return full[: self.size] + 1j * full[self.size :]

    def destroy(self) -> None:
        """Collective: free the PETSc objects."""
        for obj in (self.ksp, self.A, self.x, self.b):
            obj.destroy()


def tip_amplitudes(model: ReducedModel, Q: np.ndarray) -> np.ndarray:
    """``(N,)`` tip amplitude of every blade [m] of complex modal amplitudes ``Q``
    ``(N m,)``: ``sqrt(sum_k |tip_k . Q_s|^2)`` over the 3 displacement components."""
    tip = Q.reshape(model.blades, model.modes) @ model.tip.T  # (N, 3) complex
    return np.sqrt((np.abs(tip) ** 2).sum(axis=1))


def forced_response(model: ReducedModel, cfg: Config, frequencies, contacts: bool = True,
                    angles_deg: dict | None = None, comm=None,
                    prefix: str = PREFIX) -> ForcedResponse:
    """The steady response of ``model`` to the nozzle of ``cfg`` (``wheel.stator_vanes``,
    ``excitation.force``) at every excitation frequency of ``frequencies`` [rad/s] (KSP,
    prefix ``prefix``; over the speed when ``forced.over = "speed"``); ``angles_deg``: kind
    -> contact angle [deg] as :func:`stability.linearise`."""
    t0 = time.perf_counter()
    w_all = np.atleast_1d(np.asarray(frequencies, dtype=float))
    n_s = cfg.wheel.stator_vanes
    K, C = operators(model, cfg, contacts, angles_deg, comm, prefix)
    F = nozzle_amplitude(model, n_s, cfg.excitation.force)
    amplitude = np.empty((w_all.size, model.blades))
    t_solve = time.perf_counter()
    harmonic = HarmonicSolver(K, C, comm, prefix, speed_following(model, cfg))
    for i, w in enumerate(w_all):
        amplitude[i] = tip_amplitudes(model, harmonic.solve(F, w))
    harmonic.destroy()
    t_end = time.perf_counter()
    return ForcedResponse(
        frequency=w_all,
        blade_amplitude=amplitude,
        stator_vanes=n_s,
        nodal_diameter=int(nodal_diameter(n_s, model.blades)),
        contacts=contacts,
        wall_s=t_end - t0,
        solve_s=t_end - t_solve,
        solver=harmonic.settings,
    )


FACTOR_PCS = ("lu", "cholesky", "ilu", "icc")


def ksp_settings(ksp) -> dict:
    """What a configured KSP will do: ``prefix``, ``ksp_type``, ``pc_type``, for a
    factorisation ``pc_factor_mat_solver_type`` (``petsc`` when none was chosen), for an
    iterative KSP ``rtol``, ``atol``, ``max_it``; and ``options``: the entries of the PETSc
    options database under the prefix (name without dash -> value as given)."""
    PETSc = petsc()
    prefix = ksp.getOptionsPrefix() or ""
    pc = ksp.getPC()
    out = {"prefix": prefix, "ksp_type": ksp.getType(), "pc_type": pc.getType()}
    if out["pc_type"] in FACTOR_PCS:
        out["pc_factor_mat_solver_type"] = pc.getFactorSolverType() or "petsc"
    if out["ksp_type"] != "preonly":
        rtol, atol, _, max_it = ksp.getTolerances()
        out.update(rtol=rtol, atol=atol, max_it=max_it)
    database = PETSc.Options().getAll()
    out["options"] = {k: v for k, v in sorted(database.items()) if prefix and k.startswith(prefix)}
    return out
