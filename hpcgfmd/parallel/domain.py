"""This rank's share of the periodic surface grid, and the collectives the real-space step needs.

A line (1D) has n nodes x_i = (i - n/2) dx on a cell of length L (indenter axis on node
n/2). A surface (2D) has ny x nx nodes (x_j, y_i) = ((j - nx/2) dx, (i - ny/2) dy) on a cell
L x L, stored row by row (x fastest): node (i, j) is the flat node i nx + j, and the axis is
on node (ny/2, nx/2). Either way each rank owns one contiguous block [x_start, x_stop) of
the flat nodes (in 2D whole rows; the layout comes from the distributed FFT,
:mod:`hpcgfmd.parallel.fft`); a rank may own none. The solvers see flat blocks only: the
dimension enters through ``halo`` (the ghost nodes each side that the interface law reads:
one node of a line, one row of a surface), ``node_area`` (dx, or dx dy) and the coordinates.
Everything the solver does in real space is pointwise on the block, except:

- global reductions (dot products, sums, counts, extrema) for CG and the stop decisions: one
  ``Allreduce`` of a few doubles each, so every rank takes every decision from the same value;
- the element law of the interface (:mod:`hpcgfmd.model.interface`) couples a node to its
  neighbours: :meth:`Domain.fill_halo` exchanges ``halo`` ghost nodes (a node, or a row)
  with each neighbouring block;
- the contact measures and the moving-edge predictor of a line read a few nodes around the
  contact edges, wherever they are: :meth:`Domain.segment` assembles a short global segment.

Every method that communicates says "Collective" in its first line and must be called by all
ranks of ``comm`` in the same order. With one rank no MPI call is made.

The solver's branches compare reduced floats (``mu_new == mu``, ``rd <= 0``, energies), so
they rely on ``Allreduce`` returning the same bits on every rank. MPI does not promise it,
but Open MPI's and MPICH's reductions of a few doubles over one communicator do (every rank
combines the same partial results; floating addition is commutative); the rank-independence
tests would hang, not pass, if it failed.
"""

from __future__ import annotations

import time

import numpy as np
from mpi4py import MPI

NONE_MARKED = 2**60  # Domain.marks_around's distance to a marked node when there is none


class Domain:
    """Real-space block of this rank and the collectives over ``comm``.

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
        Communicator of the ranks sharing one case.
    n : int or (int, int)
        Number of grid nodes of a line, or the shape (ny, nx) of a surface.
    cell : float
        Cell length L (length units; a surface's cell is L x L).
    x_blocks : list of (int, int)
        Flat node block [start, stop) of every rank, in rank order, covering all nodes (whole
        rows of a surface).

    Attributes
    ----------
    n : int
        All nodes of the grid (ny nx for a surface).
    shape : tuple of int
        (n,) or (ny, nx).
    dx, dy : float
        Node spacing along x and y (length; dy = dx on a line, which has no y).
    node_area : float
        The measure of one node's cell: dx on a line (length), dx dy on a surface (area).
    halo : int
        Ghost nodes each side of a block that the interface law reads (1 or nx).
    x, y : ndarray
        The coordinates of this rank's nodes, flat (length; y is None on a line).
    """

    def __init__(self, comm, n, cell: float, x_blocks):
        self.comm = comm
        self.shape = tuple(int(k) for k in np.atleast_1d(n))
        nx = self.shape[-1]
        self.n = int(np.prod(self.shape))
        self.dimensions = len(self.shape)
        self.cell = cell
        self.dx = cell / nx
        self.dy = cell / self.shape[0] if self.dimensions == 2 else self.dx
        self.node_area = self.dx * (self.dy if self.dimensions == 2 else 1.0)
        self.halo = nx if self.dimensions == 2 else 1
        self.x_blocks = [tuple(b) for b in x_blocks]
        self.size = comm.Get_size()
        self.rank = comm.Get_rank()
        self.x_start, self.x_stop = self.x_blocks[self.rank]
        self.local_n = self.x_stop - self.x_start
        nodes = np.arange(self.x_start, self.x_stop)
        self.x = (nodes % nx - nx // 2) * self.dx
        self.y = None
        self.local_shape = (self.local_n,)
        if self.dimensions == 2:
            if self.x_start % nx or self.x_stop % nx:
                raise ValueError(f"a surface's blocks are whole rows of {nx} nodes")
            self.y = (nodes // nx - self.shape[0] // 2) * self.dy
            self.local_shape = (self.local_n // nx, nx)
        # this rank's block along the grid's first axis (nodes of a line, rows of a surface)
        rows = self.halo
        self.first_axis_block = (self.x_start // rows, self.x_stop // rows)
        # this rank's nodes, one flat array per dimension (x first)
        self.coordinates = (self.x,) if self.y is None else (self.x, self.y)
        self.serial = self.size == 1
        # Halo partners: the nearest ranks to the left and right that own nodes (periodic).
        owners = [r for r, (a, b) in enumerate(self.x_blocks) if b > a]
        if self.local_n and len(owners) > 1:
            i = owners.index(self.rank)
            self._left, self._right = owners[i - 1], owners[(i + 1) % len(owners)]
        else:
            self._left = self._right = None  # alone (or empty): the ghosts are our own ends
        self._send = np.zeros(8)
        self._receive = np.zeros(8)
        self.communication_time = 0.0  # seconds in MPI calls here (waiting included)
        self.messages = 0  # collective calls made (reductions, halo exchanges, segments)

    def axes(self):
        """The global coordinates of each axis of the grid, in the order of ``shape`` (y, x
        on a surface; length)."""
        spacings = (self.dy, self.dx) if self.dimensions == 2 else (self.dx,)
        return tuple((np.arange(k) - k // 2) * h for k, h in zip(self.shape, spacings))

    # --- reductions ------------------------------------------------------------------
    def _allreduce(self, values, op):
        k = len(values)
        if k > self._send.size:
            self._send = np.zeros(k)
            self._receive = np.zeros(k)
        self._send[:k] = values
        started = time.perf_counter()
        self.comm.Allreduce(self._send[:k], self._receive[:k], op=op)
        self.communication_time += time.perf_counter() - started
        self.messages += 1
        return self._receive[:k]

    def sums(self, *values):
        """Collective: global sums of several local scalars (one message), as floats."""
        if self.serial:
            return tuple(map(float, values))
        return tuple(map(float, self._allreduce(values, MPI.SUM)))

    def sum(self, value) -> float:
        """Collective: global sum of a local scalar."""
        return self.sums(value)[0]

    def dot(self, a, b) -> float:
        """Collective: global dot product of two local blocks."""
        return self.sum(a @ b)

    def count(self, mask) -> int:
        """Collective: number of True entries over all blocks."""
        return int(self.sum(np.count_nonzero(mask)))

    def maxes(self, *values):
        """Collective: global maxima of several local scalars (one message), as floats."""
        if self.serial:
            return tuple(map(float, values))
        return tuple(map(float, self._allreduce(values, MPI.MAX)))

    def max(self, value) -> float:
        """Collective: global maximum of a local scalar (-inf for 'nothing here')."""
        return self.maxes(value)[0]

    def min(self, value) -> float:
        """Collective: global minimum of a local scalar (+inf for 'nothing here')."""
        return -self.max(-value)

    def max_abs(self, a) -> float:
        """Collective: max |a| over all blocks (0 when no rank owns nodes); no temporary."""
        return self.max(max(float(a.max()), -float(a.min())) if a.size else 0.0)

    def any(self, mask) -> bool:
        """Collective: True when any entry of any block is True."""
        local = bool(mask.any()) if mask.size else False
        return self.max(1.0 if local else 0.0) > 0.0

    def all(self, mask) -> bool:
        """Collective: True when every entry of every block is True."""
        local = bool(mask.all()) if mask.size else True
        return self.min(1.0 if local else 0.0) > 0.0

    # --- neighbours ----------------------------------------------------------------------
    def fill_halo(self, extended):
        """Collective: set the ghost nodes, ``halo`` each side, from the neighbours.

        ``extended`` has shape (local_n + 2 halo,) with this block in
        extended[halo:-halo]; the ghosts are the halo nodes before x_start and from x_stop
        on (periodic): a node each side on a line, a row each side on a surface. Ranks that
        own nothing skip it.
        """
        if not self.local_n:
            return extended
        h = self.halo
        if self._left is None:
            extended[:h] = extended[-2 * h : -h]
            extended[-h:] = extended[h : 2 * h]
            return extended
        comm = self.comm
        started = time.perf_counter()
        comm.Sendrecv(
            extended[h : 2 * h],
            dest=self._left,
            sendtag=71,
            recvbuf=extended[-h:],
            source=self._right,
            recvtag=71,
        )
        comm.Sendrecv(
            extended[-2 * h : -h],
            dest=self._right,
            sendtag=72,
            recvbuf=extended[:h],
            source=self._left,
            recvtag=72,
        )
        self.communication_time += time.perf_counter() - started
        self.messages += 1
        return extended

    def rows_around(self, local_values, depth: int):
        """Collective (a surface): this block's rows with ``depth`` rows of the grid before
        and after them (periodic along y), shape (local rows + 2 depth, nx).

        Every rank passes the same ``depth`` (at most ny minus its block's rows, so that no
        row is needed twice); a rank that owns nothing gets an empty array. One
        ``Alltoallv`` carries only the rows a rank needs from each other one: its
        neighbours' edge rows, however thin the blocks (the owners follow from
        ``x_blocks``, known everywhere).
        """
        ny, nx = self.shape
        first, stop = self.first_axis_block
        own = np.asarray(local_values).reshape(stop - first, nx)
        wanted = (
            np.concatenate((np.arange(first - depth, first), np.arange(stop, stop + depth))) % ny
        )
        if stop == first:  # (it still takes part in the exchange, with nothing)
            wanted = wanted[:0]
        out = np.empty((stop - first + 2 * depth, nx))
        out[depth : depth + stop - first] = own
        slots = np.concatenate((np.arange(depth), depth + stop - first + np.arange(depth)))
        slots = slots[: wanted.size]
        if self.serial:
            out[slots] = own[wanted - first]
            return out
        starts = np.array([a // nx for a, _ in self.x_blocks])
        stops = np.array([b // nx for _, b in self.x_blocks])

        def owner(rows):
            # the rank whose block holds each row (empty blocks hold none)
            held = (rows[:, None] >= starts[None]) & (rows[:, None] < stops[None])
            return held.argmax(axis=1)

        sent, send_counts = [], np.zeros(self.size, dtype=np.int64)
        for rank in range(self.size):
            a, b = starts[rank], stops[rank]
            if rank == self.rank or b == a:
                continue
            theirs = np.concatenate((np.arange(a - depth, a), np.arange(b, b + depth))) % ny
            mine = theirs[(theirs >= first) & (theirs < stop)]
            sent.append(own[mine - first])
            send_counts[rank] = mine.size * nx
        sources = owner(wanted)
        from_self = sources == self.rank
        out[slots[from_self]] = own[wanted[from_self] - first]
        receive_counts = np.bincount(sources[~from_self], minlength=self.size) * nx
        order = np.argsort(sources[~from_self], kind="stable")  # grouped by source rank
        received = np.empty((int(receive_counts.sum()) // nx, nx))
        send = np.concatenate(sent) if sent else np.empty((0, nx))
        started = time.perf_counter()
        self.comm.Alltoallv(
            (np.ascontiguousarray(send), (send_counts, _offsets(send_counts)), MPI.DOUBLE),
            (received, (receive_counts, _offsets(receive_counts)), MPI.DOUBLE),
        )
        self.communication_time += time.perf_counter() - started
        self.messages += 1
        out[slots[~from_self][order]] = received
        return out if stop > first else np.empty((0, nx))

    def segment(self, local_values, start: int, length: int):
        """Collective: values at the global nodes start, start+1, ..., start+length-1 (mod n).

        Every rank receives the whole segment; each node's owner supplies it (cost: one
        Allreduce of ``length`` doubles). ``length`` is at most n.
        """
        index = (start + np.arange(min(length, self.n))) % self.n
        if self.serial:
            return local_values[index]
        values = np.zeros(index.size)
        mine = (index >= self.x_start) & (index < self.x_stop)
        values[mine] = local_values[index[mine] - self.x_start]
        started = time.perf_counter()
        self.comm.Allreduce(MPI.IN_PLACE, values, op=MPI.SUM)
        self.communication_time += time.perf_counter() - started
        self.messages += 1
        return values

    def marks_around(self, count, first, last):
        """Collective: the number of marked nodes over all blocks, and how far before this
        block's first node and after its last the nearest marked node outside it lies.

        ``count``, ``first``, ``last``: this block's marked nodes, the first's and last's
        local index (-1 for none). The distances are in nodes, periodic (this block's own
        marks count across the wrap), at most n, and ``NONE_MARKED`` (2^60) when nothing is
        marked.
        One message of 1 + 2 size numbers.
        """
        ends = np.zeros(1 + 2 * self.size)
        ends[0] = count
        if first >= 0:  # global index + 1 (0: none)
            ends[1 + 2 * self.rank] = first + self.x_start + 1
            ends[2 + 2 * self.rank] = last + self.x_start + 1
        if not self.serial:
            ends = self._allreduce(ends, MPI.SUM)
        marked = ends[1:][ends[1:] > 0.0].astype(np.int64) - 1
        left = right = NONE_MARKED
        if self.local_n and marked.size:
            before = (self.x_start - marked) % self.n
            after = (marked - (self.x_stop - 1)) % self.n
            left = int(np.where(before == 0, self.n, before).min())
            right = int(np.where(after == 0, self.n, after).min())
        return int(ends[0]), left, right

    def index_extent(self, mask):
        """Collective: (first, last) global node index where ``mask`` is True, or None."""
        where = np.flatnonzero(mask)
        if where.size:
            first, last = where[0] + self.x_start, where[-1] + self.x_start
        else:
            first, last = self.n, -1
        if self.serial:
            high, low = last, -first
        else:
            high, low = self._allreduce((last, -first), MPI.MAX)
        if high < 0:
            return None
        return int(-low), int(high)

    def position(self, index):
        """x of a global node index (length units), unwrapped on a line: index n is x_0 + L
        (on a surface: the x of the flat node, within its row)."""
        if self.dimensions == 2:
            nx = self.shape[-1]
            return (index % nx - nx // 2) * self.dx
        return (index - self.n // 2) * self.dx


def _offsets(counts):
    """Displacements of consecutive blocks of ``counts`` (an Alltoallv's)."""
    return np.concatenate(([0], np.cumsum(counts)[:-1])).astype(np.int64)
