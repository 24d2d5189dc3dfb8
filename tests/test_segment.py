"""Segment mesh and matrices against independent truth."""

import math

import numpy as np
import pytest

from wheelrom.runtime.environment import petsc
from wheelrom.segment import assembly, mesh, modes

SELF = petsc().COMM_SELF  # serial builds


def test_mass_equals_density_times_exact_volume(coarse_segment):
    seg, _ = coarse_segment
    K, M = assembly.assemble_full(seg, 2.1e11, 0.3, 7850.0)
    ex = np.tile([1.0, 0.0, 0.0], seg.n_nodes)
    assert ex @ M @ ex == pytest.approx(7850.0 * seg.info["exact_volume"], rel=1e-3)


def test_fast_assembly_equals_skfem_asm(coarse_segment):
    seg, _ = coarse_segment
    K, M = assembly.assemble_full(seg, 2.1e11, 0.3, 7850.0)
    K2, M2 = assembly.assemble_full_skfem(seg, 2.1e11, 0.3, 7850.0)
    assert abs(K - K2).max() <= 1e-12 * abs(K2).max()
    assert abs(M - M2).max() <= 1e-12 * abs(M2).max()


def test_free_free_segment_has_six_rigid_body_modes(coarse_segment):
    seg, _ = coarse_segment
    mats = assembly.assemble(seg, 2.1e11, 0.3, 7850.0, clamp=False)
    res = modes.lowest_modes(mats.K, mats.M, 8, SELF, target=-1.0, prefix="freefree_")
    lam = res.eigenvalues
    assert np.all(np.abs(lam[:6]) < 1e-6 * lam[6])
    assert lam[6] > 1.0


def test_cut_faces_pair_under_rotation_and_contacts_are_exact(coarse_segment):
    seg, _ = coarse_segment
    left, right = seg.node_sets["left"], seg.node_sets["right"]
    assert left.size == right.size > 0
    np.testing.assert_allclose(seg.nodes[left] @ seg.rotation.T, seg.nodes[right], atol=1e-12)
    for kind, l in (("tieboss", 3.1e-2), ("shroud", 3.46e-2)):
        A, B = seg.point(f"{kind}_A"), seg.point(f"{kind}_B")
        assert np.linalg.norm(B - A) == pytest.approx(l, rel=1e-12)
        a = (B - A) / np.linalg.norm(B - A)
        RA = seg.rotation @ A
        L = np.linalg.norm(RA - A)
        np.testing.assert_allclose(A + L * a, RA, atol=1e-12)  # C_s = A_{s+1}
        H = np.hypot(*((A + B) / 2)[:2])
        assert seg.info[kind]["pitch_chord"] == pytest.approx(2 * H * math.sin(math.pi / 66))


def _bar(length, width, height, n):
    """A clamped slender bar along x, meshed like the segment (hex20, same assembly)."""
    from skfem import MeshHex

    m = MeshHex.init_tensor(
        np.linspace(0, length, n + 1), np.linspace(0, width, 3), np.linspace(0, height, 3)
    )
    clamped = np.flatnonzero(m.p[0] < 1e-12)
    return mesh.with_edges(m, {"clamped": clamped}, {}, sectors=1)


def test_slender_cantilever_against_beam_theory():
    L, b, h = 2.0, 0.05, 0.02
    E, nu, rho = 2.1e11, 0.3, 7850.0
    seg = _bar(L, b, h, 40)
    mats = assembly.assemble(seg, E, nu, rho)
    res = modes.lowest_modes(mats.K, mats.M, 12, SELF, prefix="bar_")
    f = res.frequencies_hz
    # Euler-Bernoulli, first flapwise bending (thin direction h): beta1 L = 1.8751
    I = b * h**3 / 12
    f_bend = 1.87510407**2 / (2 * math.pi * L**2) * math.sqrt(E * I / (rho * b * h))
    assert f[0] == pytest.approx(f_bend, rel=0.01)
    # Saint-Venant torsion: f = (1/4L) sqrt(G J / (rho Ip)), J of a rectangle (series)
    G = E / (2 * (1 + nu))
    a_, b_ = b / 2, h / 2
    series = sum(math.tanh(k * math.pi * a_ / (2 * b_)) / k**5 for k in range(1, 40, 2))
    J = 16 * a_ * b_**3 / 3 * (1 - 192 * b_ / (math.pi**5 * a_) * series)
    Ip = b * h * (b * b + h * h) / 12
    f_tors = math.sqrt(G * J / (rho * Ip)) / (4 * L)
    closest = f[np.argmin(abs(f - f_tors))]
    assert closest == pytest.approx(f_tors, rel=0.02)


def test_segment_modes_are_mass_orthonormal(coarse_segment):
    seg, mats = coarse_segment
    res = modes.segment_modes(mats, 6, SELF)
    X = res.vectors[mats.free]
    np.testing.assert_allclose(X.T @ mats.M @ X, np.eye(6), atol=1e-8)
    KX = X.T @ mats.K @ X
    np.testing.assert_allclose(KX, np.diag(res.eigenvalues), atol=1e-8 * res.eigenvalues.max())
    assert res.residuals.max() < 1e-6
