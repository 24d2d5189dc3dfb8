#!/usr/bin/env python
"""The friction damper's design curve as a benchmark (issue #45: the design curve over 20
preloads in at most 3 minutes under ``mpirun -n 2``): the two studies of docs/results.md,
timed whole, under ``mpirun -n 2``, H = 3:

- ``both_laws``: ``run/study_damper.toml`` as it is (both contact laws, ten shroud preloads
  25 N - 12.8 kN: twenty cases);
- ``elastic_20``: the elastic law alone at twenty preloads spaced evenly in the logarithm
  over the same range (the study file with that grid, written under ``out/``).

Prints one JSON object: per study the wall time [s], the cases, the frequencies solved of
all, the case times [s] and the smallest peak (its preload [N], tip amplitude [m] and
frequency [Hz]).

    .venv/bin/python run/bench_damper.py [--harmonics 3] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1", "MPLBACKEND": "Agg"}
PRELOADS_20 = np.geomspace(25.0, 12800.0, 20)


def elastic_20(out: Path) -> Path:
    """``run/study_damper.toml`` with the elastic law alone over :data:`PRELOADS_20`."""
    text = (ROOT / "run" / "study_damper.toml").read_text()
    head = text[: text.index("[study.grid]")]
    grid = ", ".join(f"{p:.1f}" for p in PRELOADS_20)
    path = out / "bench-damper-elastic-20.toml"
    path.write_text(head + '[study.grid]\ncontacts.law = ["elastic"]\n'
                    f"contacts.shroud.normal_preload = [{grid}]\n")
    return path


def timed_study(config: Path, result: Path, harmonics: int) -> dict:
    """One design study under ``mpirun -n 2``, timed; its figures from the HDF5 file."""
    command = ["mpirun", "-n", "2", str(ROOT / ".venv" / "bin" / "wheelrom"), "study",
               str(config), "--stability-only", "--forced-nonlinear", "--set",
               f"forced.harmonics={harmonics}", "--out", str(result), "--force"]
    start = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL,
                   env={**os.environ, **MPI_ENV})
    wall = time.perf_counter() - start
    with h5py.File(result, "r") as f:
        g = f["forced_nonlinear"]
        peaks = g["peak_amplitude"][...]
        best = int(np.nanargmin(peaks))
        values = f["cases/parameters/values"][...]
        names = [n.decode() if isinstance(n, bytes) else str(n)
                 for n in f["cases/parameters/names"][...]]
        preload = float(values[best, names.index("contacts.shroud.normal_preload")])
        return {"wall_s": wall, "cases": int(peaks.size),
                "frequencies_solved": int(g["converged"][...].sum()),
                "frequencies": int(g["converged"][...].size),
                "case_wall_s": np.round(g["wall_s"][...], 1).tolist(),
                "smallest_peak": {"case": best, "preload_n": preload,
                                  "tip_amplitude_m": float(peaks[best]),
                                  "frequency_hz": float(g["peak_frequency_hz"][best])}}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--harmonics", type=int, default=3)
    ap.add_argument("--json", action="store_true", help="print the JSON object only")
    args = ap.parse_args(argv)
    out = ROOT / "out"
    out.mkdir(exist_ok=True)
    figures = {"harmonics": args.harmonics}
    for name, config in (("both_laws", ROOT / "run" / "study_damper.toml"),
                         ("elastic_20", elastic_20(out))):
        figures[name] = timed_study(config, out / f"bench-damper-{name}.h5", args.harmonics)
        if not args.json:
            f = figures[name]
            print(f"{name}: {f['cases']} cases in {f['wall_s']:.0f} s under mpirun -n 2, "
                  f"{f['frequencies_solved']} of {f['frequencies']} frequencies solved",
                  file=sys.stderr)
    print(json.dumps(figures))
    return 0


if __name__ == "__main__":
    sys.exit(main())
