"""``python -m hpcgfmd``: the command line inside an abort-on-exception guard.

Under MPI with more than one rank an uncaught exception on one rank aborts all of them
(COMM_WORLD.Abort) instead of leaving the others waiting in a collective; SystemExit
passes through. The distributed engine is not in this version: with more than one rank
the command refuses to run rather than writing the same file from every rank.
"""
import os
import sys

# One BLAS thread per process: the solver's vector dot products are tiny, and OpenBLAS's
# spinning threads made them 10x slower on a loaded 2-core node (measured: 78 s -> 19 s for
# 300 steps at n_x = 2^15). MPI ranks supply the parallelism. Must precede numpy's import.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")


def _main():
    from mpi4py import MPI

    from .cli import main

    comm = MPI.COMM_WORLD
    if comm.Get_size() > 1:
        if comm.Get_rank() == 0:
            print("hpcgfmd: error: this version runs on one MPI rank; start it without mpirun"
                  " or with -n 1", file=sys.stderr)
        return 2
    try:
        return main()
    except SystemExit:
        raise
    except BaseException:
        if comm.Get_size() > 1:
            import traceback

            traceback.print_exc()
            comm.Abort(1)
        raise


sys.exit(_main())
