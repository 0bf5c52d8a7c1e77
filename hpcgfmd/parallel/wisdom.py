"""FFTW wisdom kept in a cache file, so that measured planning is paid once per machine.

FFTW_MEASURE times candidate algorithms for every transform it plans (seconds at n = 2^17,
minutes at 2^22 on one rank). What it learns, its wisdom, is valid for the same FFTW build on
the same kind of processor; planning with it is immediate and picks the same plan again, so
runs on one machine also transform with the same algorithm (the same round-off).

The file is ``$HPCGFMD_WISDOM`` if set (``off`` disables the cache), else
``$XDG_CACHE_HOME/hpcgfmd/fftw-wisdom-<host>.json`` (``~/.cache`` without XDG_CACHE_HOME):
one file per host name, as wisdom from another processor could choose a slow plan. It holds
the wisdom of every rank that planned, merged; it is written atomically
(:func:`hpcgfmd.atomic.write_text`), so concurrent writers (the groups of a farm) lose at most
each other's additions, never the file. An unreadable file is ignored with a warning and replaced.
"""

from __future__ import annotations

import json
import logging
import os
import platform
from pathlib import Path

import pyfftw

from ..atomic import write_text

log = logging.getLogger(__name__)

_FORMAT = "hpcgfmd-fftw-wisdom-1"


def cache_path() -> Path | None:
    """The wisdom file of this host, or None when the cache is off (``HPCGFMD_WISDOM=off``)."""
    explicit = os.environ.get("HPCGFMD_WISDOM")
    if explicit is not None:
        return None if explicit.strip().lower() in ("", "off") else Path(explicit)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    host = "".join(c if c.isalnum() or c in "-._" else "_" for c in platform.node()) or "host"
    return Path(base) / "hpcgfmd" / f"fftw-wisdom-{host}.json"


def _read(path):
    """The list of wisdom tuples in ``path`` (empty when absent or unreadable)."""
    try:
        data = json.loads(path.read_text())
        if data.get("format") != _FORMAT or data.get("pyfftw") != pyfftw.__version__:
            return []
        return [tuple(part.encode("latin-1") for part in entry) for entry in data["wisdom"]]
    except FileNotFoundError:
        return []
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as err:
        log.warning("ignoring the FFTW wisdom file %s (%s); it will be rewritten", path, err)
        return []


def _lines(entries):
    """The set of wisdom lines in ``entries`` (FFTW exports the same wisdom in any order)."""
    return {line.strip() for entry in entries for part in entry for line in part.splitlines()}


def load(path):
    """Import the wisdom of ``path`` into this process (local, no communication).

    Returns
    -------
    list of tuple of bytes
        The entries imported (to tell later whether planning added any).
    """
    if path is None:
        return []
    entries = _read(path)
    for entry in entries:
        pyfftw.import_wisdom(entry)
    return entries


def save(comm, path, known):
    """Collective on ``comm``: merge every rank's wisdom into ``path`` when planning added some.

    ``known`` is what :func:`load` imported on this rank. Rank 0 of ``comm`` writes.
    """
    if path is None:
        return
    mine = pyfftw.export_wisdom()
    everyone = comm.gather(None if _lines([mine]) <= _lines(known) else mine, root=0)
    if comm.Get_rank() != 0 or all(w is None for w in everyone):
        return
    # FFTW merges what it imports: rank 0 takes in the file as it is now (another writer may
    # have added to it) and the other ranks' wisdom, and writes the union as one entry.
    for entry in _read(path) + [w for w in everyone if w is not None]:
        pyfftw.import_wisdom(entry)
    merged = pyfftw.export_wisdom()
    text = json.dumps(
        {
            "format": _FORMAT,
            "pyfftw": pyfftw.__version__,
            "wisdom": [[part.decode("latin-1") for part in merged]],
        }
    )
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_text(path, text)
    except OSError as err:  # a read-only or full home costs planning time, never the run
        log.warning("could not write the FFTW wisdom file %s (%s)", path, err)
