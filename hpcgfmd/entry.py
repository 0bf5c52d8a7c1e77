"""Process entry point shared by ``python -m hpcgfmd`` and the ``hpcgfmd`` console script.

Sets one BLAS thread per process before numpy is imported: the solver's vector dot products
are tiny and OpenBLAS's spinning threads slow them down on a loaded node (docs/results.md);
MPI ranks supply the parallelism.

This is the only place that names ``MPI.COMM_WORLD``: the command line receives it as its
communicator. Under MPI with more than one rank an uncaught exception on one rank aborts all
of them (COMM_WORLD.Abort, non-zero status) instead of leaving the others waiting in a
collective; SystemExit passes through. SIGTERM and SIGUSR1 are recorded from the first
moment (:mod:`hpcgfmd.signals`) and handed to the run or the farm, which stop cleanly.
"""
import os
import sys


def main():
    """Run the command line on COMM_WORLD; returns the exit status."""
    from .signals import StopSignals

    with StopSignals() as stop:  # first: a signal during start-up asks for a clean stop
        return _main(stop)


def _main(stop):
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    from mpi4py import MPI

    from .cli import main as cli_main

    comm = MPI.COMM_WORLD
    try:
        return cli_main(comm, stop=stop)
    except SystemExit:
        raise
    except BaseException:
        if comm.Get_size() > 1:
            import traceback

            traceback.print_exc()
            sys.stderr.write(f"hpcgfmd: rank {comm.Get_rank()} failed; aborting all"
                             f" {comm.Get_size()} ranks\n")
            sys.stderr.flush()
            comm.Abort(1)
        raise


def console():
    """Console-script wrapper (``hpcgfmd ...``)."""
    sys.exit(main())
