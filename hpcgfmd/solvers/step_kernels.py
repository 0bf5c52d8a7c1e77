"""Compiled loops of the work done once per time step around the solve.

A step's own work (the predictor's guesses and their energies, the history's time-error
estimate) is a few passes over this rank's block each;
with numpy each pass is one call and often one temporary. These kernels do each stretch in
one loop (numba, cached as :mod:`hpcgfmd.solvers.kernels` is). They are local (no MPI):
the callers reduce their sums. Sums may be reassociated (vectorised), as in the CG kernels:
the same block gives the same bits every time. NaN propagates as it did through numpy: a
non-finite displacement is never replaced by the wall.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .extremes import INF_BITS, MAGNITUDE, as_float, bits

FAST = {"reassoc"}  # reductions may be reassociated (vectorised); inf and NaN keep their meaning


@njit(cache=True)
def linear_guess(u, u_previous, ratio, wall, contact, out):
    """out = u + ratio (u - u_previous), exactly on the wall on the ``contact`` nodes."""
    for i in range(u.shape[0]):
        if contact[i]:
            out[i] = wall[i]
        else:
            out[i] = u[i] + ratio * (u[i] - u_previous[i])


@njit(cache=True)
def quadratic_guess(u, u_previous, u_before_previous, w0, w1, w2, wall, contact, out):
    """out = w0 u + w1 u_previous + w2 u_before_previous, exactly on the wall on the
    ``contact`` nodes (the weights: :func:`hpcgfmd.solvers.predictor.lagrange_weights`)."""
    for i in range(u.shape[0]):
        if contact[i]:
            out[i] = wall[i]
        else:
            out[i] = w0 * u[i] + w1 * u_previous[i] + w2 * u_before_previous[i]


@njit(cache=True, fastmath=FAST)
def energy_terms(u, k_u, linear, wall, gap):
    """gap = wall - u; returns 1/2 u.k_u + linear.u (the quadratic and linear energy terms)."""
    quadratic, first_order = 0.0, 0.0
    for i in range(u.shape[0]):
        v = u[i]
        quadratic += v * k_u[i]
        first_order += v * linear[i]
        gap[i] = wall[i] - v
    return 0.5 * quadratic + first_order


@njit(cache=True)
def interaction_state(profile, indenter, u, dmax, out):
    """out = 2 on the wall (gap <= 0), 1 in the cohesive zone (0 < gap < dmax), else 0, for
    gap = profile + indenter - u (int8)."""
    for i in range(u.shape[0]):
        g = profile[i] + indenter - u[i]
        if g <= 0.0:
            out[i] = 2
        elif g < dmax:
            out[i] = 1
        else:
            out[i] = 0


@njit(cache=True)
def curvature(older, before, after, h0, h1, state_older, state_before, state, out):
    """out = ((after - before) / h1 - (before - older) / h0) / (h1 + h0), the u_tt / 2 of the
    quadratic through three states, and 0 on the nodes whose interaction state changed;
    returns (the number of such nodes, the first's index, the last's; -1, -1 for none)."""
    inv0, inv1, inv = 1.0 / h0, 1.0 / h1, 1.0 / (h1 + h0)
    kinks, first, last = 0, -1, -1
    for i in range(out.shape[0]):
        if state_older[i] != state_before[i] or state_before[i] != state[i]:
            out[i] = 0.0
            kinks += 1
            if first < 0:
                first = i
            last = i
        else:
            out[i] = ((after[i] - before[i]) * inv1 - (before[i] - older[i]) * inv0) * inv
    return kinks, first, last


@njit(cache=True)
def clear_near_crossings(state_older, state_before, state, reach, left, right, out):
    """out = 0 on every node within ``reach`` nodes of a node whose interaction state changed.

    ``left``: how many nodes before this block's first node the nearest changed node outside
    it lies (>= 1; large for none), ``right`` the same after its last node: the changed nodes
    of the neighbouring blocks (periodic) clear this block's ends too.
    """
    n = out.shape[0]
    last = -left  # index of the nearest changed node at or before i
    for i in range(n):
        if state_older[i] != state_before[i] or state_before[i] != state[i]:
            last = i
        if i - last <= reach:
            out[i] = 0.0
    following = n - 1 + right  # ... at or after i
    for i in range(n - 1, -1, -1):
        if state_older[i] != state_before[i] or state_before[i] != state[i]:
            following = i
        if following - i <= reach:
            out[i] = 0.0


@njit(cache=True, fastmath=FAST)
def contact_sums(a, b, state):
    """(sum of a, sum of b) over the nodes on the wall (state 2)."""
    total_a, total_b = 0.0, 0.0
    for i in range(a.shape[0]):
        if state[i] == 2:
            total_a += a[i]
            total_b += b[i]
    return total_a, total_b


@njit(cache=True)
def below_wall(u, shift, wall, out, hold):
    """out = numpy's minimum(u - shift, wall) (NaN propagates; of two equal values the
    wall's); returns the number of nodes with u - shift < wall (the free nodes). With
    ``hold``, the nodes with u >= wall stay on the wall whatever the shift (not free)."""
    free = 0
    for i in range(u.shape[0]):
        if hold and u[i] >= wall[i]:
            out[i] = wall[i]
            continue
        v = u[i] - shift
        w = wall[i]
        if v < w:
            out[i] = v
            free += 1
        elif v != v:
            out[i] = v
        else:
            out[i] = w
    return free


@njit(cache=True)
def feasibility(u, wall):
    """What :func:`below_wall` at shift 0 would do, without writing: returns (the nodes it
    would move, u > wall or a NaN wall under a number; the free nodes, u < wall; max |wall|,
    NaN passed over). With no node to move its output is u (to the sign of a zero)."""
    moved, free, high = 0, 0, 0
    for i in range(u.shape[0]):
        v, w = u[i], wall[i]
        free += v < w
        moved += (not v <= w) and v == v
        b = bits(w) & MAGNITUDE  # |w|: the bits of a non-negative double are its key
        high = max(high, b if b <= INF_BITS else 0)
    return moved, free, as_float(high)


@njit(cache=True)
def equal(a, b):
    """True when the blocks are equal node by node (as numbers: NaN is equal to nothing);
    compared in vectorised chunks, stopping at the first chunk that differs."""
    for start in range(0, a.shape[0], 1024):
        x, y = a[start : start + 1024], b[start : start + 1024]  # (slices: indices from 0)
        differ = 0
        for i in range(x.shape[0]):
            differ += x[i] != y[i]
        if differ:
            return False
    return True


@njit(cache=True)
def all_beyond(wall, u, level):
    """True when every gap wall - u exceeds ``level`` (stops at the first that does not)."""
    for i in range(u.shape[0]):  # noqa: SIM110 (a compiled loop: no generator in all())
        if not wall[i] - u[i] > level:
            return False
    return True


def compile_all():
    """Compile every kernel of this module into numba's cache."""
    m = 8
    a, b, c, d = (np.linspace(-1.0, 1.0, m) for _ in range(4))
    flags = np.zeros(m, dtype=np.bool_)
    states = [np.zeros(m, dtype=np.int8) for _ in range(3)]
    linear_guess(a, b, 0.5, c, flags, d)
    energy_terms(a, b, c, d, d.copy())
    interaction_state(a, 0.1, b, 0.5, states[0])
    curvature(a, b, c, 0.5, 0.5, states[0], states[1], states[2], d)
    clear_near_crossings(states[0], states[1], states[2], 2, 3, 3, d)
    contact_sums(a, b, states[0])
    all_beyond(a, b, 0.5)
    below_wall(a, 0.1, b, c, False)
    feasibility(a, b)
    equal(a, b)
