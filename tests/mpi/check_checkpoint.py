"""Parallel check of checkpoint files (hpcgfmd.storage.checkpoint; run under mpirun, any rank
count).

Writes a checkpoint from uneven blocks with one rank owning no node (rank 1) and reads it
back on another block split (rank 0 owning nothing): every rank's block and every attribute
against the globally computed content. Exit status 1 on any failure.

    mpirun --oversubscribe -n 3 python tests/mpi/check_checkpoint.py [directory]
"""

import os
import shutil
import sys
import tempfile
import traceback
from pathlib import Path

import numpy as np
from mpi4py import MPI

from hpcgfmd.case import parse_case
from hpcgfmd.storage.checkpoint import read_checkpoint, write_checkpoint

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # tests/: the case builder
from cases import case_text  # noqa: E402

CASE = case_text("nx = 1024", maugis=1.0, modulus_ratio=1.0)


def write_edges(n, size):
    """Rank 0 owns 10 nodes (all with two ranks), rank 1 none, the others the rest unevenly."""
    if size == 1:
        return [0, n]
    if size == 2:
        return [0, n, n]
    return [0, 10, 10] + [int(e) for e in np.linspace(10, n, size - 1)[1:]]


def read_edges(n, size):
    """Another split: rank 0 owns nothing, the others share the nodes evenly."""
    if size == 1:
        return [0, n]
    return [0] + [int(e) for e in np.linspace(0, n, size)]


def main(directory):
    comm = MPI.COMM_WORLD
    case = parse_case(CASE)
    n = case.numerics.nx
    x = (np.arange(n) - n // 2) * case.cell / n
    edges = write_edges(n, comm.size)
    lo, hi = edges[comm.rank], edges[comm.rank + 1]
    rng = np.random.default_rng(7)
    state = {"u": rng.standard_normal(n), "traction": rng.standard_normal(n), "x": x}
    attrs = {
        "step": 42,
        "time": 10.5,
        "config": case.text,
        "times": np.array([0.5, 2.0]),
        "preloaded": True,
    }
    ckpt = os.path.join(directory, "case.checkpoint.h5")
    write_checkpoint(ckpt, comm, n, lo, {k: v[lo:hi] for k, v in state.items()}, attrs)

    errors = []
    redges = read_edges(n, comm.size)
    rlo, rhi = redges[comm.rank], redges[comm.rank + 1]
    got, got_attrs = read_checkpoint(ckpt, comm, rlo, rhi)
    if set(got) != set(state):
        errors.append(f"checkpoint fields {sorted(got)}")
    for name, value in state.items():
        if not np.array_equal(got.get(name), value[rlo:rhi]):
            errors.append(f"checkpoint field {name} block [{rlo}, {rhi})")
    for key, value in attrs.items():
        if not same(got_attrs.get(key), value):
            errors.append(f"checkpoint attr {key}: {got_attrs.get(key)!r} != {value!r}")
    return [f"rank {comm.rank}: {e}" for e in errors]


def same(got, want):
    """Equal, and of the same kind: numpy array for arrays, the Python type for scalars."""
    if isinstance(want, np.ndarray):
        return isinstance(got, np.ndarray) and np.array_equal(got, want)
    return type(got) is type(want) and got == want


if __name__ == "__main__":
    comm = MPI.COMM_WORLD
    own = len(sys.argv) < 2
    directory = comm.bcast(
        tempfile.mkdtemp() if own and comm.rank == 0 else (None if own else sys.argv[1]), root=0
    )
    try:
        errors = main(directory)
    except Exception:  # one failing rank would leave the others blocked in a collective call
        traceback.print_exc()
        sys.stdout.flush()
        comm.Abort(2)
    errors = sum(comm.allgather(errors), [])
    if comm.rank == 0:
        if own:
            shutil.rmtree(directory)
        print(
            "\n".join(errors) if errors else f"check_checkpoint: OK on {comm.size} ranks",
            flush=True,
        )
    sys.exit(1 if errors else 0)
