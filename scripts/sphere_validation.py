"""The elastic adhesive sphere against the Maugis-Dugdale sphere in its periodic cell, and the
collapse of viscoelastic retractions at equal chi_ve.

    python scripts/sphere_validation.py                 # lambda0 0.5, 1, 3 (the tests' runs)
    python scripts/sphere_validation.py --grids 128 256 512   # lambda0 = 1 on three grids
    python scripts/sphere_validation.py --collapse      # equal chi_ve, lambda0 and 2 lambda0

Each run is the elastic sphere (k = 1) of Maugis's lambda0 retracted at accuracy 5e-3 on its
n x n grid; its pull-off (the most tensile load) and its load against the indenter's depth
(both exact observables, not the radius of a node count) are compared with the
Maugis-Dugdale curve of docs/model.md (M56) in the periodic cell (M59). The curve error is
the largest distance of the run's (depth, load) points to the reference curve, in the
reference's largest depth and its |pull-off|. ``--grids`` refines lambda0 = 1's grid: the
order of the triangle law's error (docs/model.md, (M60)). ``--collapse``: for each pair of
hpcgfmd/paper/sphere_collapse.py's COLLAPSE_PAIRS, lambda0 and 2 lambda0 each retracted at
chi_ve = 0.1 and 0.4 (k = 0.2; V_z = 3 chi_ve / (pi lambda0^2), (M53)), the largest distance
between the two curves of equal chi_ve, the smallest between the curves of chi_ve 0.1 and
0.4, and their ratio (the paper's Fig. 9 check, hpcgfmd/paper/checks.py). Prints the date,
the machine and the commit first, a Markdown table after.
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


def collapse():
    """The table of --collapse: one row per pair of lambda0 (both chi_ve)."""
    import hpcgfmd
    from hpcgfmd.paper.sphere_collapse import (
        COLLAPSE_CHI,
        COLLAPSE_PAIRS,
        collapse_check,
        collapse_sphere,
    )

    low, high = COLLAPSE_CHI
    print(
        f"| lambda0 | n | w0/dx | pull-off Pbar, chi_ve {low:g} | pull-off Pbar, chi_ve {high:g}"
        f" | within, {low:g} | within, {high:g} | between | ratio | CPU s |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for pair in COLLAPSE_PAIRS:
        series, pulls, zones, cpu = [], {}, {}, 0.0
        for maugis, n in pair:
            for chi in COLLAPSE_CHI:
                case = collapse_sphere(maugis, chi, n, ACCURACY)
                zones[maugis] = f"{case.zone_width / case.dx:.2f}"
                started = time.process_time()
                series.append(hpcgfmd.run(case, planner_effort="FFTW_ESTIMATE").series)
                cpu += time.process_time() - started
                pulls.setdefault(chi, []).append(f"{series[-1].lbar.min():.4f}")
        values = collapse_check(series).values
        zones = ", ".join(zones.values())
        print(
            f"| {', '.join(f'{m:g}' for m, _ in pair)} | {', '.join(str(n) for _, n in pair)}"
            f" | {zones} | {', '.join(pulls[low])} | {', '.join(pulls[high])}"
            f" | {values[f'chi_ve={low:.3g}']:.4f} | {values[f'chi_ve={high:.3g}']:.4f}"
            f" | {values[f'chi_ve={low:.3g} vs {high:.3g}']:.4f} | {values['ratio']:.3f}"
            f" | {cpu:.0f} |",
            flush=True,
        )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--grids", type=int, nargs="+", help="lambda0 = 1's grid on these n instead"
    )
    parser.add_argument(
        "--collapse", action="store_true", help="the collapse at equal chi_ve instead"
    )
    args = parser.parse_args()
    from hpcgfmd.studies import report

    if args.collapse:
        print(report.header("The sphere's collapse at equal chi_ve (scripts/sphere_validation.py)"))
        collapse()
        return
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
