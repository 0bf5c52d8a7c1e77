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

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

# (lambda0, L/R, n, h0/R): >= 5 points across w0, cells of 4.6-18 starting contact radii
RUNS = ((0.5, 3.0, 256, 0.01), (1.0, 1.5, 256, 0.01), (3.0, 0.8, 384, 0.005))
ACCURACY = 5e-3


def measure(maugis, cell, n, depth):
    """One run's figures: (n, w/dx, a0/dx, steps, CPU s, pull-off, its reference, curve)."""
    import hpcgfmd
    from hpcgfmd.model import sphere_theory
    from hpcgfmd.studies.distance import polyline_distances

    case = hpcgfmd.Case(
        maugis=maugis,
        modulus_ratio=1.0,
        velocity=1.0,
        depth=depth,
        cell=cell,
        adhesion=1e-3,
        numerics={"n": n, "accuracy": ACCURACY},
        geometry="sphere",
    )
    started = time.process_time()
    series = hpcgfmd.run(case, planner_effort="FFTW_ESTIMATE").series
    cpu = time.process_time() - started
    load = series.load / case.load_scale
    depth_bar = -series.indenter / case.depth_scale
    start = series.contact_half_width[0] / case.beta
    radii = np.linspace(0.02, 1.05 * start, 400)
    ref_load, ref_depth = sphere_theory.periodic_cell(radii, case.cell / case.beta, maugis)
    scale = np.array([np.abs(ref_depth).max(), abs(ref_load.min())])
    attached = series.contact_half_width > 0
    points = np.c_[depth_bar[attached], load[attached]] / scale
    curve = polyline_distances(points, np.c_[ref_depth, ref_load] / scale).max()
    return (
        n,
        case.zone_width / case.dx,
        series.contact_half_width[0] / case.dx,
        series.time.size - 1,
        cpu,
        load.min(),
        ref_load.min(),
        curve,
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--grids", type=int, nargs="+", help="lambda0 = 1's grid on these n instead"
    )
    args = parser.parse_args()
    from hpcgfmd.studies import report

    print(report.header("The sphere against Maugis-Dugdale (scripts/sphere_validation.py)"))
    runs = [(1.0, 1.5, n, 0.01) for n in args.grids] if args.grids else RUNS
    print(
        "| lambda0 | L/R | n | w0/dx | a0/dx | steps | CPU s | pull-off Pbar | Maugis-Dugdale"
        " in the cell | pull-off error | curve error |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    worst = 0.0
    for maugis, cell, n, depth in runs:
        n, zone, contact, steps, cpu, pull, ref, curve = measure(maugis, cell, n, depth)
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
