"""Shared helpers: a small periodic grid with the solver's pieces built on it."""

import atexit
import os
import shutil
import tempfile

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):  # as python -m hpcgfmd does
    os.environ.setdefault(_var, "1")
# One FFTW wisdom file for the session and the processes it starts (hpcgfmd.parallel.wisdom):
# the tests neither read nor write the user's cache, so a stale or corrupt one cannot add
# warnings to the stderr they check, and later tests still reuse earlier plans.
_WISDOM_DIR = tempfile.mkdtemp(prefix="hpcgfmd-test-wisdom-")
atexit.register(shutil.rmtree, _WISDOM_DIR, True)
os.environ["HPCGFMD_WISDOM"] = os.path.join(_WISDOM_DIR, "fftw-wisdom.json")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from mpi4py import MPI  # noqa: E402

from hpcgfmd.model.interface import DugdaleMaugis  # noqa: E402
from hpcgfmd.parallel.domain import Domain  # noqa: E402
from hpcgfmd.parallel.fft import plan_real_fft  # noqa: E402
from hpcgfmd.solvers.cg import ConstrainedCG  # noqa: E402


class Grid:
    """Periodic grid of n points on [-L/2, L/2) with |q|/2 per rfft mode, on one rank."""

    def __init__(self, n, cell):
        self.n, self.cell = n, cell
        self.dx = cell / n
        self.x = (np.arange(n) - n // 2) * self.dx
        self.half_q = np.pi * np.arange(n // 2 + 1) / cell
        self.fft = plan_real_fft(MPI.COMM_SELF, n, planner_effort="FFTW_ESTIMATE")
        self.domain = Domain(MPI.COMM_SELF, n, cell, self.fft.x_blocks)

    def solver(self, sigma_a=0.0, dmax=1.0, tolerance=1e-10, scale=1.0, max_iterations=5000):
        return ConstrainedCG(
            self.domain, self.fft, DugdaleMaugis(sigma_a, dmax), tolerance, max_iterations, scale
        )


@pytest.fixture
def grid_factory():
    return Grid
