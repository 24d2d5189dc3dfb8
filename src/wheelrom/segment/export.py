"""Write the segment mesh with its node sets (``wheelrom mesh --out``), for ParaView and for
checking our modes with an independent FE code (CalculiX).

- ``seg.inp``: nodes, C3D20 elements, every node set as ``*NSET`` (what ``segment.source``
  reads back: a template for a user's own mesh). With a configuration also
  ``seg_cyclic.inp``, a CalculiX deck that includes ``seg.inp`` and computes the *wheel* modes
  of ``wheelrom modes --full-wheel`` per nodal diameter: cyclic symmetry with the cut-face
  springs ``c1`` (ghost nodes tied to ``left`` in the next sector, three ``SPRING2`` elements
  per pair to ``right``), the clamped bore and, with prestress, CalculiX's own centrifugal
  static step followed by a perturbation frequency step (``cd dir && ccx -i seg_cyclic``).
  docs/theory.md ("Checking against CalculiX") gives the agreement.
- any other meshio format (``.vtu``, ``.xdmf`` ...): the mesh with one 0/1 point-data array
  per node set (``set_<name>``).
"""

from __future__ import annotations

import os

import numpy as np

from wheelrom.runtime.errors import InputError
from wheelrom.runtime.outputs import replacing
from wheelrom.segment.mesh import SegmentMesh


def _meshio_mesh(seg: SegmentMesh, with_masks: bool):
    import meshio

    cells = seg.quadratic_cells()
    point_data = {}
    if with_masks:
        for name, idx in seg.node_sets.items():
            mask = np.zeros(seg.nodes.shape[0], dtype=np.int32)
            mask[idx] = 1
            point_data[f"set_{name}"] = mask
    return meshio.Mesh(seg.nodes, [("hexahedron20", cells)], point_data=point_data)


def _real(x: float) -> str:
    """``x`` in at most 20 characters (a CalculiX field) with at least 14 significant digits:
    node coordinates rounded to 12 digits move the cut faces apart by more than the tie's
    position tolerance allows on a large wheel."""
    text = repr(float(x))
    return text if len(text) <= 20 else f"{x:.13e}"


def _id_lines(ids) -> list[str]:
    """1-based ids, 16 per line (the Abaqus/CalculiX limit)."""
    ids = [str(i) for i in ids]
    return [", ".join(ids[k : k + 16]) for k in range(0, len(ids), 16)]


def mesh_text(seg: SegmentMesh) -> str:
    """The mesh part of an Abaqus/CalculiX deck: ``*NODE``, C3D20 ``*ELEMENT`` (Abaqus node
    order, ELSET ``SEGMENT``) and one ``*NSET`` per node set (upper case), 1-based ids."""
    lines = ["*NODE"]
    lines += [
        f"{i + 1}, {_real(x)}, {_real(y)}, {_real(z)}" for i, (x, y, z) in enumerate(seg.nodes)
    ]
    lines.append("*ELEMENT, TYPE=C3D20, ELSET=SEGMENT")
    for e, conn in enumerate(seg.quadratic_cells() + 1):
        ids = [str(e + 1), *map(str, conn)]
        # at most 16 entries per line: continue the 21-entry element lines
        lines += [", ".join(ids[:16]) + ",", ", ".join(ids[16:])]
    for name, idx in sorted(seg.node_sets.items()):
        lines.append(f"*NSET, NSET={name.upper()}")
        lines += _id_lines(np.sort(idx) + 1)
    return "\n".join(lines) + "\n"


def _cyclic_coupling(seg: SegmentMesh, pairs, c1: float) -> list[str]:
    """Ghost nodes at the ``right`` nodes of ``pairs`` (right, left), SPRING2 elements of
    stiffness ``c1`` [N/m] in x, y, z to ``right``, and the cyclic tie ghost <- ``left``."""
    ghosts = seg.nodes.shape[0] + 1 + np.arange(len(pairs))  # 1-based, after the segment's
    lines = ["** ghost nodes: the image of LEFT in the next sector, at the RIGHT nodes", "*NODE"]
    lines += [
        f"{g}, {_real(x)}, {_real(y)}, {_real(z)}"
        for g, (right, _) in zip(ghosts, pairs, strict=True)
        for x, y, z in [seg.nodes[right]]
    ]
    element = len(seg.quadratic_cells())
    for dof, axis in enumerate("XYZ", start=1):
        lines.append(f"*ELEMENT, TYPE=SPRING2, ELSET=SPRING{axis}")
        for g, (right, _) in zip(ghosts, pairs, strict=True):
            element += 1
            lines.append(f"{element}, {right + 1}, {g}")
        lines += [f"*SPRING, ELSET=SPRING{axis}", f"{dof}, {dof}", _real(c1)]
    lines += ["*NSET, NSET=CYCLIC_GHOST", *_id_lines(ghosts)]
    lines += ["*NSET, NSET=CYCLIC_LEFT", *_id_lines([left + 1 for _, left in pairs])]
    return lines + [
        "*SURFACE, NAME=GHOST_SURFACE, TYPE=NODE",
        "CYCLIC_GHOST",
        "*SURFACE, NAME=LEFT_SURFACE, TYPE=NODE",
        "CYCLIC_LEFT",
        "*TIE, NAME=CYCLIC, CYCLIC SYMMETRY, POSITION TOLERANCE=1.e-6",
        "GHOST_SURFACE, LEFT_SURFACE",
    ]


def calculix_deck(seg: SegmentMesh, cfg, mesh_file: str, nodal_diameters=None) -> str:
    """CalculiX input for the wheel modes of ``seg`` with the configuration's material,
    coupling stiffness ``wheel.coupling_stiffness`` [N/m], speed and prestress.

    ``mesh_file`` is the ``*INCLUDE``d mesh (:func:`mesh_text`); ``nodal_diameters`` an
    inclusive ``(first, last)`` range, default ``0..N//2``. CalculiX solves the real form of
    each nodal diameter's complex eigenproblem, so every frequency is listed twice: the
    ``*FREQUENCY`` card asks for ``2 m`` to give the ``m = wheel.modes_per_segment`` families.

    The springs ``1/2 c1 |R u_left(s+1) - u_right(s)|^2`` of docs/theory.md are realised with
    ghost nodes at the ``right`` nodes' positions, made the image of ``left`` in the next
    sector by a cyclic-symmetry ``*TIE`` (dependent ghost, independent ``left``), and joined
    to ``right`` by ``SPRING2`` elements of stiffness ``c1`` in x, y and z. Pairs clamped at
    both ends are left out: their springs do nothing and a tied node must not be fixed."""
    s, w = cfg.segment, cfg.wheel
    sectors = seg.sectors
    first, last = nodal_diameters if nodal_diameters is not None else (0, sectors // 2)
    clamped = set(seg.node_sets["clamped"].tolist())
    pairs = [
        (right, left)
        for right, left in zip(seg.node_sets["right"], seg.node_sets["left"], strict=True)
        if not (right in clamped and left in clamped)
    ]
    lines = [
        "*HEADING",
        f"wheelrom segment of a {sectors}-blade wheel: cyclic symmetry, cut-face springs (m)",
        f"*INCLUDE, INPUT={mesh_file}",
        *_cyclic_coupling(seg, pairs, w.coupling_stiffness),
        f"*CYCLIC SYMMETRY MODEL, N={sectors}, NGRAPH=1, TIE=CYCLIC",
        "0., 0., 0., 0., 0., 1.",
        "*MATERIAL, NAME=STEEL",
        "*ELASTIC",
        f"{_real(s.young)}, {_real(s.poisson)}",
        "*DENSITY",
        _real(s.density),
        "*SOLID SECTION, ELSET=SEGMENT, MATERIAL=STEEL",
        "*BOUNDARY",
        "CLAMPED, 1, 3",
    ]
    frequency = [
        "*FREQUENCY",
        f"{2 * w.modes_per_segment}",
        f"*SELECT CYCLIC SYMMETRY MODES, NMIN={first}, NMAX={last}",
        "*NODE FILE",
        "U",
        "*END STEP",
    ]
    omega = 2 * np.pi * w.speed_hz
    if s.prestress and omega > 0:
        lines += [
            f"** centrifugal state at {w.speed_hz:g} Hz about z (linear, the sector closed onto",
            "** itself through the ND 0 tie), then the modes with stress stiffening and spin",
            "** softening; CalculiX adds the initial-displacement stiffness, which wheelrom",
            "** omits (docs/theory.md: up to 1.2 % on the coarse preset)",
            "*STEP",
            "*STATIC",
            "*DLOAD",
            f"SEGMENT, CENTRIF, {_real(omega**2)}, 0., 0., 0., 0., 0., 1.",
            "*END STEP",
            "*STEP, PERTURBATION",
            *frequency,
        ]
    else:
        lines += ["*STEP", *frequency]
    return "\n".join(lines) + "\n"


def cyclic_deck_path(path: str) -> str:
    """``dir/seg.inp`` -> ``dir/seg_cyclic.inp``: where :func:`write_segment` puts the deck."""
    stem, ext = os.path.splitext(path)
    return f"{stem}_cyclic{ext}"


def write_segment(seg: SegmentMesh, path: str, cfg=None) -> list[str]:
    """Write ``seg`` to ``path`` (the format follows the extension, see the module doc); an
    ``.inp`` with a configuration also gets the CalculiX deck. Returns the paths written."""
    ext = os.path.splitext(path)[1].lower()
    if ext == ".inp":
        with replacing(path) as partial, open(partial, "w") as f:
            # a comment, not *HEADING: the cyclic deck includes this file and has its own
            f.write("** wheelrom segment (x radial, y tangential, z axial; m)\n")
            f.write(mesh_text(seg))
        if cfg is None:
            return [path]
        deck = cyclic_deck_path(path)
        with replacing(deck) as partial, open(partial, "w") as f:
            f.write(calculix_deck(seg, cfg, os.path.basename(path)))
        return [path, deck]
    import meshio

    try:
        if ext == ".xdmf":  # its heavy data file is named after it: no temporary name
            _meshio_mesh(seg, with_masks=True).write(path)
        else:
            with replacing(path) as partial:
                _meshio_mesh(seg, with_masks=True).write(partial)
    except (KeyError, ValueError, meshio.ReadError, meshio.WriteError) as exc:
        raise InputError(f"cannot write '{path}': meshio does not know '{ext}' ({exc})") from exc
    return [path]
