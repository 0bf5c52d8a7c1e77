#!/usr/bin/env bash
# The whole test suite: set up what is missing (scripts/setup.sh), then serial pytest.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$repo/scripts/setup.sh"
export OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}" OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}"
cd "$repo"
exec "${HPCGFMD_VENV:-$repo/.venv}/bin/python" -m pytest -q tests "$@"
