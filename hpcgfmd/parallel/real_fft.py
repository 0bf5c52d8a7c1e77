"""The real FFT of the periodic surface as the solvers see it: one base class for a line of
nodes (three layouts) and one for an ny x nx grid (:class:`RealFFT2D`, two layouts).

The only operation the solvers need is a mode-diagonal operator applied to a real field,
``out = irfft(diag * rfft(v))``: the elastic stiffness, its inverse (the Green's function)
and the history's maps are all of that form. The multiplier is real and depends on |q| only,
and the caller folds the 1/n of the inverse transform into it, so an application is one
forward transform, one multiply and one unnormalised backward transform. Solvers that keep
or combine spectra between transforms (the damped-dynamics baseline) split the pair:
``inverse(d * forward(f))`` equals ``apply_diagonal(f, d)``.

Each rank owns a block of nodes in real space (``x_blocks``) and a block of modes in the
spectrum (``spectrum_shape``, in the layout's own order; ``wavenumber`` gives each local
mode's index m, q = 2 pi m / L). Mode-local physics does not care about the order.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np
import pyfftw

# FFTW's planner may measure candidate algorithms at most this long per plan (seconds): a
# large grid's planning stays bounded, and a stop signal is seen between plans within it
# (FFTW then keeps the best plan it found; docs/results.md has the transforms' speed).
PLANNING_TIMELIMIT = 5.0


def fftw_plan(input_array, output_array, **options):
    """A pyfftw plan on one thread whose planning takes at most PLANNING_TIMELIMIT seconds."""
    return pyfftw.FFTW(
        input_array, output_array, threads=1, planning_timelimit=PLANNING_TIMELIMIT, **options
    )


class RealFFT(ABC):
    """A planned real transform of n nodes over the ranks of ``comm`` (module docstring).

    Attributes
    ----------
    comm : mpi4py.MPI.Comm
    n : int
        Grid nodes.
    x_start, x_stop : int
        This rank's nodes [x_start, x_stop).
    x_blocks : list of (int, int)
        Every rank's node block, in rank order.
    spectrum_shape : tuple of int
        Shape of this rank's block of the spectrum.
    wavenumber : ndarray of int
        The mode index m of each local spectrum entry.
    spectrum : ndarray of complex128
        A persistent spectrum buffer of ``spectrum_shape`` to pass to :meth:`forward` and
        :meth:`inverse`.
    pairs : int
        Forward and backward pairs done (``apply_diagonal`` and ``inverse`` count one each).
    communication_time : float
        Seconds spent in MPI calls.
    """

    pairs: int
    communication_time: float

    @abstractmethod
    def apply_diagonal(self, field, diagonal, out):
        """Collective: ``out = irfft(diagonal * rfft(field))`` on this rank's blocks."""

    @abstractmethod
    def forward(self, field, spectrum_out):
        """Collective: the unnormalised rfft of this rank's block into its spectrum block."""

    @abstractmethod
    def inverse(self, spectrum, field_out):
        """Collective: the unnormalised irfft of this rank's spectrum block."""

    def close(self):  # noqa: B027 (nothing to release by default)
        """Collective: release shared resources (nothing by default)."""

    def half_wavenumbers(self, cell: float):
        """|q|/2 = pi |m| / L of each local mode (1/length), in the local order."""
        return np.pi * np.abs(self.wavenumber) / cell

    def counters(self) -> dict:
        """The transform pairs done (a counter of the run's state, :mod:`hpcgfmd.state`)."""
        return {"fft_pairs": self.pairs}

    def restore_counters(self, counters: dict):
        self.pairs = int(counters["fft_pairs"])


def grid_shape(shape):
    """``(ny, nx)`` as ints, checked: two even sizes, each at least 2."""
    ny, nx = (int(s) for s in shape)
    if ny < 2 or nx < 2 or ny % 2 or nx % 2:
        raise ValueError(f"the grid's sizes must be even and >= 2, got {tuple(shape)}")
    return ny, nx


class RealFFT2D(RealFFT):
    """A planned real 2-D transform of an ny x nx periodic grid (node (y, x) is the flat node
    ``y * nx + x``), over the ranks of ``comm``.

    The attributes of :class:`RealFFT` keep their meaning on the flattened grid (``n`` the
    total nodes, ``x_blocks`` flat node blocks, so that code working on flat blocks needs no
    change); besides them:

    Attributes
    ----------
    shape : (int, int)
        ``(ny, nx)``.
    row_blocks : list of (int, int)
        Every rank's rows ``[row_start, row_stop)``, in rank order (``x_blocks`` times nx).
    row_start, row_stop : int
        This rank's rows.
    wavenumbers : (ndarray, ndarray) of int64
        ``(my, mx)``, broadcastable to ``spectrum_shape``: the signed mode indices of each
        local spectrum entry, my in (-ny/2, ny/2], mx in [0, nx/2]; q = 2 pi (mx/Lx, my/Ly)
        (docs/model.md, (M4) along each direction). The modes mx < 0 are the conjugates of
        the stored ones and are not stored.
    wavenumber : ndarray of float64, shape spectrum_shape
        |m| = sqrt(mx**2 + my**2) of each local entry (|q| = 2 pi |m| / L on a square
        cell); 0 at the mode (0, 0) only.
    """

    shape: tuple
    wavenumbers: tuple

    def _set_modes(self, my, mx):
        """Set ``wavenumbers`` and ``wavenumber`` from the signed index arrays."""
        self.wavenumbers = (my.astype(np.int64), mx.astype(np.int64))
        self.wavenumber = np.sqrt((mx**2 + my**2).astype(np.float64))

    def half_wavenumbers(self, cell):
        """|q|/2 = pi sqrt((mx/Lx)**2 + (my/Ly)**2) of each local mode (1/length), shape
        ``spectrum_shape`` ((M4) with q = 2 pi (mx/Lx, my/Ly)).

        Parameters
        ----------
        cell : float or (float, float)
            The side L of the square cell, or its sides ``(Ly, Lx)`` (length).
        """
        ly, lx = (cell, cell) if np.ndim(cell) == 0 else cell
        my, mx = self.wavenumbers
        return np.pi * np.sqrt((mx / lx) ** 2 + (my / ly) ** 2)


def signed_modes(count):
    """The signed FFT mode indices of ``count`` (even) entries: 0 .. count/2, then
    -count/2 + 1 .. -1 (numpy.fft.fftfreq(count) * count, as int64)."""
    k = np.arange(count, dtype=np.int64)
    return np.where(k <= count // 2, k, k - count)
