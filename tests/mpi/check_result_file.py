"""Parallel check of the result file (hpcgfmd.storage.result_file, a run's HDF5 output; run
under mpirun, any rank count).

Writes a result file from uneven blocks with one rank owning no node (rank 1), resumes it,
then rank 0 compares the file with the same content computed globally. Exit status 1 on any
failure.

    mpirun --oversubscribe -n 3 python tests/mpi/check_result_file.py [directory]
"""

import os
import shutil
import sys
import tempfile
import traceback
from pathlib import Path

import h5py
import numpy as np
from mpi4py import MPI

from hpcgfmd.case import parse_case
from hpcgfmd.parallel.domain import Domain
from hpcgfmd.storage.reader import read_series
from hpcgfmd.storage.result_file import SERIES, SERIES_UNITS, ResultFile

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


def step_values(k):
    return {
        name: (k + 1 if name == "iterations" else 0.1 * k + j + 0.5**k)
        for j, name in enumerate(SERIES)
    }


def snapshot(x, s):
    """Global snapshot s: time and (surface, pressure, gap)."""
    return 0.25 * s, (np.sin(3 * x + s), np.cos(x) - s, x**2 + s)


def main(directory):
    comm = MPI.COMM_WORLD
    case = parse_case(CASE)
    n = case.numerics.nx
    x = (np.arange(n) - n // 2) * case.cell / n
    edges = write_edges(n, comm.size)
    lo, hi = edges[comm.rank], edges[comm.rank + 1]
    path = os.path.join(directory, "case.h5")

    # 5 steps and 3 snapshots, "crash", resume at 3 steps and 2 snapshots, 2 steps + 1 more
    grid = Domain(comm, n, case.cell, [(edges[r], edges[r + 1]) for r in range(comm.size)])
    out = ResultFile(path, case, grid, comm)
    for k in range(5):
        out.append_step(step_values(k))
        if k % 2 == 0:
            t, fields = snapshot(x, k // 2)
            out.add_snapshot(t, *(f[lo:hi] for f in fields))
    out.close()
    out = ResultFile.reopen(path, case, grid, comm, steps=3, snapshots=2)
    for k in (3, 4):
        out.append_step(step_values(10 + k))
    t, fields = snapshot(x, 7)
    out.add_snapshot(t, *(f[lo:hi] for f in fields))
    out.finish({"steps": 4, "wall_time": float(comm.rank)})
    out.close()

    errors = []
    comm.Barrier()
    if comm.rank == 0:
        errors += compare_result_file(path, case, x)
    return [f"rank {comm.rank}: {e}" for e in errors]


def compare_result_file(path, case, x):
    """Rank 0, serially: the result file against the globally computed content."""
    errors = []
    steps = [step_values(k) for k in (0, 1, 2, 13, 14)]
    series = read_series(path)
    scale = {
        "time": case.units.time,
        "length": case.units.length,
        "load": case.units.load,
        None: 1.0,
    }
    for name in SERIES:
        want = np.array([v[name] * scale[SERIES_UNITS[name]] for v in steps])
        if not np.array_equal(getattr(series, name), want):
            errors.append(f"series {name}: {getattr(series, name)} != {want}")
    if series.attrs["steps_complete"] != 5 or series.attrs["finished"] is not True:
        errors.append(f"attrs steps_complete/finished {series.attrs}")
    if series.attrs["wall_time"] != 0.0:  # rank 0's summary is the one stored
        errors.append(f"summary wall_time {series.attrs['wall_time']}")
    with h5py.File(path, "r") as f:
        snaps = f["snapshots"]
        if snaps.attrs["complete"] != 3 or snaps["surface"].shape != (3, x.size):
            errors.append(
                f"snapshots complete {snaps.attrs['complete']} shape {snaps['surface'].shape}"
            )
        if not np.array_equal(snaps["x"][()], x * case.units.length):
            errors.append("snapshots/x")
        for row, s in enumerate((0, 1, 7)):
            t, fields = snapshot(x, s)
            if snaps["time"][row] != t * case.units.time:
                errors.append(f"snapshot time {row}")
            for name, field, unit in zip(
                ("surface", "pressure", "gap"),
                fields,
                (case.units.length, case.units.stress, case.units.length),
            ):
                if not np.array_equal(snaps[name][row], field * unit):
                    errors.append(f"snapshot {name} row {row}")
    return errors


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
            "\n".join(errors) if errors else f"check_result_file: OK on {comm.size} ranks",
            flush=True,
        )
    sys.exit(1 if errors else 0)
