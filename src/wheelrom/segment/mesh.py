"""Segment mesh type: one blade with its disc sector, 20-node hexahedra, named node sets.

Frame (docs/theory.md): ``x`` radial along the blade's stacking axis, ``y`` tangential
(direction of rotation), ``z`` axial. The sector spans ``theta in [-pi/N, pi/N]`` about ``z``;
its ``left`` face is at ``-pi/N``, its ``right`` face at ``+pi/N`` (next to blade ``s+1``).

Elements are 20-node serendipity hexahedra (``hex20``) on straight-edged geometry. Nodes are
numbered as scikit-fem numbers the degrees of freedom: mesh vertices first, then one node per
edge (its midpoint); node ``i`` carries the DOFs ``3 i, 3 i + 1, 3 i + 2`` (``x, y, z``).

Node sets (arrays of node indices): ``clamped``, ``left``, ``right`` (paired: ``left[k]`` of
blade ``s+1`` rotated by ``R`` coincides with ``right[k]`` of blade ``s``), ``excitation``,
``aero``, ``tip`` and per contact kind ``<kind>_A``, ``<kind>_B`` (one node each).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from wheelrom.config import CONTACT_KINDS, Config
from wheelrom.runtime.errors import InputError

REQUIRED_SETS = ("clamped", "left", "right", "excitation", "aero", "tip")

# VTK / Abaqus order of the 12 edges of a 20-node hexahedron, as pairs of corner positions:
# the mid-side node of edge e is node 8 + e of the cell
HEX20_EDGES = ((0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4),
               (0, 4), (1, 5), (2, 6), (3, 7))


def rotation_z(angle: float) -> np.ndarray:
    """3x3 rotation about the machine axis ``z`` by ``angle`` [rad]."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass
class SegmentMesh:
    """A segment mesh with its quadratic nodes and node sets.

    Attributes:
        mesh: linear scikit-fem ``MeshHex`` carrying the topology.
        nodes: ``(n_nodes, 3)`` coordinates [m], vertices first, then edge midpoints.
        node_sets: name -> node indices. ``left``/``right`` are ordered pairwise.
        sectors: number of sectors ``N`` of the wheel.
        info: geometry report (arm lengths, pitch chords, ...).
    """

    mesh: object
    nodes: np.ndarray
    node_sets: dict[str, np.ndarray]
    sectors: int
    info: dict = field(default_factory=dict)

    @property
    def n_nodes(self) -> int:
        return self.nodes.shape[0]

    @property
    def n_dofs(self) -> int:
        return 3 * self.n_nodes

    def dofs(self, name: str) -> np.ndarray:
        """DOF indices ``(len(set), 3)`` of a node set."""
        idx = self.node_sets[name]
        return 3 * idx[:, None] + np.arange(3)[None, :]

    def point(self, name: str) -> np.ndarray:
        """Coordinates ``(3,)`` of a single-node set [m]."""
        idx = self.node_sets[name]
        if idx.size != 1:
            raise InputError(f"node set '{name}' must hold exactly one node, has {idx.size}")
        return self.nodes[idx[0]]

    @property
    def sector_angle(self) -> float:
        return 2.0 * math.pi / self.sectors

    @property
    def rotation(self) -> np.ndarray:
        """``R``: maps a vector of sector ``s+1``'s frame into sector ``s``'s frame."""
        return rotation_z(self.sector_angle)

    def quadratic_cells(self) -> np.ndarray:
        """Element connectivity in VTK / Abaqus order ``(n_elem, 20)``."""
        corners = corner_cells(self)
        mids = [edge_nodes(self, corners[:, i], corners[:, j]) for i, j in HEX20_EDGES]
        return np.column_stack([corners, *mids])



def with_edges(mesh, vertex_face_sets, point_sets, sectors) -> SegmentMesh:
    """Add edge-midpoint nodes; a face set takes an edge node when it holds both ends."""
    nv = mesh.p.shape[1]
    edges = mesh.edges
    nodes = np.vstack([mesh.p.T, 0.5 * (mesh.p[:, edges[0]] + mesh.p[:, edges[1]]).T])
    sets = {}
    for name, verts in vertex_face_sets.items():
        inside = np.zeros(nv, bool)
        inside[verts] = True
        on_edge = np.flatnonzero(inside[edges[0]] & inside[edges[1]])
        sets[name] = np.concatenate([np.sort(verts), nv + on_edge])
    sets.update({k: np.asarray(v, dtype=int) for k, v in point_sets.items()})
    return SegmentMesh(mesh, nodes, sets, sectors)


def pair_cut_faces(seg: SegmentMesh, tol: float | None = None) -> None:
    """Order ``left`` so that ``R @ nodes[left[k]] == nodes[right[k]]``; error on strays."""
    from scipy.spatial import cKDTree

    for name in ("left", "right"):
        if name not in seg.node_sets or seg.node_sets[name].size == 0:
            raise InputError(f"node set '{name}' (cyclic cut face) is missing or empty")
    left, right = seg.node_sets["left"], seg.node_sets["right"]
    size = float(np.ptp(seg.nodes, axis=0).max())
    tol = tol if tol is not None else 1e-6 * size
    rotated = seg.nodes[left] @ seg.rotation.T
    tree = cKDTree(rotated)
    dist, idx = tree.query(seg.nodes[right])
    bad = np.flatnonzero(dist > tol)
    if bad.size:
        k = bad[0]
        raise InputError(
            f"node set 'right': node {right[k]} at {seg.nodes[right[k]].round(6).tolist()} has no "
            f"partner in 'left' under the sector rotation (nearest {dist[k]:.3g} m away, "
            f"tolerance {tol:.3g} m); {bad.size} unpaired node(s)"
        )
    if left.size != right.size or np.unique(idx).size != idx.size:
        raise InputError(
            f"node sets 'left' ({left.size} nodes) and 'right' ({right.size} nodes) do not pair "
            "one to one under the sector rotation"
        )
    seg.node_sets["left"] = left[idx]


def arm_report(seg: SegmentMesh, cfg: Config) -> dict:
    """Arm lengths: configured L, geometric |R A - A|, pitch chord 2 H sin(pi/N)."""
    out = {}
    for kind in CONTACT_KINDS:
        if f"{kind}_A" not in seg.node_sets:
            continue
        A, B = seg.point(f"{kind}_A"), seg.point(f"{kind}_B")
        RA = seg.rotation @ A
        c = cfg.contact(kind)
        out[kind] = dict(
            arm_length=c.arm_length,
            geometric_arm_length=float(np.linalg.norm(RA - A)),
            pitch_chord=2 * c.height * math.sin(math.pi / seg.sectors),
            profile_thickness=float(np.linalg.norm(B - A)),
            tip_to_next_A=float(
                np.linalg.norm(A + c.arm_length * (B - A) / np.linalg.norm(B - A) - RA)
            ),
        )
    return out


def _edge_lookup(seg: SegmentMesh):
    nv = seg.mesh.p.shape[1]
    e = np.sort(seg.mesh.edges, axis=0)
    keys = e[0].astype(np.int64) * nv + e[1]
    order = np.argsort(keys)
    return nv, keys[order], order


def edge_nodes(seg: SegmentMesh, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Node index of the midpoint of edge (a, b) (vertex indices, any order)."""
    nv, keys, order = _edge_lookup(seg)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    q = lo.astype(np.int64) * nv + hi
    pos = np.searchsorted(keys, q)
    if np.any(pos >= keys.size) or np.any(keys[np.minimum(pos, keys.size - 1)] != q):
        raise InputError("element edge not found in the mesh topology")
    return nv + order[pos]


def corner_cells(seg: SegmentMesh) -> np.ndarray:
    """Corner connectivity in VTK order ``(n_elem, 8)``."""
    from skfem.io.meshio import HEX_MAPPING

    return seg.mesh.t.T[:, HEX_MAPPING[:8]]
