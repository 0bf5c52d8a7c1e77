"""Checkpoint files (hpcgfmd.storage.checkpoint) on one rank (COMM_SELF): round trip, other
files refused, atomic replacement; and the parallel check tests/mpi/check_checkpoint.py
under mpirun."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from cases import case_text
from hpcgfmd.case import parse_case
from hpcgfmd.parallel.domain import Domain
from hpcgfmd.storage import checkpoint as ckpt
from hpcgfmd.storage.checkpoint import (
    checkpoint_path,
    read_checkpoint,
    remove_checkpoint,
    write_checkpoint,
)
from hpcgfmd.storage.result_file import ResultFile

COMM = MPI.COMM_SELF
CASE_TEXT = case_text("nx = 64", maugis=1.0, modulus_ratio=1.0)


def state(n):
    rng = np.random.default_rng(3)
    return (
        {"u": rng.standard_normal(n), "traction": rng.standard_normal(n)},
        {
            "step": 17,
            "time": 4.25,
            "config": CASE_TEXT,
            "flag": False,
            "times": np.array([0.5, 1.0, 2.0]),
        },
    )


def test_checkpoint_round_trip(tmp_path):
    assert checkpoint_path(tmp_path / "run.h5") == str(tmp_path / "run.checkpoint.h5")
    path = checkpoint_path(tmp_path / "run.h5")
    fields_in, attrs_in = state(50)
    write_checkpoint(path, COMM, 50, 0, fields_in, attrs_in)
    fields_out, attrs_out = read_checkpoint(path, COMM, 0, 50)
    assert fields_out.keys() == fields_in.keys()
    for name in fields_in:
        assert fields_out[name].dtype == np.float64
        assert np.array_equal(fields_out[name], fields_in[name])
    assert attrs_out.keys() == attrs_in.keys()
    for key, value in attrs_in.items():
        if isinstance(value, np.ndarray):
            assert np.array_equal(attrs_out[key], value)
        else:
            assert type(attrs_out[key]) is type(value) and attrs_out[key] == value
    part, _ = read_checkpoint(path, COMM, 20, 20)  # an empty block
    assert all(block.shape == (0,) for block in part.values())
    part, _ = read_checkpoint(path, COMM, 10, 30)
    assert np.array_equal(part["u"], fields_in["u"][10:30])
    with pytest.raises(ValueError, match="outside"):
        read_checkpoint(path, COMM, 10, 51)
    with pytest.raises(ValueError, match="reserved"):
        write_checkpoint(path, COMM, 50, 0, fields_in, {"hpcgfmd_checkpoint": 2})
    remove_checkpoint(path, COMM)
    assert not os.path.exists(path)
    remove_checkpoint(path, COMM)  # absent: nothing to do


def test_checkpoint_rejects_other_files(tmp_path):
    case = parse_case(CASE_TEXT)  # a result file is not a checkpoint
    n = case.numerics.nx
    ResultFile(tmp_path / "case.h5", case, Domain(COMM, n, case.cell, [(0, n)]), COMM).close()
    with pytest.raises(ValueError, match="not an hpcgfmd checkpoint"):
        read_checkpoint(tmp_path / "case.h5", COMM, 0, n)
    (tmp_path / "junk").write_text("junk")
    with pytest.raises(ValueError, match="not an hpcgfmd checkpoint"):
        read_checkpoint(tmp_path / "junk", COMM, 0, 1)
    with pytest.raises(FileNotFoundError):
        read_checkpoint(tmp_path / "none.h5", COMM, 0, 1)


def test_checkpoint_atomic(tmp_path, monkeypatch):
    path = str(tmp_path / "run.checkpoint.h5")
    old, attrs = state(40)
    write_checkpoint(path, COMM, 40, 0, old, attrs)
    # A crash before the rename: the .tmp holds a partial new checkpoint, the old one stays.
    new = {name: value + 1.0 for name, value in old.items()}

    def crash(src, dst):
        raise OSError("killed")

    monkeypatch.setattr(ckpt.os, "replace", crash)
    with pytest.raises(OSError, match="killed"):
        write_checkpoint(path, COMM, 40, 0, new, {**attrs, "step": 18})
    monkeypatch.undo()
    Path(path + ".tmp").write_bytes(b"partial garbage")  # or torn mid-write
    got, got_attrs = read_checkpoint(path, COMM, 0, 40)
    assert np.array_equal(got["u"], old["u"]) and got_attrs["step"] == 17
    # The next write replaces both the stale .tmp and the old checkpoint.
    write_checkpoint(path, COMM, 40, 0, new, {**attrs, "step": 18})
    got, got_attrs = read_checkpoint(path, COMM, 0, 40)
    assert np.array_equal(got["u"], new["u"]) and got_attrs["step"] == 18
    assert not os.path.exists(path + ".tmp")


@pytest.mark.mpi
@pytest.mark.parametrize("args", [["-n", "2"], ["--oversubscribe", "-n", "3"]])
def test_parallel_checkpoint(tmp_path, args):
    mpirun = shutil.which("mpirun")
    if mpirun is None:
        pytest.skip("no mpirun")
    # Should pytest itself run under an MPI launcher, keep its variables out of the new job.
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_", "PRTE_"))}
    env.update(
        OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OPENBLAS_NUM_THREADS="1"
    )
    script = Path(__file__).parent / "mpi" / "check_checkpoint.py"
    run = subprocess.run(
        [mpirun, *args, sys.executable, str(script), str(tmp_path)],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 0, run.stdout + run.stderr
