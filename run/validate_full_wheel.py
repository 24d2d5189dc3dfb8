#!/usr/bin/env python
"""Validation (not a test): the two full-wheel FE references on the whole coarse wheel.

    mpirun -n 2 .venv/bin/python run/validate_full_wheel.py [CONFIG] [--families 2]

(a) the assembled wheel (N segment copies + springs, distributed over all ranks, SLEPc) and
(b) exact cyclic symmetry per nodal diameter (rank 0); prints the largest relative
difference over the first ``families`` families of every nodal diameter, and both wall times.
With the defaults and the coarse preset: 66 x 7,251 = 478,566 DOFs for (a).
"""

from __future__ import annotations

import argparse
import json
import sys
import time

from wheelrom.runtime.environment import bootstrap

bootstrap()  # before numpy's BLAS loads: one thread per rank

import numpy as np  # noqa: E402

from wheelrom import config  # noqa: E402
from wheelrom.rom import references  # noqa: E402
from wheelrom.rom.build import build_segment  # noqa: E402
from wheelrom.runtime.environment import petsc  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("config", nargs="?")
    ap.add_argument("--set", dest="overrides", action="append",
                    default=['segment.preset="coarse"'])
    ap.add_argument("--families", type=int, default=2)
    args = ap.parse_args(argv)
    PETSc = petsc()
    comm = PETSc.COMM_WORLD
    cfg = config.load(args.config, args.overrides)
    segment = build_segment(cfg, PETSc.COMM_SELF)  # the matrices the model is built from
    seg, mats = segment.mesh, segment.matrices
    c1, N, fam = cfg.wheel.coupling_stiffness, seg.sectors, args.families
    t0 = time.perf_counter()
    assembled = np.sort(references.assembled_wheel_modes(seg, mats, c1, fam * N, comm))
    wall_a = time.perf_counter() - t0
    if comm.getRank() != 0:
        return 0
    t0 = time.perf_counter()
    table = references.cyclic_table(seg, mats, c1, fam, PETSc.COMM_SELF)
    wall_b = time.perf_counter() - t0
    cyclic = np.sort(np.concatenate(
        [table[k] if k in (0, N / 2) else np.repeat(table[k], 2) for k in range(N // 2 + 1)]
    ))[: fam * N]
    diff = float(np.abs(assembled / cyclic - 1).max())
    json.dump({"dofs_assembled": int(N * mats.free.size), "modes": fam * N,
               "max_relative_difference": diff, "assembled_wall_s": wall_a,
               "cyclic_wall_s": wall_b, "ranks": comm.getSize()}, sys.stdout, indent=1)
    print()
    return 0 if diff < 1e-6 else 1


if __name__ == "__main__":
    sys.exit(main())
