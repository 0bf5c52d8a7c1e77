"""Grid sizes the automatic resolution may choose: f 2^a with f in {1, 3, 9}.

The transforms cost the same per node on these sizes as on powers of two (FFTW's radix-3
codelets; `python -m hpcgfmd bench fft --sizes 65536 73728 98304 131072 147456 196608 262144`:
3.4-5.7 ns per node from 2^16 to 3 x 2^16), and consecutive sizes differ by at most 4/3
instead of 2, so a grid chosen for a required number of nodes carries at most a third more
nodes than it needs (on average about 15 %, against about 44 % for powers of two). Every size
is even and halves at least down to f 2^2, as the coarse-to-fine preload needs
(:mod:`hpcgfmd.runs.coarse_start`).
"""

from __future__ import annotations

import math

#: Odd factors of the automatic grid sizes.
ODD_FACTORS = (1, 3, 9)
#: The smallest automatic grid.
MIN_NODES = 64
#: No grid beyond this is run anywhere (2^50 nodes: 8 PB for each array of the state); a
#: case that asks for more is refused when it is read, whatever the machine.
MAX_NODES = 2**50


def smallest_grid(log2_nodes: float) -> int:
    """The smallest size f 2^a >= max(2^log2_nodes, 64) with f in :data:`ODD_FACTORS`.

    Parameters
    ----------
    log2_nodes : float
        log2 of the number of nodes required (a logarithm, so that requirements beyond the
        floating-point range still give an integer, which the case's check against
        :data:`MAX_NODES` then rejects).

    Returns
    -------
    int
        Grid nodes.
    """
    log2_nodes = max(log2_nodes, math.log2(MIN_NODES))
    best = None
    for factor in ODD_FACTORS:
        # the tolerance keeps an exact requirement (2^17 nodes) on its own size
        exponent = max(1, math.ceil(log2_nodes - math.log2(factor) - 1e-12))
        size = factor * 2**exponent
        if best is None or size < best:
            best = size
    return best


def grid_label(nx: int) -> str:
    """``2^17`` for a power of two, ``9x2^13`` for f 2^a with f in {3, 9}, else the number."""
    if nx <= 0:
        return str(nx)
    exponent = (nx & -nx).bit_length() - 1  # the power of two dividing nx
    factor = nx >> exponent
    if factor == 1:
        return f"2^{exponent}"
    if factor in ODD_FACTORS:
        return f"{factor}x2^{exponent}"
    return str(nx)
