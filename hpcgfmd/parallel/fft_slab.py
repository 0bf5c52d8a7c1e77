"""The real FFT of a periodic ny x nx surface split over the ranks of a communicator in slabs.

Same interface as the 1-D classes (:class:`~hpcgfmd.parallel.real_fft.RealFFT`; see
:mod:`hpcgfmd.parallel.fft`), on the flattened grid: node ``(y, x)`` is the flat node
``y * nx + x``, so that a rank's block of rows is a contiguous flat block of nodes.

Algorithm
---------
The 2-D transform of the real field ``f[y, x]`` is an rfft along x followed by complex FFTs
along y,

    F[ky, kx] = sum_y exp(-2 pi i y ky / ny) sum_x exp(-2 pi i x kx / nx) f[y, x],

with kx = 0 .. nx/2 (the other half are the conjugates, ``F[-ky, -kx] = conj F[ky, kx]``).
Back, complex inverse FFTs along y, then a c2r (irfft) along x; with a multiplier D even in
(kx, ky) (a function of |q|) the columns kx = 0 and nx/2 of ``D F`` keep their Hermitian
symmetry in ky, which is what c2r assumes (it ignores the imaginary parts they lose to
round-off, as numpy's irfft2 does). Nothing is normalised: the caller folds 1/(nx ny) into D.

Layout of rank r (``block_range`` blocks: contiguous, balanced, uneven allowed)
    * real space: the rows y in ``row_blocks[r]``, i.e. the flat node block
      ``x_blocks[r] = (row_start * nx, row_stop * nx)``, row-major, x fastest;
    * spectrum: the columns kx in ``block_range(nx/2 + 1, P, r)`` for all ky, an array
      ``(C, ny)`` whose entry ``[i, j]`` is the mode (kx, ky) = (kx_start + i, j), so that
      the y transforms run along its contiguous rows. A rank may own no rows or no columns
      when P is large; it then skips its local work but takes part in every synchronisation.

One application, on each rank (``apply_diagonal``)
    A. in chunks of rows: rfft along x of the own rows in a cache-sized work array, then
       write each destination rank's columns kx into its block ``xt`` (``(R, C_t)``);
       synchronise (the transpose, one all-to-all);
    B. in chunks of columns: gather the chunk's columns of every rank's ``xt`` block into a
       ``(chunk, ny)`` work array (the transposition happens in these reads), FFT along y,
       ``*= D``, inverse FFT, write each destination rank's rows y into its block ``z``
       (``(C, R_t)``); synchronise (the transpose back);
    C. in chunks of rows: gather the chunk's rows of every rank's ``z`` block into a
       ``(chunk, nx/2 + 1)`` work array, irfft along x into ``out``.

    ``forward`` is A and the forward half of B (the work array copied to the spectrum),
    ``inverse`` the backward half of B and C. Every FFT runs on a contiguous cache-resident
    work array; every large array is written sequentially, and the transpositions are done
    by the strided reads of the gathers (cheaper than strided writes, see
    :mod:`hpcgfmd.parallel.fft_transposed`).

Transport and synchronisation
    The ``xt`` and ``z`` blocks live in an MPI-3 shared-memory window when all ranks share a
    node (``"shared"``: the gathers read the peers' blocks in place, a synchronisation is a
    ``Win.Sync`` and a ``Barrier``) or are moved by one ``Alltoallv`` each (``"messages"``)
    (:class:`~hpcgfmd.parallel.transport.StageBuffers`); both give bitwise equal results.
    ``"auto"`` takes the window where it can: on two ranks of one node the messages made a
    pair 1.03-1.2 times slower at 512^2 to 2048^2 (``python -m hpcgfmd bench fft2d``, its
    ``msgs`` column), as each message is one more copy of the block. On one rank there is
    neither a synchronisation nor any other MPI call.
    Each rank reads ``16 (nx/2 + 1) ny (P - 1) / P**2`` bytes of the other ranks' blocks per
    transform. After a synchronisation the peers may read a stage's blocks until the next
    one, so a rank about to write the blocks of the stage synchronised last waits first
    (a forward after a forward or before an application, an inverse after an inverse or an
    application); ``apply_diagonal`` after ``apply_diagonal`` never waits: two
    synchronisations per application.
"""

from __future__ import annotations

import time

import numpy as np
import pyfftw

from .blocks import block_range, chunks
from .fft_kernels import scale
from .real_fft import RealFFT2D, fftw_plan, grid_shape, signed_modes
from .transport import TRANSPORTS, StageBuffers, padded_width

# Work-array sizes of the chunked stages in complex elements: a chunk of rows (A, C) holds
# about _ROW_CHUNK half-spectrum values (0.5 MB, and the rows' reals), a chunk of columns (B)
# about _COLUMN_CHUNK (1 MB), about the L2 cache of a core (1 MB here). Tried 2^14 to 2^17
# each at 512^2 to 2048^2 on 1 and 2 ranks: within 5 % of the best of each size (2^14 was
# up to 1.2 times slower).
_ROW_CHUNK = 2**15
_COLUMN_CHUNK = 2**16


class _ChunkPlans:
    """The cache-sized work arrays of the chunked stages and their FFTW plans: one pair per
    distinct chunk height (pyfftw refuses zero-size arrays, so a rank without rows or
    columns has none).

    Attributes
    ----------
    real : ndarray of float64, shape (tallest row chunk, nx)
    half : ndarray of complex128, shape (tallest row chunk, nx/2 + 1)
        Stages A and C: a chunk of rows and its half spectrum along x.
    work : ndarray of complex128, shape (widest column chunk, ny)
        Stage B: a chunk of spectrum columns along y.
    rows, columns : dict of int to (plan, plan)
        (forward, backward) plans of each row-chunk height and column-chunk width.
    alignment : int
        Byte alignment the row plans need of an array used in place of ``real``.
    """

    def __init__(self, shape, row_chunks, col_chunks, planner_effort):
        ny, nx = shape
        tall = max((b - a for a, b in row_chunks), default=1)
        wide = max((b - a for a, b in col_chunks), default=1)
        self.real = pyfftw.zeros_aligned((tall, nx), dtype=np.float64)
        self.half = pyfftw.zeros_aligned((tall, nx // 2 + 1), dtype=np.complex128)
        self.work = pyfftw.zeros_aligned((wide, ny), dtype=np.complex128)
        flags = (planner_effort, "FFTW_DESTROY_INPUT")
        backward = "FFTW_BACKWARD"
        # The rfft keeps its input (FFTW's default for r2c): it may be the caller's field.
        self.rows = {
            h: (
                fftw_plan(self.real[:h], self.half[:h], axes=(1,), flags=(planner_effort,)),
                fftw_plan(self.half[:h], self.real[:h], axes=(1,), direction=backward, flags=flags),
            )
            for h in {b - a for a, b in row_chunks}
        }
        self.columns = {
            w: (
                fftw_plan(self.work[:w], self.work[:w], axes=(1,), flags=flags),
                fftw_plan(self.work[:w], self.work[:w], axes=(1,), direction=backward, flags=flags),
            )
            for w in {b - a for a, b in col_chunks}
        }
        plans = [plan for pair in self.rows.values() for plan in pair]
        self.alignment = max(
            [pyfftw.simd_alignment]
            + [p.input_alignment for p in plans]
            + [p.output_alignment for p in plans]
        )

    def direct(self, array, start, nx):
        """True when the rows from ``start`` of the flat block ``array`` (rows of ``nx``) can
        be the row plans' real array in place (aligned as theirs, C-contiguous float64)."""
        return (
            array.dtype == np.float64
            and array.flags.c_contiguous
            and (array.ctypes.data + 8 * start * nx) % self.alignment == 0
        )


def _check_size(name, array, size):
    if array.size != size:
        raise ValueError(f"{name} has {array.size} values, this rank's block has {size}")


class SlabRealFFT2D(RealFFT2D):
    """Real 2-D FFT of an ny x nx periodic grid over ``comm`` in row and column slabs.

    See the module docstring for the algorithm, the layout and the transports. Construction
    is collective on ``comm`` (it decides the transport and allocates the shared window), and
    so are the transforms.

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
        Communicator over which the rows are distributed (any size, including 1).
    shape : (int, int)
        ``(ny, nx)``, both even.
    planner_effort : str
        FFTW planner flag.
    transport : {"auto", "shared", "messages"}
        ``"shared"``: the ranks read each other's blocks in an MPI shared-memory window (all
        on one node); ``"messages"``: ``Alltoallv``; ``"auto"``: shared when all ranks of
        ``comm`` share a node and the window can be made. Every rank must pass the same.

    Attributes
    ----------
    comm : mpi4py.MPI.Comm
    shape : (int, int)
        ``(ny, nx)``.
    n : int
        Grid nodes ``ny * nx`` (the inverse transform's missing normalisation).
    row_start, row_stop : int
        This rank's rows ``[row_start, row_stop)``.
    row_blocks : list of (int, int)
        Every rank's rows, in rank order.
    x_start, x_stop : int
        This rank's flat node block ``[row_start * nx, row_stop * nx)``.
    x_blocks : list of (int, int)
        Every rank's flat node block, in rank order.
    kx_start, kx_stop : int
        This rank's spectrum columns kx.
    spectrum_shape : (int, int)
        ``(kx_stop - kx_start, ny)``.
    wavenumbers : (ndarray, ndarray) of int64
        ``(my, mx)``, shapes ``(1, ny)`` and ``(C, 1)``, broadcastable to ``spectrum_shape``:
        the signed mode indices, my in (-ny/2, ny/2], mx in [0, nx/2]
        (q = 2 pi (mx / Lx, my / Ly)).
    wavenumber : ndarray of float64, shape spectrum_shape
        |m| = sqrt(mx**2 + my**2) of each local mode (|q| = 2 pi |m| / L on a square cell);
        0 only at the mode (0, 0).
    transport : str
        ``"shared"``, ``"messages"``, or ``"none"`` on one rank.
    spectrum : ndarray of complex128, shape spectrum_shape
        A spectrum buffer for :meth:`forward` and :meth:`inverse` callers.
    pairs : int
        Forward+backward pairs done (``apply_diagonal`` and ``inverse`` count one each).
    communication_time : float
        Seconds in the synchronisations (waiting for the other ranks included).
    """

    def __init__(self, comm, shape, planner_effort="FFTW_MEASURE", transport="auto"):
        if transport not in TRANSPORTS:
            raise ValueError(f"transport must be one of {TRANSPORTS}, got {transport!r}")
        ny, nx = grid_shape(shape)
        self.comm, self.shape, self.n = comm, (ny, nx), ny * nx
        size, rank = comm.Get_size(), comm.Get_rank()
        half = nx // 2 + 1
        self.row_blocks = rows = [block_range(ny, size, r) for r in range(size)]
        self._cols = cols = [block_range(half, size, r) for r in range(size)]
        self.row_start, self.row_stop = rows[rank]
        self.kx_start, self.kx_stop = cols[rank]
        R, C = self.row_stop - self.row_start, self.kx_stop - self.kx_start
        self._R, self._C = R, C
        self.x_blocks = [(a * nx, b * nx) for a, b in rows]
        self.x_start, self.x_stop = self.x_blocks[rank]
        self.spectrum_shape = (C, ny)
        self._set_modes(signed_modes(ny)[None, :], np.arange(self.kx_start, self.kx_stop)[:, None])

        # xt: (R_s, C_t) from rank s to rank t; z: (C_s, R_t). Rows padded (padded_width).
        def outputs(s):
            Rs, Cs = rows[s][1] - rows[s][0], cols[s][1] - cols[s][0]
            return {
                "xt": [(Rs, padded_width(b - a, 16)) for a, b in cols],
                "z": [(Cs, padded_width(b - a, 16)) for a, b in rows],
            }

        incoming = {
            "xt": [(b - a if s != rank else 0, C) for s, (a, b) in enumerate(rows)],
            "z": [(b - a if s != rank else 0, R) for s, (a, b) in enumerate(cols)],
        }
        self._buffers = StageBuffers(comm, outputs, incoming, transport)
        self.transport = self._buffers.transport
        self._synchronised = None  # the stage of the last synchronisation (see _write)

        self._row_chunks = chunks(R, max(1, _ROW_CHUNK // half))
        self._col_chunks = chunks(C, max(1, _COLUMN_CHUNK // ny))
        self._plans = _ChunkPlans((ny, nx), self._row_chunks, self._col_chunks, planner_effort)
        self._real, self._half, self._work = self._plans.real, self._plans.half, self._plans.work
        self._views()
        self.spectrum = pyfftw.zeros_aligned(self.spectrum_shape, dtype=np.complex128)
        self.pairs = 0
        self.communication_time = 0.0

    # --- construction ------------------------------------------------------------------
    def _views(self):
        """The (destination, source) views of the stages, built once, so that a call only
        slices the caller's arrays."""
        rank = self.comm.Get_rank()
        rows, cols = self.row_blocks, self._cols
        mine = {stage: self._buffers.mine[stage].blocks for stage in ("xt", "z")}
        # what this rank reads of each rank's blocks (its own in mine, the peers' in read)
        read = {
            stage: {
                s: (mine[stage][rank] if s == rank else self._buffers.read[stage][s])
                for s in range(self.comm.Get_size())
            }
            for stage in ("xt", "z")
        }
        self._stage_a, self._stage_c = [], []
        for a, b in self._row_chunks:
            half = self._half[: b - a]
            self._stage_a.append(
                [(mine["xt"][t][a:b, : q - p], half[:, p:q]) for t, (p, q) in enumerate(cols)]
            )
            self._stage_c.append(
                [(half[:, p:q], read["z"][t][:, a:b].T) for t, (p, q) in enumerate(cols)]
            )
        self._stage_b = []
        for a, b in self._col_chunks:
            work = self._work[: b - a]
            self._stage_b.append(
                (
                    [(work[:, p:q], read["xt"][s][:, a:b].T) for s, (p, q) in enumerate(rows)],
                    [(mine["z"][s][a:b, : q - p], work[:, p:q]) for s, (p, q) in enumerate(rows)],
                )
            )

    # --- the synchronisations ------------------------------------------------------------
    def _write(self, stage):
        """Collective when it waits: before this rank overwrites its blocks of ``stage``.

        After a synchronisation of ``stage`` the peers may still read those blocks: wait for
        them first (shared window only; messages are read from the receiver's own buffer).
        """
        if self._synchronised == stage:
            started = time.perf_counter()
            self._buffers.barrier()
            self._synchronised = None
            self.communication_time += time.perf_counter() - started

    def _exchange(self, stage):
        """Collective: the peers' blocks of ``stage`` become readable (nothing on one rank)."""
        if self.transport == "none":
            return
        started = time.perf_counter()
        self._buffers.exchange(stage)
        self._synchronised = stage
        self.communication_time += time.perf_counter() - started

    # --- the stages ----------------------------------------------------------------------
    def _rows_forward(self, field):
        """Stage A: the rfft of the own rows along x into the ``xt`` blocks; synchronise."""
        self._write("xt")
        nx = self.shape[1]
        source = field.reshape(self._R, nx)
        copy = np.copyto
        for (a, b), writes in zip(self._row_chunks, self._stage_a):
            forward = self._plans.rows[b - a][0]
            if self._plans.direct(field, a, nx):
                forward.update_arrays(source[a:b], self._half[: b - a])
            else:
                copy(self._real[: b - a], source[a:b])
                forward.update_arrays(self._real[: b - a], self._half[: b - a])
            forward.execute()
            for to, part in writes:
                copy(to, part)
        self._exchange("xt")

    def _rows_backward(self, out):
        """Stage C: gather the own rows of the ``z`` blocks, irfft along x into ``out``."""
        nx = self.shape[1]
        target = out.reshape(self._R, nx)
        copy = np.copyto
        for (a, b), gathers in zip(self._row_chunks, self._stage_c):
            backward = self._plans.rows[b - a][1]
            for to, part in gathers:
                copy(to, part)
            if self._plans.direct(out, a, nx):
                backward.update_arrays(self._half[: b - a], target[a:b])
                backward.execute()
            else:
                backward.update_arrays(self._half[: b - a], self._real[: b - a])
                backward.execute()
                copy(target[a:b], self._real[: b - a])

    # --- the transforms ------------------------------------------------------------------
    def apply_diagonal(self, field, diagonal, out):
        """out = irfft2(diagonal * rfft2(field)) on the distributed field, without the 1/n.

        Collective on ``comm`` (two synchronisations, a third after a forward): every rank
        must call it, also ranks owning no rows or no columns.

        Parameters
        ----------
        field : ndarray of float64, shape (x_stop - x_start,)
            This rank's rows of the real input field, flat (x fastest), in its own units.
        diagonal : ndarray of float64, shape spectrum_shape
            Multiplier of each local mode, even in (mx, my) (units of out / units of field,
            times 1/n), e.g. a function of |q| (:meth:`half_wavenumbers`).
        out : ndarray of float64, shape (x_stop - x_start,)
            This rank's rows of the output, flat (may be ``field``).

        Returns
        -------
        out : ndarray
        """
        _check_size("field", field, self._R * self.shape[1])
        _check_size("out", out, self._R * self.shape[1])
        self._rows_forward(field)
        copy = np.copyto
        for (a, b), (gathers, writes) in zip(self._col_chunks, self._stage_b):
            forward, backward = self._plans.columns[b - a]
            for to, part in gathers:
                copy(to, part)
            forward.execute()
            scale(self._work[: b - a].reshape(-1), diagonal[a:b].reshape(-1))
            backward.execute()
            for to, part in writes:
                copy(to, part)
        self._exchange("z")
        self._rows_backward(out)
        self.pairs += 1
        return out

    def forward(self, field, spectrum_out):
        """spectrum_out = rfft2(field) on this rank's columns kx (stage A and the forward
        half of stage B of :meth:`apply_diagonal`), unnormalised.

        Collective on ``comm`` (one synchronisation, a second after a forward). Half of a
        pair: ``inverse(d * forward(f))`` equals ``apply_diagonal(f, d)`` bitwise (the same
        plans and operations); ``pairs`` is counted in :meth:`inverse`.

        Parameters
        ----------
        field : ndarray of float64, shape (x_stop - x_start,)
            This rank's rows of the real field, flat.
        spectrum_out : ndarray of complex128, shape spectrum_shape
            Entry ``[i, j]`` is the mode (kx_start + i, j) (see ``wavenumbers``); may be
            :attr:`spectrum`.

        Returns
        -------
        spectrum_out : ndarray
        """
        _check_size("field", field, self._R * self.shape[1])
        self._rows_forward(field)
        copy = np.copyto
        for (a, b), (gathers, _) in zip(self._col_chunks, self._stage_b):
            for to, part in gathers:
                copy(to, part)
            self._plans.columns[b - a][0].execute()
            copy(spectrum_out[a:b], self._work[: b - a])
        return spectrum_out

    def inverse(self, spectrum, field_out):
        """field_out = irfft2(spectrum) without the 1/n, from this rank's columns kx.

        Collective on ``comm`` (one synchronisation, a second after an inverse or an
        application); counts one pair in ``pairs``. ``spectrum`` must be the spectrum of a
        real field times a multiplier even in (mx, my), as :meth:`forward` gives it (the
        columns kx = 0 and nx/2 Hermitian in ky); it is left unchanged.

        Parameters
        ----------
        spectrum : ndarray of complex128, shape spectrum_shape
        field_out : ndarray of float64, shape (x_stop - x_start,)

        Returns
        -------
        field_out : ndarray
        """
        _check_size("field_out", field_out, self._R * self.shape[1])
        self._write("z")
        copy = np.copyto
        for (a, b), (_, writes) in zip(self._col_chunks, self._stage_b):
            copy(self._work[: b - a], spectrum[a:b])
            self._plans.columns[b - a][1].execute()
            for to, part in writes:
                copy(to, part)
        self._exchange("z")
        self._rows_backward(field_out)
        self.pairs += 1
        return field_out

    def close(self):
        """Collective: free the shared window (the object is unusable afterwards).

        Optional: without it the window lives until ``MPI.Finalize``.
        """
        if self._buffers.shared:
            self._stage_a = self._stage_b = self._stage_c = []
            self._buffers.free()
