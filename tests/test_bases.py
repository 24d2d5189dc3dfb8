"""Attachment vectors: the reduced segment's static flexibility at the contact nodes equals
the FE's (they are what the contact springs load)."""

import numpy as np
import pytest

from wheelrom.rom.build import build
from wheelrom.segment.petsc import direct_solve


def _contact_rows(seg, mats, kinds):
    """``(6 K, n_free)`` unit-force vectors (x, y, z at A then B of every kind)."""
    rows = []
    for kind in kinds:
        for end in ("A", "B"):
            node = int(seg.node_sets[f"{kind}_{end}"][0])
            for c in range(3):
                force = np.zeros(seg.n_dofs)
                force[3 * node + c] = 1.0
                rows.append(force[mats.free])
    return np.array(rows)


def test_attachment_basis_has_the_fe_flexibility_at_the_contact_nodes(small_cfg, comm):
    cfg = small_cfg.replace(**{"wheel.basis": "attachment"})
    wheel = build(cfg, comm)
    seg, mats = wheel.segment.mesh, wheel.segment.matrices
    kinds = ("tieboss", "shroud")
    P = _contact_rows(seg, mats, kinds)
    fe = P @ direct_solve(mats.K, P.T, comm, "test_")  # (12, 12) [m/N]
    X = wheel.shapes[mats.free]  # segment Ritz vectors of the model
    reduced = (P @ X) @ np.linalg.solve(X.T @ (mats.K @ X), (P @ X).T)
    assert X.shape[1] == cfg.wheel.modes_per_segment + 6 * len(kinds)
    assert np.abs(reduced - fe).max() < 1e-8 * np.abs(fe).max()
    # the free-interface basis alone is far from it: the test can fail
    free = build(small_cfg, comm)
    Xf = free.shapes[mats.free]
    reduced_free = (P @ Xf) @ np.linalg.solve(Xf.T @ (mats.K @ Xf), (P @ Xf).T)
    assert np.abs(reduced_free - fe).max() > 1e-2 * np.abs(fe).max()
    # still a segment Ritz basis: M-orthonormal, K diagonal
    np.testing.assert_allclose(X.T @ (mats.M @ X), np.eye(X.shape[1]), atol=1e-10)
    KX = X.T @ (mats.K @ X)
    assert np.abs(KX - np.diag(np.diag(KX))).max() < 1e-8 * np.abs(KX).max()


def test_von_mises_of_known_states_and_a_uniform_stretch(coarse_segment):
    """Uniaxial sigma -> sigma, pure shear tau -> sqrt(3) tau; a displacement u = eps x of the
    whole mesh gives the Lame stress at every Gauss point."""
    from wheelrom.segment.prestress import gauss_stress, von_mises

    assert von_mises(np.diag([2.0, 0, 0])) == 2.0
    shear = np.zeros((3, 3))
    shear[0, 1] = shear[1, 0] = 1.0
    assert abs(von_mises(shear) - np.sqrt(3)) < 1e-15
    seg, _ = coarse_segment
    young, poisson, eps = 2.1e11, 0.3, 1e-4
    u = np.zeros(seg.n_dofs)
    u[0::3] = eps * seg.nodes[:, 0]  # eps_xx = eps
    S = gauss_stress(seg, young, poisson, u)
    lam = young * poisson / ((1 + poisson) * (1 - 2 * poisson))
    mu = young / (2 * (1 + poisson))
    expected = np.diag([lam + 2 * mu, lam, lam]) * eps
    assert np.abs(S - expected).max() < 1e-6 * np.abs(expected).max()


def test_modes_reports_the_prestress_peak_stress(small_model):
    peak = small_model.info["prestress_peak_von_mises_pa"]
    assert 1e8 < peak < 1e10  # a rotating steel disc at 3000 rpm: hundreds of MPa to GPa
    assert 0.4 <= small_model.info["prestress_peak_radius_m"] <= 2.2  # inside the wheel
    parts = [small_model.info[f"prestress_{name}_peak_pa"]
             for name in ("disc", "blade", "root_corner")]
    assert max(parts) == peak  # the three regions cover the segment


def test_builtin_wheel_would_not_burst(comm):
    """The built-in 66-blade wheel at its 3000 rpm: the disc and the blade (away from the
    singular root corner) stay below 0.8 GPa, a turbine steel's allowable; and the hub is
    what keeps the disc there: the same wheel with a uniform 0.36 m disc goes above it."""
    from dataclasses import replace

    import numpy as np

    from wheelrom.config import load
    from wheelrom.rom.build import build_segment
    from wheelrom.segment import builtin
    from wheelrom.segment.assembly import assemble
    from wheelrom.segment.prestress import prestress

    cfg = load(None, ['segment.preset="coarse"'])
    info = build_segment(cfg, comm).info
    assert info["prestress_disc_peak_pa"] < 0.8e9
    assert info["prestress_blade_peak_pa"] < 0.8e9
    assert info["prestress_disc_radius_m"] < 1.1 < info["prestress_blade_radius_m"]
    seg = builtin.build_builtin(cfg, replace(builtin.BuiltinGeometry(), hub_width=0.36))
    mats = assemble(seg, 2.1e11, 0.3, 7850.0)
    flat = prestress(seg, mats, 2.1e11, 0.3, 7850.0, 2 * np.pi * 50.0, 2e8, comm)
    assert flat.peak_where(flat.element_radius < 1.1)[0] > 0.8e9


def test_auto_flutter_mode_acts_on_that_mode_only(small_model, small_cfg):
    """flutter.mode = "auto": the Van der Pol force of a random state projects on the chosen
    segment mode only (the lowest whose aero y motion is at least half its tip motion), and
    the choice is the same in a larger and an attachment basis (the same free mode)."""
    from wheelrom.forces.parameters import flutter_mode, force_parameters
    from wheelrom.forces.reference import ReferenceForces
    from wheelrom.rom.build import build_model

    p, tip = np.abs(small_model.aero), np.linalg.norm(small_model.tip, axis=0)
    j = flutter_mode(small_model.aero, small_model.tip)
    assert p[j] >= 0.5 * tip[j] and (p[:j] < 0.5 * tip[:j]).all()
    bigger = build_model(small_cfg.replace(**{"wheel.modes_per_segment": 9,
                                              "wheel.basis": "attachment"}), _comm())
    assert flutter_mode(bigger.aero, bigger.tip) == j
    assert bigger.segment_hz[j] == pytest.approx(small_model.segment_hz[j], rel=1e-8)
    cfg = small_cfg.replace(**{"flutter.mode": "auto", "excitation.force": 0.0,
                               "contacts.tieboss.enabled": False,
                               "contacts.shroud.enabled": False})
    forces = ReferenceForces(force_parameters(small_model, cfg))
    rng = np.random.default_rng(1)
    N, m = small_model.blades, small_model.modes
    f = forces.evaluate(0.0, 1e-4 * rng.standard_normal((N, m)), rng.standard_normal((N, m)))
    others = np.delete(f, j, axis=1)
    assert np.abs(f[:, j]).max() > 0 and not others.any()
    every = ReferenceForces(force_parameters(small_model, cfg.replace(**{"flutter.mode": -1})))
    g = every.evaluate(0.0, 1e-4 * rng.standard_normal((N, m)), rng.standard_normal((N, m)))
    assert np.count_nonzero(np.abs(g).max(axis=0)) > 1  # the all-modes reading differs


def _comm():
    from wheelrom.runtime.environment import petsc

    return petsc().COMM_SELF
