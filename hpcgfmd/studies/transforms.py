"""``python -m hpcgfmd bench fft``: one FFT pair of the serial, the transposed and the halved
real transform, timed in one run.

    python -m hpcgfmd bench fft --sizes 65536 73728 98304 131072   # one rank, any even lengths
    mpirun -n 2 python -m hpcgfmd bench fft --n 13 14 15 16 17 20

For each length up to four transforms are timed, interleaved round by round so that a
change of the machine's load hits all of them alike:

* ``serial``: :class:`hpcgfmd.parallel.SerialRealFFT` on rank 0 alone;
* ``T x 1``: :class:`hpcgfmd.parallel.TransposedRealFFT` on ``COMM_SELF`` of rank 0 alone;
* ``T x P``: :class:`hpcgfmd.parallel.TransposedRealFFT` on all ranks (only when P > 1);
* ``H x 2``: :class:`hpcgfmd.parallel.HalvedRealFFT` on all ranks (only when P = 2 and 4
  divides n): the transform two-rank runs use;
* ``S/P x P``: every rank its own :class:`~hpcgfmd.parallel.SerialRealFFT` of n/P nodes, all
  at once, with no exchange: the split of the work without its exchanges. Its plans are
  limited like the serial one's, so from about 2^20 nodes, where a limited whole-length plan
  is poor, it measures that plan's quality as much as the cores' shared caches and memory
  (docs/results.md, "Large transforms").

While rank 0 plans or runs alone the other ranks sleep in a polled ``Ibarrier`` (they do not
spin, so rank 0 has a core to itself as in a one-rank run). A call's time is the wall time on
each rank from a common barrier to its return (``apply_diagonal``: copies in and out and the
multiplier included), maximum over the ranks; the table gives the median over all calls in
ms, the ratios of the medians to ``serial``, the share of the P-rank transforms' time spent in
their synchronisations (``communication_time``, maximum over ranks, waiting for the other
ranks included) and the planning times in s. On a shared machine compare ratios from one run,
not times across runs.
"""

import argparse
import sys
import time

import numpy as np
from mpi4py import MPI

from ..model.grid import grid_label
from ..parallel import real_fft
from ..parallel.fft import HalvedRealFFT, SerialRealFFT, TransposedRealFFT
from ..parallel.fft_halved import fits
from ..parallel.fft_transposed import TRANSPORTS
from . import report


def release(comm):
    """Rank 0: let the other ranks out of :func:`idle`."""
    if comm.Get_size() > 1:
        comm.Ibarrier().Wait()


def idle(comm):
    """Other ranks: sleep in a polled Ibarrier until rank 0 calls :func:`release`."""
    request = comm.Ibarrier()
    while not request.Test():
        time.sleep(2e-4)


def timed_calls(fft, field, diagonal, out, calls, comm):
    """Wall times (s) of ``calls`` applications, each started after a barrier on ``comm``."""
    times = np.empty(calls)
    for i in range(calls):
        comm.Barrier()
        start = time.perf_counter()
        fft.apply_diagonal(field, diagonal, out)
        times[i] = time.perf_counter() - start
    return times


def inputs(fft, n, rng):
    """Input block, even multiplier (1/n folded in) on the local modes and output block."""
    field = rng.standard_normal(fft.x_stop - fft.x_start)
    multiplier = (1.0 + np.abs(fft.wavenumber) / n) / n  # even in m, as the solver's
    return field, multiplier, np.empty_like(field)


def bench(comm, n, rounds, calls, effort, transport):
    """Medians (s), communication share and planning times (s) for length n, on rank 0."""
    rank, size = comm.Get_rank(), comm.Get_size()
    wide_name = f"T x {size}"
    rng = np.random.default_rng(rank)
    result = {"n": n}
    alone = {}
    if rank == 0:
        for name, make in (
            ("serial", lambda: SerialRealFFT(n, effort)),
            ("T x 1", lambda: TransposedRealFFT(MPI.COMM_SELF, n, effort)),
        ):
            start = time.perf_counter()
            fft = make()
            result["plan " + name] = time.perf_counter() - start
            alone[name] = (fft, *inputs(fft, n, rng))
        release(comm)
    else:
        idle(comm)
    makers = {}
    if size > 1:
        makers[wide_name] = lambda: TransposedRealFFT(comm, n, effort, transport=transport)
    if fits(size, n):
        makers["H x 2"] = lambda: HalvedRealFFT(comm, n, effort, transport=transport)
    if size > 1 and n % size == 0 and (n // size) % 2 == 0:
        # the ideal split: every rank its own serial transform of n/P nodes, all at once
        makers[f"S/{size} x {size}"] = lambda: SerialRealFFT(n // size, effort)
    wide = {}
    for name, make in makers.items():
        start = time.perf_counter()
        fft = make()
        result["plan " + name] = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
        result["transport"] = getattr(fft, "transport", result.get("transport"))
        wide[name] = (fft, *inputs(fft, n, rng))
    samples = {name: [] for name in ["serial", "T x 1", *makers]}
    communication = dict.fromkeys(wide, 0.0)
    wall = dict.fromkeys(wide, 0.0)
    for round_ in range(rounds + 1):  # round 0 warms up and is not counted
        block = {}
        if rank == 0:
            for name, (fft, *args) in alone.items():
                block[name] = timed_calls(fft, *args, calls, MPI.COMM_SELF)
            release(comm)
        else:
            idle(comm)
        for name, (fft, *args) in wide.items():
            before = fft.communication_time
            times = timed_calls(fft, *args, calls, comm)
            worst = np.empty_like(times)
            comm.Allreduce(times, worst, op=MPI.MAX)
            block[name] = worst
            if round_:
                communication[name] += fft.communication_time - before
                wall[name] += times.sum()
        if round_:
            for name, times in block.items():
                samples[name].extend(times)
    for name, times in samples.items():
        if times:
            result[name] = float(np.median(times))
    for name, (fft, *_) in wide.items():
        result["comm " + name] = comm.allreduce(communication[name] / wall[name], op=MPI.MAX)
        fft.close()
    return result


def _parser():
    parser = argparse.ArgumentParser(
        prog="python -m hpcgfmd bench fft",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=__doc__.split("\n\n", 1)[1],
    )
    parser.add_argument(
        "--n",
        type=int,
        nargs="+",
        help="exponents e of the lengths n = 2**e (default 17 20 without --sizes)",
    )
    parser.add_argument(
        "--sizes",
        type=int,
        nargs="+",
        default=[],
        help="further lengths n, any even number (the automatic grids f 2^a)",
    )
    parser.add_argument("--rounds", type=int, default=10, help="interleaved rounds")
    parser.add_argument(
        "--seconds",
        type=float,
        default=0.05,
        help="rough time of one block of calls (sets the calls per block)",
    )
    parser.add_argument("--effort", default="FFTW_MEASURE", help="FFTW planner flag")
    parser.add_argument(
        "--planning-limit",
        type=float,
        default=real_fft.PLANNING_TIMELIMIT,
        help="seconds each plan may take (0: no limit; with HPCGFMD_WISDOM=off: planned anew)",
    )
    parser.add_argument(
        "--transport", default="auto", choices=TRANSPORTS, help="transport of the P-rank transform"
    )
    return parser


def main(comm, argv=None):
    """Collective: the mode's command line; the exit status."""
    try:
        args = _parser().parse_args(argv)
    except SystemExit as exit_:
        return int(exit_.code or 0)
    size = comm.Get_size()
    real_fft.PLANNING_TIMELIMIT = args.planning_limit or None  # read as each plan is made
    exponents = args.n if args.n or args.sizes else [17, 20]
    lengths = sorted({2**e for e in exponents or []} | set(args.sizes))
    if any(n < 16 or n % 2 for n in lengths) or args.rounds < 1:
        if comm.Get_rank() == 0:
            print(
                "bench fft: expected even lengths of at least 16 and --rounds >= 1", file=sys.stderr
            )
        return 2
    if comm.Get_rank() == 0:
        print(
            report.header(f"One FFT pair on {size} rank(s) (python -m hpcgfmd bench fft)"),
            flush=True,
        )
    rows = []
    for n in lengths:
        calls = max(3, int(args.seconds / (6e-9 * n * np.log2(n))))  # ~6 ns n log2 n per pair
        rows.append(bench(comm, n, args.rounds, calls, args.effort, args.transport))
    if comm.Get_rank() != 0:
        return 0
    # the transforms over all ranks (none on one rank: "T x 1" is the column before them)
    names = (f"T x {size}", "H x 2", f"S/{size} x {size}")
    wides = [name for name in names if size > 1 and any(name in r for r in rows)]
    head = ["n", "serial ms", "ns/node", "T x 1 ms", "/serial"]
    for name in wides:
        head += [f"{name} ms", "/serial", "comm"]
    head.append("plan s (" + ", ".join(["serial", "T x 1", *wides]) + ")")
    table = []
    for r in rows:
        cells = [
            grid_label(r["n"]),
            f"{1e3 * r['serial']:.3f}",
            f"{1e9 * r['serial'] / r['n']:.2f}",
            f"{1e3 * r['T x 1']:.3f}",
            f"{r['T x 1'] / r['serial']:.2f}",
        ]
        plans = [r["plan serial"], r["plan T x 1"]]
        for name in wides:
            if name in r:
                cells += [
                    f"{1e3 * r[name]:.3f}",
                    f"{r[name] / r['serial']:.2f}",
                    f"{r['comm ' + name]:.0%}",
                ]
                plans.append(r["plan " + name])
            else:
                cells += ["-", "-", "-"]
        table.append(cells + [", ".join(f"{p:.2f}" for p in plans)])
    transport = f", transport {rows[0]['transport']}" if size > 1 else ""
    print(
        f"{args.rounds} rounds, {args.effort}, each plan at most"
        f" {args.planning_limit or 'unlimited'} s{transport}\n\n"
        + report.markdown_table(head, table)
        + "\n\n"
        + report.no_target("the two-rank target is per CG iteration: scripts/bench_scaling.py"),
        flush=True,
    )
    return 0
