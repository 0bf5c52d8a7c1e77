"""Every exception hpcgfmd raises on purpose, and the exit statuses the command line maps them to.

Exit statuses of ``python -m hpcgfmd``:

=====================  =====  ============================================================
name                   value  meaning
=====================  =====  ============================================================
``EXIT_OK``            0      the case (or every case of a farm) finished
``EXIT_FAILURE``       1      a case failed (non-convergence, non-finite value); one line
``EXIT_USAGE``         2      bad input: one line naming the key, the value and what is
                              accepted; nothing was computed and no file was touched
``EXIT_RESUMABLE``     75     stopped by SIGTERM/SIGUSR1 after a checkpoint (EX_TEMPFAIL):
                              the same command continues
``EXIT_INTERRUPTED``   130    stopped by SIGINT (Ctrl-C): one line; a run wrote a checkpoint
                              as for SIGTERM, and the same command continues
``EXIT_FAILED_BASE``   100    a farm in which N cases failed exits with 100 + min(N, 99)
=====================  =====  ============================================================

Each exception's ``str()`` is the one-line message the command line prints. Imports nothing of
hpcgfmd: every layer may raise these.
"""

from __future__ import annotations

EXIT_OK = 0
EXIT_FAILURE = 1
EXIT_USAGE = 2
EXIT_RESUMABLE = 75
EXIT_INTERRUPTED = 130
EXIT_FAILED_BASE = 100


class CaseError(ValueError):
    """A rejected case file or case: the key, the value and what is accepted (exit 2)."""


class SweepError(ValueError):
    """A rejected sweep file (exit 2)."""


class UsageError(Exception):
    """Bad input detected by the command line, e.g. an output path that exists (exit 2)."""


class OutputExistsError(UsageError, FileExistsError):
    """The output file exists and replacing it was not asked (exit 2); from Python also a
    :class:`FileExistsError`."""


class ResultFileError(ValueError):
    """A file that cannot be read as an hpcgfmd result file (exit 2 from ``info`` and ``plot``).

    Raised by the reader (:mod:`hpcgfmd.storage.reader`, :func:`hpcgfmd.open`) for a missing
    path, a directory, an unreadable, empty or non-HDF5 file, an HDF5 file of another program,
    and a result file that is cut short or whose series are shorter than ``steps_complete``. The
    message names the path, what is wrong and what is expected.
    """


class CaseFailure(RuntimeError):
    """A case cannot be completed (exit 1).

    Raised on every rank of the case alike: it is decided from reduced values, so no rank is
    left waiting in a collective.
    """


class NonConvergenceError(CaseFailure):
    """The equilibrium solver did not reach its tolerance within max_iterations."""


class Interrupted(Exception):
    """The run stopped on a signal, after writing a checkpoint when it had a state worth
    keeping; the same command continues it (exit 75, or 130 after SIGINT).

    Attributes
    ----------
    status : int
        The exit status: ``EXIT_INTERRUPTED`` after SIGINT, else ``EXIT_RESUMABLE``.
    """

    def __init__(self, message: str, status: int = EXIT_RESUMABLE):
        super().__init__(message)
        self.status = status
