"""The sphere on 1, 2 and 3 ranks (`mpirun -n P python -m hpcgfmd run`), and a run stopped on
one rank count and resumed on another: the same series and fields as the serial run.

At the solver's round-off floor (tolerance 1e-13) runs on different rank counts differ by
their transforms' and reductions' round-off, carried through the iterations: the bounds are
those of tests/test_distributed.py's line (assert_same there).
"""

import signal

import h5py
import numpy as np
import pytest
from test_distributed import MPIRUN, interrupt, relative, run
from test_sphere import SPHERE_CASE

pytestmark = [
    pytest.mark.mpi,
    pytest.mark.slow,
    pytest.mark.skipif(MPIRUN is None, reason="OpenMPI's mpirun is not installed"),
]
SERIES = ("time", "indenter", "load", "contact_area", "cohesive_area", "contact_line_radius")


def read(path):
    with h5py.File(path, "r") as f:
        assert f.attrs["finished"]
        series = {name: f["series"][name][:] for name in SERIES + ("iterations",)}
        fields = {name: f["snapshots"][name][:] for name in ("time", "surface", "gap")}
    return series, fields


def assert_same(reference, other):
    (s0, f0), (s1, f1) = reference, other
    for name in SERIES:
        assert s1[name].shape == s0[name].shape, name
        assert relative(s0[name], s1[name]) <= 1e-10, (name, relative(s0[name], s1[name]))
    np.testing.assert_array_equal(f1["time"], f0["time"])
    for name in ("surface", "gap"):
        assert relative(f0[name], f1[name]) <= 1e-10, name
    np.testing.assert_array_equal(f1["gap"] <= 0.0, f0["gap"] <= 0.0)  # the contact sets


@pytest.fixture(scope="module")
def serial_sphere(tmp_path_factory):
    cwd = tmp_path_factory.mktemp("sphere")
    (cwd / "case.toml").write_text(SPHERE_CASE)
    done = run(0, "run", "case.toml", "-o", "serial.h5", cwd=cwd)
    assert done.returncode == 0, done.stderr
    return read(cwd / "serial.h5")


@pytest.mark.parametrize("ranks", [1, 2, 3])
def test_sphere_same_answer_on_any_rank_count(serial_sphere, tmp_path, ranks):
    (tmp_path / "case.toml").write_text(SPHERE_CASE)
    done = run(ranks, "run", "case.toml", "-o", "out.h5", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert_same(serial_sphere, read(tmp_path / "out.h5"))


def test_sphere_stopped_on_two_ranks_resumes_on_three(serial_sphere, tmp_path):
    text = SPHERE_CASE.replace("[output]\n", "[output]\ncheckpoint_steps = 5\n")
    status, stdout, stderr = interrupt(tmp_path, 2, signal.SIGUSR1, text, delay=0.0)
    assert status == 75, (stdout, stderr)
    with h5py.File(tmp_path / "out.h5", "r") as f:
        stopped = int(f.attrs["steps_complete"]) - 1
    assert stopped < serial_sphere[0]["time"].size - 1  # stopped mid-run
    done = run(3, "run", "case.toml", "-o", "out.h5", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert f"at step {stopped} " in done.stdout
    assert_same(serial_sphere, read(tmp_path / "out.h5"))


def test_a_farm_of_sphere_cases_on_two_ranks(tmp_path):
    base = "".join(
        line.replace("[", "[base.", 1) if line.startswith("[") else line
        for line in SPHERE_CASE.splitlines(keepends=True)
    )
    (tmp_path / "sweep.toml").write_text(base + "\n[grid]\nvelocity = [0.5, 2.0]\n")
    done = run(2, "farm", "sweep.toml", "-o", "study", cwd=tmp_path, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    files = sorted((tmp_path / "study").glob("velocity_*.h5"))
    assert [f.name for f in files] == ["velocity_0.5.h5", "velocity_2.0.h5"]
    pull_offs = []
    for path in files:
        with h5py.File(path, "r") as f:
            assert f.attrs["finished"] and f.attrs["geometry"] == "sphere"
            pull_offs.append(f["series/load"][:].min())
    assert pull_offs[1] < pull_offs[0] < 0.0  # the faster retraction pulls harder
