"""The FFTW wisdom cache (hpcgfmd.parallel.wisdom): written by a measured plan, used by the next
process (a plan with FFTW_WISDOM_ONLY, which FFTW refuses without wisdom, then succeeds),
merged over ranks, replaced when corrupt, and off on request."""

import json
import os
import platform
import shutil
import subprocess
import sys

import pytest

MPI2 = [shutil.which("mpirun") or "mpirun", "--oversubscribe", "-n", "2"]
# A fresh process plans a transform: with MEASURE through hpcgfmd (reads and writes the cache),
# or with WISDOM_ONLY after importing the cache (fails unless the cache has that size's wisdom).
PLAN = """
import sys
from mpi4py import MPI
from hpcgfmd.parallel.fft import plan_real_fft
plan_real_fft(MPI.COMM_WORLD, int(sys.argv[1]))
"""
WISDOM_ONLY = """
import sys, pyfftw
from hpcgfmd.parallel import wisdom
wisdom.load(wisdom.cache_path())
n = int(sys.argv[1])
if sys.argv[2:] == ["complex"]:  # an in-place complex FFT of length n
    a = b = pyfftw.empty_aligned(n, dtype="complex128")
else:  # an rfft of length n
    a, b = pyfftw.empty_aligned(n), pyfftw.empty_aligned(n // 2 + 1, dtype="complex128")
try:
    pyfftw.FFTW(a, b, flags=("FFTW_MEASURE", "FFTW_WISDOM_ONLY"), threads=1)
except RuntimeError:
    sys.exit(3)
"""


def python(code, *args, path, launcher=(), **env_vars):
    env = dict(
        os.environ,
        HPCGFMD_WISDOM=str(path),
        OMP_NUM_THREADS="1",
        OMPI_ALLOW_RUN_AS_ROOT="1",
        OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
        **env_vars,
    )
    return subprocess.run(
        [*launcher, sys.executable, "-c", code, *map(str, args)],
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )


def test_measured_plan_is_cached_for_the_next_process(tmp_path):
    path = tmp_path / "wisdom.json"
    assert python(WISDOM_ONLY, 3072, path=path).returncode == 3  # no wisdom: FFTW refuses
    done = python(PLAN, 3072, path=path)
    assert done.returncode == 0, done.stderr
    assert json.loads(path.read_text())["format"] == "hpcgfmd-fftw-wisdom-1"
    assert python(WISDOM_ONLY, 3072, path=path).returncode == 0
    assert python(WISDOM_ONLY, 2048, path=path).returncode == 3  # only what was planned
    # a second size is merged in, the first stays
    assert python(PLAN, 2048, path=path).returncode == 0
    assert python(WISDOM_ONLY, 2048, path=path).returncode == 0
    assert python(WISDOM_ONLY, 3072, path=path).returncode == 0


def test_corrupt_cache_is_replaced_with_a_warning(tmp_path):
    path = tmp_path / "wisdom.json"
    path.write_text("{not json")
    done = python(PLAN, 1024, path=path)
    assert done.returncode == 0, done.stderr
    assert str(path) in done.stderr and "ignoring" in done.stderr
    assert python(WISDOM_ONLY, 1024, path=path).returncode == 0


def test_default_cache_is_per_host_under_the_xdg_cache(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "HPCGFMD_WISDOM"}
    code = "from hpcgfmd.parallel import wisdom; print(wisdom.cache_path())"
    for extra, base in (
        ({"XDG_CACHE_HOME": str(tmp_path)}, tmp_path),
        ({"HOME": str(tmp_path)}, tmp_path / ".cache"),
    ):
        run_env = {k: v for k, v in env.items() if k != "XDG_CACHE_HOME"}
        run_env.update(extra)
        out = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, env=run_env, check=True
        ).stdout.strip()
        host = platform.node()
        assert out == str(base / "hpcgfmd" / f"fftw-wisdom-{host}.json")


def test_cache_off_writes_nothing(tmp_path):
    # with the cache on, this plan would write under XDG_CACHE_HOME = tmp_path
    done = python(PLAN, 1024, path="off", XDG_CACHE_HOME=str(tmp_path))
    assert done.returncode == 0, done.stderr
    assert not any(tmp_path.iterdir())


@pytest.mark.mpi
@pytest.mark.parametrize("n", [1 << 14, 2 * 3**8])
def test_plans_of_two_ranks_are_merged(tmp_path, n):
    # each rank plans transforms of its own: the halved transform (4 divides 2^14) an rfft of
    # n/2 on rank 0 and a complex FFT of n/4 on rank 1, the four-step one (2 * 3^8) its
    # strips; both ranks' wisdom lands in the file
    path = tmp_path / "wisdom.json"
    done = python(PLAN, n, path=path, launcher=MPI2)
    assert done.returncode == 0, done.stderr
    before = path.read_text()
    again = python(PLAN, n, path=path, launcher=MPI2)
    assert again.returncode == 0, again.stderr
    assert json.loads(path.read_text()) == json.loads(before)  # nothing new to add
    if n % 4 == 0:  # a fresh process plans each rank's transforms from the file alone
        # rank 0: an rfft of n/2; rank 1: an in-place complex FFT of n/4
        for args in ((n // 2,), (n // 4, "complex")):
            known = python(WISDOM_ONLY, *args, path=path)
            assert known.returncode == 0, (args, known.stderr)


def test_unwritable_cache_costs_a_warning_not_the_run(tmp_path):
    # the cache's directory cannot be made (a file stands in its way): the plan still works
    (tmp_path / "blocker").write_text("")
    done = python(PLAN, 1024, path=tmp_path / "blocker" / "wisdom.json")
    assert done.returncode == 0, done.stderr
    assert "could not write the FFTW wisdom file" in done.stderr
