"""Whole-wheel mesh and wheel mode shapes for ParaView (paper Fig. 9).

The wheel is ``N`` copies of the segment, copy ``s`` rotated by ``2 pi s / N`` about ``z``
(cut-face nodes of neighbouring copies coincide and are kept twice: the model joins them by
springs, not by shared nodes). A wheel mode of ``K_R`` (``N m`` modal coordinates) becomes
the displacement ``u(s) = R_z(2 pi s/N) X q_s`` in the global frame.
"""

from __future__ import annotations

import numpy as np

from wheelrom.rom.model import ReducedModel, wheel_eigenpairs
from wheelrom.segment.mesh import SegmentMesh, rotation_z


def wheel_points(seg: SegmentMesh) -> np.ndarray:
    """``(N n_nodes, 3)`` node coordinates of the whole wheel [m]."""
    N = seg.sectors
    return np.concatenate([seg.nodes @ rotation_z(2 * np.pi * s / N).T for s in range(N)])


def wheel_mode(model: ReducedModel, nd: int, family: int = 0):
    """A wheel mode of nodal diameter ``nd``: ``(frequency [Hz], q (N, m))``.

    ``family`` counts the modes of that nodal diameter from the lowest (0). Of a degenerate
    pair the first (standing) eigenvector is taken.
    """
    lam, shapes, nds = wheel_eigenpairs(model)
    N = model.blades
    picks = np.flatnonzero(nds == nd)
    if nd > N // 2 or picks.size == 0:
        raise ValueError(f"no wheel mode with nodal diameter {nd} (N = {N})")
    seen, previous = -1, None
    for i in picks:  # skip the second member of each degenerate pair
        if previous is not None and abs(lam[i] - lam[previous]) < 1e-8 * abs(lam[i]):
            previous = i
            continue
        seen += 1
        previous = i
        if seen == family:
            return float(np.sqrt(max(lam[i], 0.0)) / (2 * np.pi)), shapes[i]
    raise ValueError(f"nodal diameter {nd} has only {seen + 1} mode families")


def mode_displacement(seg: SegmentMesh, shapes: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``(N n_nodes, 3)`` global displacement of modal coordinates ``q`` ``(N, m)``;
    ``shapes``: the segment basis on the full DOFs ``(3 n_nodes, m)``."""
    N = seg.sectors
    n_nodes = seg.nodes.shape[0]
    out = []
    for s in range(N):
        local = (shapes @ q[s]).reshape(n_nodes, 3)
        out.append(local @ rotation_z(2 * np.pi * s / N).T)
    return np.concatenate(out)


def write_wheel_mode(path: str, seg: SegmentMesh, shapes: np.ndarray, model: ReducedModel,
                     nd: int, family: int = 0) -> float:
    """Write the whole wheel with the mode's displacement as point data (any meshio format,
    e.g. ``.vtu``); returns the mode's frequency [Hz]."""
    import meshio

    hz, q = wheel_mode(model, nd, family)
    u = mode_displacement(seg, shapes, q)
    u /= np.abs(u).max()  # unit largest component: scale freely in ParaView (Warp By Vector)
    cells = seg.quadratic_cells()
    n_nodes = seg.nodes.shape[0]
    conn = np.concatenate([cells + s * n_nodes for s in range(seg.sectors)])
    blade = np.repeat(np.arange(seg.sectors), cells.shape[0])
    mesh = meshio.Mesh(
        wheel_points(seg),
        [("hexahedron20", conn)],
        point_data={"displacement": u},
        cell_data={"sector": [blade]},
        field_data={"frequency_hz": np.array([hz]), "nodal_diameter": np.array([nd])},
    )
    mesh.write(path)
    return hz
