"""The real 2-D FFTs of hpcgfmd.parallel (SerialRealFFT2D, SlabRealFFT2D on one rank here,
on 1, 2 and 3 ranks under mpirun through tests/mpi/check_fft2d.py): apply_diagonal, the split
forward and inverse transforms and half_wavenumbers against numpy's rfft2/irfft2, the
layout, and plan_real_fft's choice for a shape.

Tolerances: FFTW's round-off on these grids (at most 2^14 nodes) is about eps log2(n) of the
field's largest value, under 1e-14 relative; 1e-13 leaves a factor of ten and still catches
any wrong mode, sign or layout (errors of order one)."""

import shutil
import tracemalloc

import numpy as np
import pytest
from mpi4py import MPI
from test_fft import mpi_check

from hpcgfmd.parallel.fft import (
    WHOLE_PLAN_NODES,
    SerialRealFFT,
    SerialRealFFT2D,
    SlabRealFFT2D,
    aligned_empty,
    plan_real_fft,
)

TOLERANCE = 1e-13
SHAPES = [(2, 2), (2, 6), (4, 6), (8, 4), (6, 10), (30, 48), (64, 32), (128, 128)]
KINDS = ["serial", "slab"]


def make(kind, shape):
    if kind == "serial":
        return SerialRealFFT2D(shape, "FFTW_ESTIMATE")
    return SlabRealFFT2D(MPI.COMM_SELF, shape, "FFTW_ESTIMATE")


def reference(shape, cell):
    """A random field, numpy's |q|/2 on its (ny, nx/2 + 1) modes (q = 2 pi m / L per
    direction, docs/model.md (M4)), a multiplier of |q| and n irfft2(D rfft2(f))."""
    ny, nx = shape
    ly, lx = (cell, cell) if np.ndim(cell) == 0 else cell
    field = np.random.default_rng(ny * 100 + nx).standard_normal(shape)
    qy = 2 * np.pi * np.fft.fftfreq(ny, ly / ny)[:, None]
    qx = 2 * np.pi * np.fft.rfftfreq(nx, lx / nx)[None, :]
    half_q = np.hypot(qx, qy) / 2
    expected = np.fft.irfft2(multiplier(half_q) * np.fft.rfft2(field), s=shape) * field.size
    return field, half_q, expected


def multiplier(half_q):
    """A multiplier of |q| only, of order one, not smooth at q = 0."""
    return 1.0 / (1.0 + half_q) - 0.5 * np.cos(half_q)


def local(fft, modes):
    """numpy's (ny, nx/2 + 1) array of modes in the transform's spectrum layout."""
    my, mx = fft.wavenumbers
    return modes[my % fft.shape[0], mx]


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("shape", SHAPES)
def test_apply_diagonal_matches_numpy(kind, shape):
    fft = make(kind, shape)
    cell = (1.3, 0.7)
    field, half_q, expected = reference(shape, cell)
    # half_wavenumbers is numpy's |q|/2 in the transform's layout (the same two roundings)
    half_q_here = fft.half_wavenumbers(cell)
    assert half_q_here.shape == fft.spectrum_shape
    np.testing.assert_allclose(half_q_here, local(fft, half_q), rtol=1e-15, atol=0)
    diagonal = multiplier(half_q_here)
    out = fft.apply_diagonal(field.reshape(-1), diagonal, np.empty(field.size))
    error = np.abs(out - expected.reshape(-1)).max() / np.abs(expected).max()
    assert error < TOLERANCE
    in_place = field.reshape(-1).copy()
    np.testing.assert_array_equal(fft.apply_diagonal(in_place, diagonal, in_place), out)
    # aligned buffers are read and written in place, others copied: the same numbers
    aligned, misaligned = aligned_empty(field.size), np.empty(field.size + 1)[1:]
    aligned[:] = misaligned[:] = field.reshape(-1)
    for source, target in ((aligned, aligned_empty(field.size)), (misaligned, misaligned)):
        np.testing.assert_array_equal(fft.apply_diagonal(source, diagonal, target), out)
    assert fft.pairs == 4 and fft.communication_time == 0.0


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("shape", SHAPES)
def test_forward_inverse_match_numpy_and_apply_diagonal(kind, shape):
    fft = make(kind, shape)
    field, half_q, _ = reference(shape, 2.0)
    flat = field.reshape(-1)
    spectrum = np.empty(fft.spectrum_shape, dtype=complex)
    assert fft.forward(flat, spectrum) is spectrum
    numpy_spectrum = np.fft.rfft2(field)
    error = np.abs(spectrum - local(fft, numpy_spectrum)).max() / np.abs(numpy_spectrum).max()
    assert error < TOLERANCE
    kept = spectrum.copy()
    out = np.empty(field.size)
    assert fft.inverse(spectrum, out) is out
    np.testing.assert_array_equal(spectrum, kept)  # a caller's spectrum is left alone
    assert np.abs(out - fft.n * flat).max() < TOLERANCE * fft.n * np.abs(field).max()
    assert fft.pairs == 1  # counted once, in inverse
    # inverse(d * forward(f)) is apply_diagonal(f, d) bitwise, through a caller's buffer
    # and through the transform's own one
    diagonal = multiplier(fft.half_wavenumbers(2.0))
    applied = fft.apply_diagonal(flat, diagonal, np.empty(field.size))
    np.testing.assert_array_equal(fft.inverse(kept * diagonal, out), applied)
    fft.forward(flat, fft.spectrum)
    fft.spectrum *= diagonal
    np.testing.assert_array_equal(fft.inverse(fft.spectrum, out), applied)
    assert fft.pairs == 4


@pytest.mark.parametrize("kind", KINDS)
def test_layout_and_wavenumbers(kind):
    ny, nx = 6, 10
    fft = make(kind, (ny, nx))
    assert (fft.shape, fft.n) == ((ny, nx), ny * nx)
    assert fft.row_blocks == [(0, ny)] and (fft.row_start, fft.row_stop) == (0, ny)
    assert fft.x_blocks == [(0, ny * nx)] and (fft.x_start, fft.x_stop) == (0, ny * nx)
    my, mx = fft.wavenumbers
    assert my.dtype == mx.dtype == np.int64
    assert np.broadcast_shapes(my.shape, mx.shape) == fft.spectrum_shape
    if kind == "slab":  # kx major: the y transforms run along contiguous rows
        assert fft.spectrum_shape == (nx // 2 + 1, ny)
    else:  # FFTW's own order
        assert fft.spectrum_shape == (ny, nx // 2 + 1)
    # every mode (mx >= 0, my) once: my in (-ny/2, ny/2], mx in [0, nx/2]
    pairs = {(int(a), int(b)) for a, b in zip(*(m.ravel() for m in np.broadcast_arrays(mx, my)))}
    assert pairs == {(a, b) for a in range(nx // 2 + 1) for b in range(-ny // 2 + 1, ny // 2 + 1)}
    np.testing.assert_array_equal(fft.wavenumber, np.hypot(mx, my))
    assert np.count_nonzero(fft.wavenumber == 0) == 1
    # a square cell of side L is the pair (L, L); |q|/2 = pi |m| / L there
    np.testing.assert_array_equal(fft.half_wavenumbers(3.0), fft.half_wavenumbers((3.0, 3.0)))
    np.testing.assert_allclose(fft.half_wavenumbers(3.0), np.pi * fft.wavenumber / 3.0, rtol=1e-15)


@pytest.mark.parametrize("kind", KINDS)
def test_transforms_allocate_nothing_per_call(kind):
    # Persistent buffers and plans: nothing kept, and nothing of the grid's size made, per call
    shape = (128, 128)
    fft = make(kind, shape)
    field, out = aligned_empty(fft.n), aligned_empty(fft.n)
    field[:] = np.random.default_rng(0).standard_normal(fft.n)
    spectrum = np.empty(fft.spectrum_shape, dtype=complex)
    diagonal = np.ones(fft.spectrum_shape)
    calls = (
        lambda: fft.apply_diagonal(field, diagonal, out),
        lambda: (fft.forward(field, spectrum), fft.inverse(spectrum, out)),
        lambda: (fft.forward(field, fft.spectrum), fft.inverse(fft.spectrum, out)),
    )
    for call in calls:
        call()
        tracemalloc.start()
        for _ in range(3):
            call()
        current, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        assert current < 1000 and peak < 8 * fft.n // 16  # (the grid is 8 n bytes)


def test_plan_real_fft_takes_a_shape():
    # one rank: FFTW's whole 2-D plan up to WHOLE_PLAN_NODES nodes, the slab transform above
    small = plan_real_fft(MPI.COMM_SELF, (64, 32), "FFTW_ESTIMATE")
    assert isinstance(small, SerialRealFFT2D) and small.shape == (64, 32)
    side = int(np.sqrt(WHOLE_PLAN_NODES))
    assert side * side == WHOLE_PLAN_NODES
    largest = plan_real_fft(MPI.COMM_SELF, (side, side), "FFTW_ESTIMATE")
    assert isinstance(largest, SerialRealFFT2D)
    above = plan_real_fft(MPI.COMM_SELF, (side, side + 2), "FFTW_ESTIMATE")
    assert isinstance(above, SlabRealFFT2D) and above.n == side * (side + 2)
    # a plain int stays the 1-D transform
    assert isinstance(plan_real_fft(MPI.COMM_SELF, 64, "FFTW_ESTIMATE"), SerialRealFFT)
    with pytest.raises(ValueError):
        plan_real_fft(MPI.COMM_SELF, (64, 32), "FFTW_ESTIMATE", transposed=True)
    for bad in ((64, 31), (3, 4), (0, 8)):
        with pytest.raises(ValueError):
            plan_real_fft(MPI.COMM_SELF, bad, "FFTW_ESTIMATE")
    with pytest.raises(ValueError):
        SlabRealFFT2D(MPI.COMM_SELF, (4, 4), "FFTW_ESTIMATE", transport="carrier pigeon")


@pytest.mark.mpi
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="mpirun not found")
@pytest.mark.parametrize("ranks", [1, 2, 3])
def test_slab_fft_under_mpirun(ranks):
    result = mpi_check("check_fft2d.py", ranks)
    assert result.returncode == 0, result.stdout + result.stderr
    assert f"ok: 8 grids x 3 transports on {ranks} ranks" in result.stdout
