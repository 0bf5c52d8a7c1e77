"""Compiled loops of the Dugdale-Maugis law on a surface (2D grid), integrated over triangles.

The 1D law integrates the interface energy exactly over the piecewise-linear interpolant of
the nodal gaps (docs/model.md, (M35)). On a surface the same is done over linear triangles
(docs/model.md, "Discretisation", (M60)): each grid square of side dx x dy is split along a
diagonal into two triangles, over which the gap is linear, and the energy is the mean of
the two ways to split it (along either diagonal), so that the law has the lattice's mirror
symmetries. With f = dmax - g the ramp and T a triangle of vertex values f1 >= f2 >= f3,
the mean of max(f, 0) over T is

    (f1 + f2 + f3) / 3                                     f3 >= 0 (all in the zone)
    f1^3 / (3 (f1 - f2)(f1 - f3))                          f2 <= 0 < f1
    (f1 + f2 + f3) / 3 + (-f3)^3 / (3 (f1 - f3)(f2 - f3))  f3 < 0 < f2
    0                                                      f1 <= 0

(the region f > 0 is a triangle at f1's vertex, or the triangle minus one at f3's). A
square's mean S is a quarter of its four triangles' means; the interface energy per node
area is -sigma_a sum S over the squares and the traction on node i is
sigma_a sum dS/df_i over the four squares around it: sigma_a inside the zone, 0 beyond,
continuous in the gaps. A field uniform along y gives the 1D element law exactly: both
triangles of either split then hold the same linear profile along x.

Index conventions (as :mod:`.kernels`, with a row for a node): a block of m = rows nx nodes
in rows of nx (x fastest, periodic along x); ``gap_ext`` holds it with one ghost row each
side (node i is ``gap_ext[i + nx]``); spans are half-open flat node ranges [p, q).
"""

from __future__ import annotations

import numpy as np
from numba import njit

THIRD = 1.0 / 3.0


@njit(cache=True)
def _triangle(f1, f2, f3):
    """(mean of max(f, 0) over the linear triangle of vertex values f1, f2, f3, and its
    derivatives in f1, f2, f3), by the cases of the module docstring."""
    # sort descending, remembering which vertex holds which value
    a, b, c = f1, f2, f3
    ia, ib, ic = 0, 1, 2
    if a < b:
        a, b, ia, ib = b, a, ib, ia
    if b < c:
        b, c, ib, ic = c, b, ic, ib
    if a < b:
        a, b, ia, ib = b, a, ib, ia
    da = db = dc = 0.0
    mean = 0.0
    if c >= 0.0:
        mean = (a + b + c) * THIRD
        da = db = dc = THIRD
    elif a > 0.0:
        if b <= 0.0:  # the zone is a triangle at a's vertex
            ab, ac = a - b, a - c
            mean = a * a * a * THIRD / (ab * ac)
            db = mean / ab
            dc = mean / ac
            da = a * a / (ab * ac) - db - dc
        else:  # the whole triangle but one at c's vertex
            s = -c
            an, bn = a + s, b + s
            cut = s * s * s * THIRD / (an * bn)
            ja = -cut / an
            jb = -cut / bn
            js = s * s / (an * bn) + ja + jb
            mean = (a + b + c) * THIRD + cut
            da = THIRD + ja
            db = THIRD + jb
            dc = THIRD - js
    # back to the vertices' order: the vertex of index 0 holds one of a, b, c, ...
    d1 = da if ia == 0 else (db if ib == 0 else dc)
    d2 = da if ia == 1 else (db if ib == 1 else dc)
    d3 = da if ia == 2 else (db if ib == 2 else dc)
    return mean, d1, d2, d3


@njit(cache=True)
def square(f00, f10, f01, f11):
    """(S, dS/df00, dS/df10, dS/df01, dS/df11): a grid square's mean of the ramp, the mean
    of its four triangles (both diagonals), f_ab the ramp at the corner (x + a dx, y + b dy)."""
    if f00 >= 0.0 and f10 >= 0.0 and f01 >= 0.0 and f11 >= 0.0:
        return 0.25 * (f00 + f10 + f01 + f11), 0.25, 0.25, 0.25, 0.25
    # diagonal 00-11: (00, 10, 11) and (00, 11, 01); diagonal 10-01: (00, 10, 01), (10, 11, 01)
    m1, a1, b1, c1 = _triangle(f00, f10, f11)
    m2, a2, b2, c2 = _triangle(f00, f11, f01)
    m3, a3, b3, c3 = _triangle(f00, f10, f01)
    m4, a4, b4, c4 = _triangle(f10, f11, f01)
    return (
        0.25 * (m1 + m2 + m3 + m4),
        0.25 * (a1 + a2 + a3),
        0.25 * (b1 + b3 + a4),
        0.25 * (c2 + c3 + c4),
        0.25 * (c1 + b2 + b4),
    )


@njit(cache=True)
def _zone_columns(gap_ext, low, high, nx, dmax):
    """(first, last) column of the squares between the rows starting at ``low`` and ``high``
    (gap_ext offsets) that have a corner in the zone (g < dmax); (0, -1) for none. A zone
    reaching a row's end (the periodic seam) gives the whole row: (0, nx - 1)."""
    first = nx
    for c in range(nx):
        if gap_ext[low + c] < dmax or gap_ext[high + c] < dmax:
            first = c
            break
    if first == nx:
        return 0, -1
    last = first
    for c in range(nx - 1, first - 1, -1):
        if gap_ext[low + c] < dmax or gap_ext[high + c] < dmax:
            last = c
            break
    if first == 0 or last == nx - 1:
        return 0, nx - 1
    return first - 1, last  # square c joins columns c and c + 1


@njit(cache=True)
def _add(out, node, p, q, value):
    if p <= node < q:
        out[node] += value


@njit(cache=True)
def cohesive_traction(gap_ext, out, p, q, nx, dmax, sigma_a):
    """Nodal traction of the triangle-integrated Dugdale law on the nodes [p, q), into ``out``
    (stress): sigma_a times the sum of dS/df over the squares around each node.

    Every square with a corner in [p, q) and in the zone (g < dmax) is visited once and
    gives its four corners their shares; in each pair of rows only the columns between the
    first and the last such square are visited (:func:`_zone_columns`), and a square with
    all four corners in the zone gives each a quarter without evaluating its triangles.
    """
    m = gap_ext.shape[0] - 2 * nx
    for i in range(p, q):
        out[i] = 0.0
    if q <= p:
        return
    rows = m // nx
    first_row = max(p // nx - 1, -1)  # squares' lower rows, -1: the ghost row below
    last_row = min((q - 1) // nx, rows - 1)
    quarter = 0.25 * sigma_a
    for r in range(first_row, last_row + 1):
        low = (r + 1) * nx  # the square's lower row in gap_ext
        high = low + nx
        node_low = r * nx  # ... as local node indices
        node_high = node_low + nx
        start, stop = _zone_columns(gap_ext, low, high, nx, dmax)
        if start > stop:
            continue
        if p <= node_low and node_high + nx <= q and stop < nx - 1:
            # both rows in [p, q) and no square across the seam: no checks in the loop
            _row_pair(gap_ext, out, low, high, node_low, node_high, start, stop, dmax, sigma_a)
            continue
        for c in range(start, stop + 1):
            c1 = c + 1 if c + 1 < nx else 0
            g00, g10 = gap_ext[low + c], gap_ext[low + c1]
            g01, g11 = gap_ext[high + c], gap_ext[high + c1]
            if g00 < dmax and g10 < dmax and g01 < dmax and g11 < dmax:
                d00 = d10 = d01 = d11 = quarter
            elif g00 < dmax or g10 < dmax or g01 < dmax or g11 < dmax:
                _, d00, d10, d01, d11 = square(dmax - g00, dmax - g10, dmax - g01, dmax - g11)
                d00, d10, d01, d11 = sigma_a * d00, sigma_a * d10, sigma_a * d01, sigma_a * d11
            else:
                continue
            _add(out, node_low + c, p, q, d00)
            _add(out, node_low + c1, p, q, d10)
            _add(out, node_high + c, p, q, d01)
            _add(out, node_high + c1, p, q, d11)


@njit(cache=True)
def _row_pair(gap_ext, out, low, high, node_low, node_high, start, stop, dmax, sigma_a):
    """The squares [start, stop] between two rows (no seam, both rows owned) add their
    corners' shares to ``out``. A run of squares wholly in the zone gives each corner a
    quarter of sigma_a per square, added as one pass per row (the inside of a contact is
    such runs); the squares across the zone's edge are evaluated one by one."""
    quarter = 0.25 * sigma_a
    c = start
    while c <= stop:
        g00, g10 = gap_ext[low + c], gap_ext[low + c + 1]
        g01, g11 = gap_ext[high + c], gap_ext[high + c + 1]
        if g00 < dmax and g10 < dmax and g01 < dmax and g11 < dmax:
            end = c + 1  # the run of wholly inside squares [c, end)
            while end <= stop and gap_ext[low + end + 1] < dmax and gap_ext[high + end + 1] < dmax:
                end += 1
            for base in (node_low, node_high):
                out[base + c] += quarter
                for i in range(base + c + 1, base + end):
                    out[i] += 2.0 * quarter
                out[base + end] += quarter
            c = end
            continue
        if g00 < dmax or g10 < dmax or g01 < dmax or g11 < dmax:
            _, d00, d10, d01, d11 = square(dmax - g00, dmax - g10, dmax - g01, dmax - g11)
            out[node_low + c] += sigma_a * d00
            out[node_low + c + 1] += sigma_a * d10
            out[node_high + c] += sigma_a * d01
            out[node_high + c + 1] += sigma_a * d11
        c += 1


@njit(cache=True)
def cohesive_energy(gap_ext, nx, dmax):
    """Sum of S over the block's squares (those whose lower-left corner is a node of the
    block; the top row's squares reach into the ghost row above); the interface energy per
    node area is -sigma_a times it. Rows with no gap below dmax are found by scans from the
    block's two ends and not visited, and within a row only the zone's columns."""
    m = gap_ext.shape[0] - 2 * nx
    top = m + nx  # the block and the ghost row above: gap_ext[nx:top + nx]
    first = nx
    while first < top + nx and not gap_ext[first] < dmax:
        first += 1
    if first == top + nx:
        return 0.0
    last = top + nx - 1
    while not gap_ext[last] < dmax:
        last -= 1
    rows = m // nx
    first_row = max(first // nx - 2, 0)  # node row of gap_ext index k is k // nx - 1
    last_row = min(last // nx - 1, rows - 1)
    total = 0.0
    for r in range(first_row, last_row + 1):
        low = (r + 1) * nx
        high = low + nx
        start, stop = _zone_columns(gap_ext, low, high, nx, dmax)
        for c in range(start, stop + 1):
            c1 = c + 1 if c + 1 < nx else 0
            g00, g10 = gap_ext[low + c], gap_ext[low + c1]
            g01, g11 = gap_ext[high + c], gap_ext[high + c1]
            if g00 < dmax and g10 < dmax and g01 < dmax and g11 < dmax:
                total += dmax - 0.25 * (g00 + g10 + g01 + g11)
            elif g00 < dmax or g10 < dmax or g01 < dmax or g11 < dmax:
                total += square(dmax - g00, dmax - g10, dmax - g01, dmax - g11)[0]
    return total


@njit(cache=True)
def ghosts_near(gap_ext, halo, level):
    """(any ghost before the block has gap < level, any ghost after it has)."""
    before = False
    for i in range(halo):
        if gap_ext[i] < level:
            before = True
            break
    after = False
    n = gap_ext.shape[0]
    for i in range(n - halo, n):
        if gap_ext[i] < level:
            after = True
            break
    return before, after


@njit(cache=True)
def traction_on_span(gap_ext, traction, old_p, old_q, p, q, nx, dmax, sigma_a, d):
    """Zero the old traction span outside [p, q), evaluate the law on [p, q); return t.d there."""
    for i in range(old_p, min(old_q, p)):
        traction[i] = 0.0
    for i in range(max(q, old_p), old_q):
        traction[i] = 0.0
    cohesive_traction(gap_ext, traction, p, q, nx, dmax, sigma_a)
    total = 0.0
    for i in range(p, q):
        total += traction[i] * d[i]
    return total


def compile_all():
    """Compile every kernel of this module into numba's cache."""
    nx = 4
    gap_ext = np.linspace(0.0, 2.0, 4 * nx)
    out = np.zeros(2 * nx)
    cohesive_traction(gap_ext, out, 0, 2 * nx, nx, 1.0, 1.0)
    cohesive_energy(gap_ext, nx, 1.0)
    ghosts_near(gap_ext, nx, 1.0)
    traction_on_span(gap_ext, out, 0, 2 * nx, 0, 2 * nx, nx, 1.0, 1.0, out.copy())
