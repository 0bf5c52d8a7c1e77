"""A single length-n real FFT split over two ranks by one radix-2 step (decimation in frequency).

Same interface as :class:`hpcgfmd.parallel.fft_serial.SerialRealFFT` (see
:mod:`hpcgfmd.parallel.fft`); :func:`~hpcgfmd.parallel.fft.plan_real_fft` takes it for two
ranks when 4 divides n. Each rank does half the serial work in two transforms of its own,
with two exchanges of n/2 doubles per pair, against the four of the four-step transform
(:mod:`hpcgfmd.parallel.fft_transposed`), whose transposes cost more than its FFTs.

Algorithm
---------
Rank 0 owns the nodes a = x[0:M], rank 1 b = x[M:n] (M = n/2, L = M/2) and, with
w = exp(-2 pi i / n), the spectrum X[m] = sum_j x_j w^(j m) splits into

    X[2k]     = rfft_M(a + b)[k],                     k = 0 .. L       (rank 0: even modes)
    X[2k + 1] = sum_{j<M} d_j w^(j (2k + 1)),  d = a - b,  k = 0 .. L-1   (rank 1: odd modes).

The odd modes of the real d come from one complex FFT of length L. With
v_m = (d_2m + i d_2m+1) exp(-i pi m / L) and V = fft_L(v), the sums over the even and the
odd d_j are A = (V_k + conj V_(L-1-k)) / 2 and B = (V_k - conj V_(L-1-k)) / (2i), since
both have the symmetry A_(L-1-k) = conj A_k; then X[2k+1] = A_k + t_k B_k, t_k = w^(2k+1).
The odd modes above n/2 are the conjugates of these, so the two ranks hold each mode
0 .. n/2 once. Back, for a multiplier D even in m (the 1/n folded in, as everywhere),

    y[j] = p[j] + q[j],   y[j + M] = p[j] - q[j],   j < M,

with p = irfft_M(D X_even) (unnormalised, rank 0) and q the odd modes' part, real:
q[2m] + i q[2m+1] = exp(i pi m / L) ifft_L(W)[m], W_k = (Y_k + conj Y_(L-1-k))
+ i conj(t_k) (Y_k - conj Y_(L-1-k)), Y_k = D[2k+1] X[2k+1] (the same symmetry, backward).

Layout
    real space: rank 0 the nodes [0, n/2), rank 1 [n/2, n);
    spectrum: rank 0 the modes 0, 2, .., n/2 (shape (n/4 + 1,)), rank 1 the modes
    1, 3, .., n/2 - 1 (shape (n/4,)), ``wavenumber`` their indices m.

One application (``apply_diagonal``), on each rank
    1. copy the field into the shared block the peer reads; synchronise;
    2. rank 0: a + b, rfft, multiply, irfft into its shared block (p);
       rank 1: a - b twisted into v, fft, the fused odd-mode pass (A, B, X, multiply, W),
       ifft, untwisted into its shared block (q); synchronise;
    3. rank 0: out = p + q; rank 1: out = p - q.

The blocks live in a shared-memory window on one node (no message is sent) or are sent by
``Alltoallv`` across nodes (:class:`~hpcgfmd.parallel.transport.StageBuffers`; bitwise equal
results). A block written in step 1 is not written again before the peer has passed the
next synchronisation, so two synchronisations per application suffice. The odd modes' passes
are compiled loops (numba, cached per machine; :func:`compile_all`). Measurements:
docs/results.md, "Distributed transform".
"""
from __future__ import annotations

import time

import numpy as np
import pyfftw
from numba import njit

from .transport import StageBuffers, padded_width


def fits(size, n):
    """True when the two-rank split applies: two ranks and 4 dividing n (n >= 8)."""
    return size == 2 and n % 4 == 0 and n >= 8


class HalvedRealFFT:
    """Real FFT of length n over the two ranks of ``comm`` (module docstring).

    Construction is collective on ``comm``.

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
        Communicator of exactly two ranks.
    n : int
        Number of grid nodes, a multiple of 4.
    planner_effort : str
        FFTW planner flag.
    transport : {"auto", "shared", "messages"}
        How the ranks read each other's blocks (:mod:`hpcgfmd.parallel.transport`).

    Attributes
    ----------
    comm : mpi4py.MPI.Comm
    n : int
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
        Seconds in the synchronisations (waiting for the peer included).
    """

    def __init__(self, comm, n: int, planner_effort: str = "FFTW_MEASURE",
                 transport: str = "auto"):
        size, rank = comm.Get_size(), comm.Get_rank()
        if not fits(size, n):
            raise ValueError(f"the two-rank split needs 2 ranks and n a multiple of 4 "
                             f"(n >= 8), got {size} ranks and n = {n}")
        self.comm, self.n, self.rank = comm, n, rank
        half, quarter = n // 2, n // 4
        self._half, self._quarter = half, quarter
        self.x_blocks = [(0, half), (half, n)]
        self.x_start, self.x_stop = self.x_blocks[rank]
        self._peer = 1 - rank
        k = np.arange(quarter + (rank == 0), dtype=np.int64)
        self.wavenumber = 2 * k + rank
        self.spectrum_shape = (self.wavenumber.size,)

        # One block of n/2 doubles for the peer per stage: "pack" the field (step 1), "h"
        # this rank's part p or q of the result (step 2).
        width = padded_width(half, 8)

        def outputs(s):
            return {stage: [(int(t != s), width) for t in range(2)] for stage in ("pack", "h")}

        incoming = {stage: [(int(s != rank), half) for s in range(2)]
                    for stage in ("pack", "h")}
        self._buffers = StageBuffers(comm, outputs, incoming, transport)
        self.transport = self._buffers.transport
        peer = self._peer
        self._send = {stage: self._buffers.mine[stage].blocks[peer][0, :half]
                      for stage in ("pack", "h")}
        self._received = {stage: self._buffers.read[stage][peer][0]
                          for stage in ("pack", "h")}
        self._read_by_peer = None  # the stage the peer may still be reading (see _write)

        flags = (planner_effort,)
        m = np.arange(quarter, dtype=np.int64)
        # exp(-i pi m / L) = w^(2m); the integer angle reduced before the division
        self._twist = np.exp((-2j * np.pi / n) * (2 * m))
        if rank == 0:  # p is transformed straight into the block the peer reads
            self._real = pyfftw.empty_aligned(half, dtype="float64")
            self.spectrum = pyfftw.empty_aligned(quarter + 1, dtype="complex128")
            self._forward = pyfftw.FFTW(self._real, self.spectrum, flags=flags, threads=1)
            self._backward = pyfftw.FFTW(self.spectrum, self._send["h"],
                                         direction="FFTW_BACKWARD",
                                         flags=flags + ("FFTW_DESTROY_INPUT",), threads=1)
        else:  # ifft_L(W) too, untwisted by both ranks as they combine (step 3)
            self.spectrum = pyfftw.empty_aligned(quarter, dtype="complex128")
            self._forward = pyfftw.FFTW(self.spectrum, self.spectrum, flags=flags,
                                        threads=1)
            self._backward = pyfftw.FFTW(self.spectrum, self._send["h"].view(np.complex128),
                                         direction="FFTW_BACKWARD",
                                         flags=flags + ("FFTW_DESTROY_INPUT",), threads=1)
            self._odd = np.exp((-2j * np.pi / n) * ((2 * m + 1) % n))  # t_k = w^(2k+1)
        self.pairs = 0
        self.communication_time = 0.0

    # --- the synchronisations ------------------------------------------------------------
    def _write(self, stage):
        """Collective when it waits: the block of ``stage`` this rank may now overwrite.

        After a synchronisation of one stage the peer may read that stage's block until
        the next synchronisation; ``apply_diagonal`` alternates the stages, so it never
        waits here. Two forward() or two inverse() calls in a row wait once (shared window
        only: messages are read from the receiving rank's own buffer).
        """
        if self._read_by_peer == stage:
            self._buffers.barrier()
            self._read_by_peer = None
        return self._send[stage]

    def _exchange(self, stage):
        started = time.perf_counter()
        self._buffers.exchange(stage)
        self._read_by_peer = stage
        self.communication_time += time.perf_counter() - started

    def _gather_field(self, field):
        """Collective: the field to the peer (step 1); returns the peer's half."""
        np.copyto(self._write("pack"), field)
        self._exchange("pack")
        return self._received["pack"]

    # --- one application -------------------------------------------------------------------
    def apply_diagonal(self, field, diagonal, out):
        """out = irfft(diagonal * rfft(field)) on the distributed field, without the 1/n.

        Collective on ``comm`` (two synchronisations).

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
        other = self._gather_field(field)
        self._write("h")
        if self.rank == 0:
            np.add(field, other, out=self._real)
            self._forward.execute()
            scale(self.spectrum, diagonal)
        else:
            twist_difference(other, field, self._twist, self.spectrum)
            self._forward.execute()
            odd_modes_multiplied(self.spectrum, self._odd, diagonal)
        self._backward.execute()  # into the block the peer reads
        self._combine(out)
        self.pairs += 1
        return out

    def _combine(self, out):
        """Collective (step 3): out = p + q on rank 0, p - q on rank 1 (q untwisted here
        from rank 1's ifft_L(W))."""
        self._exchange("h")
        mine, peer = self._send["h"], self._received["h"]
        if self.rank == 0:
            combine(mine, peer.view(np.complex128), self._twist, 1.0, out)
        else:
            combine(peer, mine.view(np.complex128), self._twist, -1.0, out)

    # --- the halves of a pair ----------------------------------------------------------------
    def forward(self, field, spectrum_out):
        """spectrum_out = rfft(field) at this rank's modes (no normalisation).

        Collective (one synchronisation). Half of a pair: ``inverse(d * forward(f))`` equals
        ``apply_diagonal(f, d)`` to round-off; ``pairs`` is counted in :meth:`inverse`.

        Parameters
        ----------
        field : ndarray of float64, shape (n/2,)
        spectrum_out : ndarray of complex128, shape spectrum_shape
            May be :attr:`spectrum`.

        Returns
        -------
        spectrum_out : ndarray
        """
        other = self._gather_field(field)
        if self.rank == 0:
            np.add(field, other, out=self._real)
            self._forward.execute()
        else:
            twist_difference(other, field, self._twist, self.spectrum)
            self._forward.execute()
            odd_modes(self.spectrum, self._odd)
        if spectrum_out is not self.spectrum:
            spectrum_out[:] = self.spectrum
        return spectrum_out

    def inverse(self, spectrum, field_out):
        """field_out = irfft(spectrum) without the 1/n (unnormalised, like apply_diagonal).

        Collective (one synchronisation). Counts one pair in ``pairs``. Rank 0's modes 0
        and n/2 must be real (their imaginary parts are ignored, as by numpy's irfft).

        Parameters
        ----------
        spectrum : ndarray of complex128, shape spectrum_shape
            Left unchanged unless it is :attr:`spectrum` itself.
        field_out : ndarray of float64, shape (n/2,)

        Returns
        -------
        field_out : ndarray
        """
        if spectrum is not self.spectrum:
            self.spectrum[:] = spectrum
        self._write("h")
        if self.rank == 1:
            odd_modes_backward(self.spectrum, self._odd)
        self._backward.execute()
        self._combine(field_out)
        self.pairs += 1
        return field_out

    def close(self):
        """Collective: release the shared window."""
        self._buffers.free()


# --- the odd modes' passes (compiled) ---------------------------------------------------------
@njit(cache=True)
def twist_difference(a, b, twist, v):
    """v[m] = (d[2m] + i d[2m+1]) twist[m], d = a - b."""
    for m in range(v.shape[0]):
        re = a[2 * m] - b[2 * m]
        im = a[2 * m + 1] - b[2 * m + 1]
        c, s = twist[m].real, twist[m].imag
        v[m] = complex(re * c - im * s, re * s + im * c)


@njit(cache=True)
def combine(p, v, twist, sign, out):
    """out[2m] + i out[2m+1] = p[2m] + i p[2m+1] + sign v[m] conj(twist[m]) (sign +-1)."""
    for m in range(v.shape[0]):
        c, s = twist[m].real, twist[m].imag
        re, im = v[m].real, v[m].imag
        out[2 * m] = p[2 * m] + sign * (re * c + im * s)
        out[2 * m + 1] = p[2 * m + 1] + sign * (im * c - re * s)


@njit(cache=True)
def scale(spectrum, diagonal):
    """spectrum *= diagonal (real), without numpy's complex temporary."""
    f = spectrum.view(np.float64)
    for k in range(diagonal.shape[0]):
        f[2 * k] *= diagonal[k]
        f[2 * k + 1] *= diagonal[k]


@njit(cache=True)
def odd_modes(v, odd):
    """In place: V = fft_L(v) -> the odd modes X[2k+1] (module docstring).

    For the pair k, j = L-1-k: with c = conj V_j, P = (V_k + c) / 2 and
    Q = -i t_k (V_k - c) / 2, X[2k+1] = P + Q and conj X[2j+1] = P - Q.
    """
    f, t = v.view(np.float64), odd.view(np.float64)
    count = v.shape[0]
    for k in range((count + 1) // 2):
        j = count - 1 - k
        pr, pi, qr, qi = _odd_pair(f[2 * k], f[2 * k + 1], f[2 * j], f[2 * j + 1],
                                   t[2 * k], t[2 * k + 1])
        f[2 * j], f[2 * j + 1] = pr - qr, qi - pi
        f[2 * k], f[2 * k + 1] = pr + qr, pi + qi


@njit(cache=True)
def odd_modes_backward(v, odd):
    """In place: the odd modes Y[2k+1] -> W, whose ifft_L untwisted is q.

    For the pair k, j = L-1-k: with S = Y_k + conj Y_j and Z = i conj(t_k) (Y_k - conj Y_j),
    W_k = S + Z and W_j = conj(S - Z).
    """
    f, t = v.view(np.float64), odd.view(np.float64)
    count = v.shape[0]
    for k in range((count + 1) // 2):
        j = count - 1 - k
        wkr, wki, wjr, wji = _back_pair(f[2 * k], f[2 * k + 1], f[2 * j], -f[2 * j + 1],
                                        t[2 * k], t[2 * k + 1])
        f[2 * j], f[2 * j + 1] = wjr, wji
        f[2 * k], f[2 * k + 1] = wkr, wki


@njit(cache=True)
def odd_modes_multiplied(v, odd, diagonal):
    """In place, fused: V -> X[2k+1] -> Y = diagonal X -> W (one pass for apply_diagonal)."""
    f, t = v.view(np.float64), odd.view(np.float64)
    count = v.shape[0]
    for k in range((count + 1) // 2):
        j = count - 1 - k
        tr, ti = t[2 * k], t[2 * k + 1]
        pr, pi, qr, qi = _odd_pair(f[2 * k], f[2 * k + 1], f[2 * j], f[2 * j + 1], tr, ti)
        dk, dj = diagonal[k], diagonal[j]
        wkr, wki, wjr, wji = _back_pair(dk * (pr + qr), dk * (pi + qi),
                                        dj * (pr - qr), dj * (pi - qi), tr, ti)
        f[2 * j], f[2 * j + 1] = wjr, wji
        f[2 * k], f[2 * k + 1] = wkr, wki


@njit(cache=True, inline="always")
def _odd_pair(vkr, vki, vjr, vji, tr, ti):
    """P and Q of :func:`odd_modes` as (Re P, Im P, Re Q, Im Q)."""
    er, ei = vkr - vjr, vki + vji  # V_k - conj V_j
    return 0.5 * (vkr + vjr), 0.5 * (vki - vji), 0.5 * (er * ti + ei * tr), \
        -0.5 * (er * tr - ei * ti)


@njit(cache=True, inline="always")
def _back_pair(ykr, yki, ycr, yci, tr, ti):
    """W_k and W_j of :func:`odd_modes_backward` from Y_k and conj Y_j = (ycr, yci)."""
    sr, si = ykr + ycr, yki + yci
    fr, fi = ykr - ycr, yki - yci
    zr, zi = -(fi * tr - fr * ti), fr * tr + fi * ti  # i conj(t) (Y_k - conj Y_j)
    return sr + zr, si + zi, sr - zr, zi - si


def compile_all():
    """Compile the odd modes' passes into numba's cache (scripts/setup.sh, via
    :func:`hpcgfmd.solvers.cg.kernels.compile_all`)."""
    a, b = np.linspace(-1.0, 1.0, 8), np.linspace(0.0, 1.0, 8)
    twist = np.exp(-1j * np.linspace(0.0, 1.0, 4))
    v = np.zeros(4, dtype=np.complex128)
    twist_difference(a, b, twist, v)
    odd_modes(v, twist)
    odd_modes_backward(v, twist)
    odd_modes_multiplied(v, twist, np.ones(4))
    combine(a, v, twist, 1.0, b)
    scale(v, np.ones(4))
