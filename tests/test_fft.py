"""Serial and transposed real FFTs against numpy, block_range, and the MPI check program."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from hpcgfmd.parallel.fft import SerialRealFFT, TransposedRealFFT, plan_real_fft
from hpcgfmd.parallel.fft_transposed import split_length
from hpcgfmd.parallel.blocks import block_range

SIZES = [2, 16, 30, 64, 96, 1000, 2**12]


def reference(field, multiplier):
    """irfft(D * rfft(v)) without the 1/n, for a multiplier D(|m|) on m = 0 .. n/2."""
    n = field.size
    return np.fft.irfft(multiplier * np.fft.rfft(field), n) * n


def apply(fft, field, multiplier):
    out = np.empty(fft.x_stop - fft.x_start)
    return fft.apply_diagonal(field[fft.x_start:fft.x_stop],
                              multiplier[np.abs(fft.wavenumber)], out)


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


def test_factory_picks_the_serial_transform_on_one_rank():
    assert isinstance(plan_real_fft(MPI.COMM_SELF, 16, "FFTW_ESTIMATE"), SerialRealFFT)
    assert isinstance(plan_real_fft(MPI.COMM_SELF, 16, "FFTW_ESTIMATE", transposed=True),
                      TransposedRealFFT)


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


@pytest.mark.mpi
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="mpirun not found")
@pytest.mark.parametrize("ranks, sizes", MPI_RUNS)
def test_transposed_fft_under_mpirun(ranks, sizes):
    script = Path(__file__).parent / "mpi" / "check_fft.py"
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    command = ["mpirun", "--oversubscribe", "-n", str(ranks), sys.executable, str(script), *sizes]
    result = subprocess.run(command, env=env, capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stdout + result.stderr
