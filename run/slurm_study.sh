#!/usr/bin/env bash
# Slurm batch script: a design study map on a cluster (not run in CI), e.g. the 19 x 19
# tie-boss x shroud angle map of run/paper.toml: its linear stability, then the transients of
# the cases next to the stability boundary (docs/usage.md "Design studies").
#
#   sbatch run/slurm_study.sh [CONFIG] [OUT] [MODE]
#
# CONFIG: a TOML with a [study] section; the default is run/paper.toml with the 19 x 19 angle
# grid set below. MODE: --screen (default), --stability-only, or full (every case's transient).
# Cases are independent: every rank builds nothing but its share of the models (each model is
# built once and broadcast), analyses and integrates its cases on its own core, and all ranks
# write into one HDF5 file with the mpio driver (put OUT on a parallel file system). Results
# are bitwise the same for any number of ranks. Resubmitting the same job resumes it.
# Size (docs/performance.md, the 19 x 19 map of run/paper.toml): the stability map is 361 x
# 0.14 s of work, a 1.5 s transient ~32 s per case and core; 64 tasks: map ~10 s, screen (59
# boundary cases) ~1 min, full map (361 transients) ~3.5 min.
#SBATCH --job-name=wheelrom-study
#SBATCH --ntasks=64
#SBATCH --cpus-per-task=1
#SBATCH --time=01:00:00
#SBATCH --output=wheelrom-study-%j.log
set -euo pipefail
cd "${SLURM_SUBMIT_DIR:-$(dirname "$0")/..}"
CONFIG=${1:-run/paper.toml}
OUT=${2:-out/study-${SLURM_JOB_ID:-local}.h5}
MODE=${3:---screen}
mkdir -p "$(dirname "$OUT")"
# the venv from run/setup on a shared file system (run ./run/setup once on a login node);
# one BLAS thread per rank so that ranks do not oversubscribe the cores
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MPLBACKEND=Agg
args=(study "$CONFIG" --out "$OUT")
if [ "$CONFIG" = run/paper.toml ]; then
    args+=(--set 'study.grid={"contacts.tieboss.angle_deg"="0:90:5", "contacts.shroud.angle_deg"="0:90:5"}')
fi
if [ "$MODE" != full ]; then args+=("$MODE"); fi
if [ -f "$OUT" ]; then args+=(--resume); fi
# (srun needs Slurm built with PMIx support; otherwise use: mpirun -n "$SLURM_NTASKS")
status=0
srun --mpi=pmix .venv/bin/wheelrom "${args[@]}" || status=$?
.venv/bin/wheelrom plot "$OUT" --outdir "$(dirname "$OUT")/figures-${SLURM_JOB_ID:-local}"
exit $status
