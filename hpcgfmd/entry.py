"""Process entry point shared by ``python -m hpcgfmd`` and the ``hpcgfmd`` console script.

Sets one BLAS thread per process before numpy is imported: the solver's vector dot products
are tiny and OpenBLAS's spinning threads made them 10x slower on a loaded 2-core node
(measured: 78 s -> 19 s for 300 steps at n_x = 2^15); MPI ranks supply the parallelism.

Under MPI with more than one rank an uncaught exception on one rank aborts all of them
(COMM_WORLD.Abort) instead of leaving the others waiting; SystemExit passes through. This
version runs one case on one rank: with more than one rank it refuses instead of writing the
same file from every rank.
"""
import os
import sys


def main():
    """Run the command line; returns the exit status."""
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    from mpi4py import MPI

    from .cli import main as cli_main

    comm = MPI.COMM_WORLD
    if comm.Get_size() > 1:
        if comm.Get_rank() == 0:
            print("hpcgfmd: error: this version runs on one MPI rank; start it without mpirun"
                  " or with -n 1", file=sys.stderr)
        return 2
    try:
        return cli_main()
    except SystemExit:
        raise
    except BaseException:
        if comm.Get_size() > 1:
            import traceback

            traceback.print_exc()
            comm.Abort(1)
        raise


def console():
    """Console-script wrapper (``hpcgfmd ...``)."""
    sys.exit(main())
