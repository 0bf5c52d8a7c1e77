"""``python -m hpcgfmd``: the command line inside an abort-on-exception guard.

Under MPI with more than one rank an uncaught exception on one rank aborts all of them
(COMM_WORLD.Abort) instead of leaving the others waiting in a collective; SystemExit
passes through. The distributed engine is not in this version: with more than one rank
the command refuses to run rather than writing the same file from every rank.
"""
import sys


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
