"""Validation of the accuracy knob (hpcgfmd/studies/accuracy_study.py): one table.

    mpirun -n 2 python scripts/accuracy_study.py --out docs/figures/accuracy \
        --cases 1:0.1:1:0.02 3.5:0.2:0.01:0.1 --accuracies 1e-2 5e-3 1e-3
"""
import os
import sys

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from mpi4py import MPI  # noqa: E402

from hpcgfmd.studies.accuracy_study import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main(MPI.COMM_WORLD, sys.argv[1:]))
