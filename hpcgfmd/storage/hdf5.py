"""Collective block I/O on HDF5 files shared by the ranks of a communicator (the ``mpio`` driver).

Each rank owns a contiguous block of a global array and reads or writes only that block; every
rank takes part in every call, also with an empty block, because H5Dwrite/H5Dread under
``mpio`` are collective. Used by the result file and the checkpoints.
"""

from __future__ import annotations

import h5py
import numpy as np


def open_file(path, mode, comm):
    """Open ``path`` on every rank of ``comm`` (collective).

    Parameters
    ----------
    path : str or Path
        HDF5 file.
    mode : str
        h5py mode ("r", "r+", "w", "w-").
    comm : mpi4py.MPI.Comm
        Ranks that open the file together.

    Returns
    -------
    h5py.File
        Opened with the ``mpio`` driver when h5py is built with MPI, else serially (one rank
        only).
    """
    if h5py.get_config().mpi:
        return h5py.File(path, mode, driver="mpio", comm=comm)
    if comm.size > 1:
        raise RuntimeError("h5py is built without MPI: cannot write one file from several ranks")
    return h5py.File(path, mode)


def _transfer(file):
    """Dataset transfer property list: collective under mpio (every rank calls H5Dwrite)."""
    dxpl = h5py.h5p.create(h5py.h5p.DATASET_XFER)
    if file.driver == "mpio":
        dxpl.set_dxpl_mpio(h5py.h5fd.MPIO_COLLECTIVE)
    return dxpl


def _spaces(ds, row, start, shape):
    """File and memory dataspaces selecting a block of ``shape`` whose first index along the
    grid's first axis is ``start`` (in ``row`` of a dataset with a leading row axis)."""
    fspace = ds.id.get_space()
    mspace = h5py.h5s.create_simple(tuple(shape) if shape else (0,))
    if not shape or 0 in shape:
        # h5py's ds[...] skips H5Dwrite/H5Dread for an empty selection, which hangs the other
        # ranks of a collective call; an explicit "none" selection still takes part.
        fspace.select_none()
        mspace.select_none()
    elif row is None:
        fspace.select_hyperslab((start,) + (0,) * (len(shape) - 1), tuple(shape))
    else:
        fspace.select_hyperslab((row, start) + (0,) * (len(shape) - 1), (1,) + tuple(shape))
    return fspace, mspace


def write_block(ds, start, block, row=None):
    """Write this rank's ``block`` at ``[row,] start:start + len(block), ...`` of ``ds``
    (collective).

    Parameters
    ----------
    ds : h5py.Dataset
        A dataset of the grid's shape, or with a leading row axis when ``row`` is given;
        float64 or int64.
    start : int
        Global index of the block's first entry along the grid's first axis.
    block : array_like
        This rank's block: whole along every axis but the first; possibly empty (the rank
        still takes part).
    row : int, optional
        The row of a dataset with a leading row axis (a snapshot).
    """
    block = np.ascontiguousarray(block, dtype=ds.dtype)
    fspace, mspace = _spaces(ds, row, start, block.shape)
    ds.id.write(mspace, fspace, block, dxpl=_transfer(ds.file))


def read_block(ds, start, stop):
    """Read entries [start, stop) along the first axis of ``ds`` on this rank (collective)."""
    out = np.empty((stop - start,) + ds.shape[1:], dtype=ds.dtype)
    fspace, mspace = _spaces(ds, None, start, out.shape)
    ds.id.read(mspace, fspace, out, dxpl=_transfer(ds.file))
    return out


def check_blocks(comm, n, x_start, x_stop):
    """Collective: raise ValueError on every rank unless the ranks' blocks tile [0, n) in
    rank order."""
    blocks = comm.allgather((int(x_start), int(x_stop)))
    starts, stops = [a for a, _ in blocks], [b for _, b in blocks]
    if starts != [0] + stops[:-1] or stops[-1] != n or any(b < a for a, b in blocks):
        raise ValueError(f"rank blocks {blocks} do not tile the {n} grid nodes in rank order")
