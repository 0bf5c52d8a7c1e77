"""The Python API: ``hpcgfmd.Case``, ``hpcgfmd.run``, ``hpcgfmd.open`` (docs/api.md).

    import hpcgfmd
    case = hpcgfmd.Case(maugis=3.5, modulus_ratio=0.1, velocity=1.0, depth=0.03, cell=2.0,
                        adhesion=1e-4, numerics={"nx": 2048})
    result = hpcgfmd.run(case)                 # in memory; or run(case, "out.h5")
    result.pull_off().lbar, result.series.load, result.snapshots.surface
    hpcgfmd.open("out.h5")                     # a finished or running result file

The same validation, solver and file layout as ``python -m hpcgfmd run``; errors are raised
as the exceptions of :mod:`hpcgfmd.errors` (a :class:`~hpcgfmd.errors.CaseError` names the key,
the value and what is accepted).
"""

from __future__ import annotations

import os
import shutil
import tempfile

from .case import Case
from .storage.reader import Result, read_result

PLANNER_EFFORTS = (
    "FFTW_ESTIMATE",
    "FFTW_MEASURE",
    "FFTW_PATIENT",
    "FFTW_EXHAUSTIVE",
    "FFTW_WISDOM_ONLY",
)


def run(
    case: Case | str | os.PathLike,
    path: str | os.PathLike | None = None,
    comm=None,
    overwrite: bool = False,
    planner_effort: str = "FFTW_MEASURE",
) -> Result:
    """Run the retraction of ``case`` and return its :class:`~hpcgfmd.storage.reader.Result`.

    Collective over ``comm``: every rank calls it with the same arguments.

    Parameters
    ----------
    case : Case, str or os.PathLike
        A :class:`Case`, a case file's path or its TOML text.
    path : str or os.PathLike, optional
        The HDF5 file to write (kept), taken as ``python -m hpcgfmd run -o path`` takes it:
        under its lock, and continued from its checkpoint when the file and its checkpoint
        both exist (a run stopped by :class:`~hpcgfmd.errors.Interrupted`). Left out, the
        run goes to a temporary file that is read back and removed; ``Result.path`` is then
        None.
    comm : mpi4py.MPI.Comm, optional
        The ranks sharing the case; default ``MPI.COMM_SELF`` (serial).
    overwrite : bool
        Replace an existing ``path`` (and start anew instead of continuing a checkpoint).
    planner_effort : str
        FFTW planner flag: "FFTW_MEASURE" (fastest transforms, planning takes seconds at
        2^17) or "FFTW_ESTIMATE" (instant planning, for small quick runs); also
        "FFTW_PATIENT", "FFTW_EXHAUSTIVE" and "FFTW_WISDOM_ONLY".

    Raises
    ------
    CaseError, CaseFailure, FileExistsError, UsageError, Interrupted, ValueError
        An invalid case or a contact too large for the cell; a failed run (no convergence);
        ``path`` existing without a checkpoint and no ``overwrite``; ``path`` not writable
        (another writer, a missing or read-only directory, another case's or a damaged
        checkpoint); a stop by SIGTERM or SIGUSR1 after a checkpoint (the same call
        continues); an unknown ``planner_effort`` (docs/api.md).
    """
    from mpi4py import MPI

    from .runs.resume import prepare_output
    from .runs.single_case import run_case

    comm = MPI.COMM_SELF if comm is None else comm
    if planner_effort not in PLANNER_EFFORTS:
        raise ValueError(
            f"planner_effort = {planner_effort!r}: expected one of {', '.join(PLANNER_EFFORTS)}"
        )
    if not isinstance(case, Case):
        case = Case.from_toml(case)
    if path is not None:
        path = os.fspath(path)
        lock, resume = prepare_output(comm, case, path, overwrite)
        try:
            run_case(
                case, path, comm, overwrite=overwrite, resume=resume, planner_effort=planner_effort
            )
        finally:
            if lock is not None:
                lock.release()
        return read_result(path)
    directory = comm.bcast(
        tempfile.mkdtemp(prefix="hpcgfmd-") if comm.Get_rank() == 0 else None, root=0
    )
    try:
        temporary = os.path.join(directory, "case.h5")
        run_case(case, temporary, comm, planner_effort=planner_effort)
        result = read_result(temporary)
    finally:
        comm.Barrier()
        if comm.Get_rank() == 0:
            shutil.rmtree(directory, ignore_errors=True)
    result.path = None
    return result


def open_result(path: str | os.PathLike) -> Result:
    """The results in the result file ``path``, finished or still being written
    (``hpcgfmd.open``).

    Parameters
    ----------
    path : str or os.PathLike
        An HDF5 file written by ``python -m hpcgfmd run`` or :func:`run`. The series are cut
        to the steps completely written (``steps_complete``), so the file of a running or
        killed case reads too.

    Returns
    -------
    Result

    Raises
    ------
    ResultFileError
        ``path`` cannot be read as an hpcgfmd output file: it does not exist, is a directory,
        cannot be opened, is empty or not HDF5, is an HDF5 file of another program (no
        ``/series`` group or no ``config`` attribute), is cut short on disk, or holds series
        shorter than ``steps_complete`` (truncated). The one-line message names the path,
        what is wrong and what is expected; ``python -m hpcgfmd info`` and ``plot`` print it
        and exit with status 2.
    """
    return read_result(path)
