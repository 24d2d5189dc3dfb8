"""Contact stiffness ``k_c(beta)`` from the segment FE (paper section 4, Fig. 5).

The paper loads one blade with unit forces at both contact points in ``y`` and ``z`` and turns
the resulting deformation into a normal stiffness for each surface angle. Here, per contact
kind:

1. Static flexibility ``G`` (6 x 6, [m/N]) of the clamped segment at the points ``A`` and
   ``B``: six static solves ``K x = f`` (PETSc KSP, Cholesky with MUMPS, prefix
   ``stiffness_``). Each unit force is spread evenly over the nodes within
   ``load_radius`` of the point, and the displacement is read as the mean over the same nodes
   (work-conjugate), so the result does not diverge like a point load's under refinement.
   ``G`` is symmetric (Maxwell-Betti), which the tests check.
2. For the surface normal ``n(beta) = (0, cos beta, sin beta)`` of the contact of the arm
   end ``C_s`` against ``A_{s+1}``, three compliances in series:

   - blade ``s+1`` at ``A``: ``c_A = (R^T n)^T G_AA (R^T n)``;
   - the arm end of blade ``s`` (rigid arm ``C = A + L e``): a force at ``C`` acts on ``A`` and
     ``B`` through ``P = [I - S; S]``, ``S = (L/l)(I - a a^T)``, so ``c_C = n^T P^T G P n``;
   - the arm's own axial compliance ``c_arm = (n . a)^2 / k_arm`` (``arm_axial_stiffness``).

   ``k_c(beta) = 1 / (c_A + c_C + c_arm)``. Near 0 deg the normal lies almost along the arm
   (tangential ``y``) and the stiff directions dominate; near 90 deg it is axial, where the
   blade is most flexible.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from wheelrom.runtime.errors import InputError
from wheelrom.segment.assembly import SegmentMatrices
from wheelrom.segment.mesh import SegmentMesh
from wheelrom.segment.petsc import direct_solve

ANGLES_DEG = np.arange(0.0, 90.0 + 1e-9, 5.0)


@dataclass
class ContactFlexibility:
    """Flexibility of one contact kind's points and the geometry to turn it into ``k_c``.

    ``G``: ``(6, 6)`` [m/N], rows/columns ``(A_x, A_y, A_z, B_x, B_y, B_z)``;
    ``arm_direction``: unit ``a = (B - A)/|B - A|``; ``arm_length`` L and ``l = |B - A|`` [m].
    """

    kind: str
    G: np.ndarray
    rotation: np.ndarray
    arm_direction: np.ndarray
    arm_length: float
    point_distance: float
    load_nodes: tuple[int, int]
    solve_s: float
    reciprocity_error: float = 0.0  # max |G - G^T| / max |G| before symmetrising

    def stiffness(self, angle_deg, arm_axial_stiffness: float) -> np.ndarray:
        """``k_c`` [N/m] at the surface angles ``angle_deg`` (array-like)."""
        b = np.radians(np.atleast_1d(np.asarray(angle_deg, dtype=float)))
        n = np.stack([np.zeros_like(b), np.cos(b), np.sin(b)], axis=1)  # (k, 3)
        a = self.arm_direction
        S = (self.arm_length / self.point_distance) * (np.eye(3) - np.outer(a, a))
        P = np.vstack([np.eye(3) - S, S])  # (6, 3): force at C -> forces at A, B
        GAA = self.G[:3, :3]
        nA = n @ self.rotation  # rows R^T n
        c_blade = np.einsum("ki,ij,kj->k", nA, GAA, nA)
        c_arm_end = np.einsum("ki,ij,kj->k", n, P.T @ self.G @ P, n)
        c_axial = (n @ a) ** 2 / arm_axial_stiffness
        return 1.0 / (c_blade + c_arm_end + c_axial)


def _load_weights(seg: SegmentMesh, point: np.ndarray, radius: float) -> np.ndarray:
    d = np.linalg.norm(seg.nodes - point, axis=1)
    near = np.flatnonzero(d <= radius)
    if near.size == 0:
        near = np.array([int(np.argmin(d))])
    return near


def flexibility(
    seg: SegmentMesh,
    mats: SegmentMatrices,
    kinds,
    arm_lengths: dict,
    load_radius: dict,
    comm,
    prefix: str = "stiffness_",
) -> dict[str, ContactFlexibility]:
    """Static flexibility at ``A``/``B`` of every kind in ``kinds`` (one factorisation)."""
    t0 = time.perf_counter()
    columns, groups = [], {}
    for kind in kinds:
        for end in ("A", "B"):
            name = f"{kind}_{end}"
            if name not in seg.node_sets:
                raise InputError(f"node set '{name}' is missing: needed for stiffness = 'fe'")
            nodes = _load_weights(seg, seg.point(name), load_radius[kind])
            groups[name] = nodes
            for c in range(3):
                f = np.zeros(seg.n_dofs)
                f[3 * nodes + c] = 1.0 / nodes.size
                columns.append(f[mats.free])
    F = np.array(columns).T  # (n_free, 6 * kinds)
    X = direct_solve(mats.K, F, comm, prefix)
    D = F.T @ X  # work-conjugate mean displacements: D[i, j] = f_i^T K^-1 f_j
    out = {}
    for i, kind in enumerate(kinds):
        block = slice(6 * i, 6 * i + 6)
        A, B = seg.point(f"{kind}_A"), seg.point(f"{kind}_B")
        G = D[block, block]
        l = float(np.linalg.norm(B - A))
        out[kind] = ContactFlexibility(
            kind=kind,
            G=0.5 * (G + G.T),
            rotation=seg.rotation,
            arm_direction=(B - A) / l,
            arm_length=float(arm_lengths[kind]),
            point_distance=l,
            load_nodes=(groups[f"{kind}_A"].size, groups[f"{kind}_B"].size),
            solve_s=time.perf_counter() - t0,
            reciprocity_error=float(np.abs(G - G.T).max() / np.abs(G).max()),
        )
    return out


def stiffness_tables(cfg, seg: SegmentMesh, mats: SegmentMatrices, kinds, comm):
    """``{kind: (angles_deg, k_c [N/m], ContactFlexibility)}`` for the contact ``kinds`` of
    the segment ``seg`` with the matrices ``mats`` (those the model is built from)."""
    kinds = list(kinds)
    if not kinds:
        return {}
    radius = {k: 0.5 * cfg.contact(k).profile_thickness for k in kinds}
    arms = {k: cfg.contact(k).arm_length for k in kinds}
    flex = flexibility(seg, mats, kinds, arms, radius, comm)
    return {
        k: (ANGLES_DEG.copy(), flex[k].stiffness(ANGLES_DEG, cfg.contact(k).arm_axial_stiffness),
            flex[k])
        for k in kinds
    }
