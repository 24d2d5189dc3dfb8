"""Segment eigen-solve distributed over COMM_WORLD equals the serial (COMM_SELF) solve."""

import numpy as np

import wheelrom  # noqa: F401
from wheelrom import assembly, config, mesh, modes
from wheelrom._environment import petsc


def test_distributed_segment_modes_equal_serial():
    PETSc = petsc()
    cfg = config.load(overrides=['segment.preset="coarse"'])
    seg = mesh.build_builtin(cfg)
    mats = assembly.assemble(seg, 2.1e11, 0.3, 7850.0)
    par = modes.segment_modes(mats, 6, PETSc.COMM_WORLD)
    ser = modes.segment_modes(mats, 6, PETSc.COMM_SELF)
    np.testing.assert_allclose(par.eigenvalues, ser.eigenvalues, rtol=2e-8)  # EPS tol 1e-10
    # same shapes up to sign (sign fixed by the largest component)
    np.testing.assert_allclose(
        np.abs(par.vectors.T @ (mats.expand(mats.M @ ser.vectors[mats.free]))), np.eye(6), atol=1e-7
    )
