"""MPI check of Domain.rows_around: every rank's block of a surface's rows with `depth` rows
of the grid before and after it (periodic), against the global field's rows, on blocks
even, uneven, one row thick, and empty (a rank owning no row), for depths from 0 to more
than a block's rows.

    mpirun --oversubscribe -n 3 python tests/mpi/check_rows.py

Exit status 0 on every rank when all checks pass; rank 0 prints the failures otherwise.
"""

import sys

import numpy as np
from mpi4py import MPI
from report import abort, report

from hpcgfmd.parallel.domain import Domain

NY, NX = 12, 5


def layouts(size):
    """Row cuts of NY rows over ``size`` ranks: even, and with a rank of one row and (from
    three ranks) one of none."""
    even = np.linspace(0, NY, size + 1).astype(int)
    yield even
    if size >= 2:
        yield np.array([0, 1, *np.linspace(1, NY, size)[1:].astype(int)])
    if size >= 3:
        yield np.array([0, 1, 1, *np.linspace(1, NY, size - 1)[1:].astype(int)])


def main():
    comm = MPI.COMM_WORLD
    rank, errors = comm.Get_rank(), []
    field = np.arange(NY * NX, dtype=float).reshape(NY, NX) ** 1.5
    checked = 0
    for cuts in layouts(comm.Get_size()):
        blocks = [(int(a) * NX, int(b) * NX) for a, b in zip(cuts[:-1], cuts[1:])]
        domain = Domain(comm, (NY, NX), 1.0, blocks)
        first, stop = cuts[rank], cuts[rank + 1]
        for depth in (0, 1, 2, 5, NY - max(np.diff(cuts))):
            got = domain.rows_around(field[first:stop].ravel(), depth)
            want = field[np.arange(first - depth, stop + depth) % NY] if stop > first else None
            if want is None and got.shape != (0, NX):
                errors.append(f"rank {rank}, cuts {list(cuts)}, depth {depth}: {got.shape}")
            elif want is not None and not np.array_equal(got, want):
                errors.append(f"rank {rank}, cuts {list(cuts)}, depth {depth}: wrong rows")
            checked += 1
    return report(comm, errors, f"ok: {checked} layouts and depths on {comm.Get_size()} ranks")


if __name__ == "__main__":
    try:
        status = main()
    except Exception as exc:  # noqa: BLE001 (any failure must end every rank)
        abort(MPI.COMM_WORLD, exc)
    sys.exit(status)
