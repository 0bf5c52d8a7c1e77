"""MPI check of TransposedRealFFT and (on two ranks) HalvedRealFFT against numpy on the
global array: apply_diagonal, and the split forward and inverse transforms.

Run under mpirun with any number of ranks, e.g.::

    mpirun --oversubscribe -n 3 python tests/mpi/check_fft.py [n ...]

Every rank builds the same global field and even multiplier (same seed), applies the
distributed operator to its own block and compares with numpy, with each transport (the
automatic choice, shared memory on one node, and ``Alltoallv`` messages); the transports only
move data, so their results must agree bitwise. On two ranks the halved transform is checked
the same way, and its forward and inverse halves too (spectrum against numpy's at the local
wavenumbers, calls of one half twice in a row). The four-step transform's forward and
inverse (those of the damped Verlet solver) are checked apart too, against numpy's rfft and
irfft, with each transport. Exit status 0 on every rank when all checks pass; on failure
rank 0 prints the reasons and all ranks exit with 1.
"""

import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402
from report import abort, report  # noqa: E402

from hpcgfmd.parallel.fft import (
    HalvedRealFFT,
    SerialRealFFT,
    TransposedRealFFT,  # noqa: E402
    plan_real_fft,
)
from hpcgfmd.parallel.fft_halved import fits  # noqa: E402

DEFAULT_SIZES = (2, 12, 16, 30, 36, 64, 96, 1000, 4096)  # 12, 36: n/4 odd
TRANSPORTS = ("auto", "messages")


def check(comm, n, transport="auto", results=None, kind=TransposedRealFFT):
    """Return a list of failure messages for length n (empty when all is well).

    ``results`` (dict) collects the output per transport to compare them bitwise.
    """
    errors = []
    fft = kind(comm, n, planner_effort="FFTW_ESTIMATE", transport=transport)
    expected_transport = "none" if comm.Get_size() == 1 else transport
    if transport != "auto" and fft.transport != expected_transport:
        errors.append(f"n={n}: transport {fft.transport!r}, asked for {transport!r}")
    starts = [a for a, _ in fft.x_blocks]
    stops = [b for _, b in fft.x_blocks]
    if (
        starts[0] != 0
        or stops[-1] != n
        or starts[1:] != stops[:-1]
        or any(b < a for a, b in fft.x_blocks)
    ):
        errors.append(f"n={n}: x_blocks {fft.x_blocks} do not tile [0, {n})")
    if fft.x_blocks[comm.Get_rank()] != (fft.x_start, fft.x_stop):
        errors.append(f"n={n}: x_blocks disagrees with x_start, x_stop")

    rng = np.random.default_rng(12345 + n)
    field = rng.standard_normal(n)
    multiplier = rng.standard_normal(n // 2 + 1)  # D(|m|), even in m by construction
    expected = np.fft.irfft(multiplier * np.fft.rfft(field), n) * n
    scale = np.abs(expected).max()
    diagonal = multiplier[np.abs(fft.wavenumber)]
    if diagonal.shape != fft.spectrum_shape:
        errors.append(f"n={n}: wavenumber shape {fft.wavenumber.shape} != spectrum_shape")

    block = slice(fft.x_start, fft.x_stop)
    out = np.empty(fft.x_stop - fft.x_start)
    fft.apply_diagonal(field[block], diagonal, out)
    error = np.abs(out - expected[block]).max(initial=0.0) / scale
    if error > 1e-12:
        errors.append(
            f"n={n} {fft.transport}: relative error {error:.3e} on rank {comm.Get_rank()}"
        )
    if results is not None:
        for other, other_out in results.items():
            if not np.array_equal(out, other_out):
                errors.append(
                    f"n={n}: {fft.transport} and {other} differ on rank {comm.Get_rank()}"
                )
        results[fft.transport] = out

    in_place = field[block].copy()
    fft.apply_diagonal(in_place, diagonal, in_place)
    if not np.array_equal(in_place, out):
        errors.append(f"n={n}: out is field differs on rank {comm.Get_rank()}")
    if fft.pairs != 2:
        errors.append(f"n={n}: pairs = {fft.pairs}")
    if kind is HalvedRealFFT:
        errors += check_halves(fft, field[block], diagonal, out, np.fft.rfft(field), n)
    fft.close()
    return errors


def check_split(comm, n, transport):
    """Failures of TransposedRealFFT's split transforms (those of the damped Verlet solver)
    for length n: ``forward`` against numpy's rfft (each local mode, m < 0 being the
    conjugate of |m|), ``inverse`` against n irfft, and ``inverse(d * forward(f))`` against
    ``apply_diagonal(f, d)`` (bitwise: the same plans and operations); ``pairs`` counts one
    per inverse."""
    errors = []
    fft = TransposedRealFFT(comm, n, planner_effort="FFTW_ESTIMATE", transport=transport)
    rng = np.random.default_rng(777 + n)
    field = rng.standard_normal(n)
    multiplier = rng.standard_normal(n // 2 + 1)
    block = slice(fft.x_start, fft.x_stop)
    m = fft.wavenumber
    reference = np.fft.rfft(field)
    expected = np.where(m >= 0, reference[np.abs(m)], np.conj(reference[np.abs(m)]))
    spectrum = np.empty(fft.spectrum_shape, dtype=np.complex128)
    fft.forward(field[block], spectrum)
    error = np.abs(spectrum - expected).max(initial=0.0) / np.abs(reference).max()
    if error > 1e-13:
        errors.append(f"n={n} {fft.transport}: forward error {error:.2e} on rank {comm.Get_rank()}")
    out = np.empty(fft.x_stop - fft.x_start)
    fft.inverse(spectrum, out)  # unnormalised: n * irfft
    error = np.abs(out - n * field[block]).max(initial=0.0) / (n * np.abs(field).max())
    if error > 1e-13:
        errors.append(f"n={n} {fft.transport}: inverse error {error:.2e} on rank {comm.Get_rank()}")
    diagonal = multiplier[np.abs(m)]
    fft.forward(field[block], fft.spectrum)
    fft.spectrum *= diagonal
    fft.inverse(fft.spectrum, out)
    applied = fft.apply_diagonal(field[block], diagonal, np.empty_like(out))
    if not np.array_equal(out, applied):
        errors.append(
            f"n={n} {fft.transport}: inverse(d * forward(f)) != apply_diagonal on "
            f"rank {comm.Get_rank()}"
        )
    if fft.pairs != 3:
        errors.append(f"n={n}: pairs = {fft.pairs}, expected 3")
    fft.close()
    return errors


def check_halves(fft, field, diagonal, applied, spectrum, n):
    """Failures of forward and inverse on this rank, in every order of calls that makes the
    halved transform wait for its peer (forward after forward or before an application,
    inverse after inverse or after an application), each rank in turn pausing after every
    synchronisation before it reads the peer's block (a missing wait would let the peer
    overwrite that block first)."""
    errors = []
    rank = fft.comm.Get_rank()
    local, negated = (np.empty(fft.spectrum_shape, dtype=np.complex128) for _ in range(2))
    back, negated_back, again = (np.empty_like(field) for _ in range(3))
    exchange = fft._exchange
    for slow in (0, 1):
        pause = 5e-3 if rank == slow else 0.0

        def slowed(stage, exchange=exchange, pause=pause):
            exchange(stage)
            time.sleep(pause)

        # each call's input differs from the one before, so a block overwritten too early
        # changes a result
        fft._exchange = slowed
        fft.forward(field, local)
        fft.forward(-field, negated)  # forward, forward
        fft.apply_diagonal(2.0 * field, diagonal, again)  # forward, apply
        fft.inverse(diagonal * local, back)  # apply, inverse
        fft.inverse(diagonal * negated, negated_back)  # inverse, inverse
        scale = np.abs(spectrum).max()
        for name, result, sign in (("forward", local, 1.0), ("forward of -f", negated, -1.0)):
            error = np.abs(result - sign * spectrum[fft.wavenumber]).max() / scale
            if error > 1e-12:
                errors.append(f"n={n}: {name} off numpy's by {error:.3e} on rank {rank}")
        scale = max(np.abs(applied).max(), 1e-300)
        for name, result, factor in (
            ("inverse(d forward)", back, 1.0),
            ("inverse(d forward(-f))", negated_back, -1.0),
            ("apply to 2 f after forward", again, 2.0),
        ):
            error = np.abs(result - factor * applied).max() / scale
            if error > 1e-12:
                errors.append(f"n={n}: {name} off apply_diagonal by {error:.3e} on rank {rank}")
    fft._exchange = exchange
    if fft.pairs != 8:  # the two of check() and three per round
        errors.append(f"n={n}: pairs = {fft.pairs}")
    return errors


def main():
    comm = MPI.COMM_WORLD
    sizes = [int(a) for a in sys.argv[1:]] or DEFAULT_SIZES
    errors = []
    halved = 0
    for n in sizes:
        kinds = [TransposedRealFFT] + ([HalvedRealFFT] if fits(comm.Get_size(), n) else [])
        halved += len(kinds) - 1
        expected = SerialRealFFT if comm.Get_size() == 1 else kinds[-1]
        try:
            chosen = plan_real_fft(comm, n, "FFTW_ESTIMATE")
            if type(chosen) is not expected:  # the halved one wherever it fits
                errors.append(f"n={n}: plan_real_fft chose {type(chosen).__name__}")
            chosen.close()
            for kind in kinds:
                results = {}
                for transport in TRANSPORTS:
                    errors += check(comm, n, transport, results, kind)
            for transport in TRANSPORTS:
                errors += check_split(comm, n, transport)
        except Exception as exc:
            abort(comm, exc, f" n={n}")
    return report(
        comm,
        errors,
        f"ok: {len(sizes)} sizes x {len(TRANSPORTS)} transports on "
        f"{comm.Get_size()} ranks ({halved} of the sizes halved too)",
    )


if __name__ == "__main__":
    sys.exit(main())
