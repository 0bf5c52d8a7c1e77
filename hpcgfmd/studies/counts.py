"""Counts on the tests' small case (lambda0 = 3.5, k = 0.1, V_z = 1, h0/R = 0.03, L/R = 2,
alpha = 1e-4): two modes of ``python -m hpcgfmd bench``.

``bench collectives`` (``mpirun -n 2 python -m hpcgfmd bench collectives``): the
``Domain.messages`` (reductions, ghost-node exchanges, edge segments) and the FFT pairs over
``--steps`` retraction steps (after 5), divided by the CG iterations of those steps; the
per-step work (predictor energies, contact edges, step control) is included. The distributed
transform adds its own synchronisations: 2 per pair on two ranks (the halved transform), 4 on
other rank counts.

``bench lag``: the paper's method's lag behind the equilibrium against its pseudo steps per
time step. ``--steps`` fixed steps of tau/50 on nx = 2048 from the same CG preload (converged
to 1e-12): the damped-Verlet GFMD with E pseudo steps per step against CG converged to 1e-12;
for each E the largest relative load error and the largest max |u - u_cg| / dmax over the
steps.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from ..case import case_file_text, parse_case
from ..runs.protocol import Retraction
from . import report

SMALL = {
    "maugis": 3.5,
    "modulus_ratio": 0.1,
    "velocity": 1.0,
    "depth": 0.03,
    "cell": 2.0,
    "adhesion": 1e-4,
}


def _parse(parser, argv):
    """The arguments, or the exit status of --help or a usage error."""
    try:
        return parser.parse_args(argv), None
    except SystemExit as exit_:
        return None, int(exit_.code or 0)


def collectives(comm, argv=None):
    """Collective: ``bench collectives``; the exit status."""
    parser = argparse.ArgumentParser(
        prog="python -m hpcgfmd bench collectives", description=__doc__.split("\n\n")[1]
    )
    parser.add_argument("--nx", type=int, default=8192, help="nodes (default 8192)")
    parser.add_argument("--steps", type=int, default=60, help="steps counted (default 60)")
    args, status = _parse(parser, argv)
    if args is None:
        return status
    if args.nx < 1024 or args.steps < 1:
        if comm.Get_rank() == 0:
            print("bench collectives: expected --nx >= 1024 and --steps >= 1", file=sys.stderr)
        return 2
    if comm.Get_rank() == 0:
        print(
            report.header(
                "Collective calls per CG iteration (python -m hpcgfmd bench collectives)"
            ),
            flush=True,
        )
    case = parse_case(case_file_text(SMALL, {"nx": args.nx}))
    sim = Retraction(case, comm, planner_effort="FFTW_ESTIMATE")
    sim.preload()
    for _ in range(5):
        sim.step()
    messages, iterations, pairs = sim.domain.messages, sim.equilibrium.iterations, sim.fft.pairs
    steps = 0
    while steps < args.steps and not sim.detached():
        sim.step()
        steps += 1
    iterations = sim.equilibrium.iterations - iterations
    row = [
        comm.Get_size(),
        args.nx,
        steps,
        iterations,
        f"{(sim.domain.messages - messages) / max(iterations, 1):.2f}",
        f"{(sim.fft.pairs - pairs) / max(iterations, 1):.2f}",
    ]
    sim.close()
    if comm.Get_rank() == 0:
        print(
            report.markdown_table(
                (
                    "ranks",
                    "nx",
                    "steps",
                    "CG iterations",
                    "collective calls per iteration",
                    "FFT pairs per iteration",
                ),
                [row],
            )
            + "\n\n"
            + report.no_target(),
            flush=True,
        )
    return 0


def _lag_run(numerics, steps):
    """Loads and displacements of ``steps`` fixed steps of tau/50 on the small case."""
    from mpi4py import MPI

    case = parse_case(
        case_file_text(SMALL, {"nx": 2048, "step_control": "fixed", "dt": 0.02, **numerics})
    )
    sim = Retraction(case, MPI.COMM_SELF, "FFTW_ESTIMATE")
    sim.preload()
    loads, shapes = [], []
    for _ in range(steps):
        loads.append(sim.step().load)
        shapes.append(sim.surface.u.copy())
    sim.close()
    return np.array(loads), shapes, case.dmax


def paper_lag(comm, argv=None):
    """``bench lag`` (serial: rank 0 runs it); the exit status."""
    parser = argparse.ArgumentParser(
        prog="python -m hpcgfmd bench lag", description=__doc__.split("\n\n")[2]
    )
    parser.add_argument("--steps", type=int, default=4, help="fixed steps (default 4)")
    parser.add_argument(
        "--equilibration",
        type=int,
        nargs="+",
        default=[10, 50, 100, 200, 500, 1000],
        help="pseudo steps per step E (default 10 50 100 200 500 1000)",
    )
    args, status = _parse(parser, argv)
    if args is None:
        return status
    if args.steps < 1 or min(args.equilibration) < 1:
        if comm.Get_rank() == 0:
            print("bench lag: expected --steps >= 1 and --equilibration >= 1", file=sys.stderr)
        return 2
    if comm.Get_rank() != 0:
        return 0
    print(
        report.header("The paper's method: lag against pseudo steps (python -m hpcgfmd bench lag)"),
        flush=True,
    )
    exact, exact_u, dmax = _lag_run({"tolerance": 1e-12}, args.steps)
    rows = []
    for pseudo in args.equilibration:
        # its CG preload as converged as the exact run's: the error is the lag alone
        loads, shapes, _ = _lag_run(
            {"solver": "paper", "equilibration_steps": pseudo, "tolerance": 1e-12}, args.steps
        )
        load_error = float(np.max(np.abs(loads - exact) / np.abs(exact)))
        shape_error = max(float(np.abs(u - v).max()) for u, v in zip(shapes, exact_u)) / dmax
        rows.append([pseudo, f"{load_error:.2e}", f"{shape_error:.2e}"])
    print(
        report.markdown_table(
            ("E", "largest relative load error", "largest max \\|u - u_cg\\| / dmax"), rows
        )
        + "\n\n"
        + report.no_target(),
        flush=True,
    )
    return 0
