"""Segment mesh export: .inp (CalculiX) and .vtu round trips through meshio; the cyclic
CalculiX deck against our exact cyclic FE (an independent FE code; ``run/setup`` installs
``ccx``)."""

import os
import re
import shutil
import subprocess

import numpy as np
import pytest

from wheelrom.segment.export import calculix_deck, write_segment


def test_inp_round_trip_nodes_elements_and_sets(coarse_cfg, coarse_segment, tmp_path):
    import meshio

    seg, _ = coarse_segment
    path = tmp_path / "seg.inp"
    written = write_segment(seg, str(path), coarse_cfg)
    assert written == [str(path), str(tmp_path / "seg_cyclic.inp")]
    back = meshio.read(path)
    np.testing.assert_allclose(back.points, seg.nodes, rtol=1e-13, atol=0)  # >= 14 digits
    assert back.cells[0].type == "hexahedron20"
    np.testing.assert_array_equal(back.cells[0].data, seg.quadratic_cells())
    for name, idx in seg.node_sets.items():
        np.testing.assert_array_equal(np.sort(back.point_sets[name.upper()]), np.sort(idx))
    # element orientation an independent FE code accepts: positive corner volumes
    c = seg.nodes[seg.quadratic_cells()[:, :8]]
    vol = np.einsum("ei,ei->e", np.cross(c[:, 1] - c[:, 0], c[:, 3] - c[:, 0]), c[:, 4] - c[:, 0])
    assert np.all(vol > 0)


def test_cyclic_deck_structure(coarse_cfg, coarse_segment):
    seg, _ = coarse_segment
    text = calculix_deck(seg, coarse_cfg, "seg.inp")
    assert "*INCLUDE, INPUT=seg.inp" in text
    for card in ("*MATERIAL", "*SOLID SECTION", "CLAMPED, 1, 3", "*CYCLIC SYMMETRY MODEL, N=66"):
        assert card in text
    # one ghost node per cut-face pair not clamped at both ends, three springs each
    clamped = set(seg.node_sets["clamped"].tolist())
    free_pairs = sum(
        not (r in clamped and l in clamped)
        for r, l in zip(seg.node_sets["right"], seg.node_sets["left"], strict=True)
    )
    springs = re.findall(
        r"\*ELEMENT, TYPE=SPRING2, ELSET=SPRING[XYZ]\n((?:\d+, \d+, \d+\n)+)", text
    )
    assert [s.count("\n") for s in springs] == [free_pairs] * 3
    stiffness = re.findall(r"\*SPRING, ELSET=SPRING[XYZ]\n(\d), (\d)\n(\S+)\n", text)
    assert [(a, b) for a, b, _ in stiffness] == [("1", "1"), ("2", "2"), ("3", "3")]
    assert all(float(k) == coarse_cfg.wheel.coupling_stiffness for *_, k in stiffness)
    # prestress on (default): linear centrifugal static step, then a perturbation step
    omega2 = (2 * np.pi * coarse_cfg.wheel.speed_hz) ** 2
    centrif = [ln for ln in text.splitlines() if "CENTRIF" in ln][0].split(",")
    assert float(centrif[2]) == omega2
    assert [float(x) for x in centrif[3:]] == [0, 0, 0, 0, 0, 1]
    assert text.index("*STATIC") < text.index("*STEP, PERTURBATION") < text.index("*FREQUENCY")
    assert "NMIN=0, NMAX=33" in text
    assert f"*FREQUENCY\n{2 * coarse_cfg.wheel.modes_per_segment}\n" in text


def _calculix_frequencies(dat: str, families: int) -> np.ndarray:
    """``(nodal diameters, families)`` [Hz] from a .dat file: CalculiX lists every eigenvalue
    of a nodal diameter twice (the real form of the complex problem); both must agree."""
    rows: dict[int, list[tuple[int, float]]] = {}
    for block in dat.split("E I G E N V A L U E   O U T P U T")[1:]:
        body = block.split("P A R T I C I P A T I O N")[0]
        for m in re.finditer(r"^\s+(\d+)\s+(\d+)\s+(\S+)\s+\S+\s+\S+\s+\S+\s*$", body, re.M):
            rows.setdefault(int(m[1]), []).append((int(m[2]), float(m[3])))
    eig = np.array([[v for _, v in sorted(rows[k])][: 2 * families] for k in sorted(rows)])
    np.testing.assert_allclose(eig[:, 0::2], eig[:, 1::2], rtol=1e-9)
    return np.sqrt(eig[:, 0::2]) / (2 * np.pi)


@pytest.mark.parametrize("prestress, nodal_diameters", [(False, (0, 2)), (True, (4, 6))])
def test_calculix_wheel_modes_match_our_cyclic_fe(
    small_cfg, comm, tmp_path, prestress, nodal_diameters
):
    """12 blades, 6 families, three nodal diameters (incl. 0 and N/2) per run, ~10 s each.
    At standstill CalculiX and our exact cyclic FE solve the same discrete problem: 1e-6.
    Prestressed, CalculiX's perturbation step adds the initial-displacement stiffness we omit
    (docs/theory.md): within 1.5 %, and the difference is really there (> 0.05 %), so a deck
    that dropped the prestress would fail."""
    from dataclasses import replace

    from wheelrom.rom.build import build_segment
    from wheelrom.rom.references import cyclic_modes

    cfg = replace(small_cfg, segment=replace(small_cfg.segment, prestress=prestress))
    segment = build_segment(cfg, comm)
    seg, m = segment.mesh, cfg.wheel.modes_per_segment
    first, last = nodal_diameters
    c1 = cfg.wheel.coupling_stiffness
    ours = np.array(
        [cyclic_modes(seg, segment.matrices, c1, k, m, comm) for k in range(first, last + 1)]
    )
    write_segment(seg, str(tmp_path / "seg.inp"))
    deck = calculix_deck(seg, cfg, "seg.inp", nodal_diameters)
    (tmp_path / "seg_cyclic.inp").write_text(deck)
    assert shutil.which("ccx"), "CalculiX (ccx) is missing: run/setup installs calculix-ccx"
    env = dict(os.environ, OMP_NUM_THREADS="1")
    run = subprocess.run(["ccx", "-i", "seg_cyclic"], cwd=tmp_path, env=env,
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-2000:]
    theirs = _calculix_frequencies((tmp_path / "seg_cyclic.dat").read_text(), m)
    assert theirs.shape == ours.shape == (last - first + 1, m)
    difference = np.abs(theirs / ours - 1)
    print(f"max |CalculiX / wheelrom - 1| = {difference.max():.2e}")
    if prestress:
        assert 5e-4 < difference.max() < 1.5e-2
    else:
        assert difference.max() < 1e-6
