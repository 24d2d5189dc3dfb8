"""The assembled stability Jacobian solved by SLEPc distributed over COMM_WORLD has the
eigenvalues of the per-ND blocks (every rank builds the small model and the Jacobian)."""

from wheelrom.runtime.environment import bootstrap, petsc

bootstrap()  # one BLAS thread per rank, before numpy loads

import os  # noqa: E402

import numpy as np  # noqa: E402

from wheelrom import config  # noqa: E402
from wheelrom.analysis.stability import analyse, rightmost_eigenvalues  # noqa: E402
from wheelrom.rom.build import build_model  # noqa: E402

SMALL = os.path.join(os.path.dirname(os.path.dirname(__file__)), "data", "small.toml")


def test_distributed_rightmost_eigenvalues_equal_the_nd_blocks():
    PETSc = petsc()
    assert PETSc.COMM_WORLD.getSize() == 2
    cfg = config.load(SMALL)
    model = build_model(cfg, PETSc.COMM_SELF)
    res = analyse(model, cfg, {"shroud": 50.0}, keep_jacobian=True)
    reference = rightmost_eigenvalues(res.jacobian, PETSc.COMM_WORLD, nev=12)
    both = np.concatenate([res.eigenvalue, res.eigenvalue.conj()])
    for value in reference:
        assert np.min(np.abs(both - value)) < 1e-8 * abs(value)
    assert abs(reference.real.max() - res.growth_rate.max()) < 1e-8 * res.growth_rate.max()
