"""Compiled loop of the history traction of the half-space (:class:`.halfspace.MaxwellHalfSpace`).

The history of a step, H = a p_n + (E0 (1 - a) - Eeff) G_n (docs/model.md, (M8)) with the
quadratic step's terms (M46), reads three fields of the block and writes two; as numpy
expressions it was seven passes and three temporaries. One loop here, in the same order of
operations as those expressions, so the values are the same to the bit (no fastmath).
Local (no MPI), cached by numba as the solvers' kernels are.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def sls_history(
    relaxed, substrate, relaxed_before, e_history, decay, added, weight, quadratic, out, start
):
    """out = e_history G_n + decay p_n, and with ``quadratic`` - (added + weight) G_n +
    weight G_{n-1}; start = G_n (the step's start, kept for the update).

    Parameters
    ----------
    relaxed, substrate, relaxed_before : ndarray
        G_n = (|q|/2) u_n, p_n and G_{n-1} of the block (stress).
    e_history, decay, added, weight : float
        E0 (1 - a) - Eeff (stress), a, and the quadratic step's R / (dt (dt + h)) and
        R / (h (dt + h)) (stress; unused without ``quadratic``).
    """
    both = added + weight
    for i in range(out.shape[0]):
        g = relaxed[i]
        start[i] = g
        value = g * e_history
        value = value + decay * substrate[i]
        if quadratic:
            value = value - both * g
            value = value + weight * relaxed_before[i]
        out[i] = value


def compile_all():
    """Compile the kernel into numba's cache (scripts/setup.sh, through the CG kernels')."""
    a, b, c, d, e = (np.linspace(-1.0, 1.0, 4) for _ in range(5))
    sls_history(a, b, c, 0.5, 0.25, 0.1, 0.2, True, d, e)
