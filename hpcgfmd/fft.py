"""Real FFT of the periodic surface, serial or distributed over an MPI communicator.

The only operation the solver needs is a mode-diagonal operator applied to a real field,
``out = irfft(diag * rfft(v))``: the elastic stiffness, its inverse (the Green's function) and
the SLS history are all of that form. The multiplier is real and even in the mode index m
(it depends on |q| = 2 pi |m| / L only) and the caller folds the 1/n of the inverse transform
into it, so an application is one forward transform, one multiply and one unnormalised
backward transform. Plans are made once on aligned buffers and nothing is allocated per call.

Two classes share one interface (``comm``, ``n``, ``x_start``, ``x_stop``, ``x_blocks``,
``spectrum_shape``, ``wavenumber``, ``apply_diagonal``, ``pairs``, ``communication_time``);
:func:`plan_real_fft` picks one for a communicator.

* :class:`SerialRealFFT`: one rank, a pyfftw rfft/irfft pair of length n.
* :class:`TransposedRealFFT`: a single length-n transform split over the P ranks of ``comm``
  with the four-step (transposed) algorithm below.

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
    * between the stages: all N1 rows of the columns ``n2`` in ``block_range(N2, P, r)``;
    * spectrum: the mode rows ``k1`` in ``block_range(N1/2 + 1, P, r)`` for all ``k2``, a
      ``(M, N2)`` array whose entry ``[i, k2]`` is mode ``k1 + N1*k2`` (``wavenumber`` gives
      its signed index m in (-n/2, n/2]). A rank may own no rows, columns or mode rows when P
      is large; it then skips its local FFTs but still takes part in every collective.

Communication per ``apply_diagonal`` (all on ``comm``): four ``Alltoallv``: rows -> columns
(float64), columns -> mode rows (complex128), and the same two backwards. Each rank sends
(and receives) about ``8 n / P`` bytes in each real transpose and ``8 (n + 2 N2) / P`` bytes
in each complex one, about ``32 n / P`` bytes in all, a fraction 1/P of which stays local.
(Each column block row also carries under 64 bytes of padding, see ``_padded_width``.)

Why this variant: every rank keeps only its own x-block (the solver's contact and CG work
stays local) and the FFT work is split P ways. Allgathering the field and transforming it
on every rank would be simpler, but would move ``8 n`` bytes to every rank and repeat the
whole FFT redundantly P times.
"""
from __future__ import annotations

import math
import time

import numpy as np
import pyfftw
from mpi4py import MPI

from .parallel import block_range


def plan_real_fft(comm, n, planner_effort="FFTW_MEASURE", transposed=None):
    """Make the real FFT suited to ``comm``.

    Every rank of ``comm`` must call it with the same arguments (it makes no MPI call itself,
    but the object's ``apply_diagonal`` is collective).

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
        Communicator over which the surface is distributed.
    n : int
        Number of grid nodes (even).
    planner_effort : str
        FFTW planner flag, e.g. ``"FFTW_MEASURE"`` or ``"FFTW_ESTIMATE"`` (tests).
    transposed : bool or None
        ``None``: serial on one rank, transposed otherwise. ``True`` forces the transposed
        class (also on one rank, for testing). ``False`` demands the serial class and is an
        error on more than one rank.

    Returns
    -------
    SerialRealFFT or TransposedRealFFT
    """
    size = comm.Get_size()
    if transposed is None:
        transposed = size > 1
    if transposed:
        return TransposedRealFFT(comm, n, planner_effort)
    if size > 1:
        raise ValueError(f"a serial FFT cannot be spread over {size} ranks")
    return SerialRealFFT(n, planner_effort, comm=comm)


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
        which balances the two FFT stages and the two transposes.
    """
    if n < 2 or n % 2:
        raise ValueError(f"the transform length must be even and >= 2, got {n}")
    root = math.sqrt(n)
    n1 = min((d for d in range(2, n + 1, 2) if n % d == 0), key=lambda d: (abs(d - root), d))
    return n1, n // n1


def _padded_width(count, itemsize):
    """Row length in elements, >= count, whose size in bytes is an odd multiple of 64.

    Why: the column FFTs stride down the rows of an (N1, C) array. With a power-of-two row
    stride (C = 1024 at n = 2**20) a column maps onto a few cache sets and the strided FFTs
    ran 2-3 times slower; an odd number of 64-byte lines spreads it over all of them and
    keeps every row aligned for SIMD.
    """
    lines = -(-count * itemsize // 64)
    return (lines + (lines % 2 == 0)) * 64 // itemsize if count else 0


class SerialRealFFT:
    """rfft/irfft pair of length n on persistent aligned buffers, on one rank.

    Parameters
    ----------
    n : int
        Number of grid nodes (even).
    planner_effort : str
        FFTW planner flag; FFTW_MEASURE pays for itself after a few hundred transforms.
    comm : mpi4py.MPI.Comm, optional
        One-rank communicator to report as ``comm`` (default ``MPI.COMM_SELF``). The
        signature keeps ``n`` first so that the old ``RealFFT(n)`` calls still work.

    Attributes
    ----------
    comm : mpi4py.MPI.Comm
    n : int
    x_start, x_stop : int
        Owned node range, here ``0, n``.
    x_blocks : list of (int, int)
        ``[(0, n)]``.
    spectrum_shape : tuple of int
        ``(n//2 + 1,)``.
    wavenumber : ndarray of int64, shape (n//2 + 1,)
        Mode index m of each spectrum entry, ``arange(n//2 + 1)`` (q = 2 pi m / L).
    pairs : int
        Number of forward+backward pairs done, for the statistics.
    communication_time : float
        Seconds spent in MPI calls, always 0.
    """

    def __init__(self, n: int, planner_effort: str = "FFTW_MEASURE", comm=None):
        self.comm = MPI.COMM_SELF if comm is None else comm
        self.n = n
        self.x_start, self.x_stop = 0, n
        self.x_blocks = [(0, n)]
        self.spectrum_shape = (n // 2 + 1,)
        self.wavenumber = np.arange(n // 2 + 1, dtype=np.int64)
        self.real = pyfftw.empty_aligned(n, dtype="float64")
        self.spectrum = pyfftw.empty_aligned(n // 2 + 1, dtype="complex128")
        flags = (planner_effort, "FFTW_DESTROY_INPUT")
        self._forward = pyfftw.FFTW(self.real, self.spectrum, flags=flags, threads=1)
        self._backward = pyfftw.FFTW(self.spectrum, self.real, direction="FFTW_BACKWARD",
                                     flags=flags, threads=1)
        self.pairs = 0
        self.communication_time = 0.0

    def apply_diagonal(self, field, diagonal, out):
        """out = irfft(diagonal * rfft(field)) without the 1/n (fold it into ``diagonal``).

        Local (no communication).

        Parameters
        ----------
        field : ndarray of float64, shape (n,)
            Real input field, in its own units (e.g. m).
        diagonal : ndarray, shape (n//2 + 1,)
            Multiplier per mode (units of out / units of field, times 1/n).
        out : ndarray of float64, shape (n,)
            Output buffer (may be ``field``).

        Returns
        -------
        out : ndarray
        """
        self.real[:] = field
        self._forward.execute()
        self.spectrum *= diagonal
        self._backward.execute()
        out[:] = self.real
        self.pairs += 1
        return out


RealFFT = SerialRealFFT  # old name, kept while the callers move to plan_real_fft


class TransposedRealFFT:
    """Length-n real FFT distributed over ``comm`` by the four-step algorithm.

    See the module docstring for the algorithm, the layout and the communication volume.
    Construction makes local FFTW plans only (no MPI call), but every rank of ``comm`` must
    build one; ``apply_diagonal`` is collective.

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
        Communicator over which the nodes are distributed (any size, including 1).
    n : int
        Number of grid nodes (even).
    planner_effort : str
        FFTW planner flag.

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
    pairs : int
        Number of forward+backward pairs done.
    communication_time : float
        Seconds spent in ``Alltoallv`` by this rank (including waiting for the others).
    """

    def __init__(self, comm, n: int, planner_effort: str = "FFTW_MEASURE"):
        self.comm, self.n = comm, n
        self.n1, self.n2 = n1, n2 = split_length(n)
        size, rank = comm.Get_size(), comm.Get_rank()
        rows = [block_range(n1, size, r) for r in range(size)]
        cols = [block_range(n2, size, r) for r in range(size)]
        modes = [block_range(n1 // 2 + 1, size, r) for r in range(size)]
        nrow = [b - a for a, b in rows]
        ncol = [b - a for a, b in cols]
        nmode = [b - a for a, b in modes]
        R, C, M = nrow[rank], ncol[rank], nmode[rank]

        self.x_blocks = [(n2 * a, n2 * b) for a, b in rows]
        self.x_start, self.x_stop = self.x_blocks[rank]
        self.spectrum_shape = (M, n2)
        k = np.arange(*modes[rank])[:, None] + n1 * np.arange(n2)[None, :]
        self.wavenumber = np.where(k <= n // 2, k, k - n).astype(np.int64)

        # Column arrays are stored with padded rows (see _padded_width) and the padding
        # travels inside the packed blocks, so that plain Alltoallv on contiguous buffers
        # still lands every block in place. wr, wc: padded real / complex row lengths.
        wr = [_padded_width(c, 8) for c in ncol]
        wc = [_padded_width(c, 16) for c in ncol]
        offr, offc = np.cumsum([0] + wr), np.cumsum([0] + wc)

        # Buffers. _packed_x holds this rank's real block packed by column block (send of
        # the first transpose, receive of the last); _cols is the (N1, C) column block;
        # _colspec its rfft; _packed_modes the mode rows packed by column block (receive of
        # the second transpose, send of the third); _rowspec the (M, N2) spectrum rows.
        f8, c16 = "float64", "complex128"
        self._packed_x = pyfftw.empty_aligned(R * offr[-1], dtype=f8)
        cols_full = pyfftw.empty_aligned((n1, wr[rank]), dtype=f8)
        colspec_full = pyfftw.empty_aligned((n1 // 2 + 1, wc[rank]), dtype=c16)
        self._cols, self._colspec = cols_full[:, :C], colspec_full[:, :C]
        self._packed_modes = pyfftw.empty_aligned(M * offc[-1], dtype=c16)
        self._rowspec = pyfftw.empty_aligned((M, n2), dtype=c16)

        # Column block s of a packed buffer is a (rows, padded C_s) array: packing is one copy
        # per rank, and the receiving side's concatenation in rank order is directly the
        # padded (N1, C) or (N1/2+1, C) array that the column FFT wants.
        self._col_slices = [slice(a, b) for a, b in cols]
        self._x_views = [
            self._packed_x[R * offr[s]:R * offr[s + 1]].reshape(R, wr[s])[:, :ncol[s]]
            for s in range(size)]
        self._mode_views = [
            self._packed_modes[M * offc[s]:M * offc[s + 1]].reshape(M, wc[s])[:, :ncol[s]]
            for s in range(size)]

        # Alltoallv message specs, built once (counts and displacements in elements).
        def spec(buf, counts, displs, mpitype):
            return [buf, ([int(c) for c in counts], [int(d) for d in displs]), mpitype]

        dbl, cpx = MPI.DOUBLE, MPI.C_DOUBLE_COMPLEX
        x_spec = spec(self._packed_x, [R * w for w in wr], R * offr[:-1], dbl)
        cols_spec = spec(cols_full, [r * wr[rank] for r in nrow],
                         [a * wr[rank] for a, _ in rows], dbl)
        colspec_spec = spec(colspec_full, [m * wc[rank] for m in nmode],
                            [a * wc[rank] for a, _ in modes], cpx)
        modes_spec = spec(self._packed_modes, [M * w for w in wc], M * offc[:-1], cpx)
        self._to_cols = (x_spec, cols_spec)
        self._to_modes = (colspec_spec, modes_spec)
        self._from_modes = (modes_spec, colspec_spec)
        self._from_cols = (cols_spec, x_spec)

        # Twiddles w**(n2*k1) for the local columns; the integer product is reduced mod n
        # before the float division so that the angle is exact for any n.
        k1 = np.arange(n1 // 2 + 1, dtype=np.int64)[:, None]
        col = np.arange(*cols[rank], dtype=np.int64)[None, :]
        angle = (-2.0 * np.pi / n) * ((col * k1) % n)
        self._twiddle = np.exp(1j * angle)
        self._twiddle_conj = self._twiddle.conj()

        # pyfftw refuses zero-size arrays: a rank owning no columns or mode rows has no plans.
        flags = (planner_effort, "FFTW_DESTROY_INPUT")
        self._col_forward = self._col_backward = self._row_forward = self._row_backward = None
        if C:
            self._col_forward = pyfftw.FFTW(self._cols, self._colspec, axes=(0,), flags=flags,
                                            threads=1)
            self._col_backward = pyfftw.FFTW(self._colspec, self._cols, axes=(0,),
                                             direction="FFTW_BACKWARD", flags=flags, threads=1)
        if M:
            self._row_forward = pyfftw.FFTW(self._rowspec, self._rowspec, axes=(1,),
                                            flags=flags, threads=1)
            self._row_backward = pyfftw.FFTW(self._rowspec, self._rowspec, axes=(1,),
                                             direction="FFTW_BACKWARD", flags=flags, threads=1)
        self.pairs = 0
        self.communication_time = 0.0

    def _alltoallv(self, specs):
        start = time.perf_counter()
        self.comm.Alltoallv(*specs)
        self.communication_time += time.perf_counter() - start

    def apply_diagonal(self, field, diagonal, out):
        """out = irfft(diagonal * rfft(field)) on the distributed field, without the 1/n.

        Collective on ``comm`` (four ``Alltoallv``): every rank must call it, also ranks
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
        source = field.reshape(-1, self.n2)
        for view, cs in zip(self._x_views, self._col_slices):
            np.copyto(view, source[:, cs])
        self._alltoallv(self._to_cols)
        if self._col_forward is not None:
            self._col_forward.execute()
            self._colspec *= self._twiddle
        self._alltoallv(self._to_modes)
        if self._row_forward is not None:
            for view, cs in zip(self._mode_views, self._col_slices):
                np.copyto(self._rowspec[:, cs], view)
            self._row_forward.execute()
            self._rowspec *= diagonal
            self._row_backward.execute()
            for view, cs in zip(self._mode_views, self._col_slices):
                np.copyto(view, self._rowspec[:, cs])
        self._alltoallv(self._from_modes)
        if self._col_backward is not None:
            self._colspec *= self._twiddle_conj
            self._col_backward.execute()
        self._alltoallv(self._from_cols)
        target = out.reshape(-1, self.n2)
        for view, cs in zip(self._x_views, self._col_slices):
            np.copyto(target[:, cs], view)
        self.pairs += 1
        return out
