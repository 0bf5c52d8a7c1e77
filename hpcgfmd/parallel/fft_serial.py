"""Real FFT of the whole surface on one rank: a pyfftw rfft/irfft pair on aligned buffers.

Same interface as the distributed classes (:mod:`hpcgfmd.parallel.fft_halved`,
:mod:`hpcgfmd.parallel.fft_transposed`; see :mod:`hpcgfmd.parallel.fft` for what the solvers
use of it). Plans are made once; nothing is
allocated per call. The transforms read the caller's field and write the caller's output in
place whenever those are aligned as the plans' buffers are (:func:`aligned_empty` makes such
arrays): the copies in and out of the transform's own buffers would cost two more passes
over the field, each evicting cache the transform needs. Other arrays go through the buffers.
"""

from __future__ import annotations

import numpy as np
import pyfftw
from mpi4py import MPI

from .fft_kernels import scale
from .real_fft import RealFFT, fftw_plan

DIRECT_MEMORY = 8  # arrays remembered as aligned by SerialRealFFT._direct


def aligned_empty(shape):
    """An uninitialised float64 array aligned as the transforms' buffers, so that
    :meth:`SerialRealFFT.apply_diagonal` reads or writes it without a copy (each row of a 2-D
    array too, when a row's size is a multiple of the alignment)."""
    return pyfftw.empty_aligned(shape, dtype="float64")


class SerialRealFFT(RealFFT):
    """rfft/irfft pair of length n on persistent aligned buffers, on one rank.

    Parameters
    ----------
    n : int
        Number of grid nodes (even).
    planner_effort : str
        FFTW planner flag; FFTW_MEASURE pays for itself after a few hundred transforms.
    comm : mpi4py.MPI.Comm, optional
        One-rank communicator to report as ``comm`` (default ``MPI.COMM_SELF``).

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
    spectrum : ndarray of complex128, shape spectrum_shape
        The transforms' own spectrum buffer; passing it to :meth:`forward` or
        :meth:`inverse` saves a copy (contents valid until the next transform call).
    pairs : int
        Number of forward+backward pairs done, for the statistics (``apply_diagonal`` and
        ``inverse`` count one each).
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
        # The forward transform keeps its input (it may be the caller's field); the backward
        # one may overwrite the spectrum, which is the transform's own.
        self._forward = fftw_plan(self.real, self.spectrum, flags=(planner_effort,))
        self._backward = fftw_plan(
            self.spectrum,
            self.real,
            direction="FFTW_BACKWARD",
            flags=(planner_effort, "FFTW_DESTROY_INPUT"),
        )
        self._alignment = self._forward.input_alignment
        self._direct_arrays = ()  # arrays found aligned, newest first (see _direct)
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
        self._transform_from(field)
        scale(self.spectrum, diagonal)
        self._transform_to(out)
        self.pairs += 1
        return out

    def _direct(self, array):
        """True when ``array`` can be the plans' real array without a copy (the last few
        such arrays are remembered: the solvers pass the same buffers again and again, and
        a remembered array is found in about 0.07 us, the checks of a new one take about
        1.4 us, most of it reading its address)."""
        for known in self._direct_arrays:
            if array is known:
                return True
        direct = (
            array.ctypes.data % self._alignment == 0
            and array.flags.c_contiguous
            and array.shape == (self.n,)
            and array.dtype == np.float64
        )
        if direct:
            self._direct_arrays = (array,) + self._direct_arrays[: DIRECT_MEMORY - 1]
        return direct

    def _transform_from(self, field):
        """self.spectrum = rfft(field), reading ``field`` in place when aligned."""
        if self._direct(field):
            self._forward.update_arrays(field, self.spectrum)
        else:
            self.real[:] = field
            self._forward.update_arrays(self.real, self.spectrum)
        self._forward.execute()

    def _transform_to(self, out):
        """out = irfft(self.spectrum) unnormalised, writing ``out`` in place when aligned
        (the spectrum is overwritten)."""
        if self._direct(out):
            self._backward.update_arrays(self.spectrum, out)
            self._backward.execute()
        else:
            self._backward.update_arrays(self.spectrum, self.real)
            self._backward.execute()
            out[:] = self.real

    def forward(self, field, spectrum_out):
        """spectrum_out = rfft(field): the local modes of the real field (no normalisation).

        Local. Half of a pair: ``inverse(d * forward(f))`` equals ``apply_diagonal(f, d)``
        bitwise (same plans, same operations); ``pairs`` is counted in :meth:`inverse`.

        Parameters
        ----------
        field : ndarray of float64, shape (n,)
            Real input field.
        spectrum_out : ndarray of complex128, shape spectrum_shape
            Output; may be :attr:`spectrum`, the transform's own buffer, which saves one
            copy (it then stays valid only until the next call of any transform method).

        Returns
        -------
        spectrum_out : ndarray
        """
        self._transform_from(field)
        if spectrum_out is not self.spectrum:
            spectrum_out[:] = self.spectrum
        return spectrum_out

    def inverse(self, spectrum, field_out):
        """field_out = irfft(spectrum) without the 1/n (unnormalised, like apply_diagonal).

        Local. Counts one pair in ``pairs`` (the forward transform of the pair counts none).
        ``spectrum`` must be the half spectrum of a real field (modes 0 and n/2 real, their
        imaginary parts are ignored, as by numpy's irfft).

        Parameters
        ----------
        spectrum : ndarray of complex128, shape spectrum_shape
            Input modes; left unchanged unless it is :attr:`spectrum` itself, which the c2r
            transform overwrites (that saves one copy).
        field_out : ndarray of float64, shape (n,)

        Returns
        -------
        field_out : ndarray
        """
        if spectrum is not self.spectrum:
            self.spectrum[:] = spectrum
        self._transform_to(field_out)
        self.pairs += 1
        return field_out

    def close(self):
        """Nothing to release (the distributed classes free their shared windows here)."""
