"""``python -m hpcgfmd bench farm``: a farm of equal cases on 1 rank against 2 ranks.

    python -m hpcgfmd bench farm --cases 8 --nx 32768 --repeat 1

Writes a sweep of ``--cases`` computationally identical cases (the tests' small case,
lambda0 = 3.5, k = 0.1, V_z = 1, h0/R = 0.03, L/R = 2, alpha = 1e-4, on ``--nx`` nodes; they
differ only in ``[output] progress_interval`` so that their files have different names) and
times the whole command ``mpirun -n P python -m hpcgfmd farm sweep.toml`` for P = 1 and 2,
interleaved ``--repeat`` times so that drifts of the machine's load hit both alike, each from
an empty output folder. Prints the median wall time of each and their ratio (target: at most
1/1.9). Start it on one rank.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

from .. import atomic
from . import report
from .counts import SMALL


def _sweep(cases, nx):
    intervals = ", ".join(f"{10.0 + i:.1f}" for i in range(cases))
    body = "".join(f"{key} = {value!r}\n" for key, value in SMALL.items())
    return (
        f"[base.case]\n{body}[base.numerics]\nnx = {nx}\n"
        f"[grid]\noutput.progress_interval = [{intervals}]\n"
    )


def main(comm, argv=None):
    """The mode's command line (one rank); the exit status."""
    parser = argparse.ArgumentParser(
        prog="python -m hpcgfmd bench farm",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=__doc__.split("\n\n", 1)[1],
    )
    parser.add_argument("--cases", type=int, default=8, help="equal cases (default 8)")
    parser.add_argument("--nx", type=int, default=8192, help="their nodes (default 8192)")
    parser.add_argument(
        "--repeat", type=int, default=2, help="timings of each rank count (default 2)"
    )
    try:
        args = parser.parse_args(argv)
    except SystemExit as exit_:
        return int(exit_.code or 0)
    if comm.Get_size() > 1 or args.cases < 1 or args.repeat < 1:
        if comm.Get_rank() == 0:
            print(
                "bench farm: start it on one rank, with --cases and --repeat >= 1", file=sys.stderr
            )
        return 2
    print(
        report.header("A farm of equal cases on 1 and 2 ranks (python -m hpcgfmd bench farm)"),
        flush=True,
    )
    times = {1: [], 2: []}
    env = report.child_environment()
    with tempfile.TemporaryDirectory(prefix="hpcgfmd-farm-") as work:
        sweep = os.path.join(work, "sweep.toml")
        atomic.write_text(sweep, _sweep(args.cases, args.nx))
        for _ in range(args.repeat):
            for ranks in (1, 2):
                out = os.path.join(work, f"out{ranks}-{len(times[ranks])}")
                started = time.perf_counter()
                done = subprocess.run(
                    [
                        "mpirun",
                        "-n",
                        str(ranks),
                        sys.executable,
                        "-m",
                        "hpcgfmd",
                        "--quiet",
                        "farm",
                        sweep,
                        "-o",
                        out,
                    ],
                    capture_output=True,
                    text=True,
                    env=env,
                    check=False,
                )
                elapsed = time.perf_counter() - started
                if done.returncode != 0:
                    print(
                        f"bench farm: the farm on {ranks} rank(s) failed (status"
                        f" {done.returncode}): {done.stderr[-500:]}",
                        file=sys.stderr,
                    )
                    return 1
                times[ranks].append(elapsed)
                print(f"  {ranks} rank(s): {elapsed:.1f} s", flush=True)
    t1, t2 = statistics.median(times[1]), statistics.median(times[2])
    row = [args.cases, args.nx, args.repeat, f"{t1:.1f}", f"{t2:.1f}", f"{t2 / t1:.3f}"]
    print(
        "\n"
        + report.markdown_table(
            ("cases", "nx", "runs of each", "1 rank s (median)", "2 ranks s (median)", "ratio"),
            [row],
        )
        + "\n\n"
        + report.verdict("farm_ratio", t2 / t1, f"{args.cases} cases at nx {args.nx}"),
        flush=True,
    )
    return 0
