#!/usr/bin/env bash
# The main job: set up what is missing (scripts/setup.sh), then run the embedded default case.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$repo/scripts/setup.sh"
exec "${HPCGFMD_VENV:-$repo/.venv}/bin/python" -m hpcgfmd "$@"
