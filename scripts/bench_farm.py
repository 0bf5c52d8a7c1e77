"""Farm throughput: 8 equal cases on 1 rank against 2 ranks (issue: ensembles and clusters).

    python scripts/bench_farm.py --cases 8 --nx 8192 --repeat 2 --out bench_farm.csv

Writes a sweep of ``--cases`` computationally identical cases (the paper's lambda0 = 3.5, k =
0.1, V_z = 1 case on a small cell; they differ only in ``[output] progress_interval`` so that
their files have different names) and times the whole command
``mpirun -n P python -m hpcgfmd farm sweep.toml`` for P = 1 and 2, interleaved ``--repeat``
times so that drifts of the machine's load hit both alike. Reports the median wall time of each
and the ratio t(2) / t(1) (target: at most 1/1.9 = 0.526), plus the load average, and appends
the rows to ``--out``. Every run starts from an empty output directory.
"""
import argparse
import csv
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

BASE = """[base.case]
maugis = 3.5
modulus_ratio = 0.1
velocity = 1.0
depth = 0.03
cell = 2.0
adhesion = 1e-4
[base.numerics]
nx = {nx}
[grid]
output.progress_interval = [{intervals}]
"""


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=8)
    parser.add_argument("--nx", type=int, default=8192)
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--out", default="bench_farm.csv")
    args = parser.parse_args()
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    times = {1: [], 2: []}
    loads = [os.getloadavg()[0]]
    with tempfile.TemporaryDirectory() as work:
        intervals = ", ".join(f"{10.0 + i:.1f}" for i in range(args.cases))
        sweep = os.path.join(work, "sweep.toml")
        with open(sweep, "w") as fh:
            fh.write(BASE.format(nx=args.nx, intervals=intervals))
        for _ in range(args.repeat):
            for ranks in (1, 2):
                out = os.path.join(work, f"out{ranks}")
                shutil.rmtree(out, ignore_errors=True)
                started = time.monotonic()
                done = subprocess.run(["mpirun", "-n", str(ranks), sys.executable, "-m",
                                       "hpcgfmd", "farm", sweep, "-o", out],
                                      capture_output=True, text=True, env=env)
                elapsed = time.monotonic() - started
                if done.returncode != 0:
                    sys.exit(f"farm on {ranks} rank(s) failed:\n{done.stdout}{done.stderr}")
                times[ranks].append(elapsed)
                print(f"{ranks} rank(s): {elapsed:.1f} s", flush=True)
    loads.append(os.getloadavg()[0])
    t1, t2 = statistics.median(times[1]), statistics.median(times[2])
    print(f"\n{args.cases} cases at nx = {args.nx}: 1 rank {t1:.1f} s, 2 ranks {t2:.1f} s,"
          f" ratio t2/t1 = {t2 / t1:.3f} (target <= {1 / 1.9:.3f});"
          f" load average {loads[0]:.2f} -> {loads[1]:.2f}")
    new = not os.path.exists(args.out)
    with open(args.out, "a", newline="") as fh:
        writer = csv.writer(fh)
        if new:
            writer.writerow(["cases", "nx", "repeat", "t1_median_s", "t2_median_s", "ratio",
                             "load_before", "load_after"])
        writer.writerow([args.cases, args.nx, args.repeat, f"{t1:.2f}", f"{t2:.2f}",
                         f"{t2 / t1:.4f}", f"{loads[0]:.2f}", f"{loads[1]:.2f}"])


if __name__ == "__main__":
    main()
