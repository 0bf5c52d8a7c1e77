"""Time ``apply_diagonal`` of the serial, the transposed and the halved real FFT in one run.

    python scripts/bench_fft.py --n 17 20 22
    mpirun -n 2 python scripts/bench_fft.py --n 17 20 22
    python scripts/bench_fft.py --sizes 65536 73728 98304 131072   # any even lengths

For each n = 2**e up to four transforms are timed, interleaved round by round so that a
change of the machine's load hits all of them alike:

* ``serial``: :class:`hpcgfmd.parallel.SerialRealFFT` on rank 0 alone;
* ``T x 1``: :class:`hpcgfmd.parallel.TransposedRealFFT` on ``COMM_SELF`` of rank 0 alone;
* ``T x P``: :class:`hpcgfmd.parallel.TransposedRealFFT` on ``COMM_WORLD`` (only when P > 1);
* ``H x 2``: :class:`hpcgfmd.parallel.HalvedRealFFT` on ``COMM_WORLD`` (only when P = 2 and
  4 divides n): the transform two-rank runs use.

While rank 0 plans or runs alone the other ranks sleep in a polled ``Ibarrier`` (they do not
spin, so rank 0 has a core to itself as in a one-rank run). A call's time is the wall time on
each rank from a common barrier to its return, maximum over the ranks; the table gives the
median over all calls in ms, the ratios of the medians to ``serial``, the share of the
``T x P`` time spent in its synchronisations (``communication_time``, maximum over ranks,
waiting for the other ranks included) and the planning times in s. The load average is
printed with the table: on a shared machine compare ratios from one run, not times across
runs. Set ``OPENBLAS_NUM_THREADS=1``; as root, mpirun also needs the ``OMPI_ALLOW_RUN_AS_ROOT``
and ``OMPI_ALLOW_RUN_AS_ROOT_CONFIRM`` variables.
"""
import argparse
import os
import sys
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from hpcgfmd.model.grid import grid_label  # noqa: E402
from hpcgfmd.parallel.fft import HalvedRealFFT, SerialRealFFT, TransposedRealFFT  # noqa: E402
from hpcgfmd.parallel.fft_halved import fits  # noqa: E402
from hpcgfmd.parallel.fft_transposed import TRANSPORTS  # noqa: E402


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
        for name, make in (("serial", lambda: SerialRealFFT(n, effort)),
                           ("T x 1", lambda: TransposedRealFFT(MPI.COMM_SELF, n, effort))):
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
    wide = {}
    for name, make in makers.items():
        start = time.perf_counter()
        fft = make()
        result["plan " + name] = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
        result["transport"] = fft.transport
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


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, nargs="+",
                        help="exponents e of the lengths n = 2**e (default 17 20 without --sizes)")
    parser.add_argument("--sizes", type=int, nargs="+", default=[],
                        help="further lengths n, any even number (the automatic grids f 2^a)")
    parser.add_argument("--rounds", type=int, default=10, help="interleaved rounds")
    parser.add_argument("--seconds", type=float, default=0.05,
                        help="rough time of one block of calls (sets the calls per block)")
    parser.add_argument("--effort", default="FFTW_MEASURE", help="FFTW planner flag")
    parser.add_argument("--transport", default="auto", choices=TRANSPORTS,
                        help="transport of the P-rank transform")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    size = comm.Get_size()
    rows = []
    exponents = args.n if args.n or args.sizes else [17, 20]
    lengths = sorted({2 ** e for e in exponents or []} | set(args.sizes))
    for n in lengths:
        calls = max(3, int(args.seconds / (6e-9 * n * np.log2(n))))  # ~6 ns n log2 n per pair
        rows.append(bench(comm, n, args.rounds, calls, args.effort, args.transport))
    if comm.Get_rank() != 0:
        return
    load = os.getloadavg()
    # the transforms over all ranks (none on one rank: "T x 1" is the column before them)
    wides = [name for name in (f"T x {size}", "H x 2")
             if size > 1 and any(name in r for r in rows)]
    title = f"# {size} rank(s), {args.rounds} rounds, {args.effort}"
    if size > 1:
        title += f", transport {rows[0]['transport']}"
    print(title + f", load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    header = f"{'n':>7} {'serial ms':>10} {'ns/node':>7} {'T x 1 ms':>9} {'/serial':>7}"
    for name in wides:
        header += f" {name + ' ms':>9} {'/serial':>7} {'comm':>5}"
    print(header + "   plan s (" + ", ".join(["serial", "T x 1", *wides]) + ")")
    for r in rows:
        line = (f"{grid_label(r['n']):>7} {1e3 * r['serial']:10.3f} "
                f"{1e9 * r['serial'] / r['n']:7.2f} "
                f"{1e3 * r['T x 1']:9.3f} {r['T x 1'] / r['serial']:7.2f}")
        plans = [r["plan serial"], r["plan T x 1"]]
        for name in wides:
            if name in r:
                line += (f" {1e3 * r[name]:9.3f} {r[name] / r['serial']:7.2f} "
                         f"{r['comm ' + name]:5.0%}")
                plans.append(r["plan " + name])
            else:
                line += f" {'-':>9} {'-':>7} {'-':>5}"
        print(line + "   " + ", ".join(f"{p:.2f}" for p in plans))


if __name__ == "__main__":
    main()
