#!/usr/bin/env bash
# Slurm batch script: the paper's angle sweep on a cluster (not run in CI).
#
#   sbatch run/slurm_sweep.sh [CONFIG] [OUT]
#
# One MPI rank per case is the natural size (19 cases for run/paper.toml); the model is built
# once on rank 0 and broadcast, each rank integrates its cases on its own TS, and all ranks
# write into one HDF5 file with the mpio driver (put OUT on a parallel file system).
# Resubmitting the same job resumes it: finished cases are kept, pending ones are run.
# For segments too large for one node's memory add  --model-comm world  (distributed SLEPc).
#SBATCH --job-name=wheelrom-sweep
#SBATCH --ntasks=19
#SBATCH --cpus-per-task=1
#SBATCH --time=00:30:00
#SBATCH --output=wheelrom-sweep-%j.log
set -euo pipefail
cd "${SLURM_SUBMIT_DIR:-$(dirname "$0")/..}"
CONFIG=${1:-run/paper.toml}
OUT=${2:-out/sweep-${SLURM_JOB_ID:-local}.h5}
mkdir -p "$(dirname "$OUT")"
# the venv from run/setup on a shared file system (run ./run/setup once on a login node);
# one BLAS thread per rank so that ranks do not oversubscribe the cores
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MPLBACKEND=Agg
resume=""
if [ -f "$OUT" ]; then resume="--resume"; fi
# (srun needs Slurm built with PMIx support; otherwise use: mpirun -n "$SLURM_NTASKS")
status=0
srun --mpi=pmix .venv/bin/wheelrom sweep "$CONFIG" --out "$OUT" $resume || status=$?
.venv/bin/wheelrom plot "$OUT" --outdir "$(dirname "$OUT")/figures-${SLURM_JOB_ID:-local}"
exit $status
