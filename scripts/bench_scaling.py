"""Strong scaling of the engine: wall time per time step and per inner iteration on P ranks.

What is measured (one row per grid size and rank count, appended to a CSV file)
    The paper's default case (lambda0 = 7, k = 0.1, V_z = 0.45, h0/R = 0.1, L/R = 10,
    alpha = 5e-5, default dt and tolerance) on a grid of n_x = 2^N nodes. The run builds the
    :class:`~hpcgfmd.runs.protocol.Retraction` (``setup``: dominated by FFTW planning), solves the
    preload from its coarse levels (``preload``, reported with its iterations but not part of
    the per-step cost), then times ``--steps`` retraction steps exactly as the production loop
    does them (a detachment test and one step each, no output file), between two barriers.
    Times are the maximum over the ranks. Communication shares are the seconds spent in the
    FFT's exchanges (shared-memory barriers or ``Alltoallv``) and in the Domain's collectives
    (reductions, halo exchanges, segments) during the timed steps, maximum over the ranks, as
    fractions of the timed wall time; they include the time a rank waits for the other one
    (load imbalance shows up there).
    ``load`` is the load of the last timed step: runs on different rank counts agree to about
    1e-8 relative (the solver tolerance; transforms and sums round differently).

How to run it (``OPENBLAS_NUM_THREADS=1``; as root also ``OMPI_ALLOW_RUN_AS_ROOT=1
OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1``)
    One rank count, the communicator the script runs on::

        python scripts/bench_scaling.py --n 17 20 22 --steps 20 --out bench.csv
        mpirun -n 2 python scripts/bench_scaling.py --n 17 20 22 --steps 20 --out bench.csv

    Everything in one session (the ratios should come from one session on one machine): runs
    itself under ``mpirun -n P`` for each P, interleaved per grid (P = 1 then P = 2 for the
    same n_x) so that a change of the machine's load affects both alike, then reports::

        python scripts/bench_scaling.py --launch 1 2 --n 17 20 22 --steps 20 --out bench.csv \\
            --markdown bench.md

    The table of an existing CSV file (latest row per rank count and grid)::

        python scripts/bench_scaling.py --report bench.csv --markdown bench.md

    Before the table the date, the machine and the commit are printed, after it the verdict
    on the target of 2 ranks against 1 per iteration at 2^22 and 2^24 (those measured).

    ``--geometry sphere`` measures instead docs/examples/sphere.toml's sphere on n x n nodes,
    ``--n`` the log2 of the nodes per side (from 6; the target: 2 ranks against 1 per
    iteration at 2048^2, ``--n 11``)::

        python scripts/bench_scaling.py --geometry sphere --launch 1 2 --n 10 11 --steps 5 \
            --out sphere.csv

How to read the table
    ``ms/iteration`` (timed wall time / inner CG iterations, per-step work included) is the
    figure to compare between rank counts: the iteration count of a step can differ by a few
    between rank counts (round-off), the work per iteration cannot. ``speedup`` is the
    1-rank time divided by this row's time at the same n_x (per iteration and per step);
    2 ranks on 2 cores can at best reach 2. ``FFT comm`` and ``Domain comm`` are the shares of
    the wall time in communication (see above); what is neither is local work. ``pairs/it``
    (FFT forward+backward pairs) and ``msgs/it`` (Domain collectives) per iteration show what
    each iteration costs in transforms and latency-bound messages. ``setup s`` is the
    construction of the Retraction, i.e. the FFTW planning with the flag in brackets (the
    rest of it takes milliseconds). ``other CPU`` is the CPU time other processes used
    during the timed steps, in cores (from /proc/stat, 10 ms resolution): it should be ~0.
    Above ~0.1 the row is not clean; sharing the cores hurts 2 ranks most, as they wait for
    each other at every collective (tens per iteration). ``uptime`` at the start and end of
    a --launch session is printed below the table.
"""

import argparse
import csv
import datetime
import os
import resource
import shutil
import subprocess
import sys
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):  # one BLAS thread, as the CLI
    os.environ.setdefault(_var, "1")

import numpy as np

from hpcgfmd import atomic
from hpcgfmd.model.grid import grid_label  # (no MPI: the model layer only)
from hpcgfmd.studies import report as targets  # (no MPI either)

# mpi4py (and hpcgfmd, which imports it) is imported only where a measurement runs: --launch
# and --report must not initialise MPI, or the mpirun they start would inherit a singleton's
# environment.

TWO_RANK_SIZES = (22, 24)  # log2 of the grids the two-rank target judges
SPHERE_TWO_RANK_SIZES = (11,)  # ... of the sphere's nodes per side

CASE = """[case]
maugis = 7.0
modulus_ratio = 0.1
velocity = 0.45
depth = 0.1
cell = 10.0
adhesion = 5e-5
[numerics]
nx = {nx}
"""
SPHERE_CASE = """[case]
geometry = "sphere"
maugis = 3.0
modulus_ratio = 0.1
velocity = 1.0
depth = 0.01
cell = 1.0
adhesion = 1e-3
[numerics]
n = {nx}
"""
FIELDS = [
    "started",
    "other_cpu",
    "ranks",
    "nx",
    "geometry",
    "planner",
    "steps",
    "iterations",
    "fft_pairs",
    "messages",
    "wall_time",
    "time_per_step",
    "time_per_iteration",
    "fft_comm_share",
    "domain_comm_share",
    "setup_time",
    "preload_time",
    "preload_iterations",
    "preload_levels",
    "peak_memory",
    "load",
]


def measure(comm, nx, steps, planner, geometry="cylinder"):
    """Collective: time ``steps`` retraction steps of the default case on ``nx`` nodes (the
    sphere's on nx x nx).

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
        The ranks to measure.
    nx : int
        Grid nodes.
    steps : int
        Retraction steps to time (fewer if the indenter detaches before).
    planner : str
        FFTW planner flag.
    geometry : {"cylinder", "sphere"}
        The default case, or docs/examples/sphere.toml's sphere.

    Returns
    -------
    dict
        One CSV row (keys :data:`FIELDS`); rank 0's is the one to write (the clock and
        /proc/stat readings of the other ranks differ slightly).
    """
    from mpi4py import MPI

    from hpcgfmd.case import parse_case
    from hpcgfmd.runs.protocol import Retraction

    row = {
        "started": datetime.datetime.now().isoformat(timespec="seconds"),
        "ranks": comm.Get_size(),
        "nx": nx,
        "geometry": geometry,
        "planner": planner,
    }
    case = parse_case((SPHERE_CASE if geometry == "sphere" else CASE).format(nx=nx))
    comm.Barrier()
    t0 = time.perf_counter()
    sim = Retraction(case, comm, planner_effort=planner)
    t1 = time.perf_counter()
    preload = sim.preload()
    comm.Barrier()
    t2 = time.perf_counter()
    before = _counters(sim)
    done, record, t3, t4, own, busy = _timed_steps(comm, sim, steps, preload)
    after = _counters(sim)
    iterations, pairs, messages = (a - b for a, b in zip(after[:3], before[:3]))
    # Slowest rank decides; the barriers make the ranks' wall times nearly equal anyway.
    local = np.array([t1 - t0, t2 - t1, t4 - t3, after[3] - before[3], after[4] - before[4]])
    comm.Allreduce(MPI.IN_PLACE, local, op=MPI.MAX)
    setup, preload_time, wall, fft_comm, dom_comm = local
    # the largest peak resident set of a rank (ru_maxrss: KiB on Linux), in bytes
    peak = comm.allreduce(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, op=MPI.MAX)
    row.update(
        peak_memory=1024 * peak,
        other_cpu=max(busy - own, 0.0) / wall,
        steps=done,
        iterations=iterations,
        fft_pairs=pairs,
        messages=messages,
        wall_time=wall,
        time_per_step=wall / max(done, 1),
        time_per_iteration=wall / max(iterations, 1),
        fft_comm_share=fft_comm / wall,
        domain_comm_share=dom_comm / wall,
        setup_time=setup,
        preload_time=preload_time,
        preload_iterations=preload.iterations,
        preload_levels=" ".join(f"{nx}:{it}" for nx, it in sim.preload_levels),
        load=repr(record.load),
    )
    return row


def _timed_steps(comm, sim, steps, record):
    """Collective: up to ``steps`` steps of ``sim`` (fewer if it detaches) between barriers.

    Returns the steps done, the last record, the wall clock at the start and the end, the
    ranks' summed CPU seconds (busy-waiting included) and this node's busy CPU seconds.
    """
    from mpi4py import MPI

    done = 0
    comm.Barrier()
    busy, own = busy_seconds(), time.process_time()
    start = time.perf_counter()
    while done < steps and not sim.detached():
        record = sim.step()
        done += 1
    comm.Barrier()
    end = time.perf_counter()
    own = comm.allreduce(time.process_time() - own, op=MPI.SUM)
    return done, record, start, end, own, busy_seconds() - busy


def _counters(sim):
    """(iterations, FFT pairs, Domain messages, FFT and Domain communication seconds)."""
    fft, dom = sim.fft, sim.domain
    return (
        sim.equilibrium.iterations,
        fft.pairs,
        dom.messages,
        fft.communication_time,
        dom.communication_time,
    )


def busy_seconds():
    """CPU seconds used so far by everything on this machine (all cores, Linux /proc/stat).

    Minus the ranks' own CPU time it gives what other processes took during the timed
    steps (steal by the hypervisor included): the benchmark is only clean when that is ~0.
    """
    with open("/proc/stat") as fh:
        ticks = [int(v) for v in fh.readline().split()[1:9]]  # user ... steal
    return (sum(ticks) - ticks[3] - ticks[4]) / os.sysconf("SC_CLK_TCK")  # minus idle, iowait


def append_row(path, row):
    """Append ``row`` to the CSV file ``path``, writing the header if the file is new."""
    new = not os.path.exists(path) or os.path.getsize(path) == 0
    if not new:
        with open(path, newline="") as fh:
            if next(csv.reader(fh), None) != FIELDS:
                sys.exit(f"{path}: exists with other columns; give another --out")
    with open(path, "a", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=FIELDS)
        if new:
            writer.writeheader()
        writer.writerow(row)


def run_here(args):
    """Measure every grid on COMM_WORLD and append the rows (rank 0 prints and writes)."""
    from mpi4py import MPI

    from hpcgfmd.case import numerics as config

    # Cost, not accuracy, is measured: accept the quick test grid 2^14 (w/dx = 0.97 < 1).
    config.MIN_ZONE_POINTS = 0.5
    comm = MPI.COMM_WORLD
    root = comm.Get_rank() == 0
    for n in args.n:
        row = measure(comm, 2**n, args.steps, args.planner, args.geometry)
        if root:
            append_row(args.out, row)
            print(
                f"ranks {row['ranks']}  nx 2^{n}  {row['steps']} steps"
                f"  {row['iterations']} iterations  {row['time_per_step']:.4g} s/step"
                f"  {1e3 * row['time_per_iteration']:.4g} ms/iteration"
                f"  FFT comm {row['fft_comm_share']:.1%}  Domain comm"
                f" {row['domain_comm_share']:.1%}  setup {row['setup_time']:.3g} s"
                f"  preload {row['preload_time']:.3g} s ({row['preload_iterations']} it,"
                f" coarser levels nx:it {row['preload_levels'] or 'none'})"
                f"  load {float(row['load']):.10g}  other CPU {row['other_cpu']:.2f}",
                flush=True,
            )


def _levels(row):
    """The preload's iterations: the fine grid's, after those of its coarser levels."""
    coarse = row.get("preload_levels") or ""
    levels = [
        f"{grid_label(int(nx))}: {it}" for nx, it in (level.split(":") for level in coarse.split())
    ]
    return " + ".join([*levels, str(row["preload_iterations"])])


def _memory(row):
    """The peak resident set of a rank, MB, and per node of its block beyond the base of
    hpcgfmd.runs.cost (empty for rows written before it was measured)."""
    if not row.get("peak_memory"):
        return ""
    from hpcgfmd.runs.cost import BASE_MEMORY

    nx = int(row["nx"])
    nodes = (nx * nx if row.get("geometry") == "sphere" else nx) / int(row["ranks"])
    peak = float(row["peak_memory"])
    return f"{peak / 1e6:.0f} ({(peak - BASE_MEMORY) / nodes:.0f})"


def uptime():
    return subprocess.run(["uptime"], capture_output=True, text=True, check=False).stdout.strip()


def launch(args):
    """Run this script under ``mpirun -n P`` for each P and grid, then print the report."""
    mpirun = shutil.which("mpirun")
    if mpirun is None:
        sys.exit("--launch needs OpenMPI's mpirun on the PATH")
    env = dict(
        os.environ,
        OMPI_ALLOW_RUN_AS_ROOT="1",
        OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
        OPENBLAS_NUM_THREADS="1",
        OMP_NUM_THREADS="1",
    )
    notes = [f"start: {uptime()}"]
    print(notes[0], flush=True)
    for n in args.n:
        for ranks in args.launch:  # interleaved: the same n_x on every P before the next
            command = [
                mpirun,
                "-n",
                str(ranks),
                sys.executable,
                os.path.abspath(__file__),
                "--n",
                str(n),
                "--steps",
                str(args.steps),
                "--planner",
                args.planner,
                "--geometry",
                args.geometry,
                "--out",
                args.out,
            ]
            status = subprocess.run(command, env=env, check=False).returncode
            if status != 0:  # the measurement printed its own error
                sys.exit(
                    f"bench_scaling: n = 2^{n} on {ranks} rank(s) failed (exit status"
                    f" {status}); rows measured before it, if any, are in {args.out}"
                )
    notes.append(f"end: {uptime()}")
    report(args.out, args.markdown, notes)


def latest_rows(path):
    """The last row per (ranks, nx) of the CSV file, as {nx: {ranks: row}}."""
    table = {}
    with open(path, newline="") as fh:
        for row in csv.DictReader(fh):
            table.setdefault(int(row["nx"]), {})[int(row["ranks"])] = row
    return table


def _sphere_rows(table):
    """The table holds the sphere's rows (the geometry of its rows; a CSV file holds one)."""
    return any(r.get("geometry") == "sphere" for by in table.values() for r in by.values())


def report(path, markdown=None, notes=()):
    """Print the scaling table of the CSV file ``path``; also write it to ``markdown``."""
    head = [
        "n_x",
        "ranks",
        "steps",
        "iterations",
        "s/step",
        "ms/iteration",
        "speedup/it",
        "speedup/step",
        "FFT comm",
        "Domain comm",
        "pairs/it",
        "msgs/it",
        "setup s",
        "preload s (iterations per level, coarsest first)",
        "peak MB/rank (bytes/node)",
        "load of last step",
        "rel. diff",
        "other CPU",
    ]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for nx, by_ranks in sorted(latest_rows(path).items()):
        base = by_ranks[min(by_ranks)]  # the fewest ranks, normally 1
        for ranks, r in sorted(by_ranks.items()):
            it, step = float(r["time_per_iteration"]), float(r["time_per_step"])
            iterations = max(int(r["iterations"]), 1)
            load, load0 = float(r["load"]), float(base["load"])
            cells = [
                f"{nx}^2" if r.get("geometry") == "sphere" else grid_label(nx),
                str(ranks),
                r["steps"],
                r["iterations"],
                f"{step:.4g}",
                f"{1e3 * it:.4g}",
                f"{float(base['time_per_iteration']) / it:.2f}",
                f"{float(base['time_per_step']) / step:.2f}",
                f"{float(r['fft_comm_share']):.1%}",
                f"{float(r['domain_comm_share']):.1%}",
                f"{int(r['fft_pairs']) / iterations:.2f}",
                f"{int(r['messages']) / iterations:.1f}",
                f"{float(r['setup_time']):.3g} ({r['planner'].removeprefix('FFTW_')})",
                f"{float(r['preload_time']):.3g} ({_levels(r)})",
                _memory(r),
                f"{load:.10g}",
                f"{abs(load - load0) / abs(load0):.1e}",
                f"{float(r['other_cpu']):.2f}",
            ]
            lines.append("| " + " | ".join(cells) + " |")
    table = latest_rows(path)
    started = sorted(r["started"] for by_ranks in table.values() for r in by_ranks.values())
    subject = "the documented sphere" if _sphere_rows(latest_rows(path)) else "the default case"
    head = targets.header(f"Scaling of {subject} (scripts/bench_scaling.py, {path})")
    measured = f"rows measured from {started[0]} to {started[-1]}" if started else "no rows"
    sphere = _sphere_rows(table)
    sizes, key, label = (
        (SPHERE_TWO_RANK_SIZES, "sphere_two_ranks", lambda n: f"{2**n}^2")
        if sphere
        else (TWO_RANK_SIZES, "two_ranks", lambda n: f"2^{n}")
    )
    judged = [
        (label(n), float(by[1]["time_per_iteration"]) / float(by[2]["time_per_iteration"]))
        for n, by in ((n, table.get(2**n, {})) for n in sizes)
        if 1 in by and 2 in by
    ]
    if judged:
        verdict = targets.verdict(key, judged)
    elif sphere:
        verdict = targets.no_target("2048^2 on 1 and 2 ranks not measured: --launch 1 2 --n 11")
    else:
        verdict = targets.no_target(
            "2^22 and 2^24 on 1 and 2 ranks not measured: --launch 1 2 --n 22 24"
        )
    text = "\n".join([head.rstrip(), measured, "", *lines, "", *notes, verdict])
    print(text, flush=True)
    if markdown:
        atomic.write_text(markdown, text + "\n")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument(
        "--launch",
        type=int,
        nargs="+",
        metavar="P",
        help="run under mpirun -n P for each P, then report",
    )
    mode.add_argument("--report", metavar="CSV", help="only print the table of this CSV file")
    parser.add_argument(
        "--n",
        type=int,
        nargs="+",
        default=[17, 20, 22],
        help="grid sizes as powers of two, n_x = 2^N, N from 14 to 30",
    )
    parser.add_argument("--steps", type=int, default=20, help="timed retraction steps")
    parser.add_argument(
        "--geometry",
        choices=("cylinder", "sphere"),
        default="cylinder",
        help="the default case on a line, or the documented sphere on n x n nodes (--n: log2 n)",
    )
    parser.add_argument(
        "--planner",
        default="FFTW_MEASURE",
        help="FFTW planner flag (FFTW_ESTIMATE plans in no time)",
    )
    parser.add_argument("--out", default="bench.csv", help="CSV file the rows are appended to")
    parser.add_argument("--markdown", help="also write the table to this Markdown file")
    args = parser.parse_args()
    if args.markdown and not (args.launch or args.report):
        parser.error("--markdown goes with --launch or --report")
    low, high = (6, 15) if args.geometry == "sphere" else (14, 30)
    if not (args.report or all(low <= n <= high for n in args.n)):
        # the default case's zone needs w/dx >= 0.5 (accepted here): 2^14 and finer
        parser.error(f"--n {' '.join(map(str, args.n))}: expected exponents from {low} to {high}")
    if args.report and not os.path.isfile(args.report):
        parser.error(f"--report {args.report}: no such file")
    if args.report:
        report(args.report, args.markdown)
    elif args.launch:
        launch(args)
    else:
        run_here(args)


if __name__ == "__main__":
    main()
