"""Write the segment mesh with its node sets (``wheelrom mesh --out``), for ParaView and for
checking our modes with an independent FE code (CalculiX/Abaqus).

- ``.inp``: nodes, C3D20 elements, every node set as ``*NSET``; with a
  configuration also what CalculiX needs for the same segment modal analysis: material,
  ``*SOLID SECTION``, the clamped bore as ``*BOUNDARY`` and a ``*FREQUENCY`` step for the
  ``m`` lowest modes (free cut faces, no rotation: exactly ``wheelrom modes``' segment
  problem; run ``ccx -i seg``).
- any other meshio format (``.vtu``, ``.xdmf`` ...): the mesh with one 0/1 point-data array
  per node set (``set_<name>``).
"""

from __future__ import annotations

import os

import numpy as np

from wheelrom.errors import InputError
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


def _abaqus_text(seg: SegmentMesh, cfg=None) -> str:
    """Abaqus/CalculiX input (1-based ids, explicit connectivity in Abaqus order)."""
    cells = seg.quadratic_cells()
    lines = ["*HEADING", "wheelrom segment (x radial, y tangential, z axial; m)", "*NODE"]
    lines += [f"{i + 1}, {x:.12g}, {y:.12g}, {z:.12g}" for i, (x, y, z) in enumerate(seg.nodes)]
    lines.append("*ELEMENT, TYPE=C3D20, ELSET=SEGMENT")
    for e, conn in enumerate(cells + 1):
        ids = [str(e + 1), *map(str, conn)]
        # Abaqus allows 16 entries per line; continue long element lines
        lines.append(", ".join(ids[:16]) + ("," if len(ids) > 16 else ""))
        if len(ids) > 16:
            lines.append(", ".join(ids[16:]))
    for name, idx in sorted(seg.node_sets.items()):
        lines.append(f"*NSET, NSET={name.upper()}")
        ids = [str(i + 1) for i in np.sort(idx)]
        lines += [", ".join(ids[k : k + 16]) for k in range(0, len(ids), 16)]
    if cfg is not None:
        s = cfg.segment
        lines += [
            "*MATERIAL, NAME=STEEL",
            "*ELASTIC",
            f"{s.young:.6g}, {s.poisson:.6g}",
            "*DENSITY",
            f"{s.density:.6g}",
            "*SOLID SECTION, ELSET=SEGMENT, MATERIAL=STEEL",
            "*BOUNDARY",
            "CLAMPED, 1, 3",
        ]
        m = cfg.wheel.modes_per_segment
        omega = 2 * np.pi * cfg.wheel.speed_hz
        if s.prestress and omega > 0:
            lines += [
                f"** centrifugal prestress at {cfg.wheel.speed_hz:g} Hz about z, then the modes of",
                "** the stressed segment (stress stiffening, spin softening) as a perturbation.",
                "** wheelrom closes the sector onto itself (ND 0 springs) for the static state;",
                "** here the cut faces LEFT/RIGHT are free: expect small differences in the disc.",
                "*STEP, NLGEOM",
                "*STATIC",
                "*DLOAD",
                f"SEGMENT, CENTRIF, {omega**2:.10g}, 0., 0., 0., 0., 0., 1.",
                "*END STEP",
                "*STEP, PERTURBATION",
                "*FREQUENCY",
                f"{m}",
                "*NODE FILE",
                "U",
                "*END STEP",
            ]
        else:
            lines += ["*STEP", "*FREQUENCY", f"{m}", "*NODE FILE", "U", "*END STEP"]
    return "\n".join(lines) + "\n"


def write_segment(seg: SegmentMesh, path: str, cfg=None) -> None:
    """Write ``seg`` to ``path``; the format follows the extension (see the module doc)."""
    ext = os.path.splitext(path)[1].lower()
    if ext == ".inp":
        with open(path, "w") as f:
            f.write(_abaqus_text(seg, cfg))
        return
    import meshio

    try:
        _meshio_mesh(seg, with_masks=True).write(path)
    except (KeyError, ValueError, meshio.ReadError, meshio.WriteError) as exc:
        raise InputError(f"cannot write '{path}': meshio does not know '{ext}' ({exc})") from exc
