"""Contact stiffness from the segment FE: beam theory, reciprocity, the k_c composition."""

import math

import numpy as np
import pytest
from skfem import MeshHex

from wheelrom import config
from wheelrom.runtime.environment import petsc
from wheelrom.segment import assembly, mesh
from wheelrom.segment import contact_stiffness as stiffness

SELF = petsc().COMM_SELF  # serial builds


def _bar_with_tip_points(L, b, h, n):
    m = MeshHex.init_tensor(
        np.linspace(0, L, n + 1), np.linspace(-b / 2, b / 2, 3), np.linspace(-h / 2, h / 2, 3)
    )
    clamped = np.flatnonzero(m.p[0] < 1e-12)
    tip = np.flatnonzero(np.linalg.norm(m.p.T - [L, 0, 0], axis=1) < 1e-12)
    mid = np.flatnonzero(np.linalg.norm(m.p.T - [L / 2, 0, 0], axis=1) < 1e-12)
    sets = {"clamped": clamped, "bar_A": mid, "bar_B": tip}
    return mesh.with_edges(m, sets, {}, sectors=1)


def test_flexibility_of_a_cantilever_matches_beam_theory():
    L, b, h, E, nu = 2.0, 0.05, 0.02, 2.1e11, 0.3
    seg = _bar_with_tip_points(L, b, h, 40)
    mats = assembly.assemble(seg, E, nu, 7850.0)
    radius = {"bar": 0.6 * math.hypot(b, h)}  # the whole end face / mid section
    flex = stiffness.flexibility(seg, mats, ["bar"], {"bar": 0.1}, radius, SELF)["bar"]
    G = flex.G
    Iz, Iy = b * h**3 / 12, h * b**3 / 12  # bending about y (deflection z) / about z
    # tip (B) under a tip load, Euler-Bernoulli L^3 / 3EI; mid (A) under a tip load
    # (L/2)^2 (3L - L/2) / 6EI; axial L / EA
    assert G[5, 5] == pytest.approx(L**3 / (3 * E * Iz), rel=0.02)
    assert G[4, 4] == pytest.approx(L**3 / (3 * E * Iy), rel=0.02)
    assert G[2, 5] == pytest.approx((L / 2) ** 2 * (3 * L - L / 2) / (6 * E * Iz), rel=0.02)
    assert G[3, 3] == pytest.approx(L / (E * b * h), rel=0.02)
    assert flex.reciprocity_error < 1e-8  # Maxwell-Betti: G_AB = G_BA^T
    assert np.all(np.linalg.eigvalsh(G) > 0)


def test_contact_stiffness_composition_in_series(coarse_cfg, coarse_segment):
    seg, mats = coarse_segment
    tables = stiffness.stiffness_tables(coarse_cfg, seg, mats, ["shroud"], SELF)
    angles, k, flex = tables["shroud"]
    assert angles[0] == 0 and angles[-1] == 90
    assert np.all(np.isfinite(k)) and np.all(k > 0)
    # a rigid arm support cannot make the contact stiffer than the arm alone, and a softer
    # arm makes it softer everywhere the normal has a component along the arm
    k_arm = coarse_cfg.contacts.shroud.arm_axial_stiffness
    along = np.abs(np.stack([np.zeros_like(angles), np.cos(np.radians(angles)),
                             np.sin(np.radians(angles))], axis=1) @ flex.arm_direction)
    assert np.all(k <= k_arm / np.maximum(along**2, 1e-300) * (1 + 1e-12))
    soft = flex.stiffness(angles, k_arm / 100)
    assert np.all(soft[along > 0.1] < k[along > 0.1])
    # the blade part alone: c_A + c_C from G directly, by loading A and the arm end
    b = math.radians(30.0)
    n = np.array([0.0, math.cos(b), math.sin(b)])
    a = flex.arm_direction
    S = flex.arm_length / flex.point_distance * (np.eye(3) - np.outer(a, a))
    load_C = np.concatenate([n - S @ n, S @ n])  # forces on A and B from a unit force at C
    c_C = load_C @ flex.G @ load_C
    nA = flex.rotation.T @ n
    c_A = nA @ flex.G[:3, :3] @ nA
    expected = 1 / (c_A + c_C + (n @ a) ** 2 / k_arm)
    assert flex.stiffness(30.0, k_arm)[0] == pytest.approx(expected, rel=1e-12)


def test_fe_stiffness_reaches_the_force_model(coarse_cfg):
    from wheelrom.forces.parameters import force_parameters
    from wheelrom.rom.build import build_model

    cfg = coarse_cfg.replace(**{"contacts.shroud.stiffness": "fe", "wheel.modes_per_segment": 4})
    model = build_model(cfg, SELF)
    table = model.contact_stiffness["shroud"]
    assert "tieboss" not in model.contact_stiffness  # that kind keeps its number
    contacts = force_parameters(model, cfg, {"shroud": 42.5}).contacts
    i = contacts.kinds.index("shroud")
    k40, k45 = table[8, 1], table[9, 1]
    assert contacts.stiffness[i, 0] == pytest.approx(
        math.exp(0.5 * (math.log(k40) + math.log(k45))))
    assert contacts.stiffness[contacts.kinds.index("tieboss"), 0] == (
        cfg.contacts.tieboss.stiffness)


def test_contact_stiffness_command_prints_the_table_the_model_uses(capsys):
    """The command and the model take k_c from the same (prestressed) segment matrices; the
    standstill segment would give a different table (so this comparison can fail)."""
    import json

    from conftest import SMALL
    from wheelrom.cli import main as cli
    from wheelrom.rom.build import build_model

    sets = ["--set", 'contacts.shroud.stiffness="fe"', "--set", 'contacts.tieboss.stiffness="fe"']
    assert cli.main(["contact-stiffness", SMALL, *sets, "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    cfg = config.load(SMALL, [s for s in sets if s != "--set"])
    model = build_model(cfg, SELF)
    for kind in ("tieboss", "shroud"):
        table = model.contact_stiffness[kind]
        np.testing.assert_array_equal(printed[kind]["angle_deg"], table[:, 0])
        np.testing.assert_allclose(printed[kind]["fe_stiffness_n_per_m"], table[:, 1], rtol=1e-12)
    still = build_model(cfg.replace(**{"segment.prestress": False}), SELF)
    assert np.abs(still.contact_stiffness["shroud"][:, 1] / model.contact_stiffness["shroud"][:, 1]
                  - 1).max() > 1e-3
