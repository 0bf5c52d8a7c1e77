"""Real 2-D FFT of the whole ny x nx surface on one rank: FFTW's plans of the 2-D rfft and irfft.

Same interface as :class:`hpcgfmd.parallel.fft_slab.SlabRealFFT2D` (see
:mod:`hpcgfmd.parallel.fft`), with the spectrum in FFTW's own order ``(ny, nx/2 + 1)``
(entry ``[j, i]`` the mode (kx, ky) = (i, j)): the slab order ``(nx/2 + 1, ny)`` written by
the same plan runs 3 times slower. Plans are made once and nothing is allocated per call;
the transforms read the caller's field and write the caller's output in place when they are
aligned as the plans' buffers (:func:`~hpcgfmd.parallel.fft_serial.aligned_empty`), as
:class:`~hpcgfmd.parallel.fft_serial.SerialRealFFT` does.
"""

from __future__ import annotations

import numpy as np
import pyfftw
from mpi4py import MPI

from .fft_kernels import scale
from .real_fft import RealFFT2D, fftw_plan, grid_shape, signed_modes


class SerialRealFFT2D(RealFFT2D):
    """rfft2/irfft2 pair of an ny x nx grid on persistent aligned buffers, on one rank.

    Parameters
    ----------
    shape : (int, int)
        ``(ny, nx)``, both even.
    planner_effort : str
        FFTW planner flag.
    comm : mpi4py.MPI.Comm, optional
        One-rank communicator to report as ``comm`` (default ``MPI.COMM_SELF``).

    Attributes
    ----------
    comm, shape, n, row_blocks, row_start, row_stop, x_start, x_stop, x_blocks
        As in :class:`~hpcgfmd.parallel.real_fft.RealFFT2D`: all rows, ``[(0, ny)]`` and
        ``[(0, n)]``.
    kx_start, kx_stop : int
        ``0, nx/2 + 1``.
    spectrum_shape : (int, int)
        ``(ny, nx/2 + 1)``.
    wavenumbers : (ndarray, ndarray) of int64
        ``(my, mx)`` of shapes ``(ny, 1)`` and ``(1, nx/2 + 1)``.
    wavenumber : ndarray of float64, shape spectrum_shape
        |m| of each entry.
    spectrum : ndarray of complex128, shape spectrum_shape
        The transforms' own spectrum buffer; passing it to :meth:`forward` or
        :meth:`inverse` saves a copy (contents valid until the next transform call).
    pairs : int
        Forward+backward pairs done (``apply_diagonal`` and ``inverse`` count one each).
    communication_time : float
        Always 0.
    """

    def __init__(self, shape, planner_effort="FFTW_MEASURE", comm=None):
        ny, nx = grid_shape(shape)
        self.comm = MPI.COMM_SELF if comm is None else comm
        self.shape, self.n = (ny, nx), ny * nx
        self.row_blocks = [(0, ny)]
        self.row_start, self.row_stop = 0, ny
        self.x_blocks = [(0, self.n)]
        self.x_start, self.x_stop = 0, self.n
        self.kx_start, self.kx_stop = 0, nx // 2 + 1
        self.spectrum_shape = (ny, nx // 2 + 1)
        self._set_modes(signed_modes(ny)[:, None], np.arange(nx // 2 + 1)[None, :])
        self.real = pyfftw.empty_aligned(self.shape, dtype="float64")
        self.spectrum = pyfftw.empty_aligned(self.spectrum_shape, dtype="complex128")
        # The forward transform keeps its input (FFTW's default for r2c; it may be the
        # caller's field); the backward one overwrites the spectrum, the transform's own.
        self._forward = fftw_plan(self.real, self.spectrum, axes=(0, 1), flags=(planner_effort,))
        self._backward = fftw_plan(
            self.spectrum,
            self.real,
            axes=(0, 1),
            direction="FFTW_BACKWARD",
            flags=(planner_effort, "FFTW_DESTROY_INPUT"),
        )
        self._alignment = max(self._forward.input_alignment, self._backward.output_alignment)
        self.pairs = 0
        self.communication_time = 0.0

    def _grid(self, array):
        """``array`` as the (ny, nx) array the plans may use in place, or None."""
        if (
            array.dtype == np.float64
            and array.flags.c_contiguous
            and array.size == self.n
            and array.ctypes.data % self._alignment == 0
        ):
            return array.reshape(self.shape)
        return None

    def _transform_from(self, field):
        """self.spectrum = rfft2(field), reading ``field`` in place when aligned."""
        grid = self._grid(field)
        if grid is None:
            self.real.reshape(-1)[:] = field
            grid = self.real
        self._forward.update_arrays(grid, self.spectrum)
        self._forward.execute()

    def _transform_to(self, out):
        """out = irfft2(self.spectrum) unnormalised, in place when aligned (the spectrum is
        overwritten)."""
        grid = self._grid(out)
        self._backward.update_arrays(self.spectrum, self.real if grid is None else grid)
        self._backward.execute()
        if grid is None:
            out[:] = self.real.reshape(-1)

    def apply_diagonal(self, field, diagonal, out):
        """out = irfft2(diagonal * rfft2(field)) without the 1/n (fold it into ``diagonal``).

        Local (no communication).

        Parameters
        ----------
        field : ndarray of float64, shape (n,)
            Real input field, flat (x fastest), in its own units.
        diagonal : ndarray of float64, shape spectrum_shape
            Multiplier per mode, even in (mx, my) (units of out / units of field, times 1/n).
        out : ndarray of float64, shape (n,)
            Output (may be ``field``).

        Returns
        -------
        out : ndarray
        """
        self._transform_from(field)
        scale(self.spectrum.reshape(-1), np.ascontiguousarray(diagonal).reshape(-1))
        self._transform_to(out)
        self.pairs += 1
        return out

    def forward(self, field, spectrum_out):
        """spectrum_out = rfft2(field) (no normalisation).

        Local. Half of a pair: ``inverse(d * forward(f))`` equals ``apply_diagonal(f, d)``
        bitwise; ``pairs`` is counted in :meth:`inverse`.

        Parameters
        ----------
        field : ndarray of float64, shape (n,)
        spectrum_out : ndarray of complex128, shape spectrum_shape
            May be :attr:`spectrum` (saves a copy; valid until the next transform call).

        Returns
        -------
        spectrum_out : ndarray
        """
        self._transform_from(field)
        if spectrum_out is not self.spectrum:
            spectrum_out[...] = self.spectrum
        return spectrum_out

    def inverse(self, spectrum, field_out):
        """field_out = irfft2(spectrum) without the 1/n. Local; counts one pair.

        ``spectrum`` must be the spectrum of a real field times a multiplier even in
        (mx, my) (the columns kx = 0 and nx/2 Hermitian in ky); left unchanged unless it is
        :attr:`spectrum`, which the c2r transform overwrites.

        Parameters
        ----------
        spectrum : ndarray of complex128, shape spectrum_shape
        field_out : ndarray of float64, shape (n,)

        Returns
        -------
        field_out : ndarray
        """
        if spectrum is not self.spectrum:
            self.spectrum[...] = spectrum
        self._transform_to(field_out)
        self.pairs += 1
        return field_out
