#!/usr/bin/env bash
# The test suite: set up what is missing (scripts/setup.sh), then serial pytest with the given
# pytest arguments. Without a path among them (a file or directory, or a node id such as
# tests/test_result_file.py::name, relative to the repository) the whole of tests/ is run.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$repo/scripts/setup.sh"
export OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}" OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}"
cd "$repo"
paths=(tests)
skip_value=0
for arg in "$@"; do
  if [ "$skip_value" -eq 1 ]; then skip_value=0; continue; fi
  case "$arg" in
    # options whose value is the next argument: that value is not a path to test
    -k|-m|-p|-o|-c|-W|--deselect|--ignore|--ignore-glob|--basetemp|--rootdir|--confcutdir|\
    --junit-xml|--junitxml|--durations|--maxfail|--tb|-r)
      skip_value=1 ;;
    -*) ;;
    *) if [ -e "${arg%%::*}" ]; then paths=(); break; fi ;;
  esac
done
exec "${HPCGFMD_VENV:-$repo/.venv}/bin/python" -m pytest -q "${paths[@]}" "$@"
