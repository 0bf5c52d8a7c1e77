"""The ending the MPI check scripts share: a failure on any rank aborts them all (the others
may wait in a collective), and rank 0 prints every rank's failures; one exit status on
every rank."""

import sys

from mpi4py import MPI


def abort(comm, exc, where=""):
    """Print ``exc`` with this rank and abort every rank of ``comm`` (status 2)."""
    print(
        f"FAIL{where}: {type(exc).__name__}: {exc} on rank {comm.Get_rank()}",
        file=sys.stderr,
        flush=True,
    )
    comm.Abort(2)


def report(comm, errors, ok):
    """Collective: rank 0 prints every rank's ``errors`` (or ``ok`` when there are none);
    returns the exit status, 1 on every rank when any failed."""
    all_errors = comm.gather(errors, root=0)
    failed = comm.allreduce(bool(errors), op=MPI.LOR)
    if comm.Get_rank() == 0:
        for message in (m for rank_errors in all_errors for m in rank_errors):
            print("FAIL", message, flush=True)
        if not failed:
            print(ok, flush=True)
    return 1 if failed else 0
