"""The farm's cost model (hpcgfmd/runs/cost.py) against the paper's runs, run by run.

    mpirun -n 2 python scripts/farm_cost.py --run paper    # python -m hpcgfmd paper -o paper,
                                                           # each run's CPU seconds recorded
    python scripts/farm_cost.py paper                      # the table
    python scripts/farm_cost.py --study docs/figures/accuracy-sphere   # accuracy studies' runs

Reads the runs of ``python -m hpcgfmd paper`` (its shipped sweep files, or ``--accuracy``)
from DIR/runs/<name>.h5: their attributes ``steps``, ``iterations``, ``wall_time`` and
``ranks``. With ``--run`` it first makes them (the paper command on the ranks of the mpirun,
one rank per run; runs finished before are kept), recording each run's process CPU seconds in
DIR/runs/cpu-seconds.jsonl: the one-core time of a run, which a machine shared with other
work inflates less than the wall time. The table gives, per run, the predicted and measured
steps, iterations and seconds (CPU where recorded, else the wall time) and their ratio; the
exit status is 1 when a run's seconds are off by more than ``--limit`` (2) either way. Runs on
more than one rank, or unfinished, are listed and not judged. FFTW's planning is paid by the
first run of each grid size on a machine (the wisdom cache, hpcgfmd/parallel/wisdom.py): the
model is of runs with the wisdom cached, so measure a second time after a first ``--run``.

``--study PREFIX ...`` judges the saved runs of ``python -m hpcgfmd bench accuracy --out
PREFIX`` instead (PREFIX-runs/*.npz, references included; the sphere's are its cost model's
calibration): per run the predicted and measured steps, iterations and the retraction's CPU
seconds (set-up, FFTW planning and preload left out: :func:`hpcgfmd.runs.cost.plan`'s
segments against them), their ratios, and the ratios' geometric mean and range.
"""

import argparse
import json
import os
import sys
import time


def run(directory, accuracy):
    """The paper command on this process's ranks, each run's CPU seconds appended."""
    from hpcgfmd.entry import main
    from hpcgfmd.runs import farm

    record = os.path.join(directory, "runs", "cpu-seconds.jsonl")
    original = farm.run_case

    def timed(case, path, group, **options):
        cpu, wall = time.process_time(), time.monotonic()
        result = original(case, path, group, **options)
        if group.Get_size() == 1:
            with open(record, "a") as fh:  # one line, one write: ranks append whole lines
                fh.write(
                    json.dumps(
                        {
                            "name": os.path.basename(path)[:-3],
                            "cpu": time.process_time() - cpu,
                            "wall": time.monotonic() - wall,
                        }
                    )
                    + "\n"
                )
        return result

    farm.run_case = timed
    sys.argv = [sys.argv[0], "paper", "-o", directory]
    if accuracy is not None:
        sys.argv += ["--accuracy", str(accuracy)]
    return main()


def table(directory, accuracy, limit):
    """Print the table; returns the number of runs off by more than ``limit``."""
    import h5py

    from hpcgfmd.paper.study import FIGURES, paper_study
    from hpcgfmd.runs.cost import estimated_cost, estimated_steps, plan

    sweep, _ = paper_study(FIGURES, accuracy)
    cpu = {}
    record = os.path.join(directory, "runs", "cpu-seconds.jsonl")
    if os.path.exists(record):
        with open(record) as fh:
            for line in fh:
                entry = json.loads(line)
                cpu[entry["name"]] = entry["cpu"]  # the last measurement of each
    width = max(len(item.name) for item in sweep.cases)
    print(
        f"{'run':<{width}} {'nx':>7} {'steps':>13} {'iterations':>15} {'wall s':>7}"
        f" {'CPU s':>7} {'model s':>8} {'ratio':>6}"
    )
    off, judged, total = 0, 0, [0.0, 0.0]
    for item in sweep.cases:
        path = os.path.join(directory, "runs", item.name + ".h5")
        predicted = estimated_cost(item.case)
        steps = estimated_steps(item.case)
        iterations = sum(segment.iterations for segment in plan(item.case))
        try:
            with h5py.File(path, "r") as f:
                a = dict(f.attrs)
        except OSError:
            print(
                f"{item.name:<{width}} {item.case.numerics.nx:>7}  not run"
                f" {'':>36} {predicted:>8.3g}"
            )
            continue
        if not a.get("finished", False) or int(a.get("ranks", 1)) != 1:
            print(
                f"{item.name:<{width}} {item.case.numerics.nx:>7}  unfinished or on"
                f" {int(a.get('ranks', 1))} ranks: not judged"
            )
            continue
        measured = cpu.get(item.name, float(a["wall_time"]))
        ratio = predicted / measured
        judged += 1
        total[0] += predicted
        total[1] += measured
        off += not 1.0 / limit <= ratio <= limit
        print(
            f"{item.name:<{width}} {item.case.numerics.nx:>7}"
            f" {steps:>6.0f}/{int(a['steps']):<6d}"
            f" {iterations:>7.0f}/{int(a['iterations']):<7d}"
            f" {float(a['wall_time']):>7.1f}"
            f" {cpu[item.name] if item.name in cpu else float('nan'):>7.1f}"
            f" {predicted:>8.2f} {ratio:>6.2f}{'  OFF' if not 1 / limit <= ratio <= limit else ''}"
        )
    print(
        f"{judged} runs judged, {off} off by more than {limit:g}x; total predicted"
        f" {total[0]:.0f} s against {total[1]:.0f} s measured"
        f" ({'CPU' if cpu else 'wall'} seconds where recorded)"
    )
    return off


def study_table(prefixes, limit):
    """Print the table of accuracy studies' saved runs; returns the number of runs whose
    retraction seconds are off by more than ``limit``."""
    import glob
    import math

    import numpy as np

    from hpcgfmd.case import parse_case
    from hpcgfmd.runs.cost import plan

    print(
        f"{'lambda0:k:V_z:h0/R':<22} {'accuracy':>8} {'n':>5} {'steps':>11} {'ratio':>5}"
        f" {'iterations':>13} {'ratio':>5} {'CPU s':>13} {'ratio':>5}"
    )
    ratios, off = {"steps": [], "iterations": [], "seconds": []}, 0
    rows = []
    paths = [glob.glob(os.path.join(f"{prefix}-runs", "*.npz")) for prefix in prefixes]
    for path in sorted(p for found in paths for p in found):
        with np.load(path, allow_pickle=False) as saved:
            case = parse_case(str(saved["text"]))
            measured = [
                float(saved[key]) if key in saved.files else math.nan
                for key in ("steps", "iterations", "retraction_cpu_s")
            ]
        segments = plan(case)
        predicted = [sum(getattr(s, key) for s in segments) for key in ratios]
        label = f"{case.maugis:g}:{case.modulus_ratio:g}:{case.velocity:g}:{case.depth:g}"
        rows.append((label, case.numerics.accuracy, case.numerics.nx, predicted, measured))
    for label, accuracy, n, predicted, measured in sorted(rows):
        line = f"{label:<22} {accuracy:>8g} {n:>5}"
        for key, p, m in zip(ratios, predicted, measured):
            ratios[key].append(p / m)
            line += f" {p:>5.0f}/{m:<5.0f} {p / m:>5.2f}" if key != "seconds" else ""
        p, m = predicted[2], measured[2]
        line += f" {p:>6.1f}/{m:<6.1f} {p / m:>5.2f}"
        bad = not 1.0 / limit <= p / m <= limit
        off += bad
        print(line + ("  OFF" if bad else ""))
    for key, values in ratios.items():
        if values:
            mean = math.exp(sum(math.log(v) for v in values) / len(values))
            print(
                f"{key}: predicted / measured geometric mean {mean:.2f},"
                f" from {min(values):.2f} to {max(values):.2f} ({len(values)} runs)"
            )
    print(f"{off} of {len(rows)} runs' seconds off by more than {limit:g}x")
    return off


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("directory", nargs="?", help="the paper command's -o directory")
    parser.add_argument(
        "--study",
        nargs="+",
        metavar="PREFIX",
        help="judge the saved runs of python -m hpcgfmd bench accuracy --out PREFIX instead",
    )
    parser.add_argument(
        "--run",
        action="store_true",
        help="run the paper's study first (under mpirun: one run per rank)",
    )
    parser.add_argument(
        "--accuracy",
        type=float,
        default=None,
        help="[numerics] accuracy of every run (default: the sweep files')",
    )
    parser.add_argument(
        "--limit",
        type=float,
        default=2.0,
        help="the largest factor between predicted and measured (default 2)",
    )
    args = parser.parse_args()
    if args.study:
        return 1 if study_table(args.study, args.limit) else 0
    if args.directory is None:
        parser.error("the paper command's -o directory, or --study PREFIX, is needed")
    if args.run:
        status = run(args.directory, args.accuracy)
        from mpi4py import MPI

        if MPI.COMM_WORLD.Get_rank() != 0 or status != 0:
            return status
    return 1 if table(args.directory, args.accuracy, args.limit) else 0


if __name__ == "__main__":
    sys.exit(main())
