"""Full-wheel FE references under mpirun -n 2: (a) the assembled wheel of N segment copies,
distributed over COMM_WORLD, equals (b) exact cyclic symmetry on one sector."""

import os

from wheelrom.runtime.environment import bootstrap, petsc

bootstrap()  # one BLAS thread per rank, before numpy loads

import numpy as np  # noqa: E402

from wheelrom import config  # noqa: E402
from wheelrom.rom import references  # noqa: E402
from wheelrom.rom.build import build_segment  # noqa: E402

SMALL = os.path.join(os.path.dirname(os.path.dirname(__file__)), "data", "small.toml")


def test_assembled_wheel_equals_exact_cyclic_symmetry():
    PETSc = petsc()
    cfg = config.load(SMALL)
    segment = build_segment(cfg, PETSc.COMM_SELF)
    seg, mats = segment.mesh, segment.matrices
    c1 = cfg.wheel.coupling_stiffness
    N = seg.sectors
    nev = N + 2  # the whole first family and the start of the second
    assembled = np.sort(references.assembled_wheel_modes(seg, mats, c1, nev, PETSc.COMM_WORLD))
    table = references.cyclic_table(seg, mats, c1, 2, PETSc.COMM_SELF)
    # ND 0 and N/2 are single, the others double (travelling pairs)
    cyclic = np.concatenate(
        [table[k] if k in (0, N // 2) else np.repeat(table[k], 2) for k in range(N // 2 + 1)]
    )
    cyclic = np.sort(cyclic)[:nev]
    np.testing.assert_allclose(assembled, cyclic, rtol=1e-8)
    assert cyclic[N - 1] < cyclic[N]  # the first family is complete and separated
