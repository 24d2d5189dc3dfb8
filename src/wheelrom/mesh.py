"""Segment mesh: one blade with its disc sector, quadratic hexahedra/tetrahedra, named node sets.

Frame (MODEL.md): ``x`` radial along the blade's stacking axis, ``y`` tangential (direction of
rotation), ``z`` axial. The sector spans ``theta in [-pi/N, pi/N]`` about ``z``; its ``left``
face is at ``-pi/N``, its ``right`` face at ``+pi/N`` (next to blade ``s+1``).

Elements are quadratic: 20-node serendipity hexahedra (``hex20``) or 10-node tetrahedra
(``tet10``) on straight-edged geometry. Nodes are numbered as scikit-fem numbers the degrees of
freedom: mesh vertices first, then one node per edge (its midpoint); node ``i`` carries the
DOFs ``3 i, 3 i + 1, 3 i + 2`` (``x, y, z``).

Node sets (arrays of node indices): ``clamped``, ``left``, ``right`` (paired: ``left[k]`` of
blade ``s+1`` rotated by ``R`` coincides with ``right[k]`` of blade ``s``), ``excitation``,
``aero``, ``tip`` and per contact kind ``<kind>_A``, ``<kind>_B`` (one node each).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from wheelrom.config import CONTACT_KINDS, Config
from wheelrom.errors import InputError

REQUIRED_SETS = ("clamped", "left", "right", "excitation", "aero", "tip")


def rotation_z(angle: float) -> np.ndarray:
    """3x3 rotation about the machine axis ``z`` by ``angle`` [rad]."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass
class SegmentMesh:
    """A segment mesh with its quadratic nodes and node sets.

    Attributes:
        mesh: linear scikit-fem mesh (``MeshHex`` or ``MeshTet``) carrying the topology.
        element: ``"hex20"`` or ``"tet10"``.
        nodes: ``(n_nodes, 3)`` coordinates [m], vertices first, then edge midpoints.
        node_sets: name -> node indices. ``left``/``right`` are ordered pairwise.
        sectors: number of sectors ``N`` of the wheel.
        info: geometry report (arm lengths, pitch chords, ...).
    """

    mesh: object
    element: str
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
        """Element connectivity in VTK / Abaqus order: ``(n_elem, 20)`` or ``(n_elem, 10)``."""
        return _quadratic_cells(self)


# --------------------------------------------------------------------------------------
# built-in parametric segment
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class BuiltinGeometry:
    """Parameters of the built-in LP-stage segment [m, deg]."""

    bore_radius: float = 0.40
    rim_radius: float = 1.10
    disc_width: float = 0.30
    tip_radius: float = 2.20
    chord_root: float = 0.25
    chord_tip: float = 0.16
    thickness_root: float = 0.05
    thickness_tip: float = 0.03
    stagger_root_deg: float = 0.0
    stagger_tip_deg: float = 60.0

    def chord(self, r):
        return self._lin(r, self.chord_root, self.chord_tip)

    def thickness(self, r):
        return self._lin(r, self.thickness_root, self.thickness_tip)

    def stagger(self, r):
        return np.radians(self._lin(r, self.stagger_root_deg, self.stagger_tip_deg))

    def _lin(self, r, root, tip):
        f = (np.asarray(r) - self.rim_radius) / (self.tip_radius - self.rim_radius)
        return root + f * (tip - root)

    def exact_volume(self, sectors: int) -> float:
        """Volume of the exact geometry [m^3]: annular disc sector + blade + root fillet.

        The blade's sections are rectangles of area ``c(r) t(r)`` (twist does not change it);
        below the plane ``x = R_rim`` the root section reaches down to the rim cylinder.
        """
        R, Ri, w = self.rim_radius, self.bore_radius, self.disc_width
        disc = math.pi * (R**2 - Ri**2) * w / sectors
        c0, c1 = self.chord_root, self.chord_tip
        t0, t1 = self.thickness_root, self.thickness_tip
        span = self.tip_radius - R
        # integral of (c0 + (c1-c0) f)(t0 + (t1-t0) f) over f in [0, 1], times span
        blade = span * (c0 * t0 + (c0 * (t1 - t0) + t0 * (c1 - c0)) / 2 + (c1 - c0) * (t1 - t0) / 3)
        h = t0 / 2
        fillet = c0 * (2 * h * R - h * math.sqrt(R**2 - h**2) - R**2 * math.asin(h / R))
        return disc + blade + fillet


# preset -> (target element size along span [m], disc radial elements, side elements in
# theta and z, subdivision of the chord and thickness grid lines)
PRESETS = {
    "coarse": dict(span_h=0.1, disc_radial=3, side=1, sub_chord=1, sub_thick=1),
    "default": dict(span_h=0.05, disc_radial=6, side=2, sub_chord=2, sub_thick=1),
    "paper": dict(span_h=0.038, disc_radial=8, side=3, sub_chord=3, sub_thick=2),
}


def _subdivide(lines: np.ndarray, k: int) -> np.ndarray:
    """Insert ``k - 1`` equally spaced lines in each interval (last axis)."""
    if k == 1:
        return lines
    f = np.arange(k) / k
    pieces = [
        lines[..., i, None] + f * (lines[..., i + 1, None] - lines[..., i, None])
        for i in range(lines.shape[-1] - 1)
    ]
    return np.concatenate([*pieces, lines[..., -1:]], axis=-1)


def _arm_geometry(height: float, profile: float, sector_angle: float):
    """Arm direction angle ``alpha`` and points A, B of a contact at radius ``height``.

    The arm lies in the plane ``z = 0`` with direction ``a = (-sin alpha, cos alpha, 0)``;
    ``A = P - l/2 a`` and ``B = P + l/2 a`` around ``P = (H, 0, 0)`` on the stacking axis, and
    ``a`` points from ``A`` at the next blade's ``A`` (``R A``): ``alpha = psi_A + phi/2``.
    """
    alpha = sector_angle / 2
    for _ in range(50):
        a = np.array([-math.sin(alpha), math.cos(alpha), 0.0])
        A = np.array([height, 0.0, 0.0]) - 0.5 * profile * a
        new = math.atan2(A[1], A[0]) + sector_angle / 2
        if abs(new - alpha) < 1e-15:
            break
        alpha = new
    a = np.array([-math.sin(alpha), math.cos(alpha), 0.0])
    P = np.array([height, 0.0, 0.0])
    return alpha, P - 0.5 * profile * a, P + 0.5 * profile * a


def build_builtin(cfg: Config, geometry: BuiltinGeometry | None = None) -> SegmentMesh:
    """Mesh the built-in segment for ``cfg.wheel.blades`` sectors and ``cfg.segment.preset``."""
    from skfem import MeshHex

    g = geometry or BuiltinGeometry()
    N = cfg.wheel.blades
    phi = 2 * math.pi / N
    preset = PRESETS[cfg.segment.preset]
    R, Rt = g.rim_radius, g.tip_radius

    # --- contact rows: heights, arm angles and the section coordinates of A --------------
    anchors_r = [R]
    anchor_alpha = [0.25]  # chordwise line position |a| of the inner lines at each anchor
    anchor_beta = [0.5]  # thickness line position |b|
    arms = {}
    for kind in CONTACT_KINDS:
        c = cfg.contact(kind)
        H = c.height
        if not (R < H < Rt):
            raise InputError(
                f"contacts.{kind}.height = {H} m is outside the built-in blade ({R}..{Rt} m)"
            )
        alpha, A, B = _arm_geometry(H, c.profile_thickness, phi)
        gam = float(g.stagger(H))
        y_A = A[1]
        a_A = 2 * y_A * math.sin(gam) / float(g.chord(H))
        b_A = 2 * y_A * math.cos(gam) / float(g.thickness(H))
        if not (abs(a_A) < 0.45 and 0.1 < abs(b_A) < 0.9):
            raise InputError(
                f"contacts.{kind}.profile_thickness = {c.profile_thickness} m does not fit the "
                f"built-in profile at H = {H} m"
            )
        arms[kind] = dict(H=H, alpha=alpha, A=A, B=B)
        anchors_r.append(H)
        anchor_alpha.append(abs(a_A))
        anchor_beta.append(abs(b_A))
    order = np.argsort(anchors_r)
    anchors_r = list(np.array(anchors_r)[order]) + [Rt]
    anchor_alpha = list(np.array(anchor_alpha)[order]) + [anchor_alpha[order[-1]]]
    anchor_beta = list(np.array(anchor_beta)[order]) + [anchor_beta[order[-1]]]
    if np.any(np.diff(anchors_r) <= 0):
        raise InputError("contacts.tieboss.height and contacts.shroud.height must differ")

    # --- span rows: element rows between consecutive anchors ------------------------------
    rows = [np.array([R])]
    for r0, r1 in zip(anchors_r[:-1], anchors_r[1:], strict=True):
        n = max(1, int(round((r1 - r0) / preset["span_h"])))
        rows.append(np.linspace(r0, r1, n + 1)[1:])
    r_rows = np.concatenate(rows)
    row_alpha = np.interp(r_rows, anchors_r, anchor_alpha)
    row_beta = np.interp(r_rows, anchors_r, anchor_beta)

    m_line = 0.6
    a_lines = np.stack(
        [
            np.full_like(r_rows, -1.0),
            np.full_like(r_rows, -m_line),
            -row_alpha,
            np.zeros_like(r_rows),
            row_alpha,
            np.full_like(r_rows, m_line),
            np.ones_like(r_rows),
        ],
        axis=-1,
    )
    b_lines = np.stack(
        [-np.ones_like(r_rows), -row_beta, np.zeros_like(r_rows), row_beta, np.ones_like(r_rows)],
        axis=-1,
    )
    a_lines = _subdivide(a_lines, preset["sub_chord"])
    b_lines = _subdivide(b_lines, preset["sub_thick"])

    # --- blade block: parameter order (span, thickness, chord) keeps the map right-handed --
    nr, nb, na = len(r_rows), b_lines.shape[1], a_lines.shape[1]
    I, J, K = np.meshgrid(np.arange(nr), np.arange(nb), np.arange(na), indexing="ij")
    r = r_rows[I]
    bb = b_lines[I, J]
    aa = a_lines[I, K]
    gam = g.stagger(r)
    tt = 0.5 * bb * g.thickness(r)
    cc = 0.5 * aa * g.chord(r)
    y = tt * np.cos(gam) + cc * np.sin(gam)
    z = -tt * np.sin(gam) + cc * np.cos(gam)
    # root fillet: the first element row reaches down to the rim cylinder
    y_root = 0.5 * b_lines[0][J] * g.thickness_root
    fade = np.clip(1.0 - (r - R) / (r_rows[1] - R), 0.0, 1.0)
    x = r + fade * (np.sqrt(R**2 - y_root**2) - R)
    # arm rows: shear x so that A and B (z = 0) lie on the tilted arm x = H - y tan(alpha)
    for arm in arms.values():
        i_arm = int(np.argmin(abs(r_rows - arm["H"])))
        hat = np.interp(r, r_rows[i_arm - 1 : i_arm + 2], [0.0, 1.0, 0.0])
        x = x - y * math.tan(arm["alpha"]) * hat
        arm["row"] = i_arm
    blade_p = np.stack([x, y, z], axis=-1)

    # --- disc block: parameter order (r, theta, z) ----------------------------------------
    side = preset["side"]
    t_half = 0.5 * g.thickness_root
    th_root = np.arcsin(b_lines[0] * t_half / R)
    th_side = np.linspace(-phi / 2, th_root[0], side + 1)
    th_lines = np.concatenate([th_side[:-1], th_root, -th_side[:-1][::-1]])
    z_root = 0.5 * a_lines[0] * g.chord_root
    z_side = np.linspace(-g.disc_width / 2, z_root[0], side + 1)
    z_lines = np.concatenate([z_side[:-1], z_root, -z_side[:-1][::-1]])
    r_lines = np.linspace(g.bore_radius, R, preset["disc_radial"] + 1)
    Ir, It, Iz = np.meshgrid(r_lines, th_lines, z_lines, indexing="ij")
    disc_p = np.stack([Ir * np.cos(It), Ir * np.sin(It), Iz], axis=-1)

    # --- hexahedra of both blocks (scikit-fem vertex order from init_tensor), merged -------
    def block(points):
        n1, n2, n3 = points.shape[:3]
        m = MeshHex.init_tensor(np.arange(n1), np.arange(n2), np.arange(n3))
        ijk = np.rint(m.p).astype(int)
        return points[ijk[0], ijk[1], ijk[2]], m.t, ijk

    pd, td, ijk_d = block(disc_p)
    pb, tb, ijk_b = block(blade_p)
    p_all = np.vstack([pd, pb])
    t_all = np.hstack([td, tb + pd.shape[0]])
    key = np.round(p_all / 1e-9).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    p_unique = p_all[first]
    mesh = MeshHex(p_unique.T.copy(), inverse[t_all])

    # vertex sets by block parameters
    def disc_vertices(mask):
        return np.unique(inverse[np.flatnonzero(mask)])

    def blade_vertex(i, j, k):
        hit = np.flatnonzero((ijk_b[0] == i) & (ijk_b[1] == j) & (ijk_b[2] == k))
        return inverse[pd.shape[0] + hit[0]]

    n_th = len(th_lines)
    vsets = {
        "clamped": disc_vertices(ijk_d[0] == 0),
        "left": disc_vertices(ijk_d[1] == 0),
        "right": disc_vertices(ijk_d[1] == n_th - 1),
    }
    j_mid = nb // 2
    k_mid = na // 2
    tip_row = nr - 1
    points = {
        "tip": [blade_vertex(tip_row, j_mid, k_mid)],
        "aero": [blade_vertex(tip_row, j_mid, k_mid)],
        "excitation": [blade_vertex(tip_row, j_mid, 0), blade_vertex(tip_row, j_mid, na - 1)],
    }
    sub_c, sub_t = preset["sub_chord"], preset["sub_thick"]
    for kind, arm in arms.items():
        # inner lines -alpha, +alpha sit at (2, 4) * sub_c; -beta, +beta at (1, 3) * sub_t
        points[f"{kind}_A"] = [blade_vertex(arm["row"], 1 * sub_t, 2 * sub_c)]
        points[f"{kind}_B"] = [blade_vertex(arm["row"], 3 * sub_t, 4 * sub_c)]
        got_A = p_unique[points[f"{kind}_A"][0]]
        got_B = p_unique[points[f"{kind}_B"][0]]
        assert np.allclose(got_A, arm["A"], atol=1e-9), (kind, got_A, arm["A"])
        assert np.allclose(got_B, arm["B"], atol=1e-9), (kind, got_B, arm["B"])

    seg = _with_edges(mesh, "hex20", vsets, {k: np.array(v) for k, v in points.items()}, N)
    pair_cut_faces(seg)
    seg.info.update(_arm_report(seg, cfg))
    seg.info["exact_volume"] = g.exact_volume(N)
    seg.info["preset"] = cfg.segment.preset
    return seg


def _with_edges(mesh, element, vertex_face_sets, point_sets, sectors) -> SegmentMesh:
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
    return SegmentMesh(mesh, element, nodes, sets, sectors)


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


def _arm_report(seg: SegmentMesh, cfg: Config) -> dict:
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


# --------------------------------------------------------------------------------------
# element orders for output
# --------------------------------------------------------------------------------------

# VTK/Abaqus edge order of the quadratic cells, as pairs of corner positions
_HEX20_EDGES = [
    (0, 1),
    (1, 2),
    (2, 3),
    (3, 0),
    (4, 5),
    (5, 6),
    (6, 7),
    (7, 4),
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 7),
]
_TET10_EDGES = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]


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
    """Corner connectivity in VTK order ``(n_elem, 8)`` or ``(n_elem, 4)``."""
    if seg.element == "hex20":
        from skfem.io.meshio import HEX_MAPPING

        return seg.mesh.t.T[:, HEX_MAPPING[:8]]
    return seg.mesh.t.T.copy()


def _quadratic_cells(seg: SegmentMesh) -> np.ndarray:
    corners = corner_cells(seg)
    pairs = _HEX20_EDGES if seg.element == "hex20" else _TET10_EDGES
    mids = [edge_nodes(seg, corners[:, i], corners[:, j]) for i, j in pairs]
    return np.column_stack([corners, *mids])


def load_segment(cfg: Config) -> SegmentMesh:
    """The segment of a configuration: built-in, or read from ``segment.source``."""
    if cfg.segment.source == "builtin":
        return build_builtin(cfg)
    from wheelrom.mesh_import import read_segment

    return read_segment(cfg)
