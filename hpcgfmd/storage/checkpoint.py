"""Checkpoints: the full state of a run in global grid order, restartable on any number of ranks.

Layout of a checkpoint file (HDF5, written collectively with the ``mpio`` driver):

/          attrs: hpcgfmd_checkpoint (format version), hpcgfmd_version, and the caller's
           scalars, strings and small 1D arrays
/fields/   attr n (grid nodes); one float64 dataset (n,) per state field, in global node order

A checkpoint is replaced atomically: the new one is written to ``<path>.tmp``, its digest
stored, synced, the one it replaces renamed to the previous generation
``<...>.checkpoint.previous.h5`` and the new one renamed onto ``<path>``
(:func:`hpcgfmd.atomic.publish`). A crash at any moment
leaves a complete checkpoint under one of the two names: the newest one, except between the
two renames, where the one before it is found as the previous generation (a stale ``.tmp``
is ignored and overwritten by the next write).

Digest: the root attribute ``state_digest`` is the SHA-256 of every field's bytes (global
order, sorted names) and of every other attribute, computed from the written file; a file cut
short, with flipped bytes or otherwise altered fails :func:`checkpoint_problem` and is not
resumed from (:func:`usable_checkpoint` then takes the previous generation). A checkpoint of
another format (written by another version of hpcgfmd) is refused: the case starts again.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import os

import h5py
import numpy as np

from .. import __version__
from ..atomic import publish
from .hdf5 import check_blocks, open_file, read_block, write_block
from .space import MARGIN, checkpoint_bytes, free_bytes

FORMAT_VERSION = 3  # 3: the run's parts' states (hpcgfmd.state), qualified names
_MARK = "hpcgfmd_checkpoint"  # root attribute holding the format version
_DIGEST = "state_digest"
_RESERVED = (_MARK, "hpcgfmd_version", _DIGEST)


def checkpoint_path(output_path) -> str:
    """Checkpoint file of a result file: ``<output without .h5>.checkpoint.h5`` next to it."""
    path = os.fspath(output_path)
    return (path[:-3] if path.endswith(".h5") else path) + ".checkpoint.h5"


def previous_path(path) -> str:
    """The previous generation of the checkpoint ``path``: ``<...>.previous.h5``."""
    path = os.fspath(path)
    return (path[:-3] if path.endswith(".h5") else path) + ".previous.h5"


def _digest(f) -> str:
    """SHA-256 (hex) of an open checkpoint's fields and attributes, the digest excepted."""
    sha = hashlib.sha256()
    for key in sorted(k for k in f.attrs if k != _DIGEST):
        value = np.asarray(f.attrs[key])
        sha.update(key.encode() + b"=" + str(value.dtype).encode() + b":")
        sha.update(value.tobytes() if value.dtype.kind not in "OUS" else str(value).encode())
    group = f["fields"]
    sha.update(b"n=" + str(int(group.attrs["n"])).encode())
    for name in sorted(group):
        sha.update(b"field " + name.encode())
        sha.update(np.ascontiguousarray(group[name][...], dtype="<f8").tobytes())
    return sha.hexdigest()


def checkpoint_problem(path) -> str | None:
    """Why the file ``path`` cannot be resumed from (one phrase), or None when it is a
    complete hpcgfmd checkpoint whose digest matches its content. Serial (one process)."""
    path = os.fspath(path)
    if not os.path.exists(path):
        return "missing"
    try:
        if not h5py.is_hdf5(path):
            return "not an HDF5 file (truncated or overwritten)"
        with h5py.File(path, "r") as f:
            version = f.attrs.get(_MARK)
            if version is None or "fields" not in f:
                return "not an hpcgfmd checkpoint"
            if int(version) != FORMAT_VERSION:
                return format_problem(int(version))
            stored = f.attrs.get(_DIGEST)
            if stored is None:
                return "no state digest (its write did not complete)"
            if _digest(f) != str(stored):
                return "its state digest does not match its content (altered or damaged)"
    except Exception as err:  # whatever damaged metadata raises, the verdict is "unusable"
        return f"unreadable ({' '.join(str(err).split())})"
    return None


def format_problem(version: int) -> str:
    """The one phrase refusing a checkpoint of another format."""
    return (
        f"checkpoint format {version}, written by another version of hpcgfmd (this one"
        f" reads format {FORMAT_VERSION}): start the case again"
    )


def usable_checkpoint(path) -> tuple[str | None, list[str]]:
    """The newest checkpoint generation of ``path`` that can be resumed from (serial).

    Returns
    -------
    chosen : str or None
        ``path``, or its previous generation (:func:`previous_path`) when ``path`` is
        missing or fails :func:`checkpoint_problem`; None when neither can be used.
    problems : list of str
        One line per generation passed over, naming the file and why.
    """
    problems = []
    for candidate in (os.fspath(path), previous_path(path)):
        if not os.path.exists(candidate):
            continue
        problem = checkpoint_problem(candidate)
        if problem is None:
            return candidate, problems
        problems.append(f"{candidate}: {problem}")
    return None, problems


def _on_root(comm, action):
    """Collective: run ``action`` on rank 0; re-raise its error on every rank (so none
    waits forever)."""
    error = None
    if comm.rank == 0:
        try:
            action()
        except Exception as exc:  # re-raised on every rank below
            error = exc
    error = comm.bcast(error, root=0)
    if error is not None:
        raise error


def _seal(tmp, path):
    """Store the digest of the written ``tmp``, then make it ``path`` durably: data synced,
    the current ``path`` renamed to the previous generation, ``tmp`` renamed onto ``path``,
    the directory synced."""
    with h5py.File(tmp, "r+") as f:
        f.attrs[_DIGEST] = _digest(f)
    publish(tmp, path, previous=previous_path(path))


def write_checkpoint(path, comm, n, x_start, fields: dict, attrs: dict):
    """Write a checkpoint atomically (collective).

    Parameters
    ----------
    path : str or Path
        Checkpoint file, replaced if it exists.
    comm : mpi4py.MPI.Comm
        All ranks holding a block of the state.
    n : int
        Global number of grid nodes.
    x_start : int
        Global index of this rank's first node; the blocks cover [x_start, x_start + len).
    fields : dict of str to ndarray
        This rank's float64 blocks (all of the same length, possibly 0) of the global
        length-``n`` state arrays, internal units; the same names on every rank.
    attrs : dict
        Scalars, strings and small 1D arrays (rank-independent). Rank 0's dict is stored: HDF5
        needs identical attribute writes on all ranks, and e.g. wall times differ.
    """
    path = os.fspath(path)
    tmp = path + ".tmp"
    blocks = {name: np.ascontiguousarray(block, dtype="f8") for name, block in fields.items()}
    lengths = {block.shape[0] for block in blocks.values()}
    if len(lengths) > 1:
        raise ValueError(f"field blocks of different lengths {sorted(lengths)}")
    check_blocks(comm, n, x_start, x_start + (lengths.pop() if lengths else 0))
    attrs = comm.bcast(attrs, root=0)
    if clash := set(attrs) & set(_RESERVED):
        raise ValueError(f"checkpoint attribute names {sorted(clash)} are reserved")
    # Room for the new file first (storage/space.py): a failed HDF5 write is not clean.
    need = checkpoint_bytes(n, len(blocks)) + MARGIN
    free = comm.bcast(free_bytes(path) if comm.Get_rank() == 0 else None, root=0)
    if free < need:
        raise OSError(
            errno.ENOSPC,
            f"no space for checkpoint {path}: {free} bytes free,"
            f" {need} needed; the checkpoint before it is kept",
        )
    with open_file(tmp, "w", comm) as f:  # "w": a stale .tmp of a crashed write is overwritten
        f.attrs[_MARK] = FORMAT_VERSION
        f.attrs["hpcgfmd_version"] = __version__
        for key, value in attrs.items():
            f.attrs[key] = value
        group = f.create_group("fields")
        group.attrs["n"] = n
        for name in sorted(blocks):  # same creation order on every rank
            write_block(group.create_dataset(name, shape=(n,), dtype="f8"), x_start, blocks[name])
    comm.Barrier()  # every rank has closed (so written) the file before it is sealed
    _on_root(comm, lambda: _seal(tmp, path))


def read_checkpoint(path, comm, x_start, x_stop) -> tuple[dict, dict]:
    """Read this rank's part of a checkpoint (collective).

    Parameters
    ----------
    path : str or Path
        Checkpoint file written by :func:`write_checkpoint` (on any number of ranks).
    comm : mpi4py.MPI.Comm
        Ranks reading together.
    x_start, x_stop : int
        This rank's nodes [x_start, x_stop) (``x_start == x_stop`` for none).

    Returns
    -------
    fields : dict of str to ndarray
        This rank's float64 block of every field.
    attrs : dict
        The stored attributes as Python scalars, strings and numpy arrays.

    Raises
    ------
    FileNotFoundError
        No file at ``path``.
    ValueError
        The file is not an hpcgfmd checkpoint (or of a newer format), or the block is outside
        its grid.
    """
    path = os.fspath(path)
    if not os.path.exists(path):
        raise FileNotFoundError(f"no checkpoint {path}")
    if not h5py.is_hdf5(path):
        raise ValueError(f"{path} is not an hpcgfmd checkpoint (not an HDF5 file)")
    with open_file(path, "r", comm) as f:
        version = f.attrs.get(_MARK)
        if version is None or "fields" not in f:
            raise ValueError(f"{path} is not an hpcgfmd checkpoint")
        if int(version) != FORMAT_VERSION:
            raise ValueError(f"{path}: {format_problem(int(version))}")
        n = int(f["fields"].attrs["n"])
        if not 0 <= x_start <= x_stop <= n:
            raise ValueError(f"block [{x_start}, {x_stop}) outside the checkpoint's {n} nodes")
        fields = {name: read_block(ds, x_start, x_stop) for name, ds in f["fields"].items()}
        attrs = {
            key: (value.item() if isinstance(value, np.generic) else value)
            for key, value in f.attrs.items()
            if key not in _RESERVED
        }
    return fields, attrs


def read_checkpoint_attrs(path) -> dict:
    """The attributes of a checkpoint, read by one process (no communicator needed).

    Raises ``ValueError`` if the file is not an hpcgfmd checkpoint, ``OSError`` if unreadable.
    """
    with h5py.File(os.fspath(path), "r") as f:
        if f.attrs.get(_MARK) is None:
            raise ValueError(f"{path} is not an hpcgfmd checkpoint")
        return {
            key: (value.item() if isinstance(value, np.generic) else value)
            for key, value in f.attrs.items()
            if key not in _RESERVED
        }


def remove_checkpoint(path, comm):
    """Delete a checkpoint, its previous generation, a stale ``.tmp`` and a ``.corrupt``
    one passed over on resuming, if present (collective)."""
    path = os.fspath(path)

    def remove():
        for name in (path, path + ".tmp", previous_path(path), path + ".corrupt"):
            with contextlib.suppress(FileNotFoundError):
                os.remove(name)

    _on_root(comm, remove)
