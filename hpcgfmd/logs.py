"""Logging of the command line: rank 0 prints, a user can silence it or send it to a file.

Modules log to ``logging.getLogger(__name__)`` (all under ``hpcgfmd``) and install nothing;
:func:`configure` (called by the command line once per process) installs the handlers:

- standard output: INFO records of world rank 0 as plain lines (``--quiet`` raises the level
  to WARNING); a record with ``extra={"every_rank": True}`` passes on any rank (the farm's
  group leaders report their own cases);
- standard error: WARNING and above of every rank, ``hpcgfmd: <message>``;
- ``--log FILE``: everything from INFO of rank 0 with a time stamp (appended).
"""
from __future__ import annotations

import logging
import sys

LOGGER = "hpcgfmd"


class _RankFilter(logging.Filter):
    def __init__(self, rank):
        super().__init__()
        self.rank = rank

    def filter(self, record):
        return self.rank == 0 or getattr(record, "every_rank", False)


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
        Also append rank 0's records with time stamps to this file.
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
    if log_file is not None and rank == 0:
        handler = logging.FileHandler(log_file)
        handler.setLevel(logging.INFO)
        handler.setFormatter(logging.Formatter("%(asctime)s %(name)s %(levelname)s %(message)s"))
        logger.addHandler(handler)
    return logger
