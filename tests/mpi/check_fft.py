"""MPI check of TransposedRealFFT against numpy on the global array.

Run under mpirun with any number of ranks, e.g.::

    mpirun --oversubscribe -n 3 python tests/mpi/check_fft.py [n ...]

Every rank builds the same global field and even multiplier (same seed), applies the
distributed operator to its own block and compares with numpy, with each transport (the
automatic choice, shared memory on one node, and ``Alltoallw`` messages); the transports only
move data, so their results must agree bitwise. Exit status 0 on every rank when all checks
pass; on failure rank 0 prints the reasons and all ranks exit with 1.
"""
import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402

from hpcgfmd.parallel.fft import TransposedRealFFT  # noqa: E402

DEFAULT_SIZES = (2, 16, 30, 64, 96, 1000, 4096)
TRANSPORTS = ("auto", "messages")


def check(comm, n, transport="auto", results=None):
    """Return a list of failure messages for length n (empty when all is well).

    ``results`` (dict) collects the output per transport to compare them bitwise.
    """
    errors = []
    fft = TransposedRealFFT(comm, n, planner_effort="FFTW_ESTIMATE", transport=transport)
    expected_transport = "none" if comm.Get_size() == 1 else transport
    if transport != "auto" and fft.transport != expected_transport:
        errors.append(f"n={n}: transport {fft.transport!r}, asked for {transport!r}")
    starts = [a for a, _ in fft.x_blocks]
    stops = [b for _, b in fft.x_blocks]
    if starts[0] != 0 or stops[-1] != n or starts[1:] != stops[:-1] or \
            any(b < a for a, b in fft.x_blocks):
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
        errors.append(f"n={n} {fft.transport}: relative error {error:.3e} on rank "
                      f"{comm.Get_rank()}")
    if results is not None:
        for other, other_out in results.items():
            if not np.array_equal(out, other_out):
                errors.append(f"n={n}: {fft.transport} and {other} differ on rank "
                              f"{comm.Get_rank()}")
        results[fft.transport] = out

    in_place = field[block].copy()
    fft.apply_diagonal(in_place, diagonal, in_place)
    if not np.array_equal(in_place, out):
        errors.append(f"n={n}: out is field differs on rank {comm.Get_rank()}")
    if fft.pairs != 2:
        errors.append(f"n={n}: pairs = {fft.pairs}")
    fft.close()
    return errors


def main():
    comm = MPI.COMM_WORLD
    sizes = [int(a) for a in sys.argv[1:]] or DEFAULT_SIZES
    errors = []
    for n in sizes:
        results = {}
        try:
            for transport in TRANSPORTS:
                errors += check(comm, n, transport, results)
        except Exception as exc:  # the other ranks may hang in a collective: abort them all
            print(f"FAIL n={n}: {type(exc).__name__}: {exc} on rank {comm.Get_rank()}",
                  file=sys.stderr, flush=True)
            comm.Abort(2)
    all_errors = comm.gather(errors, root=0)
    failed = comm.allreduce(bool(errors), op=MPI.LOR)
    if comm.Get_rank() == 0:
        for message in (m for rank_errors in all_errors for m in rank_errors):
            print("FAIL", message, flush=True)
        if not failed:
            print(f"ok: {len(sizes)} sizes x {len(TRANSPORTS)} transports on "
                  f"{comm.Get_size()} ranks", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
