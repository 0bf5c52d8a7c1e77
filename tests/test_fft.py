"""The real FFTs of hpcgfmd.parallel (serial and transposed; the halved one under mpirun):
apply_diagonal and the split forward and inverse transforms (those of the damped Verlet
solver) against numpy's rfft/irfft, their buffers, the wavenumber layout, block_range, and
the MPI check program tests/mpi/check_fft.py."""

import os
import shutil
import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from hpcgfmd.parallel.blocks import block_range
from hpcgfmd.parallel.fft import FOUR_STEP_NODES, SerialRealFFT, TransposedRealFFT, plan_real_fft
from hpcgfmd.parallel.fft_transposed import split_length

SIZES = [2, 16, 30, 64, 96, 1000, 2**12]


def reference(field, multiplier):
    """irfft(D * rfft(v)) without the 1/n, for a multiplier D(|m|) on m = 0 .. n/2."""
    n = field.size
    return np.fft.irfft(multiplier * np.fft.rfft(field), n) * n


def apply(fft, field, multiplier):
    out = np.empty(fft.x_stop - fft.x_start)
    return fft.apply_diagonal(
        field[fft.x_start : fft.x_stop], multiplier[np.abs(fft.wavenumber)], out
    )


def numpy_modes(fft, field):
    """numpy's rfft of the global field, arranged as the transform's local modes (a mode
    m < 0 is the conjugate of |m|)."""
    spectrum = np.fft.rfft(field)
    m = fft.wavenumber
    return np.where(m >= 0, spectrum[np.abs(m)], np.conj(spectrum[np.abs(m)]))


@pytest.mark.parametrize("transposed", [False, True])
@pytest.mark.parametrize("n", SIZES)
def test_apply_diagonal_matches_numpy(n, transposed):
    fft = plan_real_fft(MPI.COMM_SELF, n, "FFTW_ESTIMATE", transposed=transposed)
    assert isinstance(fft, TransposedRealFFT if transposed else SerialRealFFT)
    assert (fft.x_start, fft.x_stop, fft.x_blocks) == (0, n, [(0, n)])
    rng = np.random.default_rng(n)
    field, multiplier = rng.standard_normal(n), rng.standard_normal(n // 2 + 1)
    expected = reference(field, multiplier)
    out = apply(fft, field, multiplier)
    assert np.abs(out - expected).max() < 1e-12 * np.abs(expected).max()
    in_place = field.copy()
    fft.apply_diagonal(in_place, multiplier[np.abs(fft.wavenumber)], in_place)
    np.testing.assert_array_equal(in_place, out)
    assert fft.pairs == 2


@pytest.mark.parametrize("transposed", [False, True])
@pytest.mark.parametrize("n", SIZES)
def test_forward_inverse_match_numpy_and_apply_diagonal(n, transposed):
    fft = plan_real_fft(MPI.COMM_SELF, n, "FFTW_ESTIMATE", transposed=transposed)
    rng = np.random.default_rng(n)
    field, multiplier = rng.standard_normal(n), rng.standard_normal(n // 2 + 1)
    diagonal = multiplier[np.abs(fft.wavenumber)]
    spectrum = np.empty(fft.spectrum_shape, dtype=np.complex128)
    assert fft.forward(field, spectrum) is spectrum
    expected = numpy_modes(fft, field)
    assert np.abs(spectrum - expected).max() < 1e-13 * np.abs(expected).max()
    kept = spectrum.copy()
    out = np.empty(n)
    assert fft.inverse(spectrum, out) is out
    np.testing.assert_array_equal(spectrum, kept)  # a caller's spectrum is left alone
    np.testing.assert_allclose(out, n * field, rtol=0, atol=1e-13 * n * np.abs(field).max())
    assert fft.pairs == 1  # the pair is counted once, in inverse
    # inverse(d * forward(f)) is apply_diagonal(f, d), bitwise, through a caller's buffer
    # and through the transform's own one (which saves the copies in the serial class).
    applied = fft.apply_diagonal(field, diagonal, np.empty(n))
    np.multiply(kept, diagonal, out=spectrum)
    np.testing.assert_array_equal(fft.inverse(spectrum, out), applied)
    fft.forward(field, fft.spectrum)
    fft.spectrum *= diagonal
    np.testing.assert_array_equal(fft.inverse(fft.spectrum, out), applied)
    assert fft.pairs == 4


@pytest.mark.parametrize("transposed", [False, True])
def test_transforms_allocate_nothing_per_call(transposed):
    # Persistent buffers: nothing is kept and nothing of size n is made per call by the
    # serial class. In the transposed class numpy makes a transient buffer for the twiddle
    # multiply into the strided xt blocks (stage A: one column chunk, at most ~1 MB; 130 kB
    # here), exactly as in apply_diagonal: forward and inverse add nothing to it.
    n = 2**14
    fft = plan_real_fft(MPI.COMM_SELF, n, "FFTW_ESTIMATE", transposed=transposed)
    field, out = np.random.default_rng(0).standard_normal(n), np.empty(n)
    spectrum = np.empty(fft.spectrum_shape, dtype=np.complex128)
    diagonal = np.ones(fft.spectrum_shape)

    def peak(call):
        call()
        tracemalloc.start()
        for _ in range(3):
            call()
        current, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        assert current < 1000
        return peak

    split = peak(lambda: (fft.forward(field, spectrum), fft.inverse(spectrum, out)))
    own = peak(lambda: (fft.forward(field, fft.spectrum), fft.inverse(fft.spectrum, out)))
    pair = peak(lambda: fft.apply_diagonal(field, diagonal, out))
    assert max(split, own) <= pair + 1000
    if not transposed:
        # (apply_diagonal's complex *= real multiply casts through a 128 kB numpy buffer)
        assert max(split, own) < 1000


@pytest.mark.parametrize("n", SIZES)
def test_wavenumbers(n):
    serial = SerialRealFFT(n, "FFTW_ESTIMATE")
    np.testing.assert_array_equal(serial.wavenumber, np.arange(n // 2 + 1))
    assert serial.spectrum_shape == (n // 2 + 1,) and serial.communication_time == 0.0

    fft = TransposedRealFFT(MPI.COMM_SELF, n, "FFTW_ESTIMATE")
    n1, n2 = fft.n1, fft.n2
    assert fft.wavenumber.dtype == np.int64 and fft.wavenumber.shape == fft.spectrum_shape
    assert fft.spectrum_shape == (n1 // 2 + 1, n2)
    m = fft.wavenumber.ravel()
    assert np.all((m > -n // 2) & (m <= n // 2))
    # Each mode appears, up to sign, and rows 0 < k1 < n1/2 stand for a +-m pair.
    assert set(np.abs(m)) == set(range(n // 2 + 1))
    # Row k1, column k2 is mode k1 + n1*k2 (mod n).
    k = np.arange(n1 // 2 + 1)[:, None] + n1 * np.arange(n2)[None, :]
    np.testing.assert_array_equal(fft.wavenumber % n, k % n)


def test_split_length():
    assert split_length(2**17) == (256, 512)
    assert split_length(2**20) == (1024, 1024)
    assert split_length(64) == (8, 8)
    assert split_length(96) == (8, 12)
    assert split_length(1000) == (40, 25)
    with pytest.raises(ValueError):
        split_length(15)


@pytest.mark.parametrize("transport", ["auto", "shared", "messages"])
def test_transport_on_one_rank(transport):
    fft = TransposedRealFFT(MPI.COMM_SELF, 64, "FFTW_ESTIMATE", transport=transport)
    assert fft.transport == "none"  # nothing to exchange
    field = np.random.default_rng(0).standard_normal(64)
    out = fft.apply_diagonal(field, np.ones(fft.spectrum_shape) / 64, np.empty(64))
    np.testing.assert_allclose(out, field, atol=1e-14)
    fft.close()
    with pytest.raises(ValueError):
        TransposedRealFFT(MPI.COMM_SELF, 64, "FFTW_ESTIMATE", transport="carrier pigeon")


def test_factory_picks_the_serial_transform_on_one_rank_up_to_the_four_step_size():
    assert isinstance(plan_real_fft(MPI.COMM_SELF, 16, "FFTW_ESTIMATE"), SerialRealFFT)
    assert isinstance(
        plan_real_fft(MPI.COMM_SELF, 16, "FFTW_ESTIMATE", transposed=True), TransposedRealFFT
    )
    below = plan_real_fft(MPI.COMM_SELF, FOUR_STEP_NODES - 2, "FFTW_ESTIMATE")
    assert isinstance(below, SerialRealFFT)
    # from 2^20 nodes the four-step transform, also on one rank; the same transform
    large = plan_real_fft(MPI.COMM_SELF, FOUR_STEP_NODES, "FFTW_ESTIMATE")
    assert isinstance(large, TransposedRealFFT)
    field = np.random.default_rng(5).standard_normal(FOUR_STEP_NODES)
    diagonal = 1.0 / (1.0 + np.abs(large.wavenumber)) / FOUR_STEP_NODES
    out = large.apply_diagonal(field, diagonal, np.empty_like(field))
    spectrum = np.fft.rfft(field) / (1.0 + np.arange(FOUR_STEP_NODES // 2 + 1))
    np.testing.assert_allclose(out, np.fft.irfft(spectrum, FOUR_STEP_NODES), atol=1e-14)
    large.close()
    below.close()


@pytest.mark.parametrize("n", [0, 1, 5, 8, 64, 97])
@pytest.mark.parametrize("size", [1, 2, 3, 6, 100])
def test_block_range(n, size):
    blocks = [block_range(n, size, r) for r in range(size)]
    assert blocks[0][0] == 0 and blocks[-1][1] == n
    assert all(blocks[r][1] == blocks[r + 1][0] for r in range(size - 1))
    lengths = [b - a for a, b in blocks]
    assert max(lengths) - min(lengths) <= 1 and lengths == sorted(lengths, reverse=True)
    if n < size:
        assert lengths.count(0) == size - n


MPI_RUNS = [(2, []), (3, []), (6, ["64", "16"])]


def mpi_check(script, ranks, *args):
    """Run tests/mpi/``script`` under ``mpirun -n ranks`` (as root too); its completed process."""
    env = dict(
        os.environ,
        OMPI_ALLOW_RUN_AS_ROOT="1",
        OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
        OPENBLAS_NUM_THREADS="1",
        OMP_NUM_THREADS="1",
    )
    path = Path(__file__).parent / "mpi" / script
    command = ["mpirun", "--oversubscribe", "-n", str(ranks), sys.executable, str(path), *args]
    return subprocess.run(command, env=env, capture_output=True, text=True, timeout=60)


@pytest.mark.mpi
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="mpirun not found")
@pytest.mark.parametrize("ranks, sizes", MPI_RUNS)
def test_transposed_fft_under_mpirun(ranks, sizes):
    result = mpi_check("check_fft.py", ranks, *sizes)
    assert result.returncode == 0, result.stdout + result.stderr
