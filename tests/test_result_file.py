"""The result file (hpcgfmd.storage.result_file, the HDF5 output of a run) on one rank
(COMM_SELF), and the parallel check tests/mpi/check_result_file.py under mpirun."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from cases import case_text, physical_text
from hpcgfmd.case import parse_case
from hpcgfmd.parallel.domain import Domain
from hpcgfmd.storage.reader import read_series
from hpcgfmd.storage.result_file import SERIES, SERIES_UNITS, ResultFile

COMM = MPI.COMM_SELF
CASE_TEXT = case_text("nx = 64", maugis=1.0, modulus_ratio=1.0)


PHYSICAL_TEXT = physical_text(
    "nx = 1024", relaxation_time="2.0", interaction_range="1e-6", depth="3e-5", cell_length="2e-3"
)


@pytest.fixture
def case():
    return parse_case(CASE_TEXT)


def grid(case):
    n = case.numerics.nx
    return n, (np.arange(n) - n // 2) * case.cell / n


def domain(case):
    """The one-rank grid of ``case``."""
    n = case.numerics.nx
    return Domain(COMM, n, case.cell, [(0, n)])


def values(k):
    return {name: (k + 1 if name == "iterations" else 1.5 * k + j) for j, name in enumerate(SERIES)}


def fields(x, s):
    return np.sin(x + s), np.cos(x) * s, x + s


@pytest.mark.parametrize("text", [CASE_TEXT, PHYSICAL_TEXT], ids=["case", "physical"])
def test_result_file_round_trip(tmp_path, text):
    case = parse_case(text)
    u = case.units
    scale = {"time": u.time, "length": u.length, "load": u.load, None: 1.0}
    n, x = grid(case)
    path = tmp_path / "case.h5"
    out = ResultFile(path, case, domain(case), COMM)
    for k in range(3):
        out.append_step(values(k))
    out.add_snapshot(0.5, *fields(x, 1))
    series = read_series(path)  # readable while open and unfinished
    assert series.attrs["finished"] is False and len(series.time) == 3
    out.finish({"steps": 2, "wall_time": 1.25})
    out.close()
    series = read_series(path)
    assert series.attrs["finished"] is True and series.attrs["steps"] == 2
    assert series.attrs["steps_complete"] == 3 and series.attrs["nx"] == n
    for name in SERIES:
        want = [values(k)[name] * scale[SERIES_UNITS[name]] for k in range(3)]
        assert np.array_equal(getattr(series, name), want)
    assert series.iterations.dtype == np.int64
    with h5py.File(path, "r") as f:
        snaps = f["snapshots"]
        assert snaps.attrs["complete"] == 1 and np.array_equal(snaps["x"][()], x * u.length)
        assert np.array_equal(snaps["time"][()], [0.5 * u.time])
        for name, want, unit in zip(
            ("surface", "pressure", "gap"), fields(x, 1), (u.length, u.stress, u.length)
        ):
            assert np.array_equal(snaps[name][()], [want * unit])
    with pytest.raises(FileExistsError):
        ResultFile(path, case, domain(case), COMM)
    ResultFile(path, case, domain(case), COMM, overwrite=True).close()
    assert len(read_series(path).time) == 0


def test_reopen_truncates(tmp_path, case):
    n, x = grid(case)
    path = tmp_path / "case.h5"
    out = ResultFile(path, case, domain(case), COMM)
    for k in range(5):
        out.append_step(values(k))
        if k in (0, 3):
            out.add_snapshot(k, *fields(x, k))
    out.finish({"steps": 4})
    out.close()
    with pytest.raises(ValueError, match="cannot resume"):
        ResultFile.reopen(path, case, domain(case), COMM, steps=6, snapshots=1)
    out = ResultFile.reopen(path, case, domain(case), COMM, steps=3, snapshots=1)
    assert read_series(path).attrs["finished"] is False
    out.append_step(values(10))
    out.add_snapshot(9.0, *fields(x, 9))
    out.close()
    series = read_series(path)
    assert series.attrs["steps_complete"] == 4 and series.attrs["finished"] is False
    assert np.array_equal(series.load, [values(k)["load"] for k in (0, 1, 2, 10)])
    with h5py.File(path, "r") as f:
        snaps = f["snapshots"]
        assert snaps.attrs["complete"] == 2 and snaps["gap"].shape == (2, n)
        assert np.array_equal(snaps["time"][()], [0.0, 9.0])
        assert np.array_equal(snaps["surface"][()], [fields(x, 0)[0], fields(x, 9)[0]])
        assert f["series/time"].shape == (4,)


@pytest.mark.mpi
@pytest.mark.parametrize("args", [["-n", "2"], ["--oversubscribe", "-n", "3"]])
def test_parallel_result_file(tmp_path, args):
    mpirun = shutil.which("mpirun")
    if mpirun is None:
        pytest.skip("no mpirun")
    # Should pytest itself run under an MPI launcher, keep its variables out of the new job.
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_", "PRTE_"))}
    env.update(
        OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OPENBLAS_NUM_THREADS="1"
    )
    script = Path(__file__).parent / "mpi" / "check_result_file.py"
    run = subprocess.run(
        [mpirun, *args, sys.executable, str(script), str(tmp_path)],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 0, run.stdout + run.stderr
