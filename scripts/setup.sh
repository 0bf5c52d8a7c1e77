#!/usr/bin/env bash
# Idempotent set-up for a fresh Debian 12 machine (as root, or with sudo for apt):
# OpenMPI, parallel HDF5 and SLURM (for the job script tests) from apt, a virtual environment
# in .venv, h5py built against parallel HDF5 (h5py.get_config().mpi is True), and hpcgfmd.
# Each step is skipped when what it provides is already there, so repeating is cheap.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="${HPCGFMD_VENV:-$repo/.venv}"
python="${PYTHON:-python3}"

# slurm-wlm munge: a private single-node SLURM 22.05 for tests/test_slurm.py (the jobs/ scripts);
# the tests start their own daemons, so the packages' system services are not used.
apt_packages=(openmpi-bin libopenmpi-dev libhdf5-openmpi-dev pkg-config python3-venv python3-dev gcc
              slurm-wlm munge)
missing=()
for p in "${apt_packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: apt-get install ${missing[*]}"
  sudo_cmd=""; [ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq "${missing[@]}" >/dev/null
fi

if [ ! -x "$venv/bin/python" ]; then
  echo "setup: creating virtual environment $venv"
  "$python" -m venv "$venv"
fi
vpy="$venv/bin/python"
pip_q() { "$vpy" -m pip install -q --disable-pip-version-check "$@"; }

if ! "$vpy" -c 'import h5py, sys; sys.exit(0 if h5py.get_config().mpi else 1)' 2>/dev/null; then
  echo "setup: building h5py against parallel HDF5 (about 3 minutes)"
  pip_q "setuptools>=77" wheel cython pkgconfig numpy mpi4py
  "$vpy" -m pip uninstall -q -y h5py 2>/dev/null || true
  CC=mpicc HDF5_MPI=ON HDF5_DIR=/usr/lib/x86_64-linux-gnu/hdf5/openmpi \
    "$vpy" -m pip install -q --disable-pip-version-check --no-binary=h5py --no-build-isolation h5py
fi

# The package and its remaining dependencies (extras: test, plot). The stamp holds a hash of
# pyproject.toml so a changed dependency list triggers a reinstall.
stamp="$venv/.hpcgfmd-installed"
want="$(sha256sum "$repo/pyproject.toml" | cut -d' ' -f1)"
if [ "$(cat "$stamp" 2>/dev/null || true)" != "$want" ] || ! "$vpy" -c 'import hpcgfmd' 2>/dev/null; then
  echo "setup: installing hpcgfmd and its dependencies"
  pip_q -e "$repo[test,plot]"
  echo "$want" > "$stamp"
fi
"$vpy" -c 'import h5py, sys; sys.exit(0 if h5py.get_config().mpi else "setup: h5py has no MPI support")'
# Compile the solver's kernels once into numba's cache (a few seconds), so that no run pays it.
"$vpy" -c "from hpcgfmd.solvers.kernels import compile_all; compile_all()"
