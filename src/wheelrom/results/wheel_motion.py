"""The whole wheel in motion, from a results file's modal state history (``wheelrom
animate``): the segment and its basis rebuilt from the file's configuration through the one
pipeline (:func:`wheelrom.rom.build.build`, deterministic: the mode signs are fixed), checked
against the stored reduced model, and the displacement ``u(s) = R_z(2 pi s / N) Xb q_s`` of
every blade on the segment's boundary faces (corner nodes: the surface only, so a frame of
the 66-blade wheel is a few megabytes), written as XDMF (one mesh, one displacement field per
time step, heavy data in an HDF5 file beside it) for ParaView.
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
from dataclasses import dataclass

import numpy as np

from wheelrom.results.layout import read_config
from wheelrom.rom.build import WheelBuild, build, quiet
from wheelrom.rom.model import rows_at
from wheelrom.runtime.errors import InputError
from wheelrom.segment.mesh import SegmentMesh, corner_cells, rotation_z

#: largest relative difference of the rebuilt reduced model from the stored one
TOLERANCE = 1e-10
# corner positions of the six faces of a hexahedron (VTK order), outward normals
HEX_FACES = ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7))


def rebuild(f, path: str, comm, log=quiet) -> WheelBuild:
    """The segment, basis and reduced model of the results file ``f`` (at ``path``) rebuilt
    from its configuration; refused (one line) when the rebuilt ``A0``, ``A1`` or tip shape
    differ from the stored ``/model`` by more than :data:`TOLERANCE` (relative)."""
    wheel = build(read_config(f, path), comm, log)
    model = wheel.model
    for name, ours in (("A0", model.A0), ("A1", model.A1), ("tip", model.tip)):
        stored = f[f"model/{name}"][()]
        if stored.shape != ours.shape:
            raise InputError(f"{path}: the model rebuilt from the file's configuration has "
                             f"{name} of shape {ours.shape}, the file {stored.shape}")
        scale = max(float(np.abs(stored).max()), np.finfo(float).tiny)
        error = float(np.abs(ours - stored).max()) / scale
        if not error <= TOLERANCE:
            raise InputError(
                f"{path}: the model rebuilt from the file's configuration differs from the "
                f"stored /model/{name} (relative {error:.1e} > {TOLERANCE:g}): the segment or "
                "the code changed since the file was written, so its shapes cannot be "
                "reconstructed")
    return wheel


def boundary_quads(seg: SegmentMesh) -> np.ndarray:
    """``(F, 4)`` corner nodes of the hexahedron faces on the segment's boundary (faces
    that belong to one element only)."""
    cells = corner_cells(seg)
    faces = cells[:, np.array(HEX_FACES)].reshape(-1, 4)
    key = np.sort(faces, axis=1)
    _, index, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    return faces[np.sort(index[counts == 1])]


@dataclass
class WheelSurface:
    """The wheel's boundary surface: ``N`` rotated copies of the segment's boundary faces.

    ``points`` ``(N P, 3)`` undeformed [m] (global frame; copy ``s`` holds points
    ``s P .. (s+1) P - 1``); ``quads`` ``(N F, 4)``; ``nodes`` ``(P,)`` the segment node of
    each point of a copy; ``shapes`` ``(P, 3, m)`` displacement per modal coordinate in the
    sector frame; ``rotations`` ``(N, 3, 3)`` ``R_z(2 pi s / N)``.
    """

    points: np.ndarray
    quads: np.ndarray
    nodes: np.ndarray
    shapes: np.ndarray
    rotations: np.ndarray

    @property
    def blades(self) -> int:
        return self.rotations.shape[0]

    def displacement(self, q: np.ndarray) -> np.ndarray:
        """``(N P, 3)`` global displacement [m] of modal coordinates ``q`` ``(N, m)``."""
        local = np.einsum("pam,sm->spa", self.shapes, q)
        return np.einsum("sba,spa->spb", self.rotations, local).reshape(-1, 3)


def wheel_surface(seg: SegmentMesh, shapes: np.ndarray) -> WheelSurface:
    """The :class:`WheelSurface` of segment ``seg`` with basis ``shapes`` ``(n_dofs, m)``."""
    faces = boundary_quads(seg)
    nodes, local = np.unique(faces, return_inverse=True)
    local = local.reshape(faces.shape)
    N, P = seg.sectors, nodes.size
    rotations = np.array([rotation_z(2.0 * math.pi * s / N) for s in range(N)])
    points = np.concatenate([seg.nodes[nodes] @ R.T for R in rotations])
    quads = np.concatenate([local + s * P for s in range(N)])
    return WheelSurface(points, quads, nodes, rows_at(shapes, nodes), rotations)


def _xdmf_text(h5_name: str, points: int, quads: int, times) -> str:
    """The XDMF 3 XML of a surface with one displacement field per time step."""

    def item(dataset, dims, kind="Float"):
        return (f'<DataItem DataType="{kind}" Dimensions="{dims}" Format="HDF" '
                f'Precision="8">{h5_name}:/{dataset}</DataItem>')

    mesh = (f'<Geometry GeometryType="XYZ">{item("points", f"{points} 3")}</Geometry>'
            f'<Topology TopologyType="Quadrilateral" NumberOfElements="{quads}">'
            f'{item("quads", f"{quads} 4", "Int")}</Topology>')
    steps = "".join(
        f'<Grid Name="step{k}" GridType="Uniform">{mesh}<Time Value="{t!r}"/>'
        f'<Attribute Name="displacement" AttributeType="Vector" Center="Node">'
        f'{item(f"displacement/{k}", f"{points} 3")}</Attribute></Grid>\n'
        for k, t in enumerate(times)
    )
    return ('<?xml version="1.0"?>\n<Xdmf Version="3.0"><Domain>\n'
            f'<Grid Name="wheel" GridType="Uniform">{mesh}</Grid>\n'
            '<Grid Name="motion" GridType="Collection" CollectionType="Temporal">\n'
            f'{steps}</Grid></Domain></Xdmf>\n')


def xdmf_paths(prefix: str) -> list[str]:
    """``PREFIX.xdmf`` and the HDF5 file of its arrays, ``PREFIX.h5``."""
    return [f"{prefix}.xdmf", f"{prefix}.h5"]


def write_xdmf(prefix: str, surface: WheelSurface, times: np.ndarray,
               q: np.ndarray) -> list[str]:
    """``PREFIX.xdmf`` + ``PREFIX.h5``: the wheel surface and its displacement [m] at
    ``times`` ``(S,)`` from the modal displacements ``q`` ``(S, N, m)``. Both are written in
    a hidden directory beside them and moved into place when complete."""
    import h5py

    paths = xdmf_paths(prefix)
    folder = os.path.dirname(os.path.abspath(paths[0]))
    work = tempfile.mkdtemp(prefix=f".{os.path.basename(prefix)}.partial", dir=folder)
    try:
        names = [os.path.join(work, os.path.basename(p)) for p in paths]
        with h5py.File(names[1], "w") as h5:
            h5["points"], h5["quads"] = surface.points, surface.quads.astype(np.int64)
            for k in range(len(times)):
                h5[f"displacement/{k}"] = surface.displacement(q[k])
        with open(names[0], "w") as fh:
            fh.write(_xdmf_text(os.path.basename(paths[1]), surface.points.shape[0],
                                surface.quads.shape[0], [float(t) for t in times]))
        for name, path in zip(names[::-1], paths[::-1], strict=True):
            os.replace(name, path)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return paths
