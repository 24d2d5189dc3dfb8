"""Reduced model against the exact cyclic-symmetry FE of the same wheel (Ritz bounds)."""

import re

import numpy as np
import pytest

from wheelrom.rom import references
from wheelrom.rom.build import build, build_model, build_segment
from wheelrom.runtime.environment import petsc
from wheelrom.segment import mesh

SELF = petsc().COMM_SELF  # serial builds


def small_model_nd5_hz(model):
    """Lowest ND 5 frequency from the block-circulant spectrum (independent of wheel_mode)."""
    return model.frequencies_by_nodal_diameter()[5, 0]


def test_reduced_model_is_an_upper_bound_of_the_cyclic_fe(small_cfg, small_model):
    segment = build_segment(small_cfg, SELF)
    seg, mats = segment.mesh, segment.matrices
    m = small_model.modes
    progress = []
    fe = references.cyclic_table(seg, mats, small_cfg.wheel.coupling_stiffness, m, SELF,
                                 log=progress.append)
    # one line per ND with the count and the time left (modes --full-wheel on stderr), in
    # whichever of time_left's words the machine's speed gives (a slow one: minutes)
    assert len(progress) == 7
    assert all(re.fullmatch(rf"cyclic FE: ND {k} done \(\d+\.\d s\), {k + 1} of 7, "
                            r"(less than 1 s|about \d+ s|about \d+\.\d min) left", line)
               for k, line in enumerate(progress[:-1])), progress
    assert progress[-1].endswith(", 7 of 7")
    rom = small_model.frequencies_by_nodal_diameter()
    assert fe.shape == rom.shape == (small_cfg.wheel.blades // 2 + 1, m)
    # Ritz projection of the same FE for every phase: never below, family by family
    assert np.all(rom >= fe * (1 - 1e-7))
    # the blade-dominated first family is reproduced closely; the second within a few %
    err = rom / fe - 1
    assert err[:, 0].max() < 0.01
    assert err[:, 1].max() < 0.05


def test_enriched_basis_reaches_one_percent_on_two_families(small_cfg):
    """Free modes + the two lowest sector modes of ND 0, N/8, N/4, N/2: those are exact and
    the first two families within 1 % (the free basis alone misses the second by ~2 %)."""
    cfg = small_cfg.replace(**{"wheel.basis": "enriched"})  # 6 modes per part
    model = build_model(cfg, SELF)
    # m + 2 (ND 0) + 4 (ND 2, complex) + 4 (ND 3) + 2 (ND 6) = 18, dependent ones dropped
    assert 16 <= model.modes <= 18
    segment = build_segment(cfg, SELF)
    fe = references.cyclic_table(segment.mesh, segment.matrices, cfg.wheel.coupling_stiffness, 4,
                                 SELF)
    rom = model.frequencies_by_nodal_diameter()[:, :4]
    assert np.all(rom >= fe * (1 - 1e-7))
    err = rom / fe - 1
    assert err[:, :2].max() < 0.01
    # the enrichment NDs are exact for the two families taken
    np.testing.assert_allclose(rom[[0, 2, 3, 6], :2], fe[[0, 2, 3, 6], :2], rtol=1e-7)


def test_accuracy_table_reports_progress_with_time_left(small_cfg):
    from wheelrom.rom.accuracy import accuracy_table

    progress = []
    table = accuracy_table(small_cfg, SELF, modes=(6,), enriched_modes=6, families=2,
                           log=progress.append)
    assert table["reference_hz"].shape == (7, 2)
    assert list(table["bases"]) == ["free m=6", "enriched m=6", "attachment m=6"]
    per_nd = [line for line in progress if line.startswith("cyclic FE: ND ")]
    assert len(per_nd) == 7 and all(" left" in line for line in per_nd[:-1])
    assert any(line.startswith("enriched basis: 4 sector phase solves, ") and " left" in line
               for line in progress)
    # the free basis is the model's: its error is the Ritz error, never negative
    assert table["bases"]["free m=6"]["relative_error"].min() > -1e-7
    # attachment vectors only add directions: never worse than the free basis they extend
    attached = table["bases"]["attachment m=6"]
    assert attached["vectors"] == 6 + 12
    assert (attached["relative_error"] <= table["bases"]["free m=6"]["relative_error"] + 1e-9).all()
    assert attached["relative_error"].min() > -1e-7


def test_time_left_reads_well():
    assert references.time_left(0.4) == "less than 1 s left"
    assert references.time_left(42.4) == "about 42 s left"
    assert references.time_left(390) == "about 6.5 min left"


def test_wheel_mode_vtu_has_the_nodal_diameter_and_a_continuous_cut(small_cfg, tmp_path):
    import meshio

    from wheelrom.rom import wheelmesh

    wheel = build(small_cfg, SELF)
    model, seg, N = wheel.model, wheel.segment.mesh, wheel.model.blades
    path = tmp_path / "nd5.vtu"
    hz = wheelmesh.write_wheel_mode(str(path), seg, wheel.shapes, model, nd=5)
    out = meshio.read(path)
    n_nodes = seg.nodes.shape[0]
    assert out.points.shape == (N * n_nodes, 3)
    u = out.point_data["displacement"]
    assert u.shape == (N * n_nodes, 3) and np.abs(u).max() == 1.0
    assert out.cells[0].type == "hexahedron20"
    assert hz == pytest.approx(small_model_nd5_hz(model), rel=1e-12)
    # ND 5: the tip motion (in each sector's own frame) is a 5-wave around the wheel
    tip = seg.node_sets["tip"][0]
    local = np.array([
        u[s * n_nodes + tip] @ mesh.rotation_z(2 * np.pi * s / N) for s in range(N)
    ])
    spectrum = np.abs(np.fft.fft(local, axis=0)).sum(axis=1)
    assert np.argmax(spectrum[: N // 2 + 1]) == 5
    # the springs are stiff: paired cut-face nodes of neighbouring sectors move together
    right, left = seg.node_sets["right"], seg.node_sets["left"]
    gap = u[right] - u[n_nodes + left]  # sector 0 right against sector 1 left
    assert np.abs(gap).max() < 0.01


def test_accuracy_command_is_monotone_in_the_basis(capsys):
    """Nested free bases: the Ritz error can only shrink as m grows, family by family."""
    import json

    from conftest import SMALL
    from wheelrom.cli import main as cli

    argv = ["accuracy", SMALL, "--modes", "3", "6", "--enriched-modes", "3", "--families", "2"]
    assert cli.main([*argv, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    e3 = np.array(out["bases"]["free m=3"]["relative_error"])
    e6 = np.array(out["bases"]["free m=6"]["relative_error"])
    assert e3.shape == e6.shape == (7, 2)
    assert np.all(e6 >= -1e-7) and np.all(e6 <= e3 + 1e-7)
    assert out["bases"]["enriched m=3"]["vectors"] <= 3 + 12


def test_accuracy_table_with_more_families_than_vectors(small_cfg):
    """A basis of r vectors has r families: the ones beyond are NaN, not a crash."""
    from wheelrom.rom.accuracy import accuracy_table

    table = accuracy_table(small_cfg, SELF, modes=(6,), enriched_modes=6, families=8)
    free = table["bases"]["free m=6"]["relative_error"]
    assert free.shape == (7, 8) and np.isnan(free[:, 6:]).all() and np.isfinite(free[:, :6]).all()
    assert np.isfinite(table["bases"]["enriched m=6"]["relative_error"]).all()
