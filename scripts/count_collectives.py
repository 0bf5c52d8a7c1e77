"""Collective calls of the real-space step per CG iteration, on however many ranks it runs.

    mpirun -n 2 python scripts/count_collectives.py [--nx 8192] [--steps 60]

Counts ``Domain.messages`` (reductions, ghost-node exchanges, edge segments) and FFT pairs
over ``--steps`` retraction steps of the tests' small case (after 5 steps), divided by the CG
iterations of those steps: the per-step work (predictor energies, contact edges, step
control) is included. The distributed transform adds its own synchronisations: 2 per pair on
two ranks (the halved transform), 4 on other rank counts.
"""
import argparse
import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))

from mpi4py import MPI  # noqa: E402

from cases import case_text  # noqa: E402
from hpcgfmd.model.case import parse_case  # noqa: E402
from hpcgfmd.runs.protocol import Retraction  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--nx", type=int, default=8192)
    parser.add_argument("--steps", type=int, default=60)
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    sim = Retraction(parse_case(case_text(f"nx = {args.nx}")), comm,
                     planner_effort="FFTW_ESTIMATE")
    sim.preload()
    for _ in range(5):
        sim.step()
    messages, iterations, pairs = sim.domain.messages, sim.total_iterations, sim.fft.pairs
    for _ in range(args.steps):
        sim.step()
    iterations = sim.total_iterations - iterations
    if comm.Get_rank() == 0:
        print(f"{comm.Get_size()} rank(s), nx = {args.nx}: {args.steps} steps, {iterations} CG"
              f" iterations, {(sim.domain.messages - messages) / iterations:.2f} collective"
              f" calls and {(sim.fft.pairs - pairs) / iterations:.2f} FFT pairs per iteration")
    sim.close()


if __name__ == "__main__":
    main()
