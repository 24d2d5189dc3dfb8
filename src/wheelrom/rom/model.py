"""Cyclic modal synthesis: the reduced wheel model (paper section 3, docs/theory.md).

Blade ``s`` has modal coordinates ``q_s`` (``m`` of them, [sqrt(kg) m]), ``u(s) = Xb q_s`` in
sector ``s``'s own frame. Springs ``c1`` join node ``k`` of ``right(s)`` with node ``k`` of
``left(s+1)``; their energy ``1/2 c1 sum |R Xl q_{s+1} - Xr q_s|^2`` gives the block-cyclic
tridiagonal reduced stiffness

    K_R = I (x) (Xb^T K Xb) + dK,   block (s, s) = A0,  (s, s+1) = A1,  (s+1, s) = A1^T,
    A0 = Xb^T K Xb + c1 (Xr^T Xr + Xl^T Xl),   A1 = -c1 Xr^T R Xl,

and ``M_R = I``. Everything the forces need of the segment is kept here as small dense
arrays (shapes at the contact points, participation vectors), so the reduced model is a
few kilobytes that rank 0 can build and broadcast.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from wheelrom.config import CONTACT_KINDS, Config
from wheelrom.config.forced import read_mistuning_file
from wheelrom.runtime.environment import petsc
from wheelrom.runtime.errors import InputError
from wheelrom.segment.mesh import SegmentMesh


@dataclass
class ReducedModel:
    """Everything downstream needs of the segment, in modal coordinates.

    Attributes:
        blades: N.  modes: m.
        segment_hz: ``(m,)`` segment natural frequencies [Hz].
        K_seg: ``(m, m)`` ``Xb^T K Xb`` [1/s^2] (``diag(omega^2)`` for free-interface modes).
        A0, A1: ``(m, m)`` diagonal and super-diagonal blocks of ``K_R`` [1/s^2].
        rotation: ``(3, 3)`` R.
        tip: ``(3, m)`` displacement of the ``tip`` node per modal coordinate [m/(sqrt(kg) m)].
        aero: ``(m,)`` mean ``y`` displacement of the ``aero`` nodes per modal coordinate.
        excitation: ``(m,)`` generalised force of a unit ``y`` force on every excitation node.
        contact_A, contact_B: kind -> ``(3, m)`` shapes at the profile points A, B.
        contact_points: kind -> ``(2, 3)`` undeformed A, B [m].
    """

    blades: int
    modes: int
    segment_hz: np.ndarray
    K_seg: np.ndarray
    A0: np.ndarray
    A1: np.ndarray
    rotation: np.ndarray
    tip: np.ndarray
    aero: np.ndarray
    excitation: np.ndarray
    contact_A: dict[str, np.ndarray] = field(default_factory=dict)
    contact_B: dict[str, np.ndarray] = field(default_factory=dict)
    contact_points: dict[str, np.ndarray] = field(default_factory=dict)
    # kind -> (k, 2) table (angle [deg], k_c [N/m]) computed from the segment FE
    contact_stiffness: dict[str, np.ndarray] = field(default_factory=dict)
    info: dict = field(default_factory=dict)
    # (N,) per-blade modal stiffness deviation delta_s: blade s's diagonal block is
    # A0 + delta_s K_seg (None: a tuned wheel, K_R block-circulant)
    mistuning: np.ndarray | None = None
    # (m, m) [1/s^2] the prestress's stiffening less the spin softening at the model's speed
    # info["speed_hz"], in its basis: Xb^T (K_sigma - Omega^2 M_s) Xb (None: no prestress);
    # both terms scale with Omega^2 (the static solve is linear), so the segment's stiffness at
    # another speed Omega' is K_seg + ((Omega' / Omega)^2 - 1) speed_stiffness (at_speed)
    speed_stiffness: np.ndarray | None = None

    @property
    def tuned(self) -> bool:
        """Whether every blade is the same (``K_R`` block-circulant)."""
        return self.mistuning is None or not np.any(self.mistuning)

    @property
    def speed_hz(self) -> float:
        """The rotor speed [Hz] the stiffness is at (``wheel.speed_hz`` of the build)."""
        return float(self.info.get("speed_hz", 0.0))

    @property
    def stiffening_per_speed(self) -> np.ndarray | None:
        """``(m, m)`` [1/s^2 per (rad/s)^2]: :attr:`speed_stiffness` per ``Omega^2`` (None
        without prestress: the stiffness does not depend on the speed)."""
        if self.speed_stiffness is None or self.speed_hz <= 0:
            return None
        return self.speed_stiffness / (2 * math.pi * self.speed_hz) ** 2

    def speed_shift(self, speed_hz: float) -> np.ndarray:
        """``(m, m)`` [1/s^2]: what the segment's (and every diagonal block's) stiffness gains
        at rotor speed ``speed_hz`` [Hz] against the model's own, in the same basis (zeros
        without prestress)."""
        per_speed = self.stiffening_per_speed
        if per_speed is None:
            return np.zeros((self.modes, self.modes))
        return (2 * math.pi) ** 2 * (speed_hz**2 - self.speed_hz**2) * per_speed

    def at_speed(self, speed_hz: float) -> ReducedModel:
        """This wheel at rotor speed ``speed_hz`` [Hz] in the same basis: ``K_seg`` and ``A0``
        moved by :meth:`speed_shift` (the coupling springs do not depend on the speed). The
        basis stays the one of the build's speed: near it (a Campbell crossing's few %) the
        frequencies match a model built at that speed (tests/test_forced_speed.py)."""
        shift = self.speed_shift(speed_hz)
        info = dict(self.info, speed_hz=float(speed_hz))
        return replace(self, K_seg=self.K_seg + shift, A0=self.A0 + shift, info=info)

    def diagonal_block(self, s: int) -> np.ndarray:
        """``(m, m)`` blade ``s``'s diagonal block of ``K_R`` [1/s^2]."""
        return self.A0 if self.tuned else self.A0 + self.mistuning[s] * self.K_seg

    @property
    def size(self) -> int:
        return self.blades * self.modes

    def dense_stiffness(self) -> np.ndarray:
        """``K_R`` as a dense ``(N m, N m)`` array [1/s^2]."""
        N, m = self.blades, self.modes
        K = np.zeros((N, m, N, m))
        for s in range(N):
            t = (s + 1) % N
            K[s, :, s, :] += self.diagonal_block(s)
            K[s, :, t, :] += self.A1
            K[t, :, s, :] += self.A1.T
        return K.reshape(N * m, N * m)

    def sparse_stiffness(self):
        """``K_R`` as a scipy CSR matrix [1/s^2]: the blade blocks only (``A0`` on the
        diagonal, ``A1`` / ``A1^T`` to the next / previous blade)."""
        import scipy.sparse as sp

        N = self.blades
        nxt = sp.csr_matrix((np.ones(N), (np.arange(N), (np.arange(N) + 1) % N)), shape=(N, N))
        diagonal = sp.block_diag([self.diagonal_block(s) for s in range(N)])
        return (diagonal + sp.kron(nxt, self.A1) + sp.kron(nxt.T, self.A1.T)).tocsr()

    def petsc_stiffness(self, comm, prefix: str = "wheel_K_"):
        """``K_R`` as a PETSc BAIJ matrix with block size m on ``comm``."""
        PETSc = petsc()
        N, m = self.blades, self.modes
        A = PETSc.Mat().create(comm=comm)
        A.setOptionsPrefix(prefix)
        A.setSizes(((PETSc.DECIDE, N * m), (PETSc.DECIDE, N * m)), bsize=m)
        A.setType(PETSc.Mat.Type.BAIJ)
        A.setBlockSize(m)
        A.setPreallocationNNZ((3 if N > 2 else N, 0))
        A.setFromOptions()
        lo, hi = A.getOwnershipRange()
        # contiguous copies: a transposed view would hand PETSc the untransposed buffer
        A1 = np.ascontiguousarray(self.A1)
        A1T = np.ascontiguousarray(self.A1.T)
        for s in range(lo // m, hi // m):
            A.setValuesBlocked([s], [s], np.ascontiguousarray(self.diagonal_block(s)))
            A.setValuesBlocked([s], [(s + 1) % N], A1)
            A.setValuesBlocked([s], [(s - 1) % N], A1T)
        A.assemble()
        return A

    def nd_stiffness(self, k: int) -> np.ndarray:
        """``(m, m)`` Hermitian ``A0 + A1 e^{i phi_k} + A1^T e^{-i phi_k}``, ``phi_k = 2 pi k /
        N``: the tuned ``K_R`` on the travelling wave ``q_s = q_0 e^{i s phi_k}`` [1/s^2]."""
        ph = np.exp(2j * np.pi * k / self.blades)
        H = self.A0 + self.A1 * ph + self.A1.T * np.conj(ph)
        return 0.5 * (H + H.conj().T)

    def block_circulant_eigenvalues(self) -> np.ndarray:
        """``(N, m)`` eigenvalues per nodal-diameter phase ``k`` (travelling-wave index).

        ``eig(A0 + A1 e^{i phi_k} + A1^T e^{-i phi_k})``, ``phi_k = 2 pi k / N``: the exact
        spectrum of the block-circulant ``K_R`` (independent of assembling it).
        """
        out = np.empty((self.blades, self.modes))
        for k in range(self.blades):
            out[k] = np.linalg.eigvalsh(self.nd_stiffness(k))
        return out

    def frequencies_by_nodal_diameter(self) -> np.ndarray:
        """``(N // 2 + 1, m)`` frequencies [Hz] for nodal diameters ``0..N//2``."""
        lam = self.block_circulant_eigenvalues()[: self.blades // 2 + 1]
        return np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi)


    def highest_frequency_hz(self) -> float:
        """The highest natural frequency of ``K_R`` [Hz]: from the ND blocks when tuned, by a
        sparse Lanczos (ARPACK) on the assembled ``K_R`` when mistuned."""
        if self.tuned:
            return float(self.frequencies_by_nodal_diameter().max())
        import scipy.sparse.linalg as spla

        K = self.sparse_stiffness()
        if K.shape[0] <= 400:  # small: dense is faster and ARPACK needs k < n
            lam = float(np.linalg.eigvalsh(K.toarray())[-1])
        else:
            lam = float(spla.eigsh(K, k=1, which="LA", return_eigenvectors=False)[0])
        return float(np.sqrt(max(lam, 0.0)) / (2 * np.pi))


def nodal_diameter(k: int | np.ndarray, blades: int):
    """Nodal diameter of travelling-wave index ``k``: ``min(k, N - k)``."""
    k = np.asarray(k) % blades
    return np.minimum(k, blades - k)


def nodal_diameters_of(shapes: np.ndarray) -> np.ndarray:
    """Nodal diameter of wheel mode shapes ``(k, N, m)`` (modal coordinates per blade): the
    ND holding most of the mode's energy, harmonics ``k`` and ``N - k`` counted together (a
    standing mode splits its energy evenly between them)."""
    N = shapes.shape[1]
    energy = (np.abs(np.fft.fft(shapes, axis=1)) ** 2).sum(axis=2)  # (modes, N)
    nd_energy = np.zeros((shapes.shape[0], N // 2 + 1))
    for k in range(N):
        nd_energy[:, nodal_diameter(k, N)] += energy[:, k]
    return np.argmax(nd_energy, axis=1)


def wheel_eigenpairs(model: ReducedModel):
    """All ``N m`` eigenpairs of ``K_R``: ``(lambda (N m,) [1/s^2] ascending, shapes
    (N m, N, m), nodal diameters (N m,))``."""
    lam, vec = np.linalg.eigh(model.dense_stiffness())
    shapes = vec.T.reshape(-1, model.blades, model.modes)
    return lam, shapes, nodal_diameters_of(shapes)


def wheel_modes(model: ReducedModel):
    """All ``N m`` wheel frequencies [Hz] from ``K_R``, each with its nodal diameter.

    Returns ``(hz, nd, kind)``: ascending frequencies, nodal diameter
    (:func:`nodal_diameters_of`) and ``"standing"`` for ND 0 and N/2 (single modes),
    ``"pair"`` for the doubly repeated travelling/standing pairs.
    """
    lam, _, nd = wheel_eigenpairs(model)
    N = model.blades
    kind = np.where((nd == 0) | ((N % 2 == 0) & (nd == N // 2)), "standing", "pair")
    return np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi), nd, kind


def rows_at(shapes: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """``(len(nodes), 3, m)`` displacement rows of full-DOF shapes ``(n_dofs, m)``."""
    dofs = 3 * np.asarray(nodes)[:, None] + np.arange(3)
    return shapes[dofs]


def reduce(
    seg: SegmentMesh,
    shapes: np.ndarray,
    K_seg: np.ndarray,
    cfg: Config,
    segment_hz: np.ndarray | None = None,
) -> ReducedModel:
    """Build the reduced wheel from a segment basis ``shapes`` (full DOFs, ``(n, m)``).

    ``shapes`` must be M-orthonormal; ``K_seg = shapes^T K shapes``.
    """
    c1 = cfg.wheel.coupling_stiffness
    R = seg.rotation
    Xr = rows_at(shapes, seg.node_sets["right"])  # (pairs, 3, m)
    Xl = rows_at(shapes, seg.node_sets["left"])
    RXl = np.einsum("ab,kbm->kam", R, Xl)
    Xr2 = Xr.reshape(-1, Xr.shape[-1])
    Xl2 = Xl.reshape(-1, Xl.shape[-1])
    A0 = K_seg + c1 * (Xr2.T @ Xr2 + Xl2.T @ Xl2)
    A1 = -c1 * Xr2.T @ RXl.reshape(-1, Xl.shape[-1])
    A0 = 0.5 * (A0 + A0.T)
    m = shapes.shape[1]
    if segment_hz is None:
        segment_hz = np.sqrt(np.maximum(np.linalg.eigvalsh(K_seg), 0)) / (2 * np.pi)
    model = ReducedModel(
        blades=seg.sectors,
        modes=m,
        segment_hz=np.asarray(segment_hz),
        K_seg=K_seg,
        A0=A0,
        A1=A1,
        rotation=R,
        tip=rows_at(shapes, seg.node_sets["tip"]).mean(axis=0),
        aero=rows_at(shapes, seg.node_sets["aero"])[:, 1, :].mean(axis=0),
        excitation=rows_at(shapes, seg.node_sets["excitation"])[:, 1, :].sum(axis=0),
    )
    for kind in CONTACT_KINDS:
        if f"{kind}_A" in seg.node_sets:
            model.contact_A[kind] = rows_at(shapes, seg.node_sets[f"{kind}_A"])[0]
            model.contact_B[kind] = rows_at(shapes, seg.node_sets[f"{kind}_B"])[0]
            model.contact_points[kind] = np.stack([seg.point(f"{kind}_A"), seg.point(f"{kind}_B")])
    model.info.update(seg.info)
    return model


def blade_mistuning(cfg: Config) -> np.ndarray | None:
    """``(N,)`` per-blade modal stiffness deviations ``delta_s`` of ``[mistuning]``: the
    pattern, plus the pattern file, plus ``+-alternate`` on even / odd blades, plus random
    values of standard deviation ``std`` (numpy ``default_rng(seed)``, drawn for this
    configuration alone: the same on every rank and for any rank count): ``normal``, or
    ``uniform`` on ``+-sqrt(3) std``; None when all are zero."""
    mt, N = cfg.mistuning, cfg.wheel.blades
    delta = np.zeros(N) if not mt.pattern else np.array(mt.pattern, dtype=float)
    if mt.file:
        try:
            delta += read_mistuning_file(mt.file, cfg.source, N)
        except ValueError as exc:
            raise InputError(f"mistuning.file: {exc}") from None
    delta += mt.alternate * np.where(np.arange(N) % 2 == 0, 1.0, -1.0)
    if mt.std > 0:
        rng = np.random.default_rng(mt.seed)
        if mt.distribution == "uniform":
            delta += mt.std * math.sqrt(3.0) * rng.uniform(-1.0, 1.0, N)
        else:
            delta += mt.std * rng.standard_normal(N)
    soft = np.flatnonzero(delta <= -0.9)  # a blade keeps at least a tenth of its stiffness
    if soft.size:
        raise InputError(
            f"mistuning: blade(s) {', '.join(map(str, soft[:5]))} get delta_s = "
            f"{delta[soft[0]]:.3g} (pattern + file + alternate + random, seed {mt.seed}): "
            "a blade's modal stiffness (1 + delta_s) Lambda must stay above 0.1 Lambda")
    return delta if np.any(delta) else None
