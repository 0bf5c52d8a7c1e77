"""Prints the preload of the shared test case at n_x = 16384 (two coarser levels) on the ranks
of COMM_WORLD: its levels, fine iterations, load and the whole displacement's digest, so that
runs on different rank counts can be compared (tests/test_coarse_start.py).

    mpirun --oversubscribe -n 3 python tests/mpi/check_preload.py
"""

import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from mpi4py import MPI  # noqa: E402

from cases import case_text  # noqa: E402
from hpcgfmd.case import parse_case  # noqa: E402
from hpcgfmd.runs.protocol import Retraction  # noqa: E402

case = parse_case(case_text("nx = 16384\ntolerance = 1e-11"))
sim = Retraction(case, MPI.COMM_WORLD, planner_effort="FFTW_ESTIMATE")
record = sim.preload()
u = sim.domain.segment(sim.surface.u, 0, sim.n)
sim.close()
if MPI.COMM_WORLD.Get_rank() == 0:
    print("levels", " ".join(f"{nx}:{it}" for nx, it in sim.preload_levels))
    print("fine", record.iterations)
    print("load", repr(record.load))
    print("u", " ".join(repr(float(v)) for v in u[::512]))
