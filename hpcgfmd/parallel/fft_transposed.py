"""A single length-n real FFT split over the ranks of a communicator (four-step algorithm).

Same interface as :class:`hpcgfmd.parallel.fft_serial.SerialRealFFT` (see
:mod:`hpcgfmd.parallel.fft`).

Four-step algorithm
-------------------
Write n = N1 * N2 with N1 even (the even divisor of n closest to sqrt(n)) and view the field
as the row-major matrix ``A[n1, n2] = x[N2*n1 + n2]``. With ``w = exp(-2 pi i / n)`` and
``k = k1 + N1*k2``,

    X[k1 + N1*k2] = sum_n2 exp(-2 pi i n2 k2 / N2) w**(n2 k1) B[k1, n2],
    B[k1, n2] = sum_n1 A[n1, n2] exp(-2 pi i n1 k1 / N1),

i.e. length-N1 transforms down the columns, a twiddle ``w**(n2 k1)``, then length-N2
transforms along the rows. The first stage is real, so only ``k1 = 0 .. N1/2`` is computed
(an rfft): the rows ``k1`` and ``N1 - k1`` of the spectrum are conjugate, since
``n - (k1 + N1 k2) = (N1 - k1) + N1 (N2 - 1 - k2)``, and the rows ``k1 = 0`` and
``k1 = N1/2`` are self-conjugate (they hold both m and n - m). Because the multiplier is even,
``diag * X`` keeps that symmetry, and the backward pass is the exact reverse: inverse complex
transforms along the rows, conjugate twiddle, then a c2r (irfft) of length N1 down the columns,
whose input rows 0 and N1/2 are real and whose missing rows N1/2 < k1 < N1 are the conjugates
of the stored ones, exactly what c2r assumes.

Layout of rank r (``block_range`` blocks: contiguous, balanced, uneven allowed)
    * real space: rows ``n1`` in ``block_range(N1, P, r)``, i.e. the contiguous node block
      ``x[x_start:x_stop]`` with ``x_start = N2 * row_start``;
    * stages A and C (column transforms): the columns ``n2`` in ``block_range(N2, P, r)``;
    * spectrum and stage B (row transforms): the mode rows ``k1`` in
      ``block_range(N1/2 + 1, P, r)`` for all ``k2``, a ``(M, N2)`` array whose entry
      ``[i, k2]`` is mode ``k1 + N1*k2`` (``wavenumber`` gives its signed index m in
      (-n/2, n/2]). A rank may own no rows, columns or mode rows when P is large; it then
      skips its local work but still takes part in every synchronisation.

One application, on each rank (``apply_diagonal``)
    1. copy the columns of ``field`` that each other rank transforms to a block for that rank;
    2. stage A, in chunks of columns: gather the chunk's column segments of all ranks into a
       cache-sized ``(chunk, N1)`` work array (the transposition happens in this copy), rfft
       along its contiguous rows, multiply by the twiddle while writing the rows of the
       ``xt[n2, k1]`` blocks (one block per rank, holding that rank's mode rows ``k1``);
    3. stage B, in chunks of mode rows: gather these mode rows from every rank's ``xt`` block
       for this rank into a ``(chunk, N2)`` work array, complex FFT, ``*= diag``, inverse FFT,
       write the rows of the ``z[k1, n2]`` blocks (one per rank: its columns ``n2``);
    4. stage C, in chunks of columns: gather from every rank's ``z`` block for this rank,
       conjugate twiddle, c2r, write the rows of the ``h[n2, n1]`` blocks (one per rank: its
       rows ``n1``);
    5. gather this rank's rows from every rank's ``h`` block for this rank into ``out``.

    Every FFT runs on a contiguous, cache-resident work array (batched along axis 1, FFTW's
    best case), every large array is written sequentially, and each transposition is done by
    the reads of a gather: strided reads of rows padded to an odd number of cache lines (see
    :func:`~.transport.padded_width`) cost about as much as sequential ones, whereas strided
    writes cost about twice as much. What a rank reads from another rank is always one
    contiguous block. The ranks synchronise between steps 1-2, 2-3, 3-4 and 4-5.

Transport (``transport``) and communication per call
    ``"shared"`` (default when all ranks share a node): the blocks of steps 1-4 live in an
    MPI-3 shared-memory window (``MPI.Win.Allocate_shared``) and the gathers read the other
    ranks' blocks in place; the four synchronisations are ``Win.Sync`` + ``Barrier`` and no
    message is sent. Data cross between ranks inside copies that are needed anyway: each rank
    reads about ``8 n (P - 1) / P**2`` bytes of other ranks' memory in steps 2 and 5 and
    ``8 (n + 2 N2) (P - 1) / P**2`` bytes in steps 3 and 4, ``32 n (P - 1) / P**2`` in all.
    ``"messages"`` (ranks on several nodes, or no shared window): the same blocks are sent by
    four ``Alltoallv`` (no packing: each block is contiguous) into receive blocks that the
    gathers read instead; each rank sends and receives the same ``32 n (P - 1) / P**2`` bytes
    per call (plus the row padding, under 64 bytes a row). The two transports give bitwise
    equal results.

Its measurements are in docs/results.md, "Large transforms"; the per-stage timings, the
transports and what was tried and dropped in that page's history ("Distributed transform").
"""

from __future__ import annotations

import math
import time

import numpy as np
import pyfftw

from .blocks import block_range, chunks
from .real_fft import RealFFT, fftw_plan
from .transport import TRANSPORTS, StageBuffers, padded_width

# Work-array sizes of the chunked stages, in elements: a stage-A/C chunk of columns holds
# about _COLUMN_CHUNK reals (plus its half spectrum), a stage-B chunk about _ROW_CHUNK complex
# values, so that input, output and FFT stay in the 2 MB L2 cache (tuned at n = 2**17..2**22).
_COLUMN_CHUNK = 2**16
_MAX_COLUMNS = 128
_ROW_CHUNK = 2**14
# Rows per call of the transposing copies from and to the caller's (power-of-two strided)
# arrays.
_ROW_BLOCK = 64


def split_length(n):
    """Factor ``n = N1 * N2`` for the four-step transform.

    Parameters
    ----------
    n : int
        Even transform length.

    Returns
    -------
    n1, n2 : int
        ``n1`` is the even divisor of ``n`` closest to ``sqrt(n)`` (the smaller one on a tie),
        which balances the two FFT stages and the two transposes (other splits were measured
        no faster at n = 2**20 on 2 ranks: docs/results.md).
    """
    if n < 2 or n % 2:
        raise ValueError(f"the transform length must be even and >= 2, got {n}")
    root = math.sqrt(n)
    n1 = min((d for d in range(2, n + 1, 2) if n % d == 0), key=lambda d: (abs(d - root), d))
    return n1, n // n1


class TransposedRealFFT(RealFFT):
    """Length-n real FFT distributed over ``comm`` by the four-step algorithm.

    See the module docstring for the algorithm, the layout, the transports and the
    communication volume. Construction is collective on ``comm`` (it decides the transport and
    allocates the shared window), and so is ``apply_diagonal``.

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
        Communicator over which the nodes are distributed (any size, including 1).
    n : int
        Number of grid nodes (even).
    planner_effort : str
        FFTW planner flag.
    transport : {"auto", "shared", "messages"}
        How the ranks see each other's data: ``"shared"`` reads it in an MPI shared-memory
        window (all ranks must be on one node), ``"messages"`` moves it with ``Alltoallv``;
        ``"auto"`` takes ``"shared"`` when all ranks of ``comm`` share a node and the window can
        be allocated, ``"messages"`` otherwise. Every rank must pass the same value.

    Attributes
    ----------
    comm : mpi4py.MPI.Comm
    n : int
    n1, n2 : int
        Factors ``n = n1 * n2`` of the four-step transform (n1 even).
    x_start, x_stop : int
        This rank's contiguous node range ``[x_start, x_stop)`` (global indices).
    x_blocks : list of (int, int)
        ``(x_start, x_stop)`` of every rank, in rank order.
    spectrum_shape : tuple of int
        ``(M, n2)``: this rank's M mode rows (M may be 0).
    wavenumber : ndarray of int64, shape spectrum_shape
        Signed mode index m in (-n/2, n/2] of each local spectrum entry (q = 2 pi m / L).
        Rows ``0 < k1 < n1/2`` also stand for the conjugate modes -m.
    transport : str
        ``"shared"``, ``"messages"``, or ``"none"`` on a one-rank communicator.
    spectrum : ndarray of complex128, shape spectrum_shape
        A spectrum buffer for :meth:`forward` and :meth:`inverse` callers (unused by
        ``apply_diagonal``).
    pairs : int
        Number of forward+backward pairs done (``apply_diagonal`` and ``inverse`` count one
        each).
    communication_time : float
        Seconds spent in the four synchronisations per call (``Barrier`` or ``Alltoallv``),
        including waiting for the other ranks.
    """

    def __init__(self, comm, n: int, planner_effort: str = "FFTW_MEASURE", transport: str = "auto"):
        if transport not in TRANSPORTS:
            raise ValueError(f"transport must be one of {TRANSPORTS}, got {transport!r}")
        self.comm, self.n = comm, n
        self.n1, self.n2 = n1, n2 = split_length(n)
        size, rank = comm.Get_size(), comm.Get_rank()
        k1_count = n1 // 2 + 1
        self._rows = rows = [block_range(n1, size, r) for r in range(size)]
        self._cols = cols = [block_range(n2, size, r) for r in range(size)]
        self._modes = modes = [block_range(k1_count, size, r) for r in range(size)]
        R, C, M = (b - a for a, b in (rows[rank], cols[rank], modes[rank]))
        self._R, self._C, self._M = R, C, M
        self._peers = [s for s in range(size) if s != rank]

        self.x_blocks = [(n2 * a, n2 * b) for a, b in rows]
        self.x_start, self.x_stop = self.x_blocks[rank]
        self.spectrum_shape = (M, n2)
        k = np.arange(*modes[rank])[:, None] + n1 * np.arange(n2)[None, :]
        self.wavenumber = np.where(k <= n // 2, k, k - n).astype(np.int64)

        self._buffers = _stage_buffers(comm, rows, cols, modes, (R, C, M), transport)
        self.transport = self._buffers.transport
        self._out, self._from = self._buffers.mine, self._buffers.read

        # Twiddles w**(n2*k1) for the local columns, [n2, k1]; the integer product is reduced
        # mod n before the float division so that the angle is exact for any n.
        k1 = np.arange(k1_count, dtype=np.int64)[None, :]
        col = np.arange(*cols[rank], dtype=np.int64)[:, None]
        self._twiddle = np.exp((-2j * np.pi / n) * ((col * k1) % n))
        self._twiddle_conj = self._twiddle.conj()

        # Chunks, work arrays and FFTW plans (one pair per distinct chunk height; pyfftw
        # refuses zero-size arrays, so a rank without columns or mode rows has none).
        col_chunks = chunks(C, min(_MAX_COLUMNS, max(1, _COLUMN_CHUNK // n1)))
        row_chunks = chunks(M, max(1, _ROW_CHUNK // n2))
        self._row_blocks = chunks(R, _ROW_BLOCK)
        work_real, work_half, work_rows, column_plans, row_plans = _plans(
            col_chunks, row_chunks, n1, n2, planner_effort
        )
        (
            self._packs,
            self._stage_a,
            self._stage_b,
            self._stage_c,
            self._final_own,
            self._final_peers,
        ) = _stage_steps(
            self, col_chunks, row_chunks, column_plans, row_plans, work_real, work_half, work_rows
        )
        # Spectrum buffer for forward/inverse callers (same role as SerialRealFFT.spectrum).
        self.spectrum = pyfftw.zeros_aligned(self.spectrum_shape, dtype=np.complex128)
        self.pairs = 0
        self.communication_time = 0.0

    def apply_diagonal(self, field, diagonal, out):
        """out = irfft(diagonal * rfft(field)) on the distributed field, without the 1/n.

        Collective on ``comm`` (four synchronisations): every rank must call it, also ranks
        owning no nodes or no modes.

        Parameters
        ----------
        field : ndarray of float64, shape (x_stop - x_start,)
            This rank's block of the real input field, in its own units (e.g. m).
        diagonal : ndarray of float64, shape spectrum_shape
            Multiplier of each local mode, even in m (units of out / units of field, times
            1/n), e.g. a function of ``abs(wavenumber)``.
        out : ndarray of float64, shape (x_stop - x_start,)
            This rank's block of the output (may be ``field``).

        Returns
        -------
        out : ndarray
        """
        copy, multiply = np.copyto, np.multiply
        # 1-2. The columns of the field to the peers; stage A: rfft down the columns,
        # twiddle, rows of the xt blocks.
        self._to_rows(field)

        # 3. Stage B: FFT along the rows, multiplier, inverse FFT, rows of the z blocks.
        for gathers, forward, work, chunk, backward, writes in self._stage_b:
            for to, part in gathers:
                copy(to, part)
            forward.execute()
            multiply(work, diagonal[chunk], out=work)
            backward.execute()
            for to, part in writes:
                copy(to, part)
        self._exchange("z")

        # 4-5. Stage C: conjugate twiddle, c2r down the columns; this rank's rows from every
        # rank's h (the own columns before the synchronisation: an early rank waits less).
        self._from_rows(out)
        self.pairs += 1
        return out

    def forward(self, field, spectrum_out):
        """spectrum_out = rfft(field) on this rank's mode rows (steps 1-2 and the forward
        half of stage B of :meth:`apply_diagonal`).

        Collective on ``comm`` (two synchronisations). Half of a pair:
        ``inverse(d * forward(f))`` equals ``apply_diagonal(f, d)`` bitwise (same plans and
        operations; the multiply moves to the caller); ``pairs`` is counted in
        :meth:`inverse`.

        Parameters
        ----------
        field : ndarray of float64, shape (x_stop - x_start,)
            This rank's block of the real field.
        spectrum_out : ndarray of complex128, shape spectrum_shape
            This rank's modes, entry ``[i, k2]`` being mode ``k1 + n1*k2`` (see
            ``wavenumber``); may be :attr:`spectrum`.

        Returns
        -------
        spectrum_out : ndarray
        """
        self._to_rows(field)
        copy = np.copyto
        for gathers, forward, work, chunk, _, _ in self._stage_b:
            for to, part in gathers:
                copy(to, part)
            forward.execute()
            copy(spectrum_out[chunk], work)
        return spectrum_out

    def inverse(self, spectrum, field_out):
        """field_out = irfft(spectrum) without the 1/n, from this rank's mode rows.

        Collective on ``comm`` (two synchronisations); counts one pair in ``pairs``.
        ``spectrum`` must be the spectrum of a real field times a multiplier even in m, as
        ``forward`` gives it (the rows k1 = 0 and n1/2 hold both m and -m); it is left
        unchanged.

        Parameters
        ----------
        spectrum : ndarray of complex128, shape spectrum_shape
        field_out : ndarray of float64, shape (x_stop - x_start,)

        Returns
        -------
        field_out : ndarray
        """
        copy = np.copyto
        for _, _, work, chunk, backward, writes in self._stage_b:
            copy(work, spectrum[chunk])
            backward.execute()
            for to, part in writes:
                copy(to, part)
        self._exchange("z")
        self._from_rows(field_out)
        self.pairs += 1
        return field_out

    def _to_rows(self, field):
        """Steps 1 and 2 of :meth:`apply_diagonal`: field columns to the xt blocks."""
        source = field.reshape(-1, self.n2)
        copy, multiply = np.copyto, np.multiply
        for block, columns in self._packs:
            copy(block, source[:, columns])
        self._exchange("pack")
        for peers, own, columns, forward, writes in self._stage_a:
            for to, part in peers:
                copy(to, part)
            for to, block in own:
                copy(to, source[block, columns].T)
            forward.execute()
            for half, twiddle, to in writes:
                multiply(half, twiddle, out=to)
        self._exchange("xt")

    def _from_rows(self, out):
        """Steps 4 and 5 of :meth:`apply_diagonal`: the z blocks to this rank's block of out."""
        target = out.reshape(-1, self.n2)
        copy, multiply = np.copyto, np.multiply
        for gathers, half, twiddle, backward, writes in self._stage_c:
            for to, part in gathers:
                copy(to, part)
            multiply(half, twiddle, out=half)
            backward.execute()
            for to, part in writes:
                copy(to, part)
        for block, columns, part in self._final_own:
            copy(target[block, columns], part)
        self._exchange("h")
        for block, columns, part in self._final_peers:
            copy(target[block, columns], part)

    def _exchange(self, stage):
        """Make the peers' blocks of ``stage`` readable (collective on ``comm``)."""
        start = time.perf_counter()
        self._buffers.exchange(stage)
        self.communication_time += time.perf_counter() - start

    def close(self):
        """Free the shared window (collective; the object is unusable afterwards).

        Optional: without it the window lives until ``MPI.Finalize``.
        """
        if self._buffers.shared:
            self._out = self._from = {}
            self._packs = self._stage_a = self._stage_b = self._stage_c = []
            self._final_own = self._final_peers = []
            self._buffers.free()


def _plans(col_chunks, row_chunks, n1, n2, planner_effort):
    """Work arrays and FFTW plans of the chunked stages: one plan pair per distinct chunk height
    (pyfftw refuses zero-size arrays, so a rank without columns or mode rows has none).

    Returns (work_real, work_half, work_rows, column_plans, row_plans); the plans map a chunk
    height to its (forward, backward) pair on the leading rows of the work arrays.
    """
    k1_count = n1 // 2 + 1
    tall = max((b - a for a, b in col_chunks), default=1)
    high = max((b - a for a, b in row_chunks), default=1)
    f8, c16 = np.dtype(np.float64), np.dtype(np.complex128)
    work_real = pyfftw.zeros_aligned((tall, n1), dtype=f8)
    work_half = pyfftw.zeros_aligned((tall, k1_count), dtype=c16)
    work_rows = pyfftw.zeros_aligned((high, n2), dtype=c16)
    flags = (planner_effort, "FFTW_DESTROY_INPUT")
    column_plans, row_plans = {}, {}
    for h in {b - a for a, b in col_chunks}:
        real, half = work_real[:h], work_half[:h]
        column_plans[h] = (
            fftw_plan(real, half, axes=(1,), flags=flags),
            fftw_plan(half, real, axes=(1,), direction="FFTW_BACKWARD", flags=flags),
        )
    for h in {b - a for a, b in row_chunks}:
        work = work_rows[:h]
        row_plans[h] = (
            fftw_plan(work, work, axes=(1,), flags=flags),
            fftw_plan(work, work, axes=(1,), direction="FFTW_BACKWARD", flags=flags),
        )
    return work_real, work_half, work_rows, column_plans, row_plans


def _stage_buffers(comm, rows, cols, modes, local, transport):
    """The shared buffers of the stages (:class:`~.transport.StageBuffers`).

    Outputs of step 1 and stages A, B, C of rank s, each split into one block per destination
    rank t (rows padded, see transport.padded_width), so that what t reads is one contiguous
    block: "pack" (R_s, C_t) field columns (none for t = s), "xt" (C_s, M_t) stage A, "z"
    (M_s, C_t) stage B, "h" (C_s, R_t) stage C, each [rows, columns]. ``local``: this rank's
    (R, C, M).
    """
    size, rank = comm.Get_size(), comm.Get_rank()
    R, C, M = local
    nrows, ncols, nmodes = ([b - a for a, b in blocks] for blocks in (rows, cols, modes))

    def outputs(s):
        Rs, Cs, Ms = (b - a for a, b in (rows[s], cols[s], modes[s]))
        return {
            "pack": [(Rs if t != s else 0, padded_width(ncols[t], 8)) for t in range(size)],
            "xt": [(Cs, padded_width(nmodes[t], 16)) for t in range(size)],
            "z": [(Ms, padded_width(ncols[t], 16)) for t in range(size)],
            "h": [(Cs, padded_width(nrows[t], 8)) for t in range(size)],
        }

    incoming = {
        stage: [(count[s] if s != rank else 0, width) for s in range(size)]
        for stage, count, width in (
            ("pack", nrows, C),
            ("xt", ncols, M),
            ("z", nmodes, C),
            ("h", ncols, R),
        )
    }
    return StageBuffers(comm, outputs, incoming, transport)


def _stage_steps(
    self, col_chunks, row_chunks, column_plans, row_plans, work_real, work_half, work_rows
):
    """The views the stages of ``self`` (a TransposedRealFFT) copy between, built once, so
    that a call only slices the caller's arrays.

    Returns (packs, stage_a, stage_b, stage_c, final_own, final_peers): the per-chunk lists of
    (destination, source) views, plans and twiddles that ``_to_rows``, ``apply_diagonal`` and
    ``_from_rows`` walk through.
    """
    rank = self.comm.Get_rank()
    cols = self._cols
    col0 = cols[rank][0]
    out, read = self._out, self._from
    blocks = {stage: out[stage].blocks for stage in out}
    packs = [
        (blocks["pack"][s][:, : cols[s][1] - cols[s][0]], slice(*cols[s])) for s in self._peers
    ]
    stage_a, stage_c = _column_stages(self, col_chunks, column_plans, work_real, work_half, blocks)
    stage_b = _row_stages(self, row_chunks, row_plans, work_rows, blocks)
    # Final gather: this rank's rows from every rank's h (own part first, see
    # apply_diagonal), as (rows slice, columns slice, source view).
    own_h = blocks["h"][rank][:, : self._R]
    final_own = [
        (slice(p, q), slice(col0, col0 + self._C), own_h[:, p:q].T) for p, q in self._row_blocks
    ]
    final_peers = [
        (slice(p, q), slice(*cols[s]), part[:, p:q].T)
        for s, part in read["h"].items()
        for p, q in self._row_blocks
    ]
    return packs, stage_a, stage_b, stage_c, final_own, final_peers


def _column_stages(self, col_chunks, column_plans, work_real, work_half, blocks):
    """Stages A and C of ``self`` (:func:`_stage_steps`), per chunk of columns."""
    rank, size = self.comm.Get_rank(), self.comm.Get_size()
    rows, modes = self._rows, self._modes
    row0, col0, mode0 = rows[rank][0], self._cols[rank][0], modes[rank][0]
    read = self._from
    stage_a, stage_c = [], []
    for a, b in col_chunks:
        real, half = work_real[: b - a], work_half[: b - a]
        forward, backward = column_plans[b - a]
        # A: peers' rows of these columns, then (per call) this rank's rows from field;
        # rfft; twiddle while writing each destination's mode block.
        stage_a.append(
            (
                [(real[:, slice(*rows[s])], part[:, a:b].T) for s, part in read["pack"].items()],
                [(real[:, row0 + p : row0 + q], slice(p, q)) for p, q in self._row_blocks],
                slice(col0 + a, col0 + b),
                forward,
                [
                    (
                        half[:, slice(*modes[t])],
                        self._twiddle[a:b, slice(*modes[t])],
                        blocks["xt"][t][a:b, : modes[t][1] - modes[t][0]],
                    )
                    for t in range(size)
                ],
            )
        )
        # C: every rank's mode rows of these columns, conjugate twiddle, c2r, then each
        # destination's row block.
        stage_c.append(
            (
                [(half[:, slice(*modes[s])], part[:, a:b].T) for s, part in read["z"].items()]
                + [(half[:, mode0 : mode0 + self._M], blocks["z"][rank][:, a:b].T)],
                half,
                self._twiddle_conj[a:b],
                backward,
                [
                    (blocks["h"][t][a:b, : rows[t][1] - rows[t][0]], real[:, slice(*rows[t])])
                    for t in range(size)
                ],
            )
        )
    return stage_a, stage_c


def _row_stages(self, row_chunks, row_plans, work_rows, blocks):
    """Stage B of ``self`` (:func:`_stage_steps`), per chunk of mode rows."""
    rank, size = self.comm.Get_rank(), self.comm.Get_size()
    cols = self._cols
    col0 = cols[rank][0]
    stage_b = []
    for a, b in row_chunks:
        work = work_rows[: b - a]
        forward, backward = row_plans[b - a]
        # B: every rank's columns of these mode rows, FFT, multiplier, inverse FFT, then
        # each destination's column block.
        stage_b.append(
            (
                [(work[:, slice(*cols[s])], part[:, a:b].T) for s, part in self._from["xt"].items()]
                + [(work[:, col0 : col0 + self._C], blocks["xt"][rank][:, a:b].T)],
                forward,
                work,
                slice(a, b),
                backward,
                [
                    (blocks["z"][t][a:b, : cols[t][1] - cols[t][0]], work[:, slice(*cols[t])])
                    for t in range(size)
                ],
            )
        )
    return stage_b
