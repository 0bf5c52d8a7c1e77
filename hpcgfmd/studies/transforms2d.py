"""``python -m hpcgfmd bench fft2d``: one 2-D FFT pair of an n x n grid on 1 and P ranks, timed
in one run.

    python -m hpcgfmd bench fft2d --n 512 1024 2048             # one rank
    mpirun -n 2 python -m hpcgfmd bench fft2d --n 512 1024 2048

For each side n these pairs (``apply_diagonal``: rfft2, multiplier, irfft2, copies in and out
included) are timed, interleaved round by round so that a change of the machine's load hits
all of them alike:

* ``slab x 1``: :class:`hpcgfmd.parallel.fft_slab.SlabRealFFT2D` on rank 0 alone;
* ``FFTW 2-D x 1``: :class:`hpcgfmd.parallel.fft_serial2d.SerialRealFFT2D`, FFTW's plans of
  the whole 2-D rfft and irfft, on rank 0 alone;
* ``slab x P``: the slab transform on all ranks (only when P > 1, with ``--transport``), and
  its speed-up against the one-rank transform that ``plan_real_fft`` takes (FFTW's whole plan
  up to ``WHOLE_PLAN_NODES`` nodes, else the slab one; marked ``*`` in the table);
* ``msgs x P``: the same with the ``Alltoallv`` transport, when the first one is the shared
  window;
* ``mpi4py-fft x 1`` and ``x P``: mpi4py-fft's ``PFFT`` of the same grid (rows over the
  ranks, its FFTW backend, the same planner flag; forward, multiplier, backward), when the
  package is installed (it is no dependency of hpcgfmd).

While rank 0 runs alone the other ranks sleep in a polled ``Ibarrier``. A call's time is the
wall time on each rank from a common barrier to its return (fields aligned as the solvers'
buffers, :func:`~hpcgfmd.parallel.fft_serial.aligned_empty`), maximum over the ranks; the table
gives the median over all calls in ms and per node in ns, the ratios, the share of the
P-rank slab transform's time in its synchronisations (``communication_time``) and the
planning times in s. On a shared machine compare ratios from one run, not times across runs.
"""

import argparse
import sys
import time

import numpy as np
from mpi4py import MPI

from ..parallel import real_fft
from ..parallel.fft import WHOLE_PLAN_NODES
from ..parallel.fft_serial import aligned_empty
from ..parallel.fft_serial2d import SerialRealFFT2D
from ..parallel.fft_slab import SlabRealFFT2D
from ..parallel.transport import TRANSPORTS
from . import report
from .transforms import idle, release, timed_calls

try:
    import mpi4py_fft
except ImportError:  # optional: measured where installed
    mpi4py_fft = None


class Mpi4pyFFT:
    """mpi4py-fft's PFFT of the grid over ``comm`` (rows over the ranks), as a pair."""

    def __init__(self, comm, shape, effort):
        self.fft = mpi4py_fft.PFFT(
            comm, shape, axes=(0, 1), dtype=np.float64, backend="fftw", planner_effort=effort
        )
        self.real = mpi4py_fft.newDistArray(self.fft, False)
        self.half = mpi4py_fft.newDistArray(self.fft, True)
        self.x_size = self.real.size

    def apply_diagonal(self, field, diagonal, out):
        self.real.reshape(-1)[:] = field
        self.fft.forward(self.real, self.half, normalize=False)
        np.multiply(self.half, diagonal, out=self.half)
        self.fft.backward(self.half, self.real, normalize=False)
        out[:] = self.real.reshape(-1)
        return out

    def close(self):
        self.fft.destroy()


def multiplier(shape, size):
    """1/(1 + |m|/n)/n on a spectrum of ``shape`` (as the solver's, a function of |q|; the
    values do not change the time)."""
    return np.full(shape, 1.0 / size) / (1.0 + np.arange(shape[-1]) / shape[-1])


def bench(comm, n, rounds, calls, effort, transport, with_mpi4py):
    """Medians (s), communication share and planning times (s) for an n x n grid, on rank 0."""
    rank, size = comm.Get_rank(), comm.Get_size()
    shape, nodes = (n, n), n * n
    rng = np.random.default_rng(rank)
    result = {"n": n}

    def prepared(fft, nodes_here, spectrum_shape):
        field = aligned_empty(nodes_here)  # as the solvers' buffers: read in place
        field[:] = rng.standard_normal(nodes_here)
        return fft, field, multiplier(spectrum_shape, nodes), aligned_empty(nodes_here)

    alone = {}
    if rank == 0:
        makers = {
            "slab x 1": lambda: SlabRealFFT2D(MPI.COMM_SELF, shape, effort),
            "FFTW 2-D x 1": lambda: SerialRealFFT2D(shape, effort),
        }
        if with_mpi4py:
            makers["mpi4py-fft x 1"] = lambda: Mpi4pyFFT(MPI.COMM_SELF, shape, effort)
        for name, make in makers.items():
            start = time.perf_counter()
            fft = make()
            result["plan " + name] = time.perf_counter() - start
            spectrum = getattr(fft, "spectrum_shape", None) or fft.half.shape
            alone[name] = prepared(fft, nodes, spectrum)
        release(comm)
    else:
        idle(comm)
    wide = {}
    if size > 1:
        makers = {f"slab x {size}": lambda: SlabRealFFT2D(comm, shape, effort, transport)}
        if with_mpi4py:
            makers[f"mpi4py-fft x {size}"] = lambda: Mpi4pyFFT(comm, shape, effort)
        for name, make in makers.items():
            start = time.perf_counter()
            fft = make()
            result["plan " + name] = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
            here = getattr(fft, "x_size", None) or fft.x_stop - fft.x_start
            spectrum = getattr(fft, "spectrum_shape", None) or fft.half.shape
            wide[name] = prepared(fft, here, spectrum)
        result["transport"] = wide[f"slab x {size}"][0].transport
        if result["transport"] == "shared":  # the other transport, for comparison
            start = time.perf_counter()
            fft = SlabRealFFT2D(comm, shape, effort, "messages")
            name = f"msgs x {size}"
            result["plan " + name] = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
            wide[name] = prepared(fft, fft.x_stop - fft.x_start, fft.spectrum_shape)
    samples = {name: [] for name in [*alone, *wide]} if rank == 0 else {name: [] for name in wide}
    communication = dict.fromkeys(wide, 0.0)
    wall = dict.fromkeys(wide, 0.0)
    for round_ in range(rounds + 1):  # round 0 warms up and is not counted
        block = {}
        if rank == 0:
            for name, args in alone.items():
                block[name] = timed_calls(*args, calls, MPI.COMM_SELF)
            release(comm)
        else:
            idle(comm)
        for name, (fft, *args) in wide.items():
            before = getattr(fft, "communication_time", 0.0)
            times = timed_calls(fft, *args, calls, comm)
            worst = np.empty_like(times)
            comm.Allreduce(times, worst, op=MPI.MAX)
            block[name] = worst
            if round_:
                communication[name] += getattr(fft, "communication_time", 0.0) - before
                wall[name] += times.sum()
        if round_:
            for name, times in block.items():
                samples[name].extend(times)
    for name, times in samples.items():
        result[name] = float(np.median(times))
    for name in wide:
        result["comm " + name] = comm.allreduce(communication[name] / wall[name], op=MPI.MAX)
    for fft, *_ in [*alone.values(), *wide.values()]:
        if hasattr(fft, "close"):
            fft.close()
    return result


def _parser():
    parser = argparse.ArgumentParser(
        prog="python -m hpcgfmd bench fft2d",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=__doc__.split("\n\n", 1)[1],
    )
    parser.add_argument(
        "--n", type=int, nargs="+", default=[512, 1024, 2048], help="sides n of the n x n grids"
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
        help="seconds each plan may take (0: no limit)",
    )
    parser.add_argument(
        "--transport", default="auto", choices=TRANSPORTS, help="transport of the P-rank transform"
    )
    parser.add_argument(
        "--no-mpi4py-fft", action="store_true", help="leave mpi4py-fft out even if installed"
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
    if any(n < 4 or n % 2 for n in args.n) or args.rounds < 1:
        if comm.Get_rank() == 0:
            print(
                "bench fft2d: expected even sides of at least 4 and --rounds >= 1", file=sys.stderr
            )
        return 2
    with_mpi4py = mpi4py_fft is not None and not args.no_mpi4py_fft
    if comm.Get_rank() == 0:
        print(
            report.header(f"One 2-D FFT pair on {size} rank(s) (python -m hpcgfmd bench fft2d)"),
            flush=True,
        )
    rows = []
    for n in sorted(set(args.n)):
        nodes = n * n
        calls = max(3, int(args.seconds / (6e-9 * nodes * np.log2(nodes))))
        rows.append(bench(comm, n, args.rounds, calls, args.effort, args.transport, with_mpi4py))
    if comm.Get_rank() != 0:
        return 0
    print(_table(rows, size, with_mpi4py, args), flush=True)
    return 0


def _table(rows, size, with_mpi4py, args):
    """The Markdown table of the medians, with its first line and its closing line."""
    slab, msgs, m4 = f"slab x {size}", f"msgs x {size}", f"mpi4py-fft x {size}"
    messages = size > 1 and any(msgs in r for r in rows)
    head = ["n x n", "slab x 1 ms", "ns/node", "FFTW 2-D x 1 ms", "/slab"]
    names = ["slab x 1", "FFTW 2-D x 1"]
    if with_mpi4py:
        head += ["mpi4py-fft x 1 ms", "/slab"]
        names.append("mpi4py-fft x 1")
    if size > 1:
        head += [f"{slab} ms", "ns/node", "speed-up", "comm"]
        names.append(slab)
        if messages:
            head += [f"{msgs} ms", f"/{slab}"]
            names.append(msgs)
        if with_mpi4py:
            head += [f"{m4} ms", f"/{slab}"]
            names.append(m4)
    head.append("plan s (" + ", ".join(names) + ")")
    table = []
    for r in rows:
        nodes, one, whole = r["n"] ** 2, r["slab x 1"], r["FFTW 2-D x 1"]
        planned = whole if nodes <= WHOLE_PLAN_NODES else one  # plan_real_fft's on one rank
        mark = ("", "*") if nodes <= WHOLE_PLAN_NODES else ("*", "")
        cells = [
            f"{r['n']} x {r['n']}",
            f"{1e3 * one:.3f}{mark[0]}",
            f"{1e9 * one / nodes:.2f}",
            f"{1e3 * whole:.3f}{mark[1]}",
            f"{whole / one:.2f}",
        ]
        if with_mpi4py:
            cells += [f"{1e3 * r['mpi4py-fft x 1']:.3f}", f"{r['mpi4py-fft x 1'] / one:.2f}"]
        if size > 1:
            cells += [
                f"{1e3 * r[slab]:.3f}",
                f"{1e9 * r[slab] / nodes:.2f}",
                f"{planned / r[slab]:.2f}",
                f"{r['comm ' + slab]:.0%}",
            ]
            for name in [msgs] * messages + [m4] * with_mpi4py:
                cells += [f"{1e3 * r[name]:.3f}", f"{r[name] / r[slab]:.2f}"]
        table.append(cells + [", ".join(f"{r['plan ' + name]:.2f}" for name in names)])
    transport = f", transport {rows[0]['transport']}" if size > 1 else ""
    return (
        f"{args.rounds} rounds, {args.effort}, each plan at most"
        f" {args.planning_limit or 'unlimited'} s{transport}; * the one-rank transform of"
        " plan_real_fft, which the speed-up divides\n\n"
        + report.markdown_table(head, table)
        + "\n\n"
        + report.no_target("the two-rank target is per CG iteration of the 2-D engine")
    )
