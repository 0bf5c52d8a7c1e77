"""Real FFT of the periodic surface, serial or distributed over an MPI communicator.

The only operation the solver needs is a mode-diagonal operator applied to a real field,
``out = irfft(diag * rfft(v))``: the elastic stiffness, its inverse (the Green's function) and
the SLS history are all of that form. The multiplier is real and even in the mode index m
(it depends on |q| = 2 pi |m| / L only) and the caller folds the 1/n of the inverse transform
into it, so an application is one forward transform, one multiply and one unnormalised
backward transform. Plans are made once on aligned buffers and nothing is allocated per call.

Three classes share one interface (``comm``, ``n``, ``x_start``, ``x_stop``, ``x_blocks``,
``spectrum_shape``, ``wavenumber``, ``apply_diagonal``, ``pairs``, ``communication_time``);
:func:`plan_real_fft` picks one for a communicator. For solvers that must keep or combine
spectra between transforms (the damped-dynamics baseline, :mod:`hpcgfmd.solvers.verlet`), all also
split the pair: ``forward(field, spectrum_out)`` and ``inverse(spectrum, field_out)``, with
``inverse(d * forward(f))`` equal to ``apply_diagonal(f, d)``, and a persistent ``spectrum``
buffer of ``spectrum_shape`` to pass to them.

* :class:`SerialRealFFT`: one rank, a pyfftw rfft/irfft pair of length n.
* :class:`HalvedRealFFT`: a single length-n transform split over two ranks by one radix-2
  step, each rank transforming half (:mod:`hpcgfmd.parallel.fft_halved`); for 2 ranks when 4
  divides n (n >= 8).
* :class:`TransposedRealFFT`: a single length-n transform split over the P ranks of ``comm``
  with the four-step (transposed) algorithm (:mod:`hpcgfmd.parallel.fft_transposed`); the
  other rank counts and lengths.
"""
from __future__ import annotations

from . import wisdom
from .fft_halved import HalvedRealFFT, fits
from .fft_serial import SerialRealFFT, aligned_empty
from .fft_transposed import TransposedRealFFT


def plan_real_fft(comm, n, planner_effort="FFTW_MEASURE", transposed=None):
    """Make the real FFT suited to ``comm``.

    Every rank of ``comm`` must call it with the same arguments (collective: the transposed
    class allocates its shared buffers on ``comm``, and measured plans gather the ranks' new
    FFTW wisdom into the cache file of :mod:`hpcgfmd.parallel.wisdom`, read first).

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
        Communicator over which the surface is distributed.
    n : int
        Number of grid nodes (even).
    planner_effort : str
        FFTW planner flag, e.g. ``"FFTW_MEASURE"`` or ``"FFTW_ESTIMATE"`` (tests).
    transposed : bool or None
        ``None``: serial on one rank, halved on two (when 4 divides n, n >= 8), transposed
        otherwise.
        ``True`` forces the transposed class (also on one or two ranks, for testing).
        ``False`` demands the serial class and is an error on more than one rank.

    Returns
    -------
    SerialRealFFT, HalvedRealFFT or TransposedRealFFT
    """
    size = comm.Get_size()
    halved = transposed is None and fits(size, n)
    if transposed is None:
        transposed = size > 1 and not halved
    if not transposed and size > 1 and not halved:
        raise ValueError(f"a serial FFT cannot be spread over {size} ranks")
    cached = planner_effort in ("FFTW_MEASURE", "FFTW_PATIENT", "FFTW_EXHAUSTIVE")
    path = wisdom.cache_path() if cached else None
    known = wisdom.load(path)
    if halved:
        fft = HalvedRealFFT(comm, n, planner_effort)
    elif transposed:
        fft = TransposedRealFFT(comm, n, planner_effort)
    else:
        fft = SerialRealFFT(n, planner_effort, comm=comm)
    wisdom.save(comm, path, known)
    return fft


__all__ = ["HalvedRealFFT", "SerialRealFFT", "TransposedRealFFT", "aligned_empty", "plan_real_fft"]
