"""Process entry point shared by ``python -m hpcgfmd`` and the ``hpcgfmd`` console script.

Sets one BLAS thread per process before numpy is imported: the solver's vector dot products
are tiny and OpenBLAS's spinning threads slow them down on a loaded node (docs/results.md);
MPI ranks supply the parallelism.

This is the only place that names ``MPI.COMM_WORLD``: the command line receives it as its
communicator. Under MPI with more than one rank an uncaught exception on one rank aborts all
of them (COMM_WORLD.Abort, non-zero status) instead of leaving the others waiting in a
collective; SystemExit passes through. Output to a reader that has gone away
(``info out.h5 | head -1``) ends the process quietly with status 1. SIGTERM and SIGUSR1 are
recorded from the first moment (:mod:`hpcgfmd.signals`) and handed to the run or the farm,
which stop cleanly; so is SIGINT while a run or a farm is under way. SIGINT anywhere else
(start-up, ``info``, ``plot``, a benchmark) ends the process with one line, "hpcgfmd:
interrupted", and status 130 (all ranks aborted with 130 when there are several).
"""

import os
import sys


def main():
    """Run the command line on COMM_WORLD; returns the exit status."""
    from .signals import StopSignals

    with StopSignals() as stop:  # first: a signal during start-up asks for a clean stop
        try:
            return _main(stop)
        except KeyboardInterrupt:  # SIGINT outside a run (one rank: nothing to abort)
            return _interrupted()


def _interrupted():
    """One line instead of a traceback after SIGINT; the shell's status of a Ctrl-C."""
    from .signals import EXIT_INTERRUPTED

    try:
        sys.stderr.write("hpcgfmd: interrupted\n")
        sys.stderr.flush()
    except OSError:
        pass
    return EXIT_INTERRUPTED


def _main(stop):
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    from mpi4py import MPI

    from .cli import main as cli_main
    from .errors import EXIT_FAILURE

    comm = MPI.COMM_WORLD
    try:
        status = cli_main(comm, stop=stop)
        sys.stdout.flush()  # here, where a reader gone away is handled below
        return status
    except SystemExit:
        raise
    except BrokenPipeError:
        if comm.Get_size() > 1:  # the other ranks may wait in a collective
            _abort(comm)
        # the reader of stdout has gone (``info out.h5 | head -1``): what it read was
        # printed; stop quietly, with stdout on /dev/null so that the interpreter's last
        # flush does not raise again
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_FAILURE
    except KeyboardInterrupt:
        if comm.Get_size() > 1:  # the other ranks may wait in a collective
            comm.Abort(_interrupted())
        raise
    except BaseException:
        if comm.Get_size() > 1:
            _abort(comm)
        raise


def _abort(comm):
    """Print the exception being handled and abort every rank of ``comm`` (status 1)."""
    import traceback

    try:  # stderr may be a pipe whose reader has gone: the abort must happen regardless
        traceback.print_exc()
        sys.stderr.write(
            f"hpcgfmd: rank {comm.Get_rank()} failed; aborting all {comm.Get_size()} ranks\n"
        )
        sys.stderr.flush()
    except OSError:
        pass
    comm.Abort(1)


def console():
    """Console-script wrapper (``hpcgfmd ...``)."""
    sys.exit(main())
