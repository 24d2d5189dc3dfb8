"""Segment mesh export: .inp (CalculiX) and .vtu round trips through meshio."""

import numpy as np
import pytest

from wheelrom.segment.export import write_segment


def test_inp_round_trip_nodes_elements_and_sets(coarse_cfg, coarse_segment, tmp_path):
    import meshio

    seg, _ = coarse_segment
    path = tmp_path / "seg.inp"
    write_segment(seg, str(path), coarse_cfg)
    back = meshio.read(path)
    np.testing.assert_allclose(back.points, seg.nodes, rtol=0, atol=1e-11)
    assert back.cells[0].type == "hexahedron20"
    np.testing.assert_array_equal(back.cells[0].data, seg.quadratic_cells())
    for name, idx in seg.node_sets.items():
        np.testing.assert_array_equal(np.sort(back.point_sets[name.upper()]), np.sort(idx))
    text = path.read_text()
    for card in ("*MATERIAL", "*SOLID SECTION", "*BOUNDARY", "*FREQUENCY"):
        assert card in text
    assert "CLAMPED, 1, 3" in text
    # prestress on (default): centrifugal static step, then a perturbation frequency step
    omega2 = (2 * np.pi * coarse_cfg.wheel.speed_hz) ** 2
    centrif = [ln for ln in text.splitlines() if "CENTRIF" in ln][0].split(",")
    assert float(centrif[2]) == pytest.approx(omega2, rel=1e-9)
    assert [float(x) for x in centrif[3:]] == [0, 0, 0, 0, 0, 1]
    assert text.index("*STATIC") < text.index("*STEP, PERTURBATION") < text.index("*FREQUENCY")
    # element orientation an independent FE code accepts: positive corner volumes
    c = seg.nodes[seg.quadratic_cells()[:, :8]]
    vol = np.einsum("ei,ei->e", np.cross(c[:, 1] - c[:, 0], c[:, 3] - c[:, 0]), c[:, 4] - c[:, 0])
    assert np.all(vol > 0)


def test_vtu_carries_node_sets_as_point_data(coarse_segment, tmp_path):
    import meshio

    seg, _ = coarse_segment
    path = tmp_path / "seg.vtu"
    write_segment(seg, str(path))
    back = meshio.read(path)
    for name, idx in seg.node_sets.items():
        assert np.flatnonzero(back.point_data[f"set_{name}"]).tolist() == sorted(idx.tolist())


def test_unknown_format_is_a_clear_error(coarse_segment, tmp_path):
    from wheelrom.errors import InputError

    seg, _ = coarse_segment
    with pytest.raises(InputError, match="seg.nope"):
        write_segment(seg, str(tmp_path / "seg.nope"))
