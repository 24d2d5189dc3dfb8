"""The built-in parametric segment: an LP-stage blade with its disc sector (``segment.source =
"builtin"``), meshed with 20-node hexahedra at the density of ``segment.preset``.

Two structured blocks, merged where their vertices coincide: the disc sector (radius, angle,
axial; the hub widens toward the bore) and the blade (span, thickness, chord tapering fastest
at the root; stagger grows linearly along the span). The
element rows of the blade pass through the contact heights so that the profile points ``A``,
``B`` of every contact kind are mesh vertices on the arm's line (docs/theory.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wheelrom.config import CONTACT_KINDS, Config
from wheelrom.runtime.errors import InputError
from wheelrom.segment.mesh import SegmentMesh, arm_report, pair_cut_faces, with_edges


@dataclass(frozen=True)
class BuiltinGeometry:
    """Parameters of the built-in LP-stage segment [m, deg]."""

    bore_radius: float = 0.50
    rim_radius: float = 1.10
    disc_width: float = 0.36  # axial width at the rim
    hub_width: float = 1.20  # axial width at the bore (linear in r to the rim's)
    tip_radius: float = 2.20
    chord_root: float = 0.28
    chord_tip: float = 0.14
    thickness_root: float = 0.10
    thickness_tip: float = 0.022
    stagger_root_deg: float = 0.0
    stagger_tip_deg: float = 60.0
    taper_exponent: float = 2.0  # chord, thickness: root + (tip - root) (1 - (1 - f)^p)

    def width(self, r):
        """Axial width of the disc [m] at radius ``r``: ``hub_width`` at the bore, linear to
        ``disc_width`` at the rim (an LP disc's hub: near the constant-strength profile
        ``w ~ exp(-rho Omega^2 r^2 / 2 sigma)`` that keeps the disc below 0.8 GPa)."""
        f = (np.asarray(r) - self.bore_radius) / (self.rim_radius - self.bore_radius)
        return self.hub_width + f * (self.disc_width - self.hub_width)

    def chord(self, r):
        return self._lin(r, self.chord_root, self.chord_tip)

    def thickness(self, r):
        return self._lin(r, self.thickness_root, self.thickness_tip)

    def stagger(self, r):
        return np.radians(self._lin(r, self.stagger_root_deg, self.stagger_tip_deg))

    def _lin(self, r, root, tip):
        """From ``root`` at the rim to ``tip`` with the span fraction ``f``: linear for
        ``taper_exponent`` 1; larger exponents taper fastest at the root, as LP blades do
        (the centrifugal stress is then nearly constant along the span)."""
        f = (np.asarray(r) - self.rim_radius) / (self.tip_radius - self.rim_radius)
        return root + (1.0 - (1.0 - f) ** self.taper_exponent) * (tip - root)

    def exact_volume(self, sectors: int) -> float:
        """Volume of the exact geometry [m^3]: annular disc sector + blade + root fillet.

        The blade's sections are rectangles of area ``c(r) t(r)`` (twist does not change it);
        below the plane ``x = R_rim`` the root section reaches down to the rim cylinder.
        """
        R, Ri, w = self.rim_radius, self.bore_radius, self.disc_width
        h = self.hub_width
        # integral of r * width(r) over the disc, width linear from h (bore) to w (rim)
        disc = h * (R**2 - Ri**2) / 2 + (w - h) / (R - Ri) * ((R**3 - Ri**3) / 3
                                                              - Ri * (R**2 - Ri**2) / 2)
        disc *= 2 * math.pi / sectors
        t0 = self.thickness_root
        # integral of chord * thickness over the span: Gauss-Legendre, exact for the
        # polynomial profiles of integer taper exponents up to 9
        x, wq = np.polynomial.legendre.leggauss(10)
        r = R + (x + 1) / 2 * (self.tip_radius - R)
        blade = float(np.sum(wq * self.chord(r) * self.thickness(r))) * (self.tip_radius - R) / 2
        h, c0 = t0 / 2, self.chord_root
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


def arm_geometry(height: float, profile: float, sector_angle: float):
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
    g = geometry or BuiltinGeometry()
    N = cfg.wheel.blades
    phi = 2 * math.pi / N
    preset = PRESETS[cfg.segment.preset]
    anchors, arms = _contact_anchors(cfg, g, phi)
    r_rows, a_lines, b_lines = _section_lines(g, preset, anchors)
    blade_p = _blade_block(g, r_rows, a_lines, b_lines, arms)
    disc_p = _disc_block(g, preset, phi, a_lines, b_lines)
    mesh, vertex_sets, point_sets = _merged_mesh(disc_p, blade_p, preset, arms)
    seg = with_edges(mesh, vertex_sets, point_sets, N)
    pair_cut_faces(seg)
    seg.info.update(arm_report(seg, cfg))
    seg.info["exact_volume"] = g.exact_volume(N)
    seg.info["preset"] = cfg.segment.preset
    seg.info["rim_radius"] = g.rim_radius
    return seg


def _contact_anchors(cfg: Config, g: BuiltinGeometry, phi: float):
    """Span positions the blade's element rows must pass through (rim, contact heights, tip),
    with the chordwise/thickness line positions of the inner lines there, and the arm geometry
    of every contact kind (height, direction angle, points A and B)."""
    R, Rt = g.rim_radius, g.tip_radius
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
        alpha, A, B = arm_geometry(H, c.profile_thickness, phi)
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
    return (anchors_r, anchor_alpha, anchor_beta), arms


def _section_lines(g: BuiltinGeometry, preset: dict, anchors):
    """Span rows ``r_rows`` and, per row, the chordwise ``a`` and thickness ``b`` grid lines
    (section coordinates in [-1, 1])."""
    anchors_r, anchor_alpha, anchor_beta = anchors
    rows = [np.array([g.rim_radius])]
    for r0, r1 in zip(anchors_r[:-1], anchors_r[1:], strict=True):
        n = max(1, int(round((r1 - r0) / preset["span_h"])))
        rows.append(np.linspace(r0, r1, n + 1)[1:])
    r_rows = np.concatenate(rows)
    row_alpha = np.interp(r_rows, anchors_r, anchor_alpha)
    row_beta = np.interp(r_rows, anchors_r, anchor_beta)
    m_line = 0.6
    ones, zeros = np.ones_like(r_rows), np.zeros_like(r_rows)
    a_lines = np.stack(
        [-ones, np.full_like(r_rows, -m_line), -row_alpha, zeros, row_alpha,
         np.full_like(r_rows, m_line), ones],
        axis=-1,
    )
    b_lines = np.stack([-ones, -row_beta, zeros, row_beta, ones], axis=-1)
    return (r_rows, _subdivide(a_lines, preset["sub_chord"]),
            _subdivide(b_lines, preset["sub_thick"]))


def _blade_block(g: BuiltinGeometry, r_rows, a_lines, b_lines, arms) -> np.ndarray:
    """Vertex coordinates ``(nr, nb, na, 3)`` of the blade block; parameter order (span,
    thickness, chord) keeps the map right-handed. Records each arm's element row."""
    R = g.rim_radius
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
    return np.stack([x, y, z], axis=-1)


def _disc_block(g: BuiltinGeometry, preset: dict, phi: float, a_lines, b_lines) -> np.ndarray:
    """Vertex coordinates of the disc sector block; parameter order (r, theta, z). Its lines
    under the blade root continue the blade's thickness and chord lines."""
    side = preset["side"]
    R = g.rim_radius
    t_half = 0.5 * g.thickness_root
    th_root = np.arcsin(b_lines[0] * t_half / R)
    th_side = np.linspace(-phi / 2, th_root[0], side + 1)
    th_lines = np.concatenate([th_side[:-1], th_root, -th_side[:-1][::-1]])
    z_root = 0.5 * a_lines[0] * g.chord_root
    r_lines = np.linspace(g.bore_radius, R, preset["disc_radial"] + 1)
    # per radius: side lines from the disc's face (hub: wider) to the root's chord lines
    z_side = np.linspace(-g.width(r_lines) / 2, np.full(r_lines.size, z_root[0]), side + 1, axis=1)
    z_lines = np.concatenate([z_side[:, :-1], np.broadcast_to(z_root, (r_lines.size,
                              z_root.size)), -z_side[:, :-1][:, ::-1]], axis=1)
    Ir, It = np.meshgrid(r_lines, th_lines, indexing="ij")
    Ir = np.broadcast_to(Ir[..., None], Ir.shape + (z_lines.shape[1],))
    It = np.broadcast_to(It[..., None], Ir.shape)
    Iz = np.broadcast_to(z_lines[:, None, :], Ir.shape)
    return np.stack([Ir * np.cos(It), Ir * np.sin(It), Iz], axis=-1)


def _tensor_block(points: np.ndarray):
    """Hexahedra of a structured block (scikit-fem vertex order from ``init_tensor``):
    ``(vertex coordinates, cells, block indices ijk of every vertex)``."""
    from skfem import MeshHex

    n1, n2, n3 = points.shape[:3]
    m = MeshHex.init_tensor(np.arange(n1), np.arange(n2), np.arange(n3))
    ijk = np.rint(m.p).astype(int)
    return points[ijk[0], ijk[1], ijk[2]], m.t, ijk


def _merged_mesh(disc_p, blade_p, preset: dict, arms):
    """Both blocks merged at coincident vertices: the linear mesh, the face vertex sets
    (``clamped``, ``left``, ``right``) and the single-point sets (tip, aero, excitation, A, B)."""
    from skfem import MeshHex

    pd, td, ijk_d = _tensor_block(disc_p)
    pb, tb, ijk_b = _tensor_block(blade_p)
    p_all = np.vstack([pd, pb])
    t_all = np.hstack([td, tb + pd.shape[0]])
    key = np.round(p_all / 1e-9).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    p_unique = p_all[first]
    mesh = MeshHex(p_unique.T.copy(), inverse[t_all])

    def disc_vertices(mask):
        return np.unique(inverse[np.flatnonzero(mask)])

    def blade_vertex(i, j, k):
        hit = np.flatnonzero((ijk_b[0] == i) & (ijk_b[1] == j) & (ijk_b[2] == k))
        return inverse[pd.shape[0] + hit[0]]

    vertex_sets = {
        "clamped": disc_vertices(ijk_d[0] == 0),
        "left": disc_vertices(ijk_d[1] == 0),
        "right": disc_vertices(ijk_d[1] == disc_p.shape[1] - 1),
    }
    nr, nb, na = blade_p.shape[:3]
    j_mid, k_mid, tip_row = nb // 2, na // 2, nr - 1
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
        for end in "AB":
            got = p_unique[points[f"{kind}_{end}"][0]]
            if not np.allclose(got, arm[end], atol=1e-9):  # a meshing bug, not bad input
                raise RuntimeError(f"built-in mesh: {kind}_{end} at {got}, not {arm[end]}")
    return mesh, vertex_sets, {k: np.array(v) for k, v in points.items()}
