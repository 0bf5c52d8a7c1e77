"""The elastic adhesive sphere against the Maugis-Dugdale sphere in its periodic cell.

    python scripts/sphere_validation.py                 # lambda0 0.5, 1, 3 (the tests' runs)
    python scripts/sphere_validation.py --grids 128 256 512   # lambda0 = 1 on three grids

Each run is the elastic sphere (k = 1) of Maugis's lambda0 retracted at accuracy 5e-3 on its
n x n grid; its pull-off (the most tensile load) and its load against the indenter's depth
(both exact observables, not the radius of a node count) are compared with the
Maugis-Dugdale curve of docs/model.md (M56) in the periodic cell (M59). The curve error is
the largest distance of the run's (depth, load) points to the reference curve, in the
reference's largest depth and its |pull-off|. ``--grids`` refines lambda0 = 1's grid: the
order of the triangle law's error (docs/model.md, (M60)). Prints the date, the machine and
the commit first, a Markdown table after.
"""

import argparse
import os
import sys
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

ACCURACY = 5e-3


def measure(maugis, cell, n, depth):
    """One run's figures: (n, w/dx, a0/dx, steps, CPU s, its MaugisDugdaleCheck)."""
    import hpcgfmd
    from hpcgfmd.studies.sphere_check import elastic_sphere, maugis_dugdale_check

    case = elastic_sphere(maugis, cell, n, depth, ACCURACY)
    started = time.process_time()
    series = hpcgfmd.run(case, planner_effort="FFTW_ESTIMATE").series
    cpu = time.process_time() - started
    return (
        n,
        case.zone_width / case.dx,
        series.contact_half_width[0] / case.dx,
        series.time.size - 1,
        cpu,
        maugis_dugdale_check(case, series),
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--grids", type=int, nargs="+", help="lambda0 = 1's grid on these n instead"
    )
    args = parser.parse_args()
    from hpcgfmd.studies import report
    from hpcgfmd.studies.sphere_check import MAUGIS_RUNS

    print(report.header("The sphere against Maugis-Dugdale (scripts/sphere_validation.py)"))
    runs = (
        [(1.0, 1.5, n, 0.01) for n in args.grids]
        if args.grids
        else [(maugis, *values) for maugis, values in sorted(MAUGIS_RUNS.items())]
    )
    print(
        "| lambda0 | L/R | n | w0/dx | a0/dx | steps | CPU s | pull-off Pbar | Maugis-Dugdale"
        " in the cell | pull-off error | curve error |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    worst = 0.0
    for maugis, cell, n, depth in runs:
        n, zone, contact, steps, cpu, check = measure(maugis, cell, n, depth)
        pull, ref, curve = check.pull_off, check.reference, check.curve
        error = abs(pull / ref - 1.0)
        worst = max(worst, error / ACCURACY, curve / ACCURACY)
        print(
            f"| {maugis:g} | {cell:g} | {n} | {zone:.1f} | {contact:.1f} | {steps} | {cpu:.1f}"
            f" | {pull:.5f} | {ref:.5f} | {error:.1e} | {curve:.1e} |",
            flush=True,
        )
    print(f"\nthe largest error {worst:.2f} of the accuracy {ACCURACY:g}")


if __name__ == "__main__":
    main()
