"""Speed against error: fast solver vs the paper's method (see hpcgfmd/studies/benchmark.py).

Same as ``python -m hpcgfmd bench``; run under mpirun for several ranks, e.g.
``python scripts/speed_vs_error.py --out /tmp/sve`` or
``mpirun -n 2 python scripts/speed_vs_error.py --cases 7:4.5 --out /tmp/sve2``.
"""
import os
import sys

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from mpi4py import MPI  # noqa: E402

from hpcgfmd.cli import main  # noqa: E402

if __name__ == "__main__":  # through the command line: --quiet and --log as for bench
    sys.exit(main(MPI.COMM_WORLD, ["bench", *sys.argv[1:]]))
