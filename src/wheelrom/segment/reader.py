"""A user's segment mesh (``segment.source = "file"``): any quadratic volume mesh meshio reads.

Accepted: 20-node hexahedra (Abaqus C3D20, VTK ``hexahedron20``, Gmsh 20-node hex) in one or
more blocks. Node sets, case-insensitive, from (in this order):

- the file: Abaqus ``*NSET`` (meshio ``point_sets``), 0/1 point data ``set_<name>`` (what
  ``wheelrom mesh --out seg.vtu`` writes), named cell sets such as Gmsh physical groups (all
  nodes of their cells);
- the configuration: ``[segment.node_sets] name = [[x, y, z], ...]``, each point the nearest
  node within ``segment.node_set_tolerance`` (farther: an error naming the set and distance).

Required: ``clamped``, ``left``, ``right``, ``excitation``, ``aero``, ``tip`` and, per enabled
contact kind, ``<kind>_A`` and ``<kind>_B`` (one node each). ``left``/``right`` must pair node
by node under the sector rotation. The geometry is taken straight-sided (mid-side nodes at edge
midpoints, as in the built-in mesh); curved mid-side nodes are reported in ``info``.
"""

from __future__ import annotations

import contextlib
import io
import os

import numpy as np

from wheelrom.config import Config
from wheelrom.config.values import beside_toml
from wheelrom.runtime.errors import InputError
from wheelrom.segment.mesh import (
    HEX20_EDGES,
    REQUIRED_SETS,
    SegmentMesh,
    arm_report,
    edge_nodes,
    pair_cut_faces,
    with_edges,
)


def source_path(cfg: Config) -> str:
    """``segment.source`` resolved against the configuration file's directory (as every file
    key is, ``--set`` overrides included)."""
    return beside_toml(cfg.segment.source, cfg.source)


def read_segment(cfg: Config) -> SegmentMesh:
    """The segment mesh of ``segment.source`` with its node sets (see the module doc)."""
    import meshio
    from skfem.io.meshio import from_meshio

    path = source_path(cfg)
    if not os.path.exists(path):
        raise InputError(f"segment.source: mesh file '{path}' not found")
    if not os.path.isfile(path):  # a FIFO, a device or a directory: read forever, or never
        raise InputError(f"segment.source: '{path}' is not a regular file (a directory, a "
                         "device or a FIFO); name a mesh file")
    said = io.StringIO()
    try:
        with contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
            raw = meshio.read(path)
    except Exception as exc:  # meshio raises many types; the message names the file
        raise InputError(f"segment.source: cannot read '{path}' ({exc})") from exc
    except SystemExit:  # some meshio readers print and call sys.exit on a garbage file
        why = " ".join(said.getvalue().split()) or "meshio gave up"
        raise InputError(f"segment.source: cannot read '{path}' ({why})") from None
    _check_points(raw.points, path)
    blocks = [b.data for b in raw.cells if b.type == "hexahedron20"]
    if not blocks:
        found = sorted({b.type for b in raw.cells}) or ["no cells"]
        raise InputError(
            f"segment.source '{path}': no 20-node hexahedra (found: {', '.join(found)}); "
            "wheelrom needs a quadratic volume mesh (C3D20 / hexahedron20)"
        )
    cells = np.vstack(blocks).astype(np.int64)
    corners_user = cells[:, :8]
    vertex_ids = np.unique(corners_user)
    to_vertex = np.full(raw.points.shape[0], -1, dtype=np.int64)
    to_vertex[vertex_ids] = np.arange(vertex_ids.size)
    linear = meshio.Mesh(raw.points[vertex_ids], [("hexahedron", to_vertex[corners_user])])
    mesh = from_meshio(linear)
    seg = with_edges(mesh, {}, {}, cfg.wheel.blades)
    # user node id -> our node index (corners and mid-side nodes)
    user_to_ours = np.full(raw.points.shape[0], -1, dtype=np.int64)
    user_to_ours[vertex_ids] = np.arange(vertex_ids.size)
    corners = to_vertex[corners_user]
    for e, (i, j) in enumerate(HEX20_EDGES):
        user_to_ours[cells[:, 8 + e]] = edge_nodes(seg, corners[:, i], corners[:, j])
    used = np.flatnonzero(user_to_ours >= 0)
    offset = np.linalg.norm(raw.points[used] - seg.nodes[user_to_ours[used]], axis=1).max()
    seg.info["source"] = path
    seg.info["curved_midside_max_offset_m"] = float(offset)

    sets = _file_sets(raw, user_to_ours)
    sets.update(_coordinate_sets(cfg, seg))
    seg.node_sets.update(sets)
    _check_required(cfg, seg, path)
    pair_cut_faces(seg)
    seg.info.update(arm_report(seg, cfg))
    return seg


def _check_points(points: np.ndarray, path: str) -> None:
    """There are nodes, in three dimensions, and every node's coordinates are finite numbers
    (a NaN one broke the node-set search)."""
    shape = np.shape(points)
    if len(shape) != 2 or shape[0] == 0 or shape[1] != 3:
        raise InputError(f"segment.source '{path}': no nodes with x, y, z coordinates (meshio "
                         f"read {shape[0] if shape else 0} node(s)); a volume mesh?")
    bad = np.flatnonzero(~np.isfinite(np.asarray(points, dtype=float)).all(axis=1))
    if bad.size:
        raise InputError(f"segment.source '{path}': node {bad[0] + 1} (in file order) has a "
                         f"coordinate that is not a finite number {list(points[bad[0]])}"
                         + (f", and {bad.size - 1} more node(s)" if bad.size > 1 else ""))


def _file_sets(raw, user_to_ours: np.ndarray) -> dict[str, np.ndarray]:
    def mapped(ids, name):
        ids = np.asarray(ids, dtype=np.int64).ravel()
        ours = user_to_ours[ids]
        if np.any(ours < 0):
            raise InputError(
                f"node set '{name}': {int((ours < 0).sum())} node(s) are not nodes of any "
                "20-node hexahedron of the mesh"
            )
        return np.unique(ours)

    sets = {}
    for name, ids in getattr(raw, "point_sets", {}).items():
        sets[name.lower()] = mapped(ids, name)
    for key, values in raw.point_data.items():
        if key.startswith("set_"):
            sets[key[4:].lower()] = mapped(np.flatnonzero(np.asarray(values) != 0), key[4:])
    for name, per_block in getattr(raw, "cell_sets", {}).items():
        nodes = [
            np.asarray(raw.cells[b].data)[np.asarray(idx, dtype=np.int64)].ravel()
            for b, idx in enumerate(per_block)
            if idx is not None and len(idx) and raw.cells[b].type != "hexahedron20"
        ]
        if nodes and name.lower() not in sets:
            sets[name.lower()] = mapped(np.concatenate(nodes), name)
    return sets


def _coordinate_sets(cfg: Config, seg: SegmentMesh) -> dict[str, np.ndarray]:
    from scipy.spatial import cKDTree

    tree = cKDTree(seg.nodes)
    tol = cfg.segment.node_set_tolerance
    out = {}
    for name, points in cfg.segment.node_sets.items():
        dist, idx = tree.query(np.asarray(points, dtype=float))
        far = np.flatnonzero(dist > tol)
        if far.size:
            k = far[0]
            raise InputError(
                f"segment.node_sets.{name}: point {list(points[k])} is {dist[k]:.3g} m from the "
                f"nearest node (segment.node_set_tolerance = {tol:g} m)"
            )
        out[name.lower()] = np.unique(idx)
    return out


def _check_required(cfg: Config, seg: SegmentMesh, path: str) -> None:
    import difflib

    need = list(REQUIRED_SETS)
    for kind in cfg.contacts.enabled_kinds():
        need += [f"{kind}_A", f"{kind}_B"]
    # contact sets are stored with their canonical case
    for name in list(seg.node_sets):
        for want in need:
            if name == want.lower() and name != want:
                seg.node_sets[want] = seg.node_sets.pop(name)
    missing = [n for n in need if n not in seg.node_sets or seg.node_sets[n].size == 0]
    if missing:
        have = sorted(seg.node_sets)
        hints = []
        for n in missing:
            close = difflib.get_close_matches(n, have, n=1)
            hints.append(f"'{n}'" + (f" (did you mean '{close[0]}'?)" if close else ""))
        raise InputError(
            f"segment.source '{path}': node set(s) {', '.join(hints)} missing; the file and "
            f"[segment.node_sets] define: {', '.join(have) or 'none'}"
        )
