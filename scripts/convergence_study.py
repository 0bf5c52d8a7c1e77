"""Convergence of the pull-off load with n_x and dt for the paper's cases (issue: engine).

For each case the pull-off (most tensile load) is computed on the grids of ``--nx`` at the
paper's fixed default time step dmax/(4 v_z), and on the grid ``--dt-nx`` (default: the largest
``--nx``) at the multiples ``--dt-factors`` of it other than 1 (default: none). Each run's row
(groups, grid, steps, iterations, wall time, pull-off Lbar and abar, detachment) is printed and
appended to the CSV file; the changes between rows are left to the reader.

    python scripts/convergence_study.py --out convergence.csv \
        --case 7:0.45 --case 7:4.5 --nx 32768 65536 131072 --dt-factors 0.5 --dt-nx 65536

Each --case is lambda0:V_z (k = 0.1, h0/R = 0.1, L/R = 10, alpha = 5e-5, as in docs/model.md).
"""
import argparse
import csv
import os
import tempfile
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):  # one BLAS thread, as the CLI
    os.environ.setdefault(_var, "1")

from mpi4py import MPI  # noqa: E402

from hpcgfmd.model import numerics as config  # noqa: E402
from hpcgfmd.storage.reader import read_series  # noqa: E402
from hpcgfmd.model.case import case_file_text, parse_case  # noqa: E402
from hpcgfmd.model.numerics import DEFAULT_STEP_PER_RANGE  # noqa: E402
from hpcgfmd.runs.single_case import run_case  # noqa: E402


def case_text(lam, vz, nx, dt_factor, depth=0.1):
    dmax = 5e-5 ** (2 / 3) / lam
    dt = dt_factor * DEFAULT_STEP_PER_RANGE * dmax / (vz * 5e-5 ** (2 / 3))
    return case_file_text({"maugis": lam, "modulus_ratio": 0.1, "velocity": vz, "depth": depth,
                           "cell": 10.0, "adhesion": 5e-5}, {"nx": nx, "dt": dt})


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", action="append", required=True, help="lambda0:V_z")
    parser.add_argument("--nx", type=int, nargs="*", default=[],
                        help="grids run at the default dt (may be empty)")
    parser.add_argument("--dt-factors", type=float, nargs="+", default=[1.0],
                        help="multiples of the default dt")
    parser.add_argument("--dt-nx", type=int, default=None,
                        help="grid of the dt runs (default: the largest --nx)")
    parser.add_argument("--out", default="convergence.csv")
    parser.add_argument("--min-zone-points", type=float, default=None,
                        help="accept grids below hpcgfmd's w/dx minimum (study only)")
    args = parser.parse_args()
    if not args.nx and args.dt_nx is None:
        parser.error("give --nx or --dt-nx")
    if args.min_zone_points is not None:
        config.MIN_ZONE_POINTS = args.min_zone_points
    fields = ["lambda0", "Vz", "nx", "dt_factor", "zone_points", "steps", "iterations",
              "wall_time", "pulloff_lbar", "pulloff_abar", "detachment_indenter"]
    new = not os.path.exists(args.out)
    with open(args.out, "a", newline="") as fh, tempfile.TemporaryDirectory() as tmp:
        writer = csv.DictWriter(fh, fieldnames=fields)
        if new:
            writer.writeheader()
        for spec in args.case:
            lam, vz = map(float, spec.split(":"))
            runs = [(nx, 1.0) for nx in args.nx]
            runs += [(args.dt_nx or max(args.nx), f) for f in args.dt_factors if f != 1.0]
            for nx, factor in runs:
                case = parse_case(case_text(lam, vz, nx, factor))
                path = os.path.join(tmp, f"{lam}_{vz}_{nx}_{factor}.h5")
                start = time.monotonic()
                summary = run_case(case, path, MPI.COMM_SELF)
                s = read_series(path)
                i = s.pull_off()
                row = {"lambda0": lam, "Vz": vz, "nx": nx, "dt_factor": factor,
                       "zone_points": case.zone_width / case.dx, "steps": summary["steps"],
                       "iterations": summary["iterations"],
                       "wall_time": round(time.monotonic() - start, 1),
                       "pulloff_lbar": s.lbar[i], "pulloff_abar": s.abar[i],
                       "detachment_indenter": summary["detachment_indenter"]}
                writer.writerow(row)
                fh.flush()
                print(row, flush=True)
                os.remove(path)


if __name__ == "__main__":
    main()
