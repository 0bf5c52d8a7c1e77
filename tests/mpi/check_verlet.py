"""MPI check of the paper's damped Verlet solver (hpcgfmd.solvers.verlet.DampedVerletGFMD)
on distributed blocks.

Run under mpirun with any number of ranks, e.g.::

    mpirun --oversubscribe -n 3 python tests/mpi/check_verlet.py

An adhesive indentation relaxed by DampedVerletGFMD on the distributed blocks (with the
four-step transform, and on two ranks with the halved one too) against the same solve on
one rank (serial transform, rank 0): the transforms round differently, so the two agree
to round-off amplified by the relaxation, not bitwise (measured 1e-14). The split forward
and inverse transforms it uses are checked by tests/mpi/check_fft.py.

Exit status 0 on every rank when all checks pass; on failure rank 0 prints the reasons and
all ranks exit with 1.
"""

import math
import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402
from report import abort, report  # noqa: E402

from hpcgfmd.model.halfspace import StepOperators  # noqa: E402
from hpcgfmd.model.interface import DugdaleMaugis  # noqa: E402
from hpcgfmd.parallel.domain import Domain  # noqa: E402
from hpcgfmd.parallel.fft import HalvedRealFFT, SerialRealFFT, TransposedRealFFT  # noqa: E402
from hpcgfmd.parallel.fft_halved import fits  # noqa: E402
from hpcgfmd.solvers.verlet import DampedVerletGFMD  # noqa: E402


def indentation(comm, fft, n, steps):
    """Adhesive indentation relaxed from flat; returns the global u and mean traction."""
    cell, depth = 4.0, 0.02
    domain = Domain(comm, n, cell, fft.x_blocks)
    half_q = np.pi * np.abs(fft.wavenumber) / cell
    ops = StepOperators.from_modulus(half_q, 3.0, n)  # Eeff = 3 E0: the viscoelastic case
    law = DugdaleMaugis(0.1, 0.01)
    solver = DampedVerletGFMD(domain, fft, law, half_q, 1.0, steps, 0.1)
    x = domain.x
    wall = x**2 / 2 - depth
    history = 1e-3 * np.cos(2 * math.pi * x / cell)  # zero mean
    u = np.zeros(domain.local_n)
    result = solver.solve(u, wall, ops, history)
    whole = np.concatenate(comm.allgather(u)) if comm.Get_size() > 1 else u
    return whole, result, solver.step_length


def main():
    comm = MPI.COMM_WORLD
    rank = comm.Get_rank()
    errors = []
    try:
        n, steps = 2048, 1500
        if rank == 0:
            serial = SerialRealFFT(n, "FFTW_ESTIMATE")
            u_ref, ref, h_ref = indentation(MPI.COMM_SELF, serial, n, steps)
            if ref.residual > 1e-9:
                errors.append(f"serial residual {ref.residual:.2e} after {steps} steps")
        kinds = [TransposedRealFFT] + ([HalvedRealFFT] if fits(comm.Get_size(), n) else [])
        for kind in kinds:
            fft = kind(comm, n, planner_effort="FFTW_ESTIMATE")
            u, result, h = indentation(comm, fft, n, steps)
            fft.close()
            name = kind.__name__
            if rank == 0:
                difference = np.abs(u - u_ref).max() / np.abs(u_ref).max()
                if h != h_ref:
                    errors.append(f"{name}: pseudo step {h!r} != serial {h_ref!r}")
                if difference > 1e-10:
                    errors.append(f"{name}: u differs from the serial solve by {difference:.2e}")
                if abs(result.mean_traction - ref.mean_traction) > 1e-10 * abs(ref.mean_traction):
                    errors.append(
                        f"{name}: mean traction {result.mean_traction!r} != serial "
                        f"{ref.mean_traction!r}"
                    )
            h_all = comm.allgather(h)
            if len(set(h_all)) != 1:
                errors.append(f"{name}: ranks disagree on the pseudo step: {h_all}")
    except Exception as exc:
        abort(comm, exc)
    return report(comm, errors, f"ok: the damped Verlet solver on {comm.Get_size()} ranks")


if __name__ == "__main__":
    sys.exit(main())
