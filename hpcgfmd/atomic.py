"""Atomic file replacement: a file is either its old content or its complete new content.

Every file hpcgfmd writes whole (tables, figures, text, HDF5 summaries, FFTW wisdom,
checkpoints) goes through :func:`replacing`: the content is written to a private temporary
file in the target's directory (same file system, so the rename is atomic), which is renamed
onto the target only once it is complete. A crash or an exception at any moment leaves the
old file (or none) and no partial one; the temporary file of a failed write is removed.
``durable=True`` also syncs the data and the directory entry to disk before returning (the
checkpoint: a power loss after the rename must not lose it).

Imports nothing of hpcgfmd: every layer may use it (as :mod:`hpcgfmd.errors`).
"""

from __future__ import annotations

import contextlib
import csv
import io
import os
import tempfile


@contextlib.contextmanager
def replacing(path, *, durable: bool = False):
    """Context manager yielding a temporary path that replaces ``path`` on success.

    The temporary file is made in ``path``'s directory with ``path``'s suffix (so that a
    writer that infers the format from the name, matplotlib's ``savefig``, still does) and
    is renamed onto ``path`` when the block ends without an exception; otherwise it is
    removed and ``path`` keeps its old content.

    Parameters
    ----------
    path : str or os.PathLike
        The file to replace (or create).
    durable : bool
        Sync the new file and its directory entry to disk (fsync) before returning.
    """
    path = os.fspath(path)
    directory, name = os.path.split(os.path.abspath(path))
    suffix = os.path.splitext(name)[1]
    fd, temporary = tempfile.mkstemp(dir=directory, prefix=f".{name}.", suffix=f".tmp{suffix}")
    os.close(fd)
    try:
        yield temporary
        if durable:
            _sync(temporary)
        os.replace(temporary, path)
        if durable:
            _sync(directory)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.remove(temporary)
        raise


def publish(temporary, path, *, previous=None):
    """Rename a completely written ``temporary`` onto ``path`` durably (data, then the
    directory entry, synced); with ``previous``, the file ``path`` held is first renamed
    there (a generation kept: the checkpoint's). For writers that cannot use
    :func:`replacing` (a file written collectively by several processes, then published by
    one)."""
    _sync(temporary)
    if previous is not None and os.path.exists(path):
        os.replace(path, previous)
    os.replace(temporary, path)
    _sync(os.path.dirname(os.path.abspath(path)))


def _sync(path):
    """fsync a file or a directory."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_text(path, text: str, *, durable: bool = False):
    """Replace ``path`` by ``text`` (UTF-8) atomically."""
    with (
        replacing(path, durable=durable) as temporary,
        open(temporary, "w", encoding="utf-8") as fh,
    ):
        fh.write(text)


def write_csv(path, columns, rows):
    """Replace ``path`` by a CSV table atomically.

    Parameters
    ----------
    columns : sequence of str
        The header.
    rows : iterable of dict or of sequences
        Each row as a dict (missing columns empty, extra keys ignored) or in column order.
    """
    buffer = io.StringIO(newline="")
    rows = list(rows)
    if rows and isinstance(rows[0], dict):
        writer = csv.DictWriter(buffer, fieldnames=list(columns), extrasaction="ignore", restval="")
        writer.writeheader()
    else:
        writer = csv.writer(buffer)
        writer.writerow(columns)
    writer.writerows(rows)
    write_text(path, buffer.getvalue())


def save_figure(figure, path, **options):
    """Save a matplotlib figure to ``path`` atomically (the format from its suffix)."""
    fmt = options.pop("format", os.path.splitext(os.fspath(path))[1].lstrip(".") or "png")
    with replacing(path) as temporary:
        figure.savefig(temporary, format=fmt, **options)
