"""Checkpoints: the full state of a run in global grid order, restartable on any number of ranks.

Layout of a checkpoint file (HDF5, written collectively with the ``mpio`` driver):

/          attrs: hpcgfmd_checkpoint (format version), hpcgfmd_version, and the caller's
           scalars, strings and small 1D arrays
/fields/   attr n (grid nodes); one float64 dataset (n,) per state field, in global node order

A checkpoint is replaced atomically: the new one is written to ``<path>.tmp``, synced, and
renamed onto ``<path>``, so a crash at any moment leaves either the old complete checkpoint or
the new one (a stale ``.tmp`` is ignored and overwritten by the next write).
"""
from __future__ import annotations

import os

import h5py
import numpy as np

from .. import __version__
from .hdf5 import check_blocks, open_file, read_block, write_block

FORMAT_VERSION = 1
_MARK = "hpcgfmd_checkpoint"  # root attribute holding the format version
_RESERVED = (_MARK, "hpcgfmd_version")


def checkpoint_path(output_path) -> str:
    """Checkpoint file of a case file: ``<output without .h5>.checkpoint.h5`` next to it."""
    path = os.fspath(output_path)
    return (path[:-3] if path.endswith(".h5") else path) + ".checkpoint.h5"


def _on_root(comm, action):
    """Run ``action`` on rank 0; re-raise its error on every rank (so none waits forever)."""
    error = None
    if comm.rank == 0:
        try:
            action()
        except Exception as exc:  # re-raised on every rank below
            error = exc
    error = comm.bcast(error, root=0)
    if error is not None:
        raise error


def _replace(tmp, path):
    """Rename ``tmp`` onto ``path`` durably: data synced before, directory synced after."""
    fd = os.open(tmp, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
    os.replace(tmp, path)
    fd = os.open(os.path.dirname(os.path.abspath(path)), os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


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
    with open_file(tmp, "w", comm) as f:  # "w": a stale .tmp of a crashed write is overwritten
        f.attrs[_MARK] = FORMAT_VERSION
        f.attrs["hpcgfmd_version"] = __version__
        for key, value in attrs.items():
            f.attrs[key] = value
        group = f.create_group("fields")
        group.attrs["n"] = n
        for name in sorted(blocks):  # same creation order on every rank
            write_block(group.create_dataset(name, shape=(n,), dtype="f8"), x_start,
                        blocks[name])
    comm.Barrier()  # every rank has closed (so written) the file before it is renamed
    _on_root(comm, lambda: _replace(tmp, path))


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
        if int(version) > FORMAT_VERSION:
            raise ValueError(f"{path}: checkpoint format {int(version)} is newer than this"
                             f" hpcgfmd reads ({FORMAT_VERSION})")
        n = int(f["fields"].attrs["n"])
        if not 0 <= x_start <= x_stop <= n:
            raise ValueError(f"block [{x_start}, {x_stop}) outside the checkpoint's {n} nodes")
        fields = {name: read_block(ds, x_start, x_stop) for name, ds in f["fields"].items()}
        attrs = {key: (value.item() if isinstance(value, np.generic) else value)
                 for key, value in f.attrs.items() if key not in _RESERVED}
    return fields, attrs


def read_checkpoint_attrs(path) -> dict:
    """The attributes of a checkpoint, read by one process (no communicator needed).

    Raises ``ValueError`` if the file is not an hpcgfmd checkpoint, ``OSError`` if unreadable.
    """
    with h5py.File(os.fspath(path), "r") as f:
        if f.attrs.get(_MARK) is None:
            raise ValueError(f"{path} is not an hpcgfmd checkpoint")
        return {key: (value.item() if isinstance(value, np.generic) else value)
                for key, value in f.attrs.items() if key not in _RESERVED}


def remove_checkpoint(path, comm):
    """Delete a checkpoint and any stale ``.tmp`` of it, if present (collective)."""
    path = os.fspath(path)

    def remove():
        for name in (path, path + ".tmp"):
            try:
                os.remove(name)
            except FileNotFoundError:
                pass

    _on_root(comm, remove)
