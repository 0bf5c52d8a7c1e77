"""A single length-n real FFT split over two ranks by one radix-2 step (decimation in frequency).

Same interface as :class:`hpcgfmd.parallel.fft_serial.SerialRealFFT` (see
:mod:`hpcgfmd.parallel.fft`); :func:`~hpcgfmd.parallel.fft.plan_real_fft` takes it for two
ranks when 4 divides n (n >= 8). Each rank does half the serial work in transforms of its
own, with two exchanges of n/2 doubles per pair, against the four of the four-step transform
(:mod:`hpcgfmd.parallel.fft_transposed`), whose transposes cost more than its FFTs.

Algorithm
---------
Rank 0 owns the nodes a = x[0:M], rank 1 b = x[M:n] (M = n/2, L = M/2) and, with
w = exp(-2 pi i / n), the spectrum X[m] = sum_j x_j w^(j m) splits into

    X[2k]     = rfft_M(a + b)[k],                     k = 0 .. L       (rank 0: even modes)
    X[2k + 1] = sum_{j<M} d_j w^(j (2k + 1)),  d = a - b,  k = 0 .. L-1   (rank 1: odd modes).

The odd modes of the real d come from one complex FFT of length L. With
v_m = (d_2m + i d_2m+1) w^(2m) and V = fft_L(v), the sums over the even and the odd d_j are
A = (V_k + conj V_(L-1-k)) / 2 and B = (V_k - conj V_(L-1-k)) / (2i), since both have the
symmetry A_(L-1-k) = conj A_k; then X[2k+1] = A_k + t_k B_k, t_k = w^(2k+1). The odd modes
above n/2 are the conjugates of these, so the two ranks hold each mode 0 .. n/2 once. Back,
for a multiplier D even in m (the 1/n folded in, as everywhere; all transforms here are
unnormalised),

    y[j] = p[j] + q[j],   y[j + M] = p[j] - q[j],   j < M,

with p = irfft_M(D X_even) (rank 0) and q the odd modes' part, real:
q[2m] + i q[2m+1] = conj(w^(2m)) ifft_L(W)[m], W_k = (Y_k + conj Y_(L-1-k))
+ i conj(t_k) (Y_k - conj Y_(L-1-k)), Y_k = D[2k+1] X[2k+1] (the same symmetry, backward).
The passes over the odd modes are compiled (:mod:`hpcgfmd.parallel.fft_kernels`).

Layout
    real space: rank 0 the nodes [0, n/2), rank 1 [n/2, n);
    spectrum: rank 0 the modes 0, 2, .., n/2 (shape (n/4 + 1,)), rank 1 the modes
    1, 3, .., n/2 - 1 (shape (n/4,)), ``wavenumber`` their indices m.

One application (``apply_diagonal``), on each rank
    1. copy the field into the shared block the peer reads; synchronise;
    2. rank 0: a + b, rfft, multiply, irfft into its shared block (p);
       rank 1: a - b twisted into v, fft, the fused odd-mode pass (A, B, X, multiply, W),
       ifft into its shared block; synchronise;
    3. both untwist rank 1's block into q as they combine: out = p + q on rank 0, p - q on
       rank 1.

The blocks live in a shared-memory window on one node (no message is sent) or are sent by
``Alltoallv`` across nodes (:class:`~hpcgfmd.parallel.transport.StageBuffers`; bitwise equal
results). After a synchronisation of one stage's blocks the peer may read them until the next
synchronisation, so a rank about to write the blocks of the stage synchronised last waits for
the peer first (:meth:`HalvedRealFFT._write`). ``apply_diagonal`` after ``apply_diagonal``
alternates the stages and never waits: two synchronisations per application. A forward
followed by a forward or an application, and an application or an inverse followed by an
inverse, wait once. Measurements: docs/results.md, "Large transforms".
"""

from __future__ import annotations

import time

import numpy as np
import pyfftw

from .fft_kernels import (
    combine,
    odd_modes,
    odd_modes_backward,
    odd_modes_multiplied,
    scale,
    twist_difference,
)
from .real_fft import RealFFT, fftw_plan
from .transport import StageBuffers, padded_width

_STAGES = ("pack", "h")  # the field (step 1) and this rank's part of the result (step 2)


def fits(size, n):
    """True when the two-rank split applies: two ranks and 4 dividing n (n >= 8)."""
    return size == 2 and n % 4 == 0 and n >= 8


class HalvedRealFFT(RealFFT):
    """Real FFT of length n over the two ranks of ``comm`` (module docstring).

    Construction is collective on ``comm``.

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
        Communicator of exactly two ranks.
    n : int
        Number of grid nodes, a multiple of 4, at least 8.
    planner_effort : str
        FFTW planner flag.
    transport : {"auto", "shared", "messages"}
        How the ranks read each other's blocks (:mod:`hpcgfmd.parallel.transport`).

    Attributes
    ----------
    comm : mpi4py.MPI.Comm
    n : int
    rank : int
        This rank in ``comm`` (0: even modes, 1: odd modes).
    x_start, x_stop : int
        Owned node range: ``0, n/2`` on rank 0, ``n/2, n`` on rank 1.
    x_blocks : list of (int, int)
        ``[(0, n/2), (n/2, n)]``.
    spectrum_shape : tuple of int
        ``(n/4 + 1,)`` on rank 0, ``(n/4,)`` on rank 1.
    wavenumber : ndarray of int64, shape spectrum_shape
        Mode index m of each local entry: the even ones on rank 0, the odd on rank 1.
    spectrum : ndarray of complex128, shape spectrum_shape
        The transforms' own spectrum buffer (passing it to :meth:`forward` or
        :meth:`inverse` saves a copy; valid until the next transform call).
    transport : str
        ``"shared"`` or ``"messages"``.
    pairs : int
        Forward+backward pairs done (``apply_diagonal`` and ``inverse`` count one each).
    communication_time : float
        Seconds in the synchronisations and the waits for the peer (s).
    """

    def __init__(self, comm, n: int, planner_effort: str = "FFTW_MEASURE", transport: str = "auto"):
        size, rank = comm.Get_size(), comm.Get_rank()
        if not fits(size, n):
            raise ValueError(
                f"the two-rank split needs 2 ranks and n a multiple of 4 "
                f"(n >= 8), got {size} ranks and n = {n}"
            )
        self.comm, self.n, self.rank = comm, n, rank
        half, quarter = n // 2, n // 4
        self.x_blocks = [(0, half), (half, n)]
        self.x_start, self.x_stop = self.x_blocks[rank]
        self._field_shape = (half,)
        k = np.arange(quarter + (rank == 0), dtype=np.int64)
        self.wavenumber = 2 * k + rank
        self.spectrum_shape = (self.wavenumber.size,)

        # One block of n/2 doubles for the peer per stage.
        width = padded_width(half, 8)

        def outputs(s):
            return {stage: [(int(t != s), width) for t in range(2)] for stage in _STAGES}

        incoming = {stage: [(int(s != rank), half) for s in range(2)] for stage in _STAGES}
        self._buffers = StageBuffers(comm, outputs, incoming, transport)
        self.transport = self._buffers.transport
        peer = 1 - rank
        self._send = {stage: self._buffers.mine[stage].blocks[peer][0, :half] for stage in _STAGES}
        self._received = {stage: self._buffers.read[stage][peer][0] for stage in _STAGES}
        self._synchronised = None  # the stage of the last synchronisation (see _write)

        flags = (planner_effort,)
        m = np.arange(quarter, dtype=np.int64)
        self._twist = np.exp((-2j * np.pi / n) * (2 * m))  # w^(2m), 2m < n
        if rank == 0:  # p is transformed straight into the block the peer reads
            self._real = pyfftw.empty_aligned(half, dtype="float64")
            self.spectrum = pyfftw.empty_aligned(quarter + 1, dtype="complex128")
            self._forward = fftw_plan(self._real, self.spectrum, flags=flags)
            self._backward = fftw_plan(
                self.spectrum,
                self._send["h"],
                direction="FFTW_BACKWARD",
                flags=flags + ("FFTW_DESTROY_INPUT",),
            )
        else:  # ifft_L(W) too, untwisted by both ranks as they combine (step 3)
            self.spectrum = pyfftw.empty_aligned(quarter, dtype="complex128")
            self._forward = fftw_plan(self.spectrum, self.spectrum, flags=flags)
            self._backward = fftw_plan(
                self.spectrum,
                self._send["h"].view(np.complex128),
                direction="FFTW_BACKWARD",
                flags=flags + ("FFTW_DESTROY_INPUT",),
            )
            self._odd = np.exp((-2j * np.pi / n) * (2 * m + 1))  # t_k = w^(2k+1)
        self.pairs = 0
        self.communication_time = 0.0

    # --- the synchronisations ------------------------------------------------------------
    def _write(self, stage):
        """Collective when it waits: the block of ``stage`` this rank may now overwrite.

        After a synchronisation of ``stage`` the peer may still read its block: wait for
        the peer first (shared window only: messages are read from the receiving rank's own
        buffer). See the module docstring for the sequences of calls that wait.
        """
        if self._send is None:
            raise ValueError("the transform was closed")
        if self._synchronised == stage:
            started = time.perf_counter()
            self._buffers.barrier()
            self._synchronised = None
            self.communication_time += time.perf_counter() - started
        return self._send[stage]

    def _exchange(self, stage):
        """Collective: the peer's block of ``stage`` becomes readable."""
        started = time.perf_counter()
        self._buffers.exchange(stage)
        self._synchronised = stage
        self.communication_time += time.perf_counter() - started

    def _check(self, name, array, shape):
        if array.shape != shape:
            raise ValueError(
                f"{name} has shape {array.shape}, rank {self.rank} of the "
                f"two-rank transform takes {shape}"
            )

    def _transform_field(self, field):
        """Collective (step 1 and the forward half of step 2): the local modes of the field
        in :attr:`spectrum`, before rank 1's odd-mode pass."""
        self._check("field", field, self._field_shape)
        np.copyto(self._write("pack"), field)
        self._exchange("pack")
        other = self._received["pack"]
        if self.rank == 0:
            np.add(field, other, out=self._real)
        else:
            twist_difference(other, field, self._twist, self.spectrum)
        self._forward.execute()

    def _combine(self, out):
        """Collective (step 3): out = p + q on rank 0, p - q on rank 1, q untwisted here
        from rank 1's ifft_L(W)."""
        self._exchange("h")
        mine, peer = self._send["h"], self._received["h"]
        if self.rank == 0:
            combine(mine, peer.view(np.complex128), self._twist, 1.0, out)
        else:
            combine(peer, mine.view(np.complex128), self._twist, -1.0, out)

    # --- one application -------------------------------------------------------------------
    def apply_diagonal(self, field, diagonal, out):
        """out = irfft(diagonal * rfft(field)) on the distributed field, without the 1/n.

        Collective on ``comm`` (two synchronisations, a third after a forward).

        Parameters
        ----------
        field : ndarray of float64, shape (n/2,)
            This rank's half of the real input field, in its own units (e.g. m).
        diagonal : ndarray of float64, shape spectrum_shape
            Multiplier of each local mode, even in m (units of out / units of field, times
            1/n), e.g. a function of ``abs(wavenumber)``.
        out : ndarray of float64, shape (n/2,)
            This rank's half of the output (may be ``field``).

        Returns
        -------
        out : ndarray
        """
        self._check("diagonal", diagonal, self.spectrum_shape)
        self._check("out", out, self._field_shape)
        self._transform_field(field)  # its synchronisation frees the "h" blocks
        if self.rank == 0:
            scale(self.spectrum, diagonal)
        else:
            odd_modes_multiplied(self.spectrum, self._odd, diagonal)
        self._backward.execute()  # into the block the peer reads
        self._combine(out)
        self.pairs += 1
        return out

    # --- the halves of a pair ----------------------------------------------------------------
    def forward(self, field, spectrum_out):
        """spectrum_out = rfft(field) at this rank's modes (no normalisation).

        Collective (one synchronisation, two after a forward). Half of a pair:
        ``inverse(d * forward(f))`` equals ``apply_diagonal(f, d)`` (the same operations in
        the same order); ``pairs`` is counted in :meth:`inverse`.

        Parameters
        ----------
        field : ndarray of float64, shape (n/2,)
        spectrum_out : ndarray of complex128, shape spectrum_shape
            May be :attr:`spectrum`.

        Returns
        -------
        spectrum_out : ndarray
        """
        self._check("spectrum_out", spectrum_out, self.spectrum_shape)
        self._transform_field(field)
        if self.rank == 1:
            odd_modes(self.spectrum, self._odd)
        if spectrum_out is not self.spectrum:
            spectrum_out[:] = self.spectrum
        return spectrum_out

    def inverse(self, spectrum, field_out):
        """field_out = irfft(spectrum) without the 1/n (unnormalised, like apply_diagonal).

        Collective (one synchronisation, two after an application or an inverse). Counts
        one pair in ``pairs``. Rank 0's modes 0 and n/2 must be real (their imaginary parts
        are ignored, as by numpy's irfft).

        Parameters
        ----------
        spectrum : ndarray of complex128, shape spectrum_shape
            Left unchanged unless it is :attr:`spectrum` itself.
        field_out : ndarray of float64, shape (n/2,)

        Returns
        -------
        field_out : ndarray
        """
        self._check("spectrum", spectrum, self.spectrum_shape)
        self._check("field_out", field_out, self._field_shape)
        self._write("h")
        if spectrum is not self.spectrum:
            self.spectrum[:] = spectrum
        if self.rank == 1:
            odd_modes_backward(self.spectrum, self._odd)
        self._backward.execute()
        self._combine(field_out)
        self.pairs += 1
        return field_out

    def close(self):
        """Collective: release the shared window; the transform is unusable afterwards."""
        self._send = self._received = None
        self._buffers.free()
