"""The planned real FFT of the periodic surface for a communicator (:func:`plan_real_fft`).

Three classes share the interface of :class:`~.real_fft.RealFFT` for a line of n nodes:

* :class:`SerialRealFFT`: one rank, a pyfftw rfft/irfft pair of length n.
* :class:`HalvedRealFFT`: a single length-n transform split over two ranks by one radix-2
  step, each rank transforming half (:mod:`hpcgfmd.parallel.fft_halved`); for 2 ranks when 4
  divides n (n >= 8).
* :class:`TransposedRealFFT`: a single length-n transform split over the P ranks of ``comm``
  with the four-step (transposed) algorithm (:mod:`hpcgfmd.parallel.fft_transposed`); the
  other rank counts and lengths, and every rank count from ``FOUR_STEP_NODES`` nodes on.

From 2^20 nodes the four-step transform is the faster on one and on two ranks: its
transforms of about sqrt(n) points work in the cache and plan in a second, while FFTW's plan
of the whole length, limited to ``PLANNING_TIMELIMIT`` per plan, is 1.3-2.1 times slower on
one rank (2^20 to 2^24) and the halved transform's half-length plans 1.2-1.8 times slower on
two (docs/results.md, "Large transforms").

Two more (:class:`~.real_fft.RealFFT2D`) transform an ny x nx grid (``n`` a shape):

* :class:`SlabRealFFT2D`: rows in slabs over the ranks, one transpose per transform
  (:mod:`hpcgfmd.parallel.fft_slab`); on more than one rank, and on one above
  ``WHOLE_PLAN_NODES`` nodes.
* :class:`SerialRealFFT2D`: FFTW's plans of the whole 2-D transform on one rank
  (:mod:`hpcgfmd.parallel.fft_serial2d`), up to ``WHOLE_PLAN_NODES`` nodes.

On one rank FFTW's whole plan is 1.05-1.2 times faster than the slab transform up to 1024^2
nodes, whose arrays fit the 32 MB L3 cache, and the slab one 1.15-1.4 times faster at
2048^2, where they do not; two ranks are 1.8-2.1 times faster than one at 2048^2 on an idle
machine (``python -m hpcgfmd bench fft2d``). mpi4py-fft's PFFT of the same grid (measured by
that bench where installed; no dependency) was 1.1-2.2 times slower than the slab transform
on one rank (one plan per axis over the whole array, on its own FFTW build) and 1.9-4.4
times on two, where its transpose goes through ``Alltoallw`` with subarray datatypes (MPI
packs and unpacks the strided blocks) while the slab transform reads the peer's blocks in
a shared window.
"""

from __future__ import annotations

import numpy as np

from . import wisdom
from .fft_halved import HalvedRealFFT, fits
from .fft_serial import SerialRealFFT, aligned_empty
from .fft_serial2d import SerialRealFFT2D
from .fft_slab import SlabRealFFT2D
from .fft_transposed import TransposedRealFFT
from .real_fft import PLANNING_TIMELIMIT, RealFFT, RealFFT2D, grid_shape

FOUR_STEP_NODES = 2**20  # from this size the four-step transform is the faster on any ranks
WHOLE_PLAN_NODES = 2**20  # up to this many nodes FFTW's whole 2-D plan on one rank
_CACHED = ("FFTW_MEASURE", "FFTW_PATIENT", "FFTW_EXHAUSTIVE")  # efforts worth a wisdom file


def plan_real_fft(comm, n, planner_effort="FFTW_MEASURE", transposed=None):
    """Make the real FFT suited to ``comm``.

    Every rank of ``comm`` must call it with the same arguments (collective: the transposed
    class allocates its shared buffers on ``comm``, and measured plans gather the ranks' new
    FFTW wisdom into the cache file of :mod:`hpcgfmd.parallel.wisdom`, read first).

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
        Communicator over which the surface is distributed.
    n : int or (int, int)
        Number of grid nodes (even), or the shape ``(ny, nx)`` of a 2-D grid (both even):
        then :class:`SlabRealFFT2D`, or :class:`SerialRealFFT2D` on one rank up to
        ``WHOLE_PLAN_NODES`` nodes (``transposed`` must be None).
    planner_effort : str
        FFTW planner flag, e.g. ``"FFTW_MEASURE"`` or ``"FFTW_ESTIMATE"`` (tests).
    transposed : bool or None
        ``None``: from ``FOUR_STEP_NODES`` nodes on transposed; below, serial on one rank,
        halved on two (when 4 divides n, n >= 8), transposed otherwise.
        ``True`` forces the transposed class (also on one or two ranks, for testing).
        ``False`` demands the serial class and is an error on more than one rank.

    Returns
    -------
    RealFFT
    """
    if not isinstance(n, int | np.integer):
        return _plan_2d(comm, n, planner_effort, transposed)
    size = comm.Get_size()
    if transposed is None and n >= FOUR_STEP_NODES:
        transposed = True
    halved = transposed is None and fits(size, n)
    if transposed is None:
        transposed = size > 1 and not halved
    if not transposed and size > 1 and not halved:
        raise ValueError(f"a serial FFT cannot be spread over {size} ranks")
    path = wisdom.cache_path() if planner_effort in _CACHED else None
    known = wisdom.load(path)
    if halved:
        fft = HalvedRealFFT(comm, n, planner_effort)
    elif transposed:
        fft = TransposedRealFFT(comm, n, planner_effort)
    else:
        fft = SerialRealFFT(n, planner_effort, comm=comm)
    wisdom.save(comm, path, known)
    return fft


def _plan_2d(comm, shape, planner_effort, transposed):
    """plan_real_fft of a 2-D grid ``shape`` (collective on ``comm``)."""
    if transposed is not None:
        raise ValueError("transposed applies to 1-D transforms only")
    ny, nx = grid_shape(shape)
    path = wisdom.cache_path() if planner_effort in _CACHED else None
    known = wisdom.load(path)
    if comm.Get_size() == 1 and ny * nx <= WHOLE_PLAN_NODES:
        fft = SerialRealFFT2D((ny, nx), planner_effort, comm=comm)
    else:
        fft = SlabRealFFT2D(comm, (ny, nx), planner_effort)
    wisdom.save(comm, path, known)
    return fft


__all__ = [
    "FOUR_STEP_NODES",
    "PLANNING_TIMELIMIT",
    "HalvedRealFFT",
    "RealFFT",
    "RealFFT2D",
    "SerialRealFFT",
    "SerialRealFFT2D",
    "SlabRealFFT2D",
    "TransposedRealFFT",
    "WHOLE_PLAN_NODES",
    "aligned_empty",
    "plan_real_fft",
]
