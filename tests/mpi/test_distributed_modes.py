"""Segment eigen-solve distributed over COMM_WORLD equals the serial (COMM_SELF) solve."""

from wheelrom.runtime.environment import bootstrap, petsc

bootstrap()  # one BLAS thread per rank, before numpy loads

import numpy as np  # noqa: E402

from wheelrom import config  # noqa: E402
from wheelrom.segment import assembly, builtin, modes  # noqa: E402


def test_distributed_segment_modes_equal_serial():
    PETSc = petsc()
    cfg = config.load(overrides=['segment.preset="coarse"'])
    seg = builtin.build_builtin(cfg)
    mats = assembly.assemble(seg, 2.1e11, 0.3, 7850.0)
    par = modes.segment_modes(mats, 6, PETSc.COMM_WORLD)
    ser = modes.segment_modes(mats, 6, PETSc.COMM_SELF)
    np.testing.assert_allclose(par.eigenvalues, ser.eigenvalues, rtol=2e-8)  # EPS tol 1e-10
    # same shapes up to sign (sign fixed by the largest component)
    np.testing.assert_allclose(
        np.abs(par.vectors.T @ (mats.expand(mats.M @ ser.vectors[mats.free]))), np.eye(6), atol=1e-7
    )
