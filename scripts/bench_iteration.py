"""Cost of one inner CG iteration of the equilibrium solver against a bare FFT pair.

    taskset -c 0 python scripts/bench_iteration.py --n 17 --steps 20
    mpirun -n 2 python scripts/bench_iteration.py --n 17 --steps 20 --out bench.csv
    taskset -c 0 python scripts/bench_iteration.py --geometry sphere --n 10 --steps 10
    taskset -c 0 python scripts/bench_iteration.py --n 17 --steps 4 --solver paper

Prints first the date, the machine and the commit, last (at n_x = 2^17) the verdict on the
target of at most 3 bare pairs of time per iteration, in CPU time (the ``CPU time`` ratio
below: the wall time's on an idle machine, and on a shared one not inflated by the time
other processes hold the core).

Builds the paper's default case (lambda0 = 7, k = 0.1, V_z = 0.45, h0/R = 0.1, L/R = 10,
alpha = 5e-5; ``hpcgfmd/default_case.toml``) at n_x = 2**n, runs the preload and ``--steps``
retraction steps of :class:`hpcgfmd.runs.protocol.Retraction`, and reports for the solves of the
retraction steps (:meth:`hpcgfmd.solvers.cg.ConstrainedCG.solve` only: the predictor, history
and records of a step are outside):

* ms per CG iteration (solve wall time / iterations; the one FFT pair at the start and the
  end of each solve included);
* FFT pairs per iteration (``fft.pairs`` counted inside the solves);
* a bare pair of the same size, timed in the same run, interleaved with the steps (after
  each step, ``--repeats`` calls of each; the minimum over all): ``apply_diagonal`` of the
  case's own transform (the floor the solver sees: copies in and out, multiplier) and a raw
  ``pyfftw.builders`` rfft + irfft pair (FFTW_MEASURE, ``execute`` only, n points on every
  rank);
* the ratio of the per-iteration time to the bare pair, and a profile of the solves: time in
  the transforms (``fft.apply_diagonal``, ``forward``, ``inverse``), in the Domain
  collectives (Python and MPI, waiting included) and the rest (elementwise numpy and
  interpreter), accumulated with ``perf_counter``;
* the check values: load of the last step, total iterations of the retraction steps and
  of the preload, to verify that an optimisation leaves the solution unchanged.

``--geometry sphere`` builds instead docs/examples/sphere.toml's case (the sphere of Maugis's
lambda0 = 3, k = 0.1, V_z = 1, h0/R = 0.01, L/R = 1, alpha = 1e-3) on n x n nodes, n = 2**n,
and times against a bare 2-D pair (the target: at most 3 pairs at 512^2 to 2048^2).


The per-iteration cost is also given as the median over the steps of (solve time / iterations)
/ (the pair timed right after that step), which is robust to a change of the machine's load
between steps, and as the minimum over ``--replays`` repeats of every solve from its start
(each preceded, untimed, by ``energy`` of the start as in the driver's predictor), summed over
the solves: the estimate comparable with the minimum taken for the bare pair when other jobs
share the cores; and in CPU time of the process (solve CPU time per iteration over the fastest
bare pair's CPU time). On a shared machine compare ratios from one run, not times across runs.
``--solver paper`` times the paper's damped Verlet solver instead (its preload is CG, untimed):
an iteration is then one pseudo step, one FFT pair, and ``--equilibration-steps`` sets the
pseudo steps of a solve. ``--tracemalloc`` adds one more step (untimed) solved under
``tracemalloc`` and reports the peak of the memory allocated above the start of the solve
(temporaries). ``--planner FFTW_ESTIMATE`` makes the transforms' round-off the same in every
run, for comparing the check values of two versions (with FFTW_MEASURE the plan, and so the
last digits and the iteration counts, can change between runs). With several ranks the times
are the maximum over the ranks.
"""

import argparse
import json
import os
import sys
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np
import pyfftw
import pyfftw.builders
from mpi4py import MPI

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from hpcgfmd import atomic
from hpcgfmd.case import case_file_text, parse_case
from hpcgfmd.errors import CaseError
from hpcgfmd.runs.protocol import Retraction
from hpcgfmd.studies import report

DEFAULT_GROUPS = {
    "maugis": 7.0,
    "modulus_ratio": 0.1,
    "velocity": 0.45,
    "depth": 0.1,
    "cell": 10.0,
    "adhesion": 5e-5,
}
SPHERE_GROUPS = {  # docs/examples/sphere.toml
    "geometry": "sphere",
    "maugis": 3.0,
    "modulus_ratio": 0.1,
    "velocity": 1.0,
    "depth": 0.01,
    "cell": 1.0,
    "adhesion": 1e-3,
}
STATISTICS = ("projections", "cut_steps", "residual_steps", "held_steps", "recalled")
COLLECTIVES = (
    "sums",
    "sum",
    "dot",
    "count",
    "maxes",
    "max",
    "min",
    "max_abs",
    "any",
    "all",
    "fill_halo",
    "segment",
    "index_extent",
)


class Clock:
    """Accumulates perf_counter time of wrapped calls (outermost call only)."""

    def __init__(self):
        self.total = 0.0
        self.calls = 0
        self.depth = 0
        self.active = False

    def wrap(self, function):
        def timed(*args, **kwargs):
            if self.depth or not self.active:
                return function(*args, **kwargs)
            self.depth = 1
            start = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                self.total += time.perf_counter() - start
                self.calls += 1
                self.depth = 0

        return timed


class Profile:
    """Wraps the solver's FFT and collectives and its solve; counts time, pairs, iterations."""

    def __init__(self, sim):
        self.sim = sim
        self.fft = Clock()
        self.collective = Clock()
        self.solve_time = 0.0
        self.mpi_time = 0.0  # MPI calls inside the solves (domain and transform)
        self.replays = 0
        self.replay_time = 0.0  # sum over the solves of the minimum replay time
        self.solve_cpu = 0.0  # CPU time of this process in the solves
        self.solves = 0
        self.pairs = 0
        self.iterations = 0
        self.active = False
        for name in ("apply_diagonal", "forward", "inverse"):  # (the Verlet solver's halves)
            setattr(sim.fft, name, self.fft.wrap(getattr(sim.fft, name)))
        for name in COLLECTIVES:
            setattr(sim.domain, name, self.collective.wrap(getattr(sim.domain, name)))
        solve = sim.solver.solve

        def timed_solve(*args, **kwargs):
            if not self.active:
                return solve(*args, **kwargs)
            initial = args[0].copy()
            pairs = sim.fft.pairs
            waited = sim.domain.communication_time + sim.fft.communication_time
            self.fft.active = self.collective.active = True
            start, cpu = time.perf_counter(), time.process_time()
            try:
                result = solve(*args, **kwargs)
            finally:
                self.fft.active = self.collective.active = False
            self.solve_time += time.perf_counter() - start
            self.solve_cpu += time.process_time() - cpu
            self.pairs += sim.fft.pairs - pairs
            self.mpi_time += sim.domain.communication_time + sim.fft.communication_time - waited
            self.iterations += result.iterations
            self.solves += 1
            if self.replays:
                self.replay_time += self._replay(solve, initial, *args[1:], **kwargs)
            return result

        sim.solver.solve = timed_solve

    def _replay(self, solve, start, wall, ops, history, *rest, **kwargs):
        """Minimum time of ``replays`` repeats of the solve just done, from the same start.

        Each repeat is preceded (untimed) by ``energy`` of the start, as the driver's
        predictor does, so a solver that keeps K of evaluated vectors sees the same cache.
        The solve is deterministic: the last repeat leaves the solver as the real one did.
        """
        best = np.inf
        u = np.empty_like(start)
        solver = self.sim.solver
        counters = solver.counters()
        pairs = self.sim.fft.pairs
        for _ in range(self.replays):
            u[:] = start
            self.sim.solver.problem.energy(u, wall, ops, history)
            self.sim.domain.comm.Barrier()
            begin = time.perf_counter()
            solve(u, wall, ops, history, *rest, **kwargs)
            best = min(best, time.perf_counter() - begin)
        solver.restore_counters(counters)  # the counters count the real solves only
        self.sim.fft.pairs = pairs
        return best

    def start(self):
        self.active = True
        self.fft.total = self.collective.total = 0.0

    def snapshot(self):
        return (self.solve_time, self.fft.total, self.collective.total, self.iterations)


def bare_pairs(fft, shape, repeats):
    """Makes the two bare-pair timers: (apply_diagonal, raw builders pair), each -> seconds
    (the grid's ``shape``: (n,) or (n, n))."""
    rng = np.random.default_rng(fft.comm.Get_rank())
    field = rng.standard_normal(fft.x_stop - fft.x_start)
    nodes = int(np.prod(shape))
    diagonal = (1.0 + np.abs(fft.wavenumber) / shape[-1]) / nodes
    out = np.empty_like(field)
    raw_in = pyfftw.empty_aligned(shape, dtype="float64")
    forward = pyfftw.builders.rfftn(
        raw_in, planner_effort="FFTW_MEASURE", threads=1, avoid_copy=True
    )
    backward = pyfftw.builders.irfftn(
        forward.output_array, s=shape, planner_effort="FFTW_MEASURE", threads=1, avoid_copy=True
    )
    raw_in[:] = rng.standard_normal(shape)
    comm = fft.comm

    def timed(call):
        """(wall, CPU) seconds of the fastest of ``repeats`` calls."""
        best, best_cpu = np.inf, np.inf
        for _ in range(repeats):
            comm.Barrier()
            start, cpu = time.perf_counter(), time.process_time()
            call()
            best = min(best, time.perf_counter() - start)
            best_cpu = min(best_cpu, time.process_time() - cpu)
        return comm.allreduce(best, op=MPI.MAX), comm.allreduce(best_cpu, op=MPI.MAX)

    def pair():
        forward.execute()
        backward.execute()

    return (lambda: timed(lambda: fft.apply_diagonal(field, diagonal, out)), lambda: timed(pair))


def peak_temporaries(sim):
    """One more step solved under tracemalloc: peak bytes above the start of the solve."""
    import tracemalloc

    solve = sim.solver.solve
    peaks = []

    def traced(*args, **kwargs):
        tracemalloc.start()
        base = tracemalloc.get_traced_memory()[0]
        tracemalloc.reset_peak()
        result = solve(*args, **kwargs)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        peaks.append((peak - base, result.iterations))
        return result

    sim.solver.solve = traced
    sim.step()
    sim.solver.solve = solve
    return peaks[-1]


def _parser():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--n",
        type=int,
        default=17,
        help=("n_x = 2**n (default 17; from 13: the default case needs about 7600 nodes)"),
    )
    parser.add_argument("--steps", type=int, default=20, help="retraction steps timed")
    parser.add_argument(
        "--geometry",
        choices=("cylinder", "sphere"),
        default="cylinder",
        help="the paper's default case on a line (default) or the documented sphere on n x n",
    )
    parser.add_argument(
        "--repeats", type=int, default=5, help="bare pairs timed after each step (minimum taken)"
    )
    parser.add_argument(
        "--replays",
        type=int,
        default=3,
        help="repeats of every timed solve from its start (minimum taken)",
    )
    parser.add_argument("--out", help="append the result as a CSV row to this file")
    parser.add_argument("--record", help="write the per-step loads and iterations (JSON)")
    parser.add_argument(
        "--tracemalloc",
        action="store_true",
        help="one more step under tracemalloc: peak temporaries of a solve",
    )
    parser.add_argument(
        "--planner",
        default="FFTW_MEASURE",
        help="planner of the case's transform (FFTW_ESTIMATE: the same plan in"
        " every run, for comparing check values bitwise between versions)",
    )
    parser.add_argument(
        "--solver",
        default="cg",
        choices=("cg", "paper"),
        help="the equilibrium solver timed (paper: the damped Verlet GFMD, per pseudo step)",
    )
    parser.add_argument(
        "--equilibration-steps",
        type=int,
        default=200,
        help="pseudo steps per solve of --solver paper (default 200)",
    )
    parser.add_argument(
        "--ranks", type=int, default=None, help="ignored (the rank count is mpirun's)"
    )
    return parser


def main():
    parser = _parser()
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    rank = comm.Get_rank()
    n = 2**args.n
    sphere = args.geometry == "sphere"
    numerics = {"n": n} if sphere else {"nx": n}
    if args.solver != "cg":
        numerics.update(solver=args.solver, equilibration_steps=args.equilibration_steps)
    text = case_file_text(SPHERE_GROUPS if sphere else DEFAULT_GROUPS, numerics)
    try:
        case = parse_case(text)
    except CaseError as err:  # too coarse a grid: one line
        parser.error(f"--n {args.n}: {err}")
    if rank == 0:
        print(report.header("Cost per CG iteration (scripts/bench_iteration.py)"), flush=True)
    start = time.perf_counter()
    sim = Retraction(case, comm, planner_effort=args.planner)
    applied, raw = bare_pairs(sim.fft, case.numerics.shape, args.repeats)
    setup = time.perf_counter() - start
    profile = Profile(sim)
    profile.replays = args.replays
    preload = sim.preload()
    start_pairs = sim.fft.pairs
    profile.start()
    loads, iterations, per_step = [preload.load], [preload.iterations], []
    pair_applied, pair_raw = [], []
    pair_applied.append(applied())
    pair_raw.append(raw())
    pair_applied_cpu = [pair_applied[-1][1]]
    pair_applied[-1] = pair_applied[-1][0]
    pair_raw[-1] = pair_raw[-1][0]
    for _ in range(args.steps):
        before = profile.snapshot()
        record = sim.step()
        after = profile.snapshot()
        wall_time, cpu_time = applied()
        pair_applied.append(wall_time)
        pair_applied_cpu.append(cpu_time)
        pair_raw.append(raw()[0])
        solve_time = comm.allreduce(after[0] - before[0], op=MPI.MAX)
        if record.iterations:
            per_step.append(solve_time / record.iterations / pair_applied[-1])
        loads.append(record.load)
        iterations.append(record.iterations)
    profile.active = False
    temporaries = peak_temporaries(sim) if args.tracemalloc else None
    times = (pair_applied, pair_applied_cpu, pair_raw, per_step, setup, start_pairs)
    result = _result(comm, sim, profile, args, n, times, loads, iterations, temporaries)
    if rank != 0:
        return
    _print(comm, sim, profile, args, n, result, loads, iterations, temporaries, pair_applied)
    if args.out:
        new = not os.path.exists(args.out)
        with open(args.out, "a") as fh:
            if new:
                fh.write(",".join(result) + "\n")
            fh.write(
                ",".join(repr(v) if isinstance(v, float) else str(v) for v in result.values())
                + "\n"
            )
    if args.record:
        atomic.write_text(args.record, json.dumps({"loads": loads, "iterations": iterations}))


def _result(comm, sim, profile, args, n, times, loads, iterations, temporaries):
    """The measured figures (reduced over the ranks)."""
    pair_applied, pair_applied_cpu, pair_raw, per_step, setup, start_pairs = times
    solve_time = comm.allreduce(profile.solve_time, op=MPI.MAX)
    replay_time = comm.allreduce(profile.replay_time, op=MPI.MAX)
    solve_cpu = comm.allreduce(profile.solve_cpu, op=MPI.MAX)
    pair_cpu = min(pair_applied_cpu)
    fft_time = comm.allreduce(profile.fft.total, op=MPI.MAX)
    coll_time = comm.allreduce(profile.collective.total, op=MPI.MAX)
    its = profile.iterations
    per_iteration = solve_time / its
    pair = min(pair_applied)
    pair_builders = min(pair_raw)
    pairs_per_it = profile.pairs / its
    result = {
        "n": n,
        "solver": args.solver,
        "ranks": comm.Get_size(),
        "steps": args.steps,
        "iterations": its,
        "ms_per_iteration": 1e3 * per_iteration,
        "pairs_per_iteration": pairs_per_it,
        "pair_ms": 1e3 * pair,
        "raw_pair_ms": 1e3 * pair_builders,
        "ratio": per_iteration / pair,
        "ratio_raw": per_iteration / pair_builders,
        "ratio_median_step": float(np.median(per_step)) if per_step else float("nan"),
        "replay_ms_per_iteration": 1e3 * replay_time / its,
        "replay_ratio": replay_time / its / pair,
        "cpu_ms_per_iteration": 1e3 * solve_cpu / its,
        "pair_cpu_ms": 1e3 * pair_cpu,
        "cpu_ratio": solve_cpu / its / pair_cpu,
        "fft_share": fft_time / solve_time,
        "collective_share": coll_time / solve_time,
        "other_share": 1.0 - (fft_time + coll_time) / solve_time,
        "fft_ms_per_iteration": 1e3 * fft_time / its,
        "other_ms_per_iteration": 1e3 * (solve_time - fft_time - coll_time) / its,
        "collective_ms_per_iteration": 1e3 * coll_time / its,
        "mpi_ms_per_iteration": 1e3 * comm.allreduce(profile.mpi_time, op=MPI.MAX) / its,
        "load_last": loads[-1],
        "iterations_total": int(sum(iterations[1:])),
        "iterations_preload": int(iterations[0]),
        **{key: sim.solver.counters().get(key, 0) for key in STATISTICS},
        "pairs_outside_solves": sim.fft.pairs - start_pairs - profile.pairs,
        "setup_s": setup,
        "load_average": os.getloadavg()[0],
    }
    if temporaries is not None:
        result["temporaries_kib"] = temporaries[0] / 1024.0
    return result


def _print(comm, sim, profile, args, n, result, loads, iterations, temporaries, pair_applied):
    """Rank 0: the report of :func:`_result`'s figures, the target's verdict."""
    its, per_iteration = result["iterations"], result["ms_per_iteration"] / 1e3
    pairs_per_it, pair = result["pairs_per_iteration"], result["pair_ms"] / 1e3
    print(
        f"n = 2^{args.n} = {n}{' per side' if sim.domain.dimensions == 2 else ''},"
        f" {comm.Get_size()} rank(s), {args.steps} retraction steps,"
        f" {its} CG iterations (preload {iterations[0]}); load average"
        f" {result['load_average']:.2f} (shared machine: compare ratios within one run)"
    )
    print(
        f"  bare pair: apply_diagonal {result['pair_ms']:.3f} ms, raw builders rfft+irfft"
        f" {result['raw_pair_ms']:.3f} ms (min over {len(pair_applied) * args.repeats})"
    )
    print(
        f"  per iteration {result['ms_per_iteration']:.3f} ms = {result['ratio']:.2f} pairs"
        f" of time (raw pair: {result['ratio_raw']:.2f}; median over steps"
        f" {result['ratio_median_step']:.2f}); {pairs_per_it:.3f} FFT pairs per iteration"
    )
    print(
        f"  CPU time of this process: {result['cpu_ms_per_iteration']:.3f} ms per iteration,"
        f" bare pair {result['pair_cpu_ms']:.3f} ms: {result['cpu_ratio']:.2f} pairs"
    )
    if args.replays:
        print(
            f"  per iteration, minimum of {args.replays} replays of each solve:"
            f" {result['replay_ms_per_iteration']:.3f} ms = {result['replay_ratio']:.2f} pairs"
            " of time"
        )
    print(
        f"  profile per iteration: FFT {result['fft_ms_per_iteration']:.3f} ms"
        f" ({100 * result['fft_share']:.0f} %), elementwise/other"
        f" {result['other_ms_per_iteration']:.3f} ms ({100 * result['other_share']:.0f} %),"
        f" collectives {result['collective_ms_per_iteration']:.3f} ms"
        f" ({100 * result['collective_share']:.0f} %); MPI calls in the collectives and"
        f" transforms {result['mpi_ms_per_iteration']:.3f} ms"
    )
    stats = {key: result[key] for key in STATISTICS}
    print(
        f"  solver {args.solver}: {stats['projections']} projections,"
        f" {stats['cut_steps']} cut steps,"
        f" {stats['residual_steps']} along the residual,"
        f" {stats['held_steps']} with held nodes,"
        f" {stats['recalled']} first transforms recalled"
        f" (since start, {profile.solves} timed solves)"
    )
    if temporaries is not None:
        print(
            f"  tracemalloc: peak {result['temporaries_kib']:.1f} KiB above the start of a"
            f" solve of {temporaries[1]} iterations (one vector = {8 * n / 1024:.0f} KiB)"
        )
    print(
        f"  check: load_last = {loads[-1]:.15e}, iterations = {result['iterations_total']}"
        f" (+ preload {iterations[0]})"
    )
    print(
        f"RESULT n={n} ranks={comm.Get_size()} ms_per_iteration={per_iteration * 1e3:.3f}"
        f" pairs_per_iteration={pairs_per_it:.3f} pair_ms={pair * 1e3:.3f}"
        f" ratio={result['ratio']:.2f} replay_ratio={result['replay_ratio']:.2f}"
        f" cpu_ratio={result['cpu_ratio']:.2f} load_last={loads[-1]:.15e}"
        f" iterations={result['iterations_total']}"
    )
    # judged in CPU time: equal to the wall time's ratio on an idle machine, and on a shared
    # one not inflated by the time other processes hold the core
    where = f"on {comm.Get_size()} rank(s), in CPU time"
    if sim.domain.dimensions == 2:
        print(
            report.verdict("sphere_iteration_pairs", result["cpu_ratio"], f"{n}^2 {where}")
            if 9 <= args.n <= 11
            else report.no_target("the sphere's target is at 512^2 to 2048^2: --n 9 to 11")
        )
        return
    print(
        report.verdict("iteration_pairs", result["cpu_ratio"], where)
        if n == 2**17 and args.solver == "cg"
        else report.no_target("the target is CG's at n_x = 2^17: --n 17 --solver cg")
    )


if __name__ == "__main__":
    main()
