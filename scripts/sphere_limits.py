"""The viscoelastic sphere's retraction against its limits (docs/model.md, (M57)-(M59)).

    python scripts/sphere_limits.py            # the tables of docs/results.md, "The sphere"
    python scripts/sphere_limits.py --quick    # the same on the tests' grids (n = 128)

Four tables (hpcgfmd/studies/sphere_limits.py measures, tests/test_sphere_limits.py asserts):

1. The glassy limit: lambda0 = 2, k = 0.5 retracted at V_z = 1000 from its relaxed preload,
   on three grids: the pull-off against the instantaneous limit's least force in the cell
   (M57), (M59), and the (depth, force) points whose instantaneous zone lies inside the
   preload's contact against the curve (Dbar_inst k + (1 - k) Dbar0, Pbar_inst).
2. The same case from slow to fast: the pull-off between the relaxed (0) and instantaneous
   (1) least forces, and k dgamma_eff / dgamma0 of the steady points (Maugis-Dugdale reading).
3. Persson-Brener: the steady points (from where two depths' curves merge within 1.5e-2 to
   the pull-off) against Eq. 8 at their edge speed in both conventions (M58): the medians of
   ln(dgamma_eff / Eq. 8) over the deep run's points, dgamma_eff read from the
   Maugis-Dugdale curve (M56) and from JKR's line (M55).
4. docs/examples/sphere.toml's case: its effective work read both ways.

Prints the date, the machine and the commit first.
"""

import argparse
import os
import sys
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

MERGED = 1.5e-2  # the cylinder's 3 x accuracy (docs/paper.md, Fig. 5a)
# (lambda0, k, L/R, deep and shallow h0/R, n, n --quick, V_z values)
PERSSON_BRENER = [
    (1.0, 0.5, 1.5, (0.03, 0.02), 256, 128, (0.03, 0.1, 0.3)),
    (2.0, 0.5, 1.5, (0.03, 0.02), 256, 128, (0.03, 0.1, 0.3)),
    (3.0, 0.5, 1.4, (0.025, 0.017), 512, 128, (0.03, 0.1, 0.3)),
    (1.0, 0.1, 1.5, (0.03, 0.02), 256, 128, (0.01, 0.03)),
]


def retraction(maugis, k, velocity, depth, cell, n):
    """One run: (its SphereCurve, steps, CPU s)."""
    import hpcgfmd
    from hpcgfmd.studies import sphere_check, sphere_limits

    case = sphere_check.sphere_case(maugis, k, velocity, depth, cell, n)
    started = time.process_time()
    series = hpcgfmd.run(case, planner_effort="FFTW_ESTIMATE").series
    cpu = time.process_time() - started
    return sphere_limits.sphere_curve(case, series), series.time.size - 1, cpu


def glassy_table(grids):
    from hpcgfmd.studies import sphere_limits

    print(
        "| n | w0/dx | steps | CPU s | pull-off Pbar | instantaneous in the cell | error |"
        " points | curve distance | k dgamma_eff/dgamma0 |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for n in grids:
        curve, steps, cpu = retraction(2.0, 0.5, 1000.0, 0.03, 1.5, n)
        check = sphere_limits.glassy_check(curve)
        print(
            f"| {n} | {0.1875 / curve.dx:.1f} | {steps} | {cpu:.1f} | {check.pull_off:.4f} |"
            f" {check.reference:.4f} | {check.pull_off / check.reference - 1:+.1e} |"
            f" {check.points} | {check.curve:.1e} | {check.work[0]:.3f}-{check.work[1]:.3f} |",
            flush=True,
        )


def velocity_table(n):
    from hpcgfmd.studies import sphere_limits

    print("\n| V_z | T at pull-off | pull-off Pbar | relaxed | instantaneous | fraction |")
    print("|---|---|---|---|---|---|")
    for velocity in (0.03, 0.1, 0.3, 1.0, 3.0, 1000.0):
        curve, _, _ = retraction(2.0, 0.5, velocity, 0.03, 1.5, n)
        pull, relaxed, instantaneous, fraction = sphere_limits.pull_off_fraction(curve)
        at = curve.time[int(curve.pbar.argmin())]
        print(
            f"| {velocity:g} | {at:.3g} | {pull:.4f} | {relaxed:.4f} | {instantaneous:.4f} |"
            f" {fraction:.3f} |",
            flush=True,
        )


def persson_brener_table(quick):
    from hpcgfmd.studies import sphere_limits

    print(
        "\n| lambda0 | k | n | V_z | merged from Abar | points | vbar (ret.) | k dgamma_eff |"
        " MD: ln ret. | MD: ln rel. | JKR: ln ret. | JKR: ln rel. |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for maugis, k, cell, depths, n, n_quick, velocities in PERSSON_BRENER:
        grid = n_quick if quick else n
        for velocity in velocities:
            deep, shallow = (retraction(maugis, k, velocity, d, cell, grid)[0] for d in depths)
            mask, _, start = sphere_limits.steady_masks(deep, shallow, MERGED)
            if not mask.any():
                print(f"| {maugis:g} | {k:g} | {grid} | {velocity:g} | never merged |")
                continue
            c = sphere_limits.persson_brener_check(deep, mask, 2.5 * deep.dx)
            print(
                f"| {maugis:g} | {k:g} | {grid} | {velocity:g} | {start:.3f} | {c.points} |"
                f" {c.vbar[0]:.3g}-{c.vbar[1]:.3g} | {c.work[0]:.3f}-{c.work[1]:.3f} |"
                f" {c.maugis['retardation']:+.3f} | {c.maugis['relaxation']:+.3f} |"
                f" {c.jkr['retardation']:+.3f} | {c.jkr['relaxation']:+.3f} |",
                flush=True,
            )


def documented_case(n):
    import numpy as np

    from hpcgfmd.studies import sphere_limits

    curve, steps, cpu = retraction(3.0, 0.1, 1.0, 0.01, 1.0, n)
    i = int(np.argmin(curve.pbar))
    upto = slice(0, i + 1)
    jkr = curve.k * sphere_limits.jkr_work(curve.abar[upto], curve.pbar[upto], curve.cell)
    md = curve.k * sphere_limits.maugis_work(
        curve.abar[upto], curve.pbar[upto], curve.maugis, curve.cell, 2.0 / curve.k
    )
    print(
        f"\ndocs/examples/sphere.toml's case on n = {n} ({steps} steps, {cpu:.1f} s): Abar"
        f" {curve.abar[0]:.3f} -> {curve.abar[i]:.3f} at the pull-off {curve.pbar[i]:.4f};"
        f" k dgamma_eff / dgamma0 there {jkr[-1]:.3f} (JKR's line), {md[-1]:.3f}"
        f" (Maugis-Dugdale); the largest up to it {np.nanmax(jkr):.3f} and {np.nanmax(md):.3f}"
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="the tests' grids (n = 128)")
    args = parser.parse_args()
    from hpcgfmd.studies import report

    print(report.header("The sphere's limits (scripts/sphere_limits.py)"))
    glassy_table((128,) if args.quick else (128, 256, 384))
    velocity_table(128)
    persson_brener_table(args.quick)
    documented_case(128 if args.quick else 384)


if __name__ == "__main__":
    main()
