"""Compiled passes of the paper's damped Verlet pseudo step (:mod:`.verlet`).

Between its two transforms a pseudo step has one stretch of work on the modes and one on the
nodes; each kernel here does one of them in a single pass (numba, cached as
:mod:`.kernels` is), with the same arithmetic, in the same order, as the numpy calls it
replaces, so the pseudo steps keep their bits. Local (no MPI).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .extremes import KEY_INF, bits, low_key, value


@njit(cache=True)
def modes(spectrum, a1, a0, v_old, load, v_new):
    """The pseudo step on the modes, as interleaved floats (module docstring of
    :mod:`.verlet`): v_new = a0 U, then U <- a1 U - v_old - load, in place.

    ``v_old`` may be ``v_new`` itself: the first step, at rest (U_old = U).
    """
    for k in range(spectrum.shape[0]):
        x = spectrum[k]
        v_new[k] = x * a0[k]
        spectrum[k] = x * a1[k] - v_old[k] - load[k]


@njit(cache=True)
def hard_wall(u, wall):
    """u = numpy's minimum(u, wall), in place; returns the free nodes (u < wall)."""
    free = 0
    for i in range(u.shape[0]):
        v, w = u[i], wall[i]
        v = v if v < w or v != v else w  # a NaN on either side is numpy's minimum
        u[i] = v
        free += v < w
    return free


@njit(cache=True)
def hard_wall_adhesive(u, traction, wall, gap, level):
    """u = numpy's minimum(u + traction, wall), in place, and gap = wall - u, the next step's
    gaps; returns (the free nodes, u < wall; (first, last, smallest) of the gaps as
    :func:`.kernels.near` gives them for ``level``)."""
    m = u.shape[0]
    free, first, last, lk = 0, m, -1, KEY_INF
    for i in range(m):
        v, w = u[i] + traction[i], wall[i]
        v = v if v < w or v != v else w
        u[i] = v
        free += v < w
        g = w - v
        gap[i] = g
        near = g < level
        first = min(first, i if near else m)
        last = max(last, i if near else -1)
        lk = min(lk, low_key(bits(g)))
    return free, (first, last, value(lk))


def compile_all():
    """Compile the kernels of this module into numba's cache."""
    a, b, c, d, e = (np.linspace(-1.0, 1.0, 8) for _ in range(5))
    modes(a, b, c, d, e, d)
    hard_wall(a, b)
    hard_wall_adhesive(a, b, c, d, 0.5)
