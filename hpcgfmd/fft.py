"""Real FFT of the periodic surface with pyfftw plans made once.

The only operation the solver needs is a mode-diagonal operator applied to a real field,
``out = irfft(diag * rfft(v))``: the elastic stiffness, its inverse (the Green's function) and
the SLS history are all of that form. Plans are made once on aligned buffers (FFTW_MEASURE),
and the 1/n of the inverse transform is folded into the diagonals by the caller, so an
application costs one rfft, one complex multiply and one irfft, with no allocation.
"""
from __future__ import annotations

import numpy as np
import pyfftw


class RealFFT:
    """rfft/irfft pair of length n on persistent aligned buffers.

    Parameters
    ----------
    n : int
        Number of grid points (even).
    planner_effort : str
        FFTW planner flag; FFTW_MEASURE pays for itself after a few hundred transforms.
    """

    def __init__(self, n: int, planner_effort: str = "FFTW_MEASURE"):
        self.n = n
        self.real = pyfftw.empty_aligned(n, dtype="float64")
        self.spectrum = pyfftw.empty_aligned(n // 2 + 1, dtype="complex128")
        flags = (planner_effort, "FFTW_DESTROY_INPUT")
        self._forward = pyfftw.FFTW(self.real, self.spectrum, flags=flags, threads=1)
        self._backward = pyfftw.FFTW(self.spectrum, self.real, direction="FFTW_BACKWARD",
                                     flags=flags, threads=1)
        self.pairs = 0  # number of forward+backward pairs done, for the statistics

    def apply_diagonal(self, field, diagonal, out):
        """out = irfft(diagonal * rfft(field)) without the 1/n (fold it into ``diagonal``).

        Parameters
        ----------
        field : ndarray, shape (n,)
            Real input field.
        diagonal : ndarray, shape (n//2+1,)
            Real or complex multiplier per mode.
        out : ndarray, shape (n,)
            Output buffer (may be ``field``).
        """
        self.real[:] = field
        self._forward.execute()
        self.spectrum *= diagonal
        self._backward.execute()
        out[:] = self.real
        self.pairs += 1
        return out
