"""Cyclic modal synthesis against the block-circulant identity and limiting cases."""

import numpy as np
import pytest

from wheelrom.rom import model as rom
from wheelrom.runtime.environment import petsc

SELF = petsc().COMM_SELF  # serial builds


def test_reduced_stiffness_symmetric_and_block_circulant(coarse_model):
    K = coarse_model.dense_stiffness()
    np.testing.assert_allclose(K, K.T, atol=1e-12 * abs(K).max())
    lam = np.sort(np.linalg.eigvalsh(K))
    per_nd = np.sort(coarse_model.block_circulant_eigenvalues().ravel())
    np.testing.assert_allclose(per_nd, lam, rtol=1e-8)


def test_petsc_baij_matches_dense(coarse_model):
    A = coarse_model.petsc_stiffness(SELF)
    assert A.getType() == "seqbaij" and A.getBlockSize() == coarse_model.modes
    x, y = A.createVecs()
    rng = np.random.default_rng(1)
    xv = rng.normal(size=coarse_model.size)
    x.setArray(xv)
    A.mult(x, y)
    ref = coarse_model.dense_stiffness() @ xv
    np.testing.assert_allclose(y.getArray(), ref, rtol=1e-12, atol=1e-12 * abs(ref).max())


def test_uncoupled_wheel_repeats_segment_frequencies(coarse_cfg, coarse_segment):
    from wheelrom.segment import modes

    seg, mats = coarse_segment
    cfg = coarse_cfg.replace(**{"wheel.coupling_stiffness": 0.0, "wheel.blades": 66})
    eig = modes.segment_modes(mats, 4, SELF)
    model = rom.reduce(seg, eig.vectors, np.diag(eig.eigenvalues), cfg)
    hz, nd, kind = rom.wheel_modes(model)
    expect = np.repeat(eig.frequencies_hz, 66)
    np.testing.assert_allclose(hz, expect, rtol=1e-10)


def test_rigid_rotation_gives_zero_spring_gap(coarse_segment):
    """A rigid rotation of the wheel about z: gap R u_left(s+1) - u_right(s) vanishes."""
    seg, _ = coarse_segment
    ez = np.array([0.0, 0.0, 1.0])
    u_left = np.cross(ez, seg.nodes[seg.node_sets["left"]])  # every sector, own frame
    u_right = np.cross(ez, seg.nodes[seg.node_sets["right"]])
    gap = u_left @ seg.rotation.T - u_right
    assert abs(gap).max() < 1e-12
    wrong = u_left @ seg.rotation - u_right  # R^T instead of R: does not vanish
    assert abs(wrong).max() > 1e-3


def test_nodal_diameters_of_wheel_modes(coarse_model):
    hz, nd, kind = rom.wheel_modes(coarse_model)
    table = coarse_model.frequencies_by_nodal_diameter()
    for k in (0, 2, 5, 33):
        f = table[k, 0]
        i = np.argmin(abs(hz - f))
        assert nd[i] == k
        assert kind[i] == ("standing" if k in (0, 33) else "pair")
    assert np.sum(nd == 0) == coarse_model.modes
    assert np.sum(nd == 5) == 2 * coarse_model.modes


@pytest.mark.parametrize("k", [1, 7])
def test_travelling_wave_is_eigenvector(coarse_model, k):
    N, _m = coarse_model.blades, coarse_model.modes
    ph = np.exp(2j * np.pi * k / N)
    H = coarse_model.A0 + coarse_model.A1 * ph + coarse_model.A1.T * np.conj(ph)
    lam, v = np.linalg.eigh(H)
    wave = (np.exp(2j * np.pi * k * np.arange(N) / N)[:, None] * v[:, 0]).ravel()
    K = coarse_model.dense_stiffness()
    np.testing.assert_allclose(K @ wave, lam[0] * wave, atol=1e-8 * abs(lam).max())
