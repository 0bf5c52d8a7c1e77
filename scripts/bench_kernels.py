"""Time the CG iteration's compiled passes on one block, against a dot product of it.

    taskset -c 0 python scripts/bench_kernels.py --n 73728 98304 131072

For each block size: random data in a dozen vectors as the solver's, a contact span of 600
nodes in the middle; each kernel called ``--repeats`` times in a row, the best of five such
rounds, in milliseconds per call. A kernel called in a loop keeps its own arrays in cache,
so these are lower bounds of its cost within a solve, whose vectors together exceed L2.
The kernels are :mod:`hpcgfmd.solvers.cg.kernels`' (``_extremes``, ``residual``,
``dot_and_entry``, ``update_and_residual``, ``project_direction``) and ``below_wall`` of
:mod:`hpcgfmd.solvers.step_kernels`; ``dot`` is the floor of a pass that reads two arrays.
To compare two versions, run it with ``PYTHONPATH`` on each checkout (a kernel a version
lacks is printed as ``-``).
"""
import argparse
import os
import sys
import time

if not os.environ.get("PYTHONPATH"):  # else the checkout it names is the one timed
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import numpy as np  # noqa: E402

from hpcgfmd.solvers import step_kernels  # noqa: E402
from hpcgfmd.solvers.cg import kernels  # noqa: E402


def best_ms(function, args, repeats):
    function(*args)
    best = np.inf
    for _ in range(5):
        start = time.perf_counter()
        for _ in range(repeats):
            function(*args)
        best = min(best, (time.perf_counter() - start) / repeats)
    return 1e3 * best


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, nargs="+", default=[73728, 131072])
    parser.add_argument("--repeats", type=int, default=200)
    args = parser.parse_args()
    print(f"{'n':>8} " + " ".join(f"{name:>20}" for name in (
        "dot", "_extremes", "residual", "dot_and_entry", "update_and_residual",
        "project_direction", "below_wall")))
    for n in args.n:
        rng = np.random.default_rng(n)
        u, d, load, kd, traction, r, r_old, z, d_old, wall, out, k_u = (
            rng.standard_normal(n) for _ in range(12))
        gap = np.abs(rng.standard_normal(n)) + 0.1
        lo, hi = n // 2 - 300, n // 2 + 300
        pressed = np.zeros(hi - lo, dtype=bool)
        calls = {
            "dot": (kernels.dot, (d, kd)),
            "_extremes": (kernels._extremes, (r, lo, hi)),
            "residual": (kernels.residual, (load, traction, lo, hi, lo, hi, r)),
            "dot_and_entry": (kernels.dot_and_entry, (d, kd, gap, lo, hi, 0.01, 600)),
            # length 0: the same data every call
            "update_and_residual": (kernels.update_and_residual,
                                    (u, d, load, kd, gap, 0.0, traction, lo, hi, lo, hi, r)),
            "project_direction": (kernels.project_direction,
                                  (z, 0.0, lo, hi, pressed, r, r_old, d_old, False)),
            "below_wall": (getattr(step_kernels, "below_wall", None), (u, 0.0, wall, out)),
        }
        cells = []
        for function, call_args in calls.values():
            cells.append("-" if function is None
                         else f"{best_ms(function, call_args, args.repeats):.4f}")
        print(f"{n:>8} " + " ".join(f"{cell:>20}" for cell in cells))


if __name__ == "__main__":
    main()
