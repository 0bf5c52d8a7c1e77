"""Time ``apply_diagonal`` of the serial and the transposed real FFT in one run.

    python scripts/bench_fft.py --n 17 20 22
    mpirun -n 2 python scripts/bench_fft.py --n 17 20 22

For each n = 2**e three transforms are timed, interleaved round by round so that a change of
machine load hits all of them alike:

* ``serial``: :class:`hpcgfmd.fft.SerialRealFFT` on rank 0 alone;
* ``T x 1``: :class:`hpcgfmd.fft.TransposedRealFFT` on ``COMM_SELF`` of rank 0 alone;
* ``T x P``: :class:`hpcgfmd.fft.TransposedRealFFT` on ``COMM_WORLD`` (only when P > 1).

While rank 0 runs alone the other ranks sleep in a polled ``Ibarrier`` (they do not spin, so
rank 0 has a core to itself as in a one-rank run). A call's time is the wall time on each
rank from a common barrier to its return, maximum over the ranks; the table gives the median
over all calls in ms, the ratios of the medians to ``serial``, the share of the ``T x P`` time
spent in MPI (``communication_time``, maximum over ranks) and the planning times in s.
Set ``OPENBLAS_NUM_THREADS=1``; as root, mpirun also needs the ``OMPI_ALLOW_RUN_AS_ROOT*``
variables.
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
from hpcgfmd.fft import SerialRealFFT, TransposedRealFFT  # noqa: E402


def idle_until_released(comm):
    """Wait in a polled, sleeping Ibarrier until rank 0 enters it (no busy MPI progress)."""
    request = comm.Ibarrier()
    while not request.Test():
        time.sleep(2e-4)


def timed_calls(fft, field, diagonal, out, calls, comm):
    """Wall times of ``calls`` applications, each started after a barrier on ``comm``."""
    times = np.empty(calls)
    for i in range(calls):
        comm.Barrier()
        start = time.perf_counter()
        fft.apply_diagonal(field, diagonal, out)
        times[i] = time.perf_counter() - start
    return times


def setup(fft, n, rng):
    """Input block, even multiplier on the local modes and output block for ``fft``."""
    field = rng.standard_normal(fft.x_stop - fft.x_start)
    multiplier = 1.0 + np.abs(fft.wavenumber) / n  # even in m, as the solver's
    return field, multiplier.astype(np.float64), np.empty_like(field)


def bench(comm, n, rounds, calls, effort):
    """Return a dict of medians (s), communication share and planning times for length n."""
    rank, size = comm.Get_rank(), comm.Get_size()
    rng = np.random.default_rng(rank)
    result = {"n": n}
    alone = {}
    if rank == 0:
        for name, make in (("serial", lambda: SerialRealFFT(n, effort)),
                           ("T x 1", lambda: TransposedRealFFT(MPI.COMM_SELF, n, effort))):
            start = time.perf_counter()
            fft = make()
            result["plan " + name] = time.perf_counter() - start
            alone[name] = (fft, *setup(fft, n, rng))
    start = time.perf_counter()
    wide = TransposedRealFFT(comm, n, effort) if size > 1 else None
    planned = time.perf_counter() - start
    result[f"plan T x {size}"] = comm.allreduce(planned, op=MPI.MAX)
    if wide is not None:
        wide_args = setup(wide, n, rng)
    samples = {name: [] for name in ("serial", "T x 1")}
    samples[f"T x {size}"] = []
    comm_time = wall = 0.0
    for _ in range(rounds + 1):  # round 0 warms up and is dropped
        block = {}
        if rank == 0:
            for name, (fft, *args) in alone.items():
                block[name] = timed_calls(fft, *args, calls, MPI.COMM_SELF)
            if size > 1:
                comm.Ibarrier().Wait()
        else:
            idle_until_released(comm)
        if wide is not None:
            before = wide.communication_time
            times = timed_calls(wide, *wide_args, calls, comm)
            comm_time += wide.communication_time - before
            wall += times.sum()
            block[f"T x {size}"] = comm.allreduce(times, op=MPI.MAX)
        if _:
            for name, times in block.items():
                samples[name].extend(times)
    for name, times in samples.items():
        if rank == 0 and times:
            result[name] = float(np.median(times))
    if wide is not None:
        result["comm share"] = comm.allreduce(comm_time / wall, op=MPI.MAX)
    return result


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, nargs="+", default=[17, 20],
                        help="exponents e of the lengths n = 2**e")
    parser.add_argument("--rounds", type=int, default=10, help="interleaved rounds")
    parser.add_argument("--seconds", type=float, default=0.05,
                        help="target time of one block of calls (sets calls per block)")
    parser.add_argument("--effort", default="FFTW_MEASURE", help="FFTW planner flag")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    size = comm.Get_size()
    rows = []
    for e in args.n:
        n = 2 ** e
        calls = max(3, int(args.seconds / (4e-9 * n * e)))  # ~4 ns * n log2 n per pair
        rows.append(bench(comm, n, args.rounds, calls, args.effort))
    if comm.Get_rank() != 0:
        return
    load = os.getloadavg()
    print(f"# {size} rank(s), {args.rounds} rounds, {args.effort}, "
          f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    wide = f"T x {size}"
    header = f"{'n':>9} {'serial ms':>10} {'T x 1 ms':>9} {'T/serial':>8}"
    if size > 1:
        header += f" {wide + ' ms':>9} {'T/serial':>8} {'comm':>5}"
    header += "   plan s (serial, T x 1" + (f", {wide})" if size > 1 else ")")
    print(header)
    for r in rows:
        line = (f"{'2^%d' % int(np.log2(r['n'])):>9} {1e3 * r['serial']:10.3f} "
                f"{1e3 * r['T x 1']:9.3f} {r['T x 1'] / r['serial']:8.2f}")
        if size > 1:
            line += (f" {1e3 * r[wide]:9.3f} {r[wide] / r['serial']:8.2f} "
                     f"{r['comm share']:5.0%}")
        plans = [r["plan serial"], r["plan T x 1"]] + ([r["plan " + wide]] if size > 1 else [])
        line += "   " + ", ".join(f"{p:.2f}" for p in plans)
        print(line)


if __name__ == "__main__":
    main()
