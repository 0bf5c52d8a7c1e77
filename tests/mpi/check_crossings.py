"""MPI check of the history estimate's crossing mask on blocks of any layout.

Run under mpirun with any number of ranks, e.g.::

    mpirun --oversubscribe -n 3 python tests/mpi/check_crossings.py

The curvature a window with a crossing is not read on every node within ``reach`` nodes
(periodic) of a node whose interaction state changed (``step_kernels.curvature``,
``Domain.marks_around``, ``step_kernels.clear_near_crossings``): on every rank's block,
for random states on grids of 1 to 64 nodes and blocks of every size (empty ones, blocks
shorter than the reach), against the mask found on the whole grid from the distances to
every changed node. The count of changed nodes must be the whole grid's on every rank.

Exit status 0 on every rank when all checks pass; on failure rank 0 prints the reasons and
all ranks exit with 1.
"""

import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402

from hpcgfmd.parallel.domain import Domain  # noqa: E402
from hpcgfmd.solvers.step_kernels import clear_near_crossings, curvature  # noqa: E402


def cleared_on_whole_grid(changed, reach):
    """Nodes within ``reach`` (periodic) of a changed node, from every pairwise distance."""
    n = changed.size
    where = np.flatnonzero(changed)
    if where.size == 0:
        return np.zeros(n, dtype=bool)
    distance = np.abs(np.arange(n)[:, None] - where[None, :])
    return np.minimum(distance, n - distance).min(axis=1) <= reach


def random_blocks(rng, n, size):
    """Contiguous blocks of random sizes (some empty) covering [0, n), in rank order."""
    cuts = np.sort(rng.integers(0, n + 1, size - 1))
    edges = np.concatenate([[0], cuts, [n]])
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


def check(comm, cases=300):
    """The reasons this rank's blocks fail (empty when all agree)."""
    errors = []
    rng = np.random.default_rng(2024)  # the same draws on every rank
    for case in range(cases):
        n = int(rng.integers(1, 65))
        states = rng.integers(0, 3, size=(3, n)).astype(np.int8)
        # mostly unchanged nodes, as around a contact edge
        for s in (1, 2):
            keep = rng.random(n) < rng.choice([1.0, 0.97, 0.8, 0.3])
            states[s][keep] = states[s - 1][keep]
        reach = int(rng.integers(0, 12))
        blocks = random_blocks(rng, n, comm.Get_size())
        domain = Domain(comm, n, 1.0, blocks)
        block = slice(domain.x_start, domain.x_stop)
        u = [rng.standard_normal(n) for _ in range(3)]
        out = np.empty(domain.local_n)
        local = [s[block].copy() for s in states]
        kinks, first, last = curvature(
            u[0][block], u[1][block], u[2][block], 0.5, 0.25, *local, out
        )
        count, left, right = domain.marks_around(kinks, first, last)
        if reach > 0:
            clear_near_crossings(*local, reach, left, right, out)
        changed = (states[0] != states[1]) | (states[1] != states[2])
        expected = cleared_on_whole_grid(changed, reach)[block]
        if count != int(changed.sum()):
            errors.append(f"case {case}: {count} crossings counted, {changed.sum()} present")
        smooth = ((u[2] - u[1]) / 0.25 - (u[1] - u[0]) / 0.5) / 0.75
        if not (
            np.array_equal(out == 0.0, expected)
            and np.allclose(out[~expected], smooth[block][~expected], rtol=1e-12, atol=1e-12)
        ):
            errors.append(
                f"case {case} (n {n}, reach {reach}, blocks {blocks}): the mask "
                f"differs on rank {comm.Get_rank()}"
            )
    return errors


def main():
    from report import abort, report  # (beside this script; check() runs without it)

    comm = MPI.COMM_WORLD
    try:
        errors = check(comm)
    except Exception as exc:
        abort(comm, exc)
    return report(comm, errors, f"ok: crossing mask on {comm.Get_size()} ranks")


if __name__ == "__main__":
    sys.exit(main())
