"""Logging of the command line: rank 0 prints, a user can silence it or send it to a file.

Modules log to ``logging.getLogger(__name__)`` (all under ``hpcgfmd``) and install nothing;
:func:`configure` (called by the command line once per process) installs the handlers:

- standard output: INFO records of world rank 0 as plain lines (``--quiet`` raises the level
  to WARNING); a record with ``extra={"every_rank": True}`` passes on any rank (the farm's
  group leaders report their own cases);
- standard error: WARNING and above of every rank, ``hpcgfmd: <message>``;
- ``--log FILE``: INFO and above of rank 0 and the records marked ``every_rank`` of any
  rank, with a time stamp and the rank, appended. Every process opens the file itself with
  ``O_APPEND`` and writes each record, its lines whole, in one ``write``: on POSIX the
  lines of several processes interleave but never mix.
"""

from __future__ import annotations

import logging
import os
import sys

LOGGER = "hpcgfmd"


class _RankFilter(logging.Filter):
    def __init__(self, rank):
        super().__init__()
        self.rank = rank

    def filter(self, record):
        return self.rank == 0 or getattr(record, "every_rank", False)


class _AppendedLines(logging.Handler):
    """Appends each record to a file as whole lines, one ``write`` per record on a descriptor
    opened with ``O_APPEND`` (no buffer that could split a line between two writes)."""

    def __init__(self, path):
        super().__init__()
        self.fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)

    def emit(self, record):
        try:
            data = (self.format(record) + "\n").encode("utf-8", "replace")
            while data:  # a regular file takes it whole; a short write only when it fills
                data = data[os.write(self.fd, data) :]
        except Exception:  # noqa: BLE001 (logging's own convention: report, never raise)
            self.handleError(record)

    def close(self):
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1
        super().close()


class _BelowWarning(logging.Filter):
    def filter(self, record):
        return record.levelno < logging.WARNING


def configure(rank: int, quiet: bool = False, log_file=None):
    """Install the handlers of the ``hpcgfmd`` logger for this process (replacing earlier ones).

    Parameters
    ----------
    rank : int
        This process's rank in the job (only rank 0 prints INFO).
    quiet : bool
        Print warnings and errors only.
    log_file : str, optional
        Also append the records this process shows (rank 0's, and those marked
        ``every_rank``) with time stamps to this file.
    """
    logger = logging.getLogger(LOGGER)
    for handler in list(logger.handlers):
        logger.removeHandler(handler)
        handler.close()
    logger.setLevel(logging.INFO)
    logger.propagate = False
    out = logging.StreamHandler(sys.stdout)
    out.setLevel(logging.WARNING if quiet else logging.INFO)
    out.addFilter(_RankFilter(rank))
    out.addFilter(_BelowWarning())
    out.setFormatter(logging.Formatter("%(message)s"))
    logger.addHandler(out)
    err = logging.StreamHandler(sys.stderr)
    err.setLevel(logging.WARNING)
    err.setFormatter(logging.Formatter("hpcgfmd: %(message)s"))
    logger.addHandler(err)
    if log_file is not None:
        handler = _AppendedLines(log_file)
        handler.setLevel(logging.INFO)
        handler.addFilter(_RankFilter(rank))
        handler.setFormatter(
            logging.Formatter(f"%(asctime)s rank {rank} %(name)s %(levelname)s %(message)s")
        )
        logger.addHandler(handler)
    return logger
