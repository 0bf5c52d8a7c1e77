"""Compiled loops of a CG iteration: each fuses the elementwise work between two reductions.

The CG iteration (:mod:`.solver`) alternates elementwise work on this rank's block with
global reductions and transforms. Each kernel here does the whole stretch of elementwise work
between two of them in one loop (numba, compiled once per machine and cached next to this
file), so an iteration makes a dozen calls instead of hundreds of numpy calls. The kernels
are local (no MPI). Sums may be reassociated (``FAST``: LLVM vectorises them, as numpy's
own SIMD sums do), which makes them depend on the machine's vector width but not on the
run: the same block gives the same bits every time. Maxima and minima, and the first and
last node below a level, are integer extremes (:mod:`.extremes`), which vectorise where
floating ones do not; the extreme of a set does not depend on the order. Loops over a whole
block are split into branch-free segments around the contact span, and loops over a span
index its slice from 0, so that they vectorise.

Index conventions: a block of m nodes; ``gap_ext`` holds its gaps with one ghost node each
side (node i is ``gap_ext[i + 1]``); spans are half-open node ranges [lo, hi).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..model import history_kernels
from ..parallel import fft_kernels
from . import extremes, step_kernels, verlet_kernels
from .extremes import KEY_INF, KEY_NEG_INF, bits, key_extremes, low_key, low_scan, max_min, value
from .step_kernels import FAST

CHUNK = 4096  # nodes per chunk of a pass that reads its output again (it stays in the L2 cache)


@njit(cache=True)
def _element(ga, gb, dmax, sigma_a):
    """Tractions on the two ends of a straddling element (one end in the zone, one beyond).

    With the ramp r = max(dmax - g, 0) and M = (r_a^2 - r_b^2) / (2 (g_b - g_a)), the mean of
    r over the element, t_a = -sigma_a dM/dg_a and t_b = -sigma_a dM/dg_b.
    """
    ra = max(dmax - ga, 0.0)
    rb = max(dmax - gb, 0.0)
    dg = gb - ga
    mean = (ra * ra - rb * rb) / (2.0 * dg)
    return -sigma_a * (mean - ra) / dg, -sigma_a * (rb - mean) / dg


@njit(cache=True)
def cohesive_traction(gap_ext, out, p, q, dmax, sigma_a):
    """Nodal traction of the element-integrated Dugdale law on nodes [p, q), into ``out``.

    Element j joins ``gap_ext[j]`` and ``gap_ext[j + 1]``; node i gets half of sigma_a from
    each element with both ends in the zone (g < dmax) and the exact share of each straddling
    element (docs/model.md, (M35)); elements beyond the zone give nothing.
    """
    half = 0.5 * sigma_a
    for i in range(p, q):
        g0, g1, g2 = gap_ext[i], gap_ext[i + 1], gap_ext[i + 2]
        in0, in1, in2 = g0 < dmax, g1 < dmax, g2 < dmax
        both = (1.0 if (in0 and in1) else 0.0) + (1.0 if (in1 and in2) else 0.0)
        t = both * half
        if in1 != in2:  # element i: node i is its left end
            t += _element(g1, g2, dmax, sigma_a)[0]
        if in0 != in1:  # element i - 1: node i is its right end
            t += _element(g0, g1, dmax, sigma_a)[1]
        out[i] = t


@njit(cache=True)
def cohesive_energy(gap_ext, dmax):
    """Sum of M_e over the block's elements, M_e the mean of the ramp max(dmax - g, 0) over
    element e of the piecewise-linear gap (docs/model.md, (M35)); the interface energy is
    -sigma_a dx times it (:meth:`hpcgfmd.model.interface.DugdaleMaugis.energy`, same terms).

    Element e joins ``gap_ext[e + 1]`` and ``gap_ext[e + 2]``: the block owns the elements
    from each of its nodes to the next one (the last to the right ghost). Only elements with
    an end in the zone (g < dmax) contribute; two scans from the block's ends find them and
    stop there, so the nodes beyond the zone are compared once and nothing is allocated.
    """
    n = gap_ext.shape[0] - 1  # the block's nodes and the right ghost
    first = 0
    while first < n and not gap_ext[first + 1] < dmax:
        first += 1
    if first == n:
        return 0.0
    last = n - 1
    while not gap_ext[last + 1] < dmax:
        last -= 1
    total = 0.0
    for e in range(max(first - 1, 0), min(last, n - 2) + 1):
        ga, gb = gap_ext[e + 1], gap_ext[e + 2]
        ra = max(dmax - ga, 0.0)
        rb = max(dmax - gb, 0.0)
        if (ra > 0.0) != (rb > 0.0):  # straddling: the exact mean of the cut ramp
            total += (ra * ra - rb * rb) / (2.0 * (gb - ga))
        else:
            total += 0.5 * (ra + rb)
    return total


@njit(cache=True)
def contact_reaction(gap, lo, hi, k_u, history, mean, out):
    """out = k_u + history + mean on the nodes of [lo, hi) on the wall (gap <= 0): the
    reaction that balances the substrate there."""
    for i in range(lo, hi):
        if gap[i] <= 0.0:
            out[i] = k_u[i] + history[i] + mean


@njit(cache=True)
def _shifted_scan(base, d, length, out, level):
    """out = base - length d; (first, last, smallest) of out as :func:`.extremes.low_scan`
    gives them, in the same vectorised pass."""
    m = base.shape[0]
    first, last, lk = m, -1, KEY_INF
    for i in range(m):
        g = base[i] - length * d[i]
        out[i] = g
        near = g < level
        first = min(first, i if near else m)
        last = max(last, i if near else -1)
        lk = min(lk, low_key(bits(g)))
    return first, last, value(lk)


@njit(cache=True)
def shifted_gaps(base, d, length, out, level):
    """out = base - length d over the block (the gaps of u + length d, base = wall - u).

    Returns (first, last, smallest): the first and last node with a gap below ``level``
    (m, -1 when none) and the smallest gap of the block (+inf when empty).
    """
    return _shifted_scan(base, d, length, out, level)


@njit(cache=True)
def shifted_window(base, d, length, out, level, w0, w1):
    """:func:`shifted_gaps` on the window [w0, w1) and the block's two end nodes only.

    Valid when no node outside the window can come below ``level`` at this length (the
    caller's bound :func:`entry_bound`); the ends feed the ghost exchange.
    """
    m = base.shape[0]
    first, last, smallest = m, -1, np.inf
    if w1 > w0:
        f, la, smallest = _shifted_scan(base[w0:w1], d[w0:w1], length, out[w0:w1], level)
        if la >= 0:
            first, last = w0 + f, w0 + la
    if m:
        out[0] = base[0] - length * d[0]
        out[m - 1] = base[m - 1] - length * d[m - 1]
    return first, last, smallest


@njit(cache=True, inline="always")
def _exact_entry(d, gap, first, last, level, entry):
    """min(entry, keys of (gap - level) / d over the nodes [first, last) with d > 0)."""
    if last > first:
        ds, gs = d[first:last], gap[first:last]
        for i in range(ds.shape[0]):
            length = (gs[i] - level) / ds[i] if ds[i] > 0.0 else np.inf
            entry = min(entry, low_key(bits(length)))
    return entry


@njit(cache=True, inline="always")
def _entry_pieces(d, gap, c, e, lo, hi, a, b, level, rise, room, entry):
    """The parts of :func:`entry_bound` on the nodes [c, e), as keys: the far nodes' largest
    d and smallest gap ([0, a) and [b, m)), the exact entry lengths of the nodes within the
    margin ([a, lo) and [hi, b))."""
    rise, room = key_extremes(d, gap, c, min(e, a), rise, room)
    rise, room = key_extremes(d, gap, max(c, b), e, rise, room)
    entry = _exact_entry(d, gap, max(c, a), min(e, lo), level, entry)
    return rise, room, _exact_entry(d, gap, max(c, hi), min(e, b), level, entry)


@njit(cache=True, inline="always")
def _entry_length(rise, room, entry, level):
    """The bound of :func:`entry_bound` from its parts' keys."""
    rise, room = value(rise), value(room)
    far = (room - level) / rise if rise > 0.0 else np.inf
    return min(far, value(entry))


@njit(cache=True)
def entry_bound(d, gap, lo, hi, level, margin):
    """A length below which no node outside [lo, hi) comes below ``level`` along d.

    Nodes within ``margin`` of the span (where the zone grows) contribute their exact entry
    length (gap - level) / d; farther nodes the bound min(gap - level) / max(d), which is
    below each of their own entry lengths. +inf when nothing can enter.
    """
    m = d.shape[0]
    a, b = max(lo - margin, 0), min(hi + margin, m)
    rise, room, entry = _entry_pieces(d, gap, 0, m, lo, hi, a, b, level, 0, KEY_INF, KEY_INF)
    return _entry_length(rise, room, entry, level)


@njit(cache=True)
def axpy_entry(y, x, s, gap, lo, hi, level, margin):
    """y += s x (the direction update), and the :func:`entry_bound` of the new y, in one pass
    (chunk by chunk: each chunk's y is read again from the cache)."""
    m = y.shape[0]
    a, b = max(lo - margin, 0), min(hi + margin, m)
    rise, room, entry = 0, KEY_INF, KEY_INF
    for c in range(0, m, CHUNK):
        e = min(c + CHUNK, m)
        yc, xc = y[c:e], x[c:e]
        for i in range(yc.shape[0]):
            yc[i] += s * xc[i]
        rise, room, entry = _entry_pieces(y, gap, c, e, lo, hi, a, b, level, rise, room, entry)
    return _entry_length(rise, room, entry, level)


@njit(cache=True, fastmath=FAST)
def update_and_residual(u, d, load, kd, gap, length, traction, p, q, lo, hi, r):
    """The accepted step and the next residual in one pass: u += length d, load += length kd,
    gap -= length d, then r as :func:`residual` (same returns), chunk by chunk."""
    m = u.shape[0]
    total = 0.0
    high, low = KEY_NEG_INF, KEY_INF
    for c in range(0, m, CHUNK):
        e = min(c + CHUNK, m)
        uc, dc, gc, lc, kc, rc = u[c:e], d[c:e], gap[c:e], load[c:e], kd[c:e], r[c:e]
        for i in range(uc.shape[0]):
            uc[i] += length * dc[i]
            gc[i] = gc[i] - length * dc[i]
            v = lc[i] + length * kc[i]
            lc[i] = v
            rc[i] = -v
            total -= v
        total = _add_span(r, traction, max(c, p), min(e, q), total)
        high, low = key_extremes(r, r, c, min(e, lo), high, low)
        high, low = key_extremes(r, r, max(c, hi), e, high, low)
    return total, value(high), value(low)


@njit(cache=True, fastmath=FAST, inline="always")
def _add_span(r, traction, first, last, total):
    """r += traction on [first, last); returns total plus the traction's sum there."""
    if last > first:
        rs, ts = r[first:last], traction[first:last]
        for i in range(rs.shape[0]):
            rs[i] += ts[i]
            total += ts[i]
    return total


@njit(cache=True, fastmath=FAST)
def start_point(u, wall, k_u, linear, load, gap, r, level):
    """The start of a solve in one pass: load = k_u + linear, r = -load (the residual
    before the cohesive traction, :func:`residual_span` adds it), gap = wall - u; returns
    (the sum of r, (first, last, smallest) of the gaps as :func:`near`)."""
    m = u.shape[0]
    total = 0.0
    first, last, lk = m, -1, KEY_INF
    for i in range(m):
        v = k_u[i] + linear[i]
        load[i] = v
        r[i] = -v
        total -= v
        g = wall[i] - u[i]
        gap[i] = g
        near = g < level
        first = min(first, i if near else m)
        last = max(last, i if near else -1)
        lk = min(lk, low_key(bits(g)))
    return total, (first, last, value(lk))


@njit(cache=True, fastmath=FAST)
def residual_span(r, traction, p, q, lo, hi, total):
    """r += traction on [p, q) (zero elsewhere); returns (total plus its sum there, max and
    min of r outside [lo, hi)) as :func:`residual`."""
    total = _add_span(r, traction, p, q, total)
    high, low = _extremes(r, lo, hi)
    return total, high, low


@njit(cache=True)
def near(gap, level):
    """(first, last, smallest) of :func:`shifted_gaps` for gaps already in place."""
    return low_scan(gap, level)


@njit(cache=True)
def spans(first, last, m, ghost_left_near, ghost_right_near):
    """(lo, hi, p, q): the near span of a point and the span its traction can reach.

    [lo, hi) holds every node with gap < level (the ghosts, when near, stretch it to the
    block's ends); [p, q) one node more each side, which a straddling element reaches.
    """
    if ghost_left_near:
        first = -1
    if ghost_right_near:
        last = m
    if first > last:  # nothing near, no ghost near
        return 0, 0, 0, 0
    return (max(first, 0), min(last + 1, m), max(first - 1, 0), min(last + 2, m))


@njit(cache=True)
def traction_on_span(gap_ext, traction, old_p, old_q, p, q, dmax, sigma_a, d):
    """Zero the old traction span outside [p, q), evaluate the law on [p, q); return t.d there."""
    for i in range(old_p, min(old_q, p)):
        traction[i] = 0.0
    for i in range(max(q, old_p), old_q):
        traction[i] = 0.0
    cohesive_traction(gap_ext, traction, p, q, dmax, sigma_a)
    total = 0.0
    for i in range(p, q):
        total += traction[i] * d[i]
    return total


@njit(cache=True)
def span_dot(a, b, p, q):
    """sum a[p:q] b[p:q]."""
    total = 0.0
    for i in range(p, q):
        total += a[i] * b[i]
    return total


@njit(cache=True)
def _extremes(r, lo, hi):
    """max and min of r outside [lo, hi) (-inf, +inf when that is empty)."""
    high, low = max_min(r, r, 0, lo, -np.inf, np.inf)
    return max_min(r, r, hi, r.shape[0], high, low)


@njit(cache=True, fastmath=FAST)
def residual(load, traction, p, q, lo, hi, r):
    """r = traction - load (traction zero outside [p, q)).

    Returns (sum of r, max and min of r outside the near span [lo, hi)) (-inf/+inf when
    that is empty): the span's extremes follow once the pressed nodes are set to mu.
    """
    total = 0.0
    for i in range(r.shape[0]):
        v = -load[i]
        r[i] = v
        total += v
    for i in range(p, q):
        r[i] += traction[i]
        total += traction[i]
    high, low = _extremes(r, lo, hi)
    return total, high, low


@njit(cache=True)
def on_wall(gap, lo, hi, tolerance, on):
    """on[k] = gap[lo + k] <= tolerance on the near span; returns (the count, the first and
    the last node on the wall; hi and lo - 1 when none)."""
    g = gap[lo:hi]
    m = g.shape[0]
    count, first, last = 0, m, -1
    for k in range(m):
        flag = g[k] <= tolerance
        on[k] = flag
        count += flag
        first = min(first, k if flag else m)
        last = max(last, k if flag else -1)
    return count, lo + first, lo + last


@njit(cache=True)
def press(r, lo, hi, on, mu, pressed):
    """pressed = on and r > mu on the near span; returns (sum of r over pressed, count)."""
    span = r[lo:hi]
    total, count = 0.0, 0
    for k in range(span.shape[0]):
        flag = on[k] and span[k] > mu
        pressed[k] = flag
        if flag:
            total += span[k]
            count += 1
    return total, count


@njit(cache=True)
def settle(r, lo, hi, pressed, before, mu):
    """Set r = mu on the pressed nodes; returns (max, min of r on the span, any node joined
    the pressed set since ``before``, the last iteration's set on the span)."""
    span, was = r[lo:hi], before[lo:hi]
    joined = False
    for k in range(span.shape[0]):
        if pressed[k]:
            span[k] = mu
            joined |= not was[k]
    high, low = max_min(span, span, 0, span.shape[0], -np.inf, np.inf)
    return high, low, joined


@njit(cache=True)
def masked_sum(a, lo, hi, mask):
    """sum of a[lo + k] where mask[k], k < hi - lo."""
    span = a[lo:hi]
    total = 0.0
    for k in range(span.shape[0]):
        if mask[k]:
            total += span[k]
    return total


@njit(cache=True)
def pushed(d, lo, hi, on, out):
    """out = on and d > 0 on the near span (on-wall nodes the direction pushes into the
    wall); returns their count."""
    span = d[lo:hi]
    count = 0
    for k in range(span.shape[0]):
        flag = on[k] and span[k] > 0.0
        out[k] = flag
        count += flag
    return count


@njit(cache=True, fastmath=FAST)
def project_direction(z, shift, lo, hi, pressed, r, r_old, d_old, restart, gap, level, margin):
    """z -= shift, z = 0 on the pressed nodes (mask ``pressed`` of [lo, hi)), and the
    Polak-Ribiere dots in the same pass, chunk by chunk: returns (r.z, r_old.z, r.d_old,
    +inf); when ``restart`` (z is the direction) (r.z, 0, 0, the :func:`entry_bound` of z
    with ``gap``, ``level`` and ``margin``)."""
    m = z.shape[0]
    a, b = max(lo - margin, 0), min(hi + margin, m)
    rz, r_old_z, r_d = 0.0, 0.0, 0.0
    rise, room, entry = 0, KEY_INF, KEY_INF
    for c in range(0, m, CHUNK):
        e = min(c + CHUNK, m)
        zc, rc = z[c:e], r[c:e]
        for i in range(zc.shape[0]):
            zc[i] -= shift
        first, last = max(c, lo), min(e, hi)
        if last > first:
            zs, ps = z[first:last], pressed[first - lo : last - lo]
            for k in range(zs.shape[0]):
                if ps[k]:
                    zs[k] = 0.0
        if restart:
            for i in range(zc.shape[0]):
                rz += rc[i] * zc[i]
            rise, room, entry = _entry_pieces(z, gap, c, e, lo, hi, a, b, level, rise, room, entry)
        else:
            oc, dc = r_old[c:e], d_old[c:e]
            for i in range(zc.shape[0]):
                rz += rc[i] * zc[i]
                r_old_z += oc[i] * zc[i]
                r_d += rc[i] * dc[i]
    return rz, r_old_z, r_d, (_entry_length(rise, room, entry, level) if restart else np.inf)


@njit(cache=True, fastmath=FAST)
def dot(a, b):
    """a.b, summed in order."""
    total = 0.0
    for i in range(a.shape[0]):
        total += a[i] * b[i]
    return total


def compile_all():
    """Compile every kernel for this machine into numba's cache (scripts/setup.sh calls it),
    those of the per-step work (:mod:`hpcgfmd.solvers.step_kernels`), of the transforms
    (:mod:`hpcgfmd.parallel.fft_kernels`) and of the SLS history
    (:mod:`hpcgfmd.model.history_kernels`) too."""
    step_kernels.compile_all()
    extremes.compile_all()
    verlet_kernels.compile_all()
    fft_kernels.compile_all()
    history_kernels.compile_all()
    m = 8
    gap_ext = np.linspace(0.0, 2.0, m + 2)
    a, b, c, d = (np.linspace(-1.0, 1.0, m) for _ in range(4))
    flags, flags2 = np.zeros(m, dtype=np.bool_), np.zeros(m, dtype=np.bool_)
    cohesive_traction(gap_ext, a, 0, m, 1.0, 1.0)
    cohesive_energy(gap_ext, 1.0)
    contact_reaction(a, 0, m, b, c, 0.1, d)
    first, last, smallest = shifted_gaps(b, c, 0.5, a, 1.0)
    shifted_window(b, c, 0.5, a, 1.0, 2, 6)
    entry_bound(a, c, 2, 6, 1.0, 1)
    axpy_entry(a.copy(), b, 0.5, c, 2, 6, 1.0, 1)
    update_and_residual(a, b, c, d, gap_ext[1:-1], 0.5, a, 0, m, 1, m - 1, b)
    near(a, 1.0)
    start_point(a, b, c, d, a.copy(), b.copy(), c.copy(), 1.0)
    residual_span(a.copy(), b, 1, 7, 2, 6, 0.0)
    spans(first, last, m, True, False)
    traction_on_span(gap_ext, a, 0, m, 1, m - 1, 1.0, 1.0, b)
    span_dot(a, b, 0, m)
    residual(a, b, 0, m, 1, m - 1, c)
    on_wall(a, 0, m, 0.0, flags)
    press(a, 0, m, flags, 0.0, flags2)
    settle(a, 0, m, flags2, flags, 0.0)
    masked_sum(a, 0, m, flags)
    pushed(a, 0, m, flags, flags2)
    project_direction(a, 0.1, 0, m, flags, b, c, d, False, c, 1.0, 2)
    project_direction(a, 0.1, 0, m, flags, b, c, d, True, c, 1.0, 2)
    dot(a, b)
