"""An anchor on the same core: Tamaas 2.9 and hpcgfmd solve the same non-adhesive sphere.

    pip install tamaas==2.9.0
    taskset -c 0 python scripts/bench_tamaas.py --n 512 1024

The problem (both codes, n x n nodes)
    A rigid paraboloid h = r^2 / (2R) (docs/model.md, "The sphere") pressed to the depth
    d = 0.01 R into an elastic periodic half-space of E* = 1 on a square cell L x L, L = R = 1,
    without adhesion: Hertz's contact radius sqrt(R d) = L / 10 (the periodic images make it
    about 11 % larger). The nodes are hpcgfmd's, the apex on node (n/2, n/2); Tamaas gets the
    same heights as an n x n array (rows y, columns x), so the two fields compare node by
    node. Both codes use the same kernel: (M4) sampled at the grid's wavenumbers.

    hpcgfmd: :class:`~hpcgfmd.solvers.cg.ConstrainedCG` on one rank (FFTW_MEASURE, its
    planning timed apart), the wall h - d, zero-mean displacement u, gap h - d - u >= 0
    (M2) with u_z = -d. Tamaas: ``model_type.basic_2d`` (E = 1, nu = 0: its E* = E / (1 -
    nu^2) = 1, checked), the Westergaard operator, ``PolonskyKeerRey`` with the gap as primal
    and its mean as the constraint. Tamaas's rigid surface is below the elastic body, so it
    gets -h, and its gap is u_T + h >= 0 with u_T = -u - d: its displacement carries the
    rigid approach in its mean (-d), hpcgfmd's puts it in the wall. The gap fields are then
    one field, and its mean fixes the problem: mean(h) - d, since mean(u) = 0 (the q = 0 mode
    has no stiffness in either code). So "gap" control at that mean gap is hpcgfmd's
    displacement control at depth d. A third solve, Tamaas's own primal, the pressure, in load
    control at the reference load (below), shows Tamaas's fastest path to the same solution.

Tolerances (what each solver tests; both stop there)
    hpcgfmd: max |projected residual traction| <= tol p0, tol = 1e-8, p0 = 2 E* sqrt(d / R) /
    pi = 0.064, Hertz's peak pressure (M54). Tamaas: its ``computeError``, not a relative
    change but the complementarity |sum p g| / (|sum p| std(h)) (that formula gives its value
    after a solve to 2e-6), at most 1e-8 in gap control (its floor: 1e-10 at 512^2, 2e-10 at
    1024^2) and 1e-11 in load control, where 1e-8 leaves the pressure 5e-6 of its peak away
    (measured at 512^2). What each reaches is printed against a
    reference, hpcgfmd at tol 1e-12, which Tamaas's load-controlled solve confirms: the
    second table gives the load's relative difference and the pressure fields' max and rms
    difference over the cell relative to the reference's peak pressure. (In load control the
    load is imposed; in gap control Tamaas's pressure keeps a uniform offset of ~1e-11 off
    the contact, its dual shifted to a zero minimum, which is most of its load's difference.)

Timing
    CPU seconds (``time.process_time``) around the solve call only, the minimum of
    ``--repeats`` solves, each from the same cold start (hpcgfmd: u = 0; Tamaas: a new model
    and solver, so that its primal starts uniform). The slowest of them is printed too:
    hpcgfmd's first solve in a process compiles or loads its numba kernels. Setup is apart:
    hpcgfmd's FFTW planning (read from its wisdom cache when there) and the rest (domain,
    operators, solver), Tamaas's model and solver construction (the first repeat's). Tamaas's
    iterations are its solver's passes, read from the last line it logs (stderr, captured at
    the file descriptor during the timed call; the cost of the one line is negligible).
    Tamaas 2.9's wheel is single-threaded (``TamaasInfo.backend`` "cpp"); run the script
    under ``taskset -c 0`` so that both codes have the same one core.
"""

import argparse
import contextlib
import ctypes
import math
import os
import sys
import tempfile
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np
from mpi4py import MPI

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from hpcgfmd.model.geometry import Sphere
from hpcgfmd.model.halfspace import StepOperators
from hpcgfmd.model.interface import DugdaleMaugis
from hpcgfmd.parallel.domain import Domain
from hpcgfmd.parallel.fft import plan_real_fft
from hpcgfmd.solvers.cg import ConstrainedCG
from hpcgfmd.studies import report

TAMAAS = "2.9.0"
CELL = 1.0  # L / R
DEPTH = 0.01  # d / R: Hertz's radius sqrt(R d) = L / 10
# Hertz's peak pressure 2 E* a / (pi R), a = sqrt(R d) (M54): hpcgfmd's traction scale
PEAK = 2.0 / math.pi * math.sqrt(DEPTH)
TOLERANCE = 1e-8  # hpcgfmd: residual / PEAK; Tamaas in gap control: its complementarity
REFERENCE_TOLERANCE = 1e-12  # hpcgfmd's reference: 24 iterations at 1024^2
PRESSURE_TOLERANCE = 1e-11  # Tamaas in load control: 4e-9 of the peak at 512^2
MAX_ITERATIONS = 20000


class Solved:
    """One solve: its pressure field (n x n, compressive positive), load, contact nodes,
    iterations, the error its solver reports at exit and the CPU seconds."""

    def __init__(self, pressure, contact, iterations, reached, cpu, setup):
        self.pressure = pressure
        self.load = float(pressure.sum()) * (CELL / pressure.shape[0]) ** 2
        self.contact = int(np.count_nonzero(contact))
        self.contact_mask = contact
        self.iterations = iterations
        self.reached = reached
        self.cpu = cpu  # CPU seconds of every repeat's solve
        self.setup = setup


def coordinates(n):
    """The coordinates (x, y) of all nodes of the n x n grid (hpcgfmd's, flat, rows y)."""
    return Domain(MPI.COMM_SELF, (n, n), CELL, [(0, n * n)]).coordinates


def hpcgfmd_solves(n, repeats):
    """hpcgfmd on one rank: (planning CPU s, the timed solve, the reference solve)."""
    comm = MPI.COMM_SELF
    start = time.process_time()
    fft = plan_real_fft(comm, (n, n), "FFTW_MEASURE")
    planning = time.process_time() - start
    start = time.process_time()
    domain = Domain(comm, (n, n), CELL, fft.x_blocks)
    ops = StepOperators.from_modulus(fft.half_wavenumbers(CELL), 1.0, domain.n)
    law = DugdaleMaugis(0.0, 1.0)  # no adhesion
    solver = ConstrainedCG(domain, fft, law, TOLERANCE, MAX_ITERATIONS, PEAK)
    wall = Sphere().profile(domain.coordinates) - DEPTH
    history = np.zeros(domain.local_n)
    setup = time.process_time() - start

    def solve(cg):
        u = np.zeros(domain.local_n)
        start = time.process_time()
        result = cg.solve(u, wall, ops, history)
        cpu = time.process_time() - start
        if not result.converged:
            raise RuntimeError(f"hpcgfmd did not converge at {n}^2: {result}")
        traction = np.empty(domain.local_n)
        cg.problem.interface_traction(
            u, cg.elastic_traction(), wall, history, result.mean_traction, traction
        )
        # the solver puts its contact nodes exactly on the wall
        contact = (wall - u <= 0.0).reshape(n, n)
        return -traction.reshape(n, n), contact, result.iterations, result.residual, cpu

    runs = [solve(solver) for _ in range(repeats)]
    pressure, contact, iterations, reached, _ = runs[-1]
    timed = Solved(pressure, contact, iterations, reached, [r[-1] for r in runs], setup)
    tight = ConstrainedCG(domain, fft, law, REFERENCE_TOLERANCE, MAX_ITERATIONS, PEAK)
    pressure, contact, iterations, reached, cpu = solve(tight)
    reference = Solved(pressure, contact, iterations, reached, [cpu], 0.0)
    return planning, timed, reference


@contextlib.contextmanager
def stderr_to(path):
    """Sends what the process writes to file descriptor 2 (Tamaas's log) to ``path``."""
    sys.stderr.flush()
    libc = ctypes.CDLL(None)
    saved = os.dup(2)
    with open(path, "wb") as fh:
        os.dup2(fh.fileno(), 2)
        try:
            yield
        finally:
            libc.fflush(None)
            os.dup2(saved, 2)
            os.close(saved)


def tamaas_solves(tm, n, control, target, tolerance, repeats, log):
    """Tamaas's PolonskyKeerRey, ``control`` "gap" (mean gap ``target``, the gap as primal)
    or "pressure" (mean pressure ``target``, the pressure as primal), ``repeats`` times from
    a new model: the last solve, with every repeat's CPU seconds."""
    surface = np.ascontiguousarray(-Sphere().profile(coordinates(n)).reshape(n, n))  # apex up
    kind = getattr(tm.PolonskyKeerRey, control)
    cpus, setups = [], []
    for _ in range(repeats):
        start = time.process_time()
        model = tm.ModelFactory.createModel(tm.model_type.basic_2d, [CELL, CELL], [n, n])
        model.E, model.nu = 1.0, 0.0
        if not math.isclose(model.E_star, 1.0):
            raise RuntimeError(f"Tamaas's E* is {model.E_star}, not 1")
        solver = tm.PolonskyKeerRey(model, surface, tolerance, kind, kind)
        solver.max_iter = MAX_ITERATIONS
        solver.dump_freq = MAX_ITERATIONS + 1  # logs its first pass and its last
        setups.append(time.process_time() - start)
        with stderr_to(log):
            start = time.process_time()
            reached = solver.solve(target)
            cpus.append(time.process_time() - start)
        with open(log) as fh:
            last = int(fh.read().split("\n")[-2].split()[0])
    # its log's last line is the index of the last pass, from 0, or max_iter + 1 when capped
    iterations = last + 1 if reached <= tolerance else last
    if reached > tolerance:
        raise RuntimeError(f"Tamaas ({control}) did not converge at {n}^2: {reached:.3g}")
    pressure = np.array(model.traction, copy=True)
    if control == "gap":  # its primal: the nodes at zero gap
        gap = np.asarray(model.displacement) - surface
        contact = gap <= 1e-14 * np.abs(surface).max()  # hpcgfmd's on-wall round-off
    else:  # its primal: the nodes under pressure
        contact = pressure > 0.0
    return Solved(pressure, contact, iterations, reached, cpus, setups[0])


def difference(a, b, reference):
    """(relative load difference, max and rms of the pressure difference over the cell
    relative to ``reference``'s peak, contact nodes that differ) of solve ``a`` to ``b``."""
    peak = reference.pressure.max()
    delta = a.pressure - b.pressure
    return (
        a.load / b.load - 1.0,
        np.abs(delta).max() / peak,
        math.sqrt(np.mean(delta * delta)) / peak,
        int(np.count_nonzero(a.contact_mask != b.contact_mask)),
    )


def _parser():
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--n",
        type=int,
        nargs="+",
        default=[512, 1024],
        help="nodes per side, even, from 64 (default 512 1024)",
    )
    parser.add_argument(
        "--repeats", type=int, default=3, help="solves of each code timed (minimum taken)"
    )
    return parser


def time_rows(n, planning, ours, gap, load):
    """The timing table's rows of one grid: hpcgfmd's solve and Tamaas's two."""
    rows = []
    solves = (
        ("hpcgfmd, displacement control", ours, TOLERANCE),
        ("Tamaas, gap control", gap, TOLERANCE),
        ("Tamaas, load control", load, PRESSURE_TOLERANCE),
    )
    for name, solved, tolerance in solves:
        best = min(solved.cpu)
        setup = f"{planning:.2f} + {solved.setup:.2f}" if solved is ours else f"{solved.setup:.2f}"
        rows.append(
            [
                f"{n}^2",
                name,
                f"{tolerance:.0e} / {solved.reached:.1e}",
                setup,
                f"{best:.3f}",
                f"{max(solved.cpu):.3f}",
                solved.iterations,
                f"{1e3 * best / max(solved.iterations, 1):.1f}",
                f"{solved.load:.10e}",
                solved.contact,
                f"{best / min(ours.cpu):.1f}",
            ]
        )
    return rows


def accuracy_rows(n, ours, gap, load, reference):
    """The agreement table's rows of one grid: each solve against the others and the
    reference."""
    pairs = (
        ("Tamaas, gap control", gap, "hpcgfmd", ours),
        ("Tamaas, load control", load, "hpcgfmd", ours),
        ("hpcgfmd", ours, "reference", reference),
        ("Tamaas, gap control", gap, "reference", reference),
        ("Tamaas, load control", load, "reference", reference),
    )
    rows = []
    for name, a, other, b in pairs:
        dload, dmax, drms, nodes = difference(a, b, reference)
        rows.append([f"{n}^2", name, other, f"{dload:.1e}", f"{dmax:.1e}", f"{drms:.1e}", nodes])
    return rows


def main():
    parser = _parser()
    args = parser.parse_args()
    if any(n % 2 or n < 64 for n in args.n):
        parser.error(f"--n {args.n}: even sizes from 64")
    if args.repeats < 1:
        parser.error("--repeats: at least 1")
    try:
        import tamaas as tm
    except ImportError:
        parser.exit(2, f"{parser.prog}: Tamaas is not installed: pip install tamaas=={TAMAAS}\n")
    tm.initialize(1)
    print(report.header("Tamaas against hpcgfmd on one core (scripts/bench_tamaas.py)"))
    cores = sorted(os.sched_getaffinity(0))
    print(
        f"Tamaas {tm.__version__} (backend {tm.TamaasInfo.backend})"
        f"{'' if tm.__version__ == TAMAAS else f', not {TAMAAS}'}; this process on cores"
        f" {cores}{'' if len(cores) == 1 else ' (run it under taskset -c 0)'};"
        f" sphere R = 1 at depth {DEPTH} on a {CELL} x {CELL} cell, E* = 1;"
        f" hpcgfmd's tolerance on the residual / p0, p0 = {PEAK:.4f}\n",
        flush=True,
    )
    times, accuracy = [], []
    with tempfile.TemporaryDirectory() as folder:
        log = os.path.join(folder, "tamaas.log")
        for n in args.n:
            planning, ours, reference = hpcgfmd_solves(n, args.repeats)
            mean_gap = float(np.mean(Sphere().profile(coordinates(n)))) - DEPTH
            gap = tamaas_solves(tm, n, "gap", mean_gap, TOLERANCE, args.repeats, log)
            load = tamaas_solves(
                tm, n, "pressure", reference.load / CELL**2, PRESSURE_TOLERANCE, args.repeats, log
            )
            times += time_rows(n, planning, ours, gap, load)
            accuracy += accuracy_rows(n, ours, gap, load, reference)
            print(
                f"n = {n}: reference (hpcgfmd at {REFERENCE_TOLERANCE:g}) load"
                f" {reference.load:.12e}, {reference.contact} contact nodes,"
                f" {reference.iterations} iterations, peak pressure"
                f" {reference.pressure.max():.6f}",
                flush=True,
            )
    print()
    head = [
        "n",
        "code, control",
        "tolerance / reached",
        "setup CPU s",
        f"solve CPU s (min of {args.repeats})",
        "slowest",
        "iterations",
        "ms / iteration",
        "load (E* R^2)",
        "contact nodes",
        "CPU / hpcgfmd's",
    ]
    print(report.markdown_table(head, times))
    print()
    head = ["n", "solve", "against", "load rel. diff.", "max abs dp / peak", "rms dp / peak"]
    print(report.markdown_table(head + ["contact nodes differing"], accuracy))
    print()
    print(report.no_target("an anchor against another code"))


if __name__ == "__main__":
    main()
