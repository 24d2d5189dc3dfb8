"""Rotating segment: Southwell relation of a rotating cantilever, stiffening with speed."""

import math

import numpy as np
import pytest
from skfem import MeshHex

from wheelrom.runtime.environment import petsc
from wheelrom.segment import assembly, mesh, modes, prestress

SELF = petsc().COMM_SELF  # serial builds

E, NU, RHO = 2.1e11, 0.3, 7850.0


@pytest.fixture(scope="module")
def radial_bar():
    """A uniform bar along the radius x from the axis (hub radius 0), clamped at x = 0,
    thin along z: its first mode is flapwise (out of the rotation plane)."""
    L, b, h = 1.0, 0.1, 0.05
    m = MeshHex.init_tensor(
        np.linspace(0, L, 21), np.linspace(-b / 2, b / 2, 3), np.linspace(-h / 2, h / 2, 3)
    )
    seg = mesh.with_edges(m, {"clamped": np.flatnonzero(m.p[0] < 1e-12)}, {}, 1)
    return seg, assembly.assemble(seg, E, NU, RHO)


def _omegas(seg, mats, rpm):
    Om = rpm * 2 * math.pi / 60
    ps = prestress.prestress(seg, mats, E, NU, RHO, Om, 0.0, SELF)
    assert ps.residual < 1e-9
    return Om, 2 * math.pi * modes.lowest_modes(
        ps.stiffness(mats), mats.M, 2, SELF, prefix="bar_"
    ).frequencies_hz


def test_rotating_cantilever_follows_southwell(radial_bar):
    seg, mats = radial_bar
    _, w0 = _omegas(seg, mats, 0.0)
    for rpm in (1000.0, 2000.0, 3000.0):
        Om, w = _omegas(seg, mats, rpm)
        # flapwise: w^2 = w0^2 + K_s Omega^2, K_s = 1.1730 for a uniform beam, hub radius 0
        assert w[0] == pytest.approx(math.sqrt(w0[0] ** 2 + 1.1730 * Om**2), rel=0.02)
        # in-plane (lead-lag): spin softening takes Omega^2 off the coefficient
        assert w[1] == pytest.approx(math.sqrt(w0[1] ** 2 + 0.1730 * Om**2), rel=0.02)


def test_stiffening_is_monotonic_and_off_means_standstill(coarse_cfg):
    from wheelrom.rom.build import build_model

    base = coarse_cfg.replace(**{"wheel.modes_per_segment": 4})
    still = build_model(base.replace(**{"segment.prestress": False}), SELF)
    hz = [still.segment_hz]
    for speed in (25.0, 50.0):
        model = build_model(base.replace(**{"segment.prestress": True,
                                            "wheel.speed_hz": speed}), SELF)
        hz.append(model.segment_hz)
    hz = np.array(hz)
    assert np.all(np.diff(hz[:, :2], axis=0) > 0)  # blade-dominated modes stiffen with speed
    # prestress = false: exactly the standstill modes (speed does not matter)
    other = build_model(base.replace(**{"segment.prestress": False, "wheel.speed_hz": 7.0}), SELF)
    np.testing.assert_array_equal(other.segment_hz, still.segment_hz)
    np.testing.assert_array_equal(other.A0, still.A0)
