#!/usr/bin/env bash
# The main job: set up what is missing (scripts/setup.sh), then run the embedded default case
# on HPCGFMD_RANKS MPI ranks (default 2): mpirun -n 2 python -m hpcgfmd.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$repo/scripts/setup.sh"
export OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}" OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}"
ranks="${HPCGFMD_RANKS:-2}"
launcher=(mpirun -n "$ranks")
if [ "$ranks" -gt "$(nproc)" ]; then launcher+=(--oversubscribe); fi
if [ "$(id -u)" = 0 ]; then  # OpenMPI refuses root unless told
    export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
fi
exec "${launcher[@]}" "${HPCGFMD_VENV:-$repo/.venv}/bin/python" -m hpcgfmd "$@"
