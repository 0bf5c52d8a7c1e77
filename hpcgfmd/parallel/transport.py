"""How the ranks of a distributed FFT see each other's blocks: a shared-memory window on one
node, or ``Alltoallv`` messages across nodes (:mod:`hpcgfmd.parallel.fft_transposed`,
:mod:`hpcgfmd.parallel.fft_halved`).

Each stage of a transform writes one block per destination rank, padded so that
every block is a whole number of cache lines; the destination reads it in place from the
shared window (``"shared"``) or from its receive buffer after an ``Alltoallv``
(``"messages"``). Both give bitwise equal results.
"""

from __future__ import annotations

import numpy as np
import pyfftw
from mpi4py import MPI

TRANSPORTS = ("auto", "shared", "messages")


def padded_width(count, itemsize):
    """Row length in elements, >= count, whose size in bytes is an odd multiple of 64.

    Why: the gathers read a few elements from each of many rows. With a power-of-two row
    stride (e.g. 1024 doubles at n = 2**20) those rows map onto a few cache sets and the reads
    ran 2-3 times slower; an odd number of 64-byte lines spreads them over all sets and keeps
    every row aligned for SIMD.
    """
    lines = -(-count * itemsize // 64)
    return (lines + (lines % 2 == 0)) * 64 // itemsize if count else 0


DTYPES = {
    "pack": np.dtype(np.float64),
    "xt": np.dtype(np.complex128),
    "z": np.dtype(np.complex128),
    "h": np.dtype(np.float64),
}
_MPI_TYPES = {np.dtype(np.float64): MPI.DOUBLE, np.dtype(np.complex128): MPI.C_DOUBLE_COMPLEX}


class BlockArray:
    """A sequence of 2-D blocks stored one after the other in one flat array.

    Block ``t`` is what rank ``t`` reads (or what was received from rank ``t``), so the flat
    array with :attr:`counts` and :attr:`displacements` is directly an ``Alltoallv`` buffer.

    Parameters
    ----------
    shapes : list of (int, int)
        ``(rows, width)`` of each block, ``width`` padded (:func:`padded_width`) so that every
        block is a whole number of cache lines and stays 64-byte aligned.
    dtype : numpy.dtype
    memory : ndarray of uint8, optional
        ``nbytes(shapes, dtype)`` bytes to use (e.g. in a shared window), 64-byte aligned;
        default: a new zeroed aligned array.

    Attributes
    ----------
    flat : ndarray, 1-D
    blocks : list of ndarray
        The ``(rows, width)`` views.
    counts, displacements : list of int
        Elements and offsets (in elements) of the blocks in ``flat``.
    """

    def __init__(self, shapes, dtype, memory=None):
        total = max(1, sum(rows * width for rows, width in shapes))  # MPI wants a buffer
        if memory is None:
            self.flat = pyfftw.zeros_aligned(total, dtype=dtype)
        else:
            self.flat = memory[: total * dtype.itemsize].view(dtype)
        self.counts = [rows * width for rows, width in shapes]
        self.displacements = [int(d) for d in np.cumsum([0] + self.counts[:-1])]
        self.blocks = [
            self.flat[d : d + c].reshape(shape)
            for d, c, shape in zip(self.displacements, self.counts, shapes)
        ]
        self.mpi_type = _MPI_TYPES[np.dtype(dtype)]

    @staticmethod
    def nbytes(shapes, dtype):
        """Bytes to reserve for the blocks, rounded up to whole cache lines."""
        total = max(1, sum(rows * width for rows, width in shapes)) * dtype.itemsize
        return -(-total // 64) * 64


class StageBuffers:
    """The stage outputs of this rank and the views of the peers' blocks it reads.

    Collective construction on ``comm``.

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
    outputs : callable
        ``outputs(s)``: dict stage -> list over destination ranks t of the padded
        ``(rows, width)`` of rank s's block for t.
    incoming : dict
        stage -> list over source ranks s of the ``(rows, width)`` this rank reads from s
        (unpadded width; 0 rows for itself).
    transport : {"auto", "shared", "messages"}
        ``"auto"``: shared when all ranks share a node and the window can be made.

    Attributes
    ----------
    transport : str
        ``"shared"``, ``"messages"``, or ``"none"`` on one rank.
    mine : dict
        stage -> :class:`BlockArray` of this rank's outputs.
    read : dict
        stage -> {peer: (rows, width) view of the peer's block for this rank}.
    """

    def __init__(self, comm, outputs, incoming, transport="auto"):
        if transport not in TRANSPORTS:
            raise ValueError(f"transport must be one of {TRANSPORTS}, got {transport!r}")
        self.comm = comm
        rank, size = comm.Get_rank(), comm.Get_size()
        peers = [s for s in range(size) if s != rank]
        self._window = None
        self.transport = "none" if size == 1 else self._choose(transport)
        if self.transport == "shared":
            mine, theirs = self._shared(outputs, peers)
        if self.transport != "shared":
            mine = {
                stage: BlockArray(shapes, DTYPES[stage]) for stage, shapes in outputs(rank).items()
            }
        self.mine = mine
        if self.transport == "shared":
            self.read = {
                stage: {s: theirs[s][stage].blocks[rank][:, : shapes[s][1]] for s in peers}
                for stage, shapes in incoming.items()
            }
        else:
            self._receive = {
                stage: BlockArray(
                    [(rows, padded_width(width, DTYPES[stage].itemsize)) for rows, width in shapes],
                    DTYPES[stage],
                )
                for stage, shapes in incoming.items()
            }
            self.read = {
                stage: {s: self._receive[stage].blocks[s][:, : shapes[s][1]] for s in peers}
                for stage, shapes in incoming.items()
            }

    @property
    def shared(self) -> bool:
        """A shared window is held (:meth:`free` releases it)."""
        return self._window is not None

    def _choose(self, transport):
        """Collective: ``"shared"`` or ``"messages"``, the same on every rank."""
        if transport == "messages":
            return transport
        node = self.comm.Split_type(MPI.COMM_TYPE_SHARED)
        on_one_node = node.Get_size() == self.comm.Get_size()
        node.Free()
        on_one_node = self.comm.allreduce(on_one_node, op=MPI.LAND)
        if transport == "shared" and not on_one_node:
            raise ValueError("transport='shared' needs all ranks of comm on one node")
        return "shared" if on_one_node else "messages"

    def _shared(self, outputs, peers):
        """Allocate the stage outputs in a shared window; return mine and the peers'.

        Returns ``(mine, theirs)``: a dict stage -> :class:`BlockArray` for this rank and
        one such dict per peer. Falls back to ``transport = "messages"`` (on every rank) if
        the window cannot be made, e.g. where the MPI library has no shared-memory one-sided
        component; then returns ``(None, None)``.
        """
        comm, rank = self.comm, self.comm.Get_rank()

        def nbytes(s):
            return sum(
                BlockArray.nbytes(shapes, DTYPES[stage]) for stage, shapes in outputs(s).items()
            )

        try:
            window = MPI.Win.Allocate_shared(nbytes(rank) + 64, 1, comm=comm)
            ok = True
        except MPI.Exception:
            window, ok = None, False
        if not comm.allreduce(ok, op=MPI.LAND):
            if window is not None:
                window.Free()
            self.transport = "messages"
            return None, None
        self._window = window

        def arrays(s):
            memory = np.frombuffer(window.Shared_query(s)[0], dtype=np.uint8)
            start = -memory.ctypes.data % 64  # align every block to a cache line
            found = {}
            for stage, shapes in outputs(s).items():
                size = BlockArray.nbytes(shapes, DTYPES[stage])
                found[stage] = BlockArray(shapes, DTYPES[stage], memory[start : start + size])
                start += size
            return found

        mine = arrays(rank)
        for stage in mine.values():
            stage.flat[...] = 0
        window.Lock_all(MPI.MODE_NOCHECK)
        self._synchronise()
        return mine, {s: arrays(s) for s in peers}

    def _synchronise(self):
        """Make every rank's writes to the shared window visible to all ranks."""
        self._window.Sync()
        self.comm.Barrier()
        self._window.Sync()

    def exchange(self, stage):
        """Collective: make the peers' blocks of ``stage`` readable in :attr:`read`."""
        if self.transport == "shared":
            self._synchronise()
        elif self.transport == "messages":
            send, receive = self.mine[stage], self._receive[stage]
            rank = self.comm.Get_rank()
            counts = [0 if t == rank else c for t, c in enumerate(send.counts)]
            self.comm.Alltoallv(
                [send.flat, (counts, send.displacements), send.mpi_type],
                [receive.flat, (receive.counts, receive.displacements), receive.mpi_type],
            )

    def barrier(self):
        """Collective: with the shared window, wait until every rank has read what it read
        before (messages need no wait: each rank reads its own receive buffer)."""
        if self.transport == "shared":
            self._synchronise()

    def free(self):
        """Collective: release the shared window (the buffers are unusable afterwards)."""
        if self._window is not None:
            self.mine = self.read = {}
            self._window.Unlock_all()
            self._window.Free()
            self._window = None
