"""MPI check of the 2-D slab transform (SlabRealFFT2D) against numpy's rfft2/irfft2 on the
global grid: apply_diagonal, the split forward and inverse transforms, half_wavenumbers, the
layout, and the same result as on one rank.

Run under mpirun with any number of ranks, e.g.::

    mpirun --oversubscribe -n 3 python tests/mpi/check_fft2d.py [ny nx ...]

Every rank builds the same global field (same seed) and a multiplier D(|q|) of a non-square
cell, applies the distributed operator to its rows and compares with numpy, with each
transport (the automatic choice, shared memory on one node, and ``Alltoallv`` messages, whose
results must agree bitwise: they only move data); and with the one-rank transforms of the
same grid on ``COMM_SELF`` (the slab one and FFTW's whole 2-D plan). The forward and inverse
halves are checked in every order of calls that makes a rank wait for its peers before it
overwrites a block they may still read, each rank in turn pausing after every
synchronisation. Exit status 0 on every rank when all checks pass; on failure rank 0 prints
the reasons and all ranks exit with 1.

Tolerances: FFTW's round-off on these grids (at most 2^14 nodes) is about eps log2(n) of the
field's largest value, under 1e-14 relative; 1e-13 leaves a factor of ten and still catches
any wrong mode, sign or layout (errors of order one).
"""

import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from mpi4py import MPI
from report import abort, report

from hpcgfmd.parallel.fft import SerialRealFFT2D, SlabRealFFT2D, plan_real_fft

# (ny, nx): square and not, ny not divisible by 2 or 3 ranks, ny < ranks (a rank owns no
# rows) and nx/2 + 1 < ranks (a rank owns no columns)
DEFAULT_SHAPES = ((2, 2), (2, 8), (4, 6), (6, 4), (10, 12), (14, 30), (64, 64), (48, 20))
TRANSPORTS = ("auto", "shared", "messages")
TOLERANCE = 1e-13
CELL = (1.7, 2.3)  # (Ly, Lx)


def numpy_reference(shape):
    """The global field, the multiplier on numpy's (ny, nx/2 + 1) modes, the expected
    ``n irfft2(D rfft2(f))`` and numpy's spectrum."""
    ny, nx = shape
    field = np.random.default_rng(ny * 1000 + nx).standard_normal(shape)
    qy = 2 * np.pi * np.fft.fftfreq(ny, CELL[0] / ny)[:, None]  # q = 2 pi m / L (M4)
    qx = 2 * np.pi * np.fft.rfftfreq(nx, CELL[1] / nx)[None, :]
    half_q = np.hypot(qx, qy) / 2
    spectrum = np.fft.rfft2(field)
    expected = np.fft.irfft2(multiplier(half_q) * spectrum, s=shape) * field.size
    return field, half_q, expected, spectrum


def multiplier(half_q):
    """A multiplier of |q| only (even in (mx, my)), of order one, not smooth at q = 0."""
    return 1.0 / (1.0 + half_q) - 0.5 * np.cos(half_q)


def local(fft, global_modes):
    """numpy's (ny, nx/2 + 1) modes arranged as the transform's local spectrum."""
    my, mx = fft.wavenumbers
    return global_modes[my % fft.shape[0], mx]


def check(comm, shape, transport, results):
    """Failures of apply_diagonal, forward and inverse with ``transport`` on grid ``shape``;
    ``results`` collects apply_diagonal's output per transport (bitwise comparison)."""
    errors = []
    rank = comm.Get_rank()
    where = f"{shape} {transport} rank {rank}"
    fft = SlabRealFFT2D(comm, shape, "FFTW_ESTIMATE", transport)
    ny, nx = shape
    if transport != "auto" and comm.Get_size() > 1 and fft.transport != transport:
        errors.append(f"{where}: transport {fft.transport}")
    # layout: the rows tile [0, ny) and the flat blocks are the rows times nx
    if (
        [a for a, _ in fft.row_blocks][1:] != [b for _, b in fft.row_blocks][:-1]
        or fft.row_blocks[0][0] != 0
        or fft.row_blocks[-1][1] != ny
        or fft.x_blocks != [(a * nx, b * nx) for a, b in fft.row_blocks]
        or (fft.x_start, fft.x_stop) != fft.x_blocks[rank]
        or fft.n != ny * nx
        or fft.shape != shape
    ):
        errors.append(f"{where}: blocks {fft.row_blocks} {fft.x_blocks}")
    columns = comm.allgather((fft.kx_start, fft.kx_stop))
    if [c for pair in columns for c in pair] != sorted(c for pair in columns for c in pair) or (
        columns[0][0],
        columns[-1][1],
    ) != (0, nx // 2 + 1):
        errors.append(f"{where}: spectrum columns {columns} do not tile [0, nx/2]")

    field, half_q, expected, spectrum = numpy_reference(shape)
    half_q_here = fft.half_wavenumbers(CELL)
    if half_q_here.shape != fft.spectrum_shape or not np.allclose(
        half_q_here, local(fft, half_q), rtol=1e-15, atol=0
    ):
        errors.append(f"{where}: half_wavenumbers off numpy's")
    diagonal = multiplier(half_q_here)
    mine = field.reshape(-1)[fft.x_start : fft.x_stop]
    scale = np.abs(expected).max()

    out = fft.apply_diagonal(mine, diagonal, np.empty(mine.size))
    error = np.abs(out - expected.reshape(-1)[fft.x_start : fft.x_stop]).max(initial=0) / scale
    if error > TOLERANCE:
        errors.append(f"{where}: apply_diagonal off numpy's by {error:.2e}")
    for other, other_out in results.items():
        if not np.array_equal(out, other_out):
            errors.append(f"{where}: apply_diagonal differs from transport {other}")
    results[fft.transport] = out
    in_place = mine.copy()
    if not np.array_equal(fft.apply_diagonal(in_place, diagonal, in_place), out):
        errors.append(f"{where}: apply_diagonal in place differs")

    local_spectrum = fft.forward(mine, np.empty(fft.spectrum_shape, dtype=complex))
    error = np.abs(local_spectrum - local(fft, spectrum)).max(initial=0) / np.abs(spectrum).max()
    if error > TOLERANCE:
        errors.append(f"{where}: forward off numpy's rfft2 by {error:.2e}")
    kept = local_spectrum.copy()
    back = fft.inverse(local_spectrum, np.empty(mine.size))
    if not np.array_equal(local_spectrum, kept):
        errors.append(f"{where}: inverse changed its input")
    error = np.abs(back - fft.n * mine).max(initial=0) / (fft.n * np.abs(field).max())
    if error > TOLERANCE:
        errors.append(f"{where}: inverse(forward(f)) off n f by {error:.2e}")
    fft.forward(mine, fft.spectrum)
    fft.spectrum *= diagonal
    if not np.array_equal(fft.inverse(fft.spectrum, back), out):
        errors.append(f"{where}: inverse(d forward(f)) != apply_diagonal(f, d) bitwise")
    errors += check_orders(fft, mine, diagonal, out, where)
    if fft.pairs != 10:  # 2 applications and 2 inverses here, 3 per round of check_orders
        errors.append(f"{where}: pairs = {fft.pairs}")
    fft.close()
    return errors


def check_orders(fft, field, diagonal, applied, where):
    """Failures of the calls in every order that makes a rank wait before it overwrites a
    block its peers may read (forward after forward, forward before an application, inverse
    after an application or an inverse), each rank in turn pausing after every
    synchronisation; each call's input differs from the one before, so that a block
    overwritten too early changes a result."""
    errors = []
    exchange = fft._exchange
    local_spectrum, negated = (np.empty(fft.spectrum_shape, dtype=complex) for _ in range(2))
    back, negated_back, again = (np.empty(field.size) for _ in range(3))
    for slow in (0, 1):
        pause = 5e-3 if fft.comm.Get_rank() == slow else 0.0

        def slowed(stage, exchange=exchange, pause=pause):
            exchange(stage)
            time.sleep(pause)

        fft._exchange = slowed
        fft.forward(field, local_spectrum)
        fft.forward(-field, negated)  # forward, forward
        fft.apply_diagonal(2.0 * field, diagonal, again)  # forward, apply
        fft.inverse(diagonal * local_spectrum, back)  # apply, inverse
        fft.inverse(diagonal * negated, negated_back)  # inverse, inverse
        scale = max(np.abs(applied).max(initial=0), 1e-300)
        for name, result, factor in (
            ("inverse(d forward(f))", back, 1.0),
            ("inverse(d forward(-f))", negated_back, -1.0),
            ("apply_diagonal(2 f) after forward", again, 2.0),
        ):
            error = np.abs(result - factor * applied).max(initial=0) / scale
            if error > TOLERANCE:
                errors.append(f"{where}: {name} off by {error:.2e} (rank {slow} slow)")
    fft._exchange = exchange
    return errors


def check_one_rank(comm, shape, mine):
    """Failures of the P-rank result against the one-rank transforms on COMM_SELF (the slab
    one with the same plans, and FFTW's whole 2-D plan), on this rank's rows."""
    errors = []
    rank = comm.Get_rank()
    field, half_q, expected, _ = numpy_reference(shape)
    rows = SlabRealFFT2D(comm, shape, "FFTW_ESTIMATE", "messages")
    block = slice(rows.x_start, rows.x_stop)
    rows.close()
    scale = np.abs(expected).max()
    for kind in (SlabRealFFT2D, SerialRealFFT2D):
        if kind is SlabRealFFT2D:
            one = kind(MPI.COMM_SELF, shape, "FFTW_ESTIMATE")
        else:
            one = kind(shape, "FFTW_ESTIMATE")
        diagonal = multiplier(one.half_wavenumbers(CELL))
        out = one.apply_diagonal(field.reshape(-1), diagonal, np.empty(one.n))
        error = np.abs(out[block] - mine).max(initial=0) / scale
        if error > TOLERANCE:
            errors.append(f"{shape} rank {rank}: {kind.__name__} on one rank differs by {error}")
    return errors


def main():
    comm = MPI.COMM_WORLD
    numbers = [int(a) for a in sys.argv[1:]]
    shapes = list(zip(numbers[::2], numbers[1::2])) or DEFAULT_SHAPES
    errors = []
    for shape in shapes:
        try:
            chosen = plan_real_fft(comm, shape, "FFTW_ESTIMATE")
            if comm.Get_size() > 1 and not isinstance(chosen, SlabRealFFT2D):
                errors.append(f"{shape}: plan_real_fft chose {type(chosen).__name__}")
            chosen.close()
            results = {}
            for transport in TRANSPORTS:
                errors += check(comm, shape, transport, results)
            errors += check_one_rank(comm, shape, next(iter(results.values())))
        except Exception as exc:
            abort(comm, exc, f" {shape}")
    return report(
        comm,
        errors,
        f"ok: {len(shapes)} grids x {len(TRANSPORTS)} transports on {comm.Get_size()} ranks",
    )


if __name__ == "__main__":
    sys.exit(main())
