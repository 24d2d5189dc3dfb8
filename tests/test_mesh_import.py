"""User segment meshes: .inp/.vtu round trips equal the built-in segment; clear input errors."""

import re

import numpy as np
import pytest

from wheelrom.runtime.environment import petsc
from wheelrom.runtime.errors import InputError
from wheelrom.segment import assembly, builtin, modes
from wheelrom.segment.export import write_segment
from wheelrom.segment.load import load_segment

SELF = petsc().COMM_SELF  # serial builds


@pytest.fixture(scope="module")
def exported(tmp_path_factory, coarse_cfg):
    seg = builtin.build_builtin(coarse_cfg)
    d = tmp_path_factory.mktemp("mesh")
    write_segment(seg, str(d / "seg.inp"), coarse_cfg)
    write_segment(seg, str(d / "seg.vtu"))
    return seg, d


def _user_cfg(coarse_cfg, path, *extra):
    return coarse_cfg.replace(**{"segment.source": str(path), **dict(extra)})


@pytest.mark.parametrize("name", ["seg.inp", "seg.vtu"])
def test_round_trip_gives_the_builtin_segment(coarse_cfg, exported, name):
    seg, d = exported
    user = load_segment(_user_cfg(coarse_cfg, d / name))
    np.testing.assert_allclose(user.nodes, seg.nodes, atol=1e-10)
    np.testing.assert_array_equal(user.quadratic_cells(), seg.quadratic_cells())
    for key, nodes in seg.node_sets.items():
        np.testing.assert_array_equal(user.node_sets[key], nodes)


def test_user_mesh_modes_equal_builtin_modes(coarse_cfg, coarse_segment, exported):
    _, d = exported
    ref_seg, ref_mats = coarse_segment
    user = load_segment(_user_cfg(coarse_cfg, d / "seg.inp"))
    mats = assembly.assemble(user, 2.1e11, 0.3, 7850.0)
    a = modes.segment_modes(mats, 4, SELF).frequencies_hz
    b = modes.segment_modes(ref_mats, 4, SELF).frequencies_hz
    np.testing.assert_allclose(a, b, rtol=1e-9)


def _edited(d, old, new, count=1):
    text = (d / "seg.inp").read_text()
    assert old in text
    path = d / f"edited_{abs(hash((old, new)))}.inp"
    path.write_text(text.replace(old, new, count))
    return path


def test_misspelt_set_is_named_with_a_suggestion(coarse_cfg, exported):
    _, d = exported
    path = _edited(d, "*NSET, NSET=TIP\n", "*NSET, NSET=TIPP\n")
    with pytest.raises(InputError, match=r"'tip' \(did you mean 'tipp'\?\) missing"):
        load_segment(_user_cfg(coarse_cfg, path))


def test_unpaired_cut_face_node_is_reported(coarse_cfg, exported):
    seg, d = exported
    text = (d / "seg.inp").read_text()
    block = re.search(r"\*NSET, NSET=LEFT\n(.*?)\n\*", text, re.S).group(1)
    first = block.split(",")[0].strip()
    path = _edited(d, f"*NSET, NSET=LEFT\n{first}, ", "*NSET, NSET=LEFT\n")
    with pytest.raises(InputError, match="'right'.*no partner in 'left'|do not pair"):
        load_segment(_user_cfg(coarse_cfg, path))


def test_node_sets_by_coordinates(coarse_cfg, exported):
    seg, d = exported
    tip = seg.nodes[seg.node_sets["tip"][0]]
    path = _edited(d, "*NSET, NSET=TIP\n", "*NSET, NSET=IGNORED\n")
    near = (tip + [0.0, 0.0, 2e-4]).tolist()
    user = load_segment(_user_cfg(coarse_cfg, path, ("segment.node_sets", {"tip": [near]})))
    np.testing.assert_array_equal(user.node_sets["tip"], seg.node_sets["tip"])
    far = (tip + [0.0, 0.0, 0.05]).tolist()
    with pytest.raises(InputError, match=r"segment.node_sets.tip: point .* m from the nearest"):
        load_segment(_user_cfg(coarse_cfg, path, ("segment.node_sets", {"tip": [far]})))


def test_linear_or_missing_meshes_are_clear_errors(coarse_cfg, exported, tmp_path):
    import meshio

    seg, _ = exported
    lin = tmp_path / "linear.vtu"
    meshio.Mesh(seg.nodes, [("hexahedron", seg.quadratic_cells()[:, :8])]).write(lin)
    with pytest.raises(InputError, match="no 20-node hexahedra.*hexahedron"):
        load_segment(_user_cfg(coarse_cfg, lin))
    with pytest.raises(InputError, match="not found"):
        load_segment(_user_cfg(coarse_cfg, tmp_path / "nope.inp"))
