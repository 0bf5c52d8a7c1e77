"""The paper's method's lag behind the equilibrium, against its pseudo steps per time step.

    python scripts/paper_lag.py [--steps 4] [--equilibration 10 50 100 200 500 1000]

The tests' small case (lambda0 = 3.5, k = 0.1, V_z = 1, h0/R = 0.03, L/R = 2, alpha = 1e-4,
nx = 2048) for a few fixed steps of dt = tau/50 from the same CG preload: the damped-Verlet
GFMD with E pseudo steps per step against CG converged to 1e-12. Prints, for each E, the
largest relative load error and the largest max |u - u_cg| / dmax over the steps.
"""
import argparse
import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))

import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402

from cases import case_text  # noqa: E402
from hpcgfmd.model.case import parse_case  # noqa: E402
from hpcgfmd.runs.protocol import Retraction  # noqa: E402


def run(numerics, steps):
    case = parse_case(case_text('nx = 2048\nstep_control = "fixed"\ndt = 0.02\n' + numerics))
    sim = Retraction(case, MPI.COMM_SELF, "FFTW_ESTIMATE")
    sim.preload()
    loads, shapes = [], []
    for _ in range(steps):
        loads.append(sim.step().load)
        shapes.append(sim.u.copy())
    sim.close()
    return np.array(loads), shapes, case.dmax


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--steps", type=int, default=4)
    parser.add_argument("--equilibration", type=int, nargs="+",
                        default=[10, 50, 100, 200, 500, 1000])
    args = parser.parse_args()
    exact, exact_u, dmax = run("tolerance = 1e-12", args.steps)
    print(f"{'E':>6}  {'load error':>10}  {'max |u - u_cg| / dmax':>22}")
    for pseudo in args.equilibration:
        loads, shapes, _ = run(f'solver = "paper"\nequilibration_steps = {pseudo}', args.steps)
        load_error = float(np.max(np.abs(loads - exact) / np.abs(exact)))
        shape_error = max(float(np.abs(u - v).max()) for u, v in zip(shapes, exact_u)) / dmax
        print(f"{pseudo:>6}  {load_error:>10.2e}  {shape_error:>22.2e}")


if __name__ == "__main__":
    main()
