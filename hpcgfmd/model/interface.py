"""Real-space interface physics: indenter gap, Dugdale-Maugis adhesion, contact measures.

Dugdale-Maugis law with a hard wall (docs/model.md, "Interface"; paper Eq. 4): with
sigma_a = dgamma0 / dmax the interface energy per area is

    Phi(g) = -sigma_a max(dmax - g, 0)   for g >= 0,   +infinity for g < 0.

Discretisation (docs/model.md, "Discretisation"): Phi is integrated EXACTLY over the piecewise
linear interpolant of the nodal gaps, element by element (node i to node i+1, periodic).
The nodal cohesive traction is then continuous in the gaps, which removes the O(dx)
lattice-trapping bias of the node-by-node law. With the ramp r = max(dmax - g, 0) the mean
of r over an element with end gaps g_a, g_b is

    M = (r_a^2 - r_b^2) / (2 (g_b - g_a))    (= (r_a + r_b)/2 when both ends are in the zone)

and the element energy is -sigma_a dx M. Traction on the substrate is positive upward
(attractive), as in the paper. The law is pure numpy on one rank's block of nodes (with one
ghost node each side); the contact measures are collective over the case's ranks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class DugdaleMaugis:
    """Dugdale-Maugis cohesive law.

    Parameters
    ----------
    sigma_a : float
        Adhesive (cohesive) traction, stress units; 0 disables adhesion.
    dmax : float
        Interaction range, length units.
    """

    sigma_a: float
    dmax: float

    def traction(self, gap_ext, out=None, work=None):
        """Nodal cohesive traction of the exactly integrated element law (stress units).

        t_i = -(1/dx) dE/du_i = -sigma_a (dM_{i-1}/dg_b + dM_i/dg_a): sigma_a inside the
        zone, 0 beyond it, continuous in between. Local: node i needs the gaps of nodes
        i - 1 and i + 1, so the block comes with one ghost node on each side
        (:meth:`hpcgfmd.parallel.domain.Domain.fill_halo`).

        Cost: one comparison pass over the block finds the span of nodes in the zone; the
        law is evaluated on that span (and its two neighbours each side, which a straddling
        element reaches), the rest of ``out`` is set to zero. Same values as evaluating every
        element: outside the span no element has an end in the zone.

        Parameters
        ----------
        gap_ext : ndarray, shape (m + 2,)
            Nodal gaps g >= 0 (length units) of a block of m nodes, with the node before it
            in gap_ext[0] and the node after it in gap_ext[-1].
        out : ndarray, optional
            Output buffer, shape (m,).
        work : ndarray of bool, optional
            Scratch buffer of shape (3, m + 2) reused between calls.
        """
        m = gap_ext.shape[0] - 2
        if out is None:
            out = np.empty(m)
        if self.sigma_a == 0.0 or m == 0:
            out[:] = 0.0
            return out
        if work is None:
            work = np.empty((3, m + 2), dtype=bool)
        inside_ext = work[0]
        np.less(gap_ext, self.dmax, out=inside_ext)  # node in the zone: ramp > 0
        span = true_span(inside_ext)
        if span is None:
            out[:] = 0.0
            return out
        # Nodes gap_ext[first - 1 .. last + 1] can get traction; evaluate on the extended
        # block gap_ext[a:b], whose inner nodes are out[a:b - 2].
        a, b = max(span[0] - 2, 0), min(span[1] + 3, m + 2)
        out[:a] = 0.0
        out[b - 2 :] = 0.0
        gap_ext, inside, out_all, out = gap_ext[a:b], inside_ext[a:b], out, out[a : b - 2]
        m = b - a - 2
        both, straddle = work[1][: m + 2], work[2][: m + 2]
        # Element j joins gap_ext[j] and gap_ext[j + 1]; node i (gap_ext[i + 1]) gets the
        # elements i and i + 1. Elements with both ends inside (trapezoid rule) give
        # sigma_a / 2 to each end.
        np.logical_and(inside[:-1], inside[1:], out=both[:-1])
        np.add(both[1:-1], both[:-2], out=out, dtype=np.float64)  # bool + bool would be OR
        out *= 0.5 * self.sigma_a
        # Elements with one end in the zone and the other beyond dmax: exact formula,
        # t_a = -sigma_a dM/dg_a, t_b = -sigma_a dM/dg_b with M = (r_a^2 - r_b^2) / (2 dg).
        np.not_equal(inside[:-1], inside[1:], out=straddle[:-1])
        element = np.flatnonzero(straddle[:-1])
        if element.size:
            ga, gb = gap_ext[element], gap_ext[element + 1]
            ra, rb = np.maximum(self.dmax - ga, 0.0), np.maximum(self.dmax - gb, 0.0)
            dg = gb - ga  # nonzero: one gap < dmax <= the other
            mean = (ra * ra - rb * rb) / (2.0 * dg)
            left = element >= 1  # the element's left node is in the block (not the ghost)
            np.add.at(out, element[left] - 1, (-self.sigma_a * (mean - ra) / dg)[left])
            right = element < m  # its right node is in the block
            np.add.at(out, element[right], (-self.sigma_a * (rb - mean) / dg)[right])
        return out_all

    def energy(self, gap_ext, dx):
        """Interface energy of the block's elements, sum_e -sigma_a dx M_e (energy/length).

        The block owns the elements from each of its nodes to the next one, so summing over
        the blocks counts every element once; ``gap_ext`` as in :meth:`traction`. Only the
        elements with an end in the zone are evaluated (the others have M = 0).
        """
        if self.sigma_a == 0.0 or gap_ext.shape[0] <= 2:
            return 0.0
        gaps = gap_ext[1:]  # the block's nodes and the one after: element i joins i, i + 1
        span = true_span(gaps < self.dmax)
        if span is None:
            return -self.sigma_a * dx * 0.0
        first, last = max(span[0] - 1, 0), min(span[1], gaps.shape[0] - 2)  # elements
        gaps = gaps[first : last + 2]
        ramp_ext = np.maximum(self.dmax - gaps, 0.0)
        ramp, ramp_next = ramp_ext[:-1], ramp_ext[1:]
        dg = np.diff(gaps)
        straddle = (ramp > 0.0) != (ramp_next > 0.0)
        mean = 0.5 * (ramp + ramp_next)
        mean[straddle] = (ramp[straddle] ** 2 - ramp_next[straddle] ** 2) / (2.0 * dg[straddle])
        return -self.sigma_a * dx * float(mean.sum())


def true_span(mask):
    """(first, last) index of the True entries of a 1-D bool array, or None if there is none.

    Fast (a few microseconds at 2^17 entries, no allocation) when the True entries form one
    run, as the cohesive zone and the contact of one indenter do; otherwise one
    ``flatnonzero``.
    """
    if mask.size == 0:
        return None
    first = int(mask.argmax())  # stops at the first True
    if not mask[first]:
        return None
    last = first + int(np.count_nonzero(mask)) - 1
    if mask[first : last + 1].all():
        return first, last
    where = np.flatnonzero(mask)
    return int(where[0]), int(where[-1])


def edge_positions(domain, gap, level, shape_exponent):
    """Collective: left and right positions where the gap first exceeds ``level``.

    The region is the span from the first to the last node (global index) with
    g <= level. For shape_exponent p != 1 the gap beyond the edge is modelled as
    g - level ~ (x - a)^p from the first two open nodes (docs/model.md, "Discretisation":
    p = 3/2 for the edge of intimate contact); p = 1 interpolates linearly between the last
    closed and the first open node (the cohesive-zone edge, where g crosses dmax with a
    finite slope).

    Parameters
    ----------
    domain : hpcgfmd.parallel.domain.Domain
        This rank's block and the collectives.
    gap : ndarray, shape (local_n,)
        Nodal gaps of this rank's block (length units).
    level : float
        Gap level that defines the region (0 for contact, dmax for the cohesive zone).
    shape_exponent : float
        Exponent of the gap profile beyond the edge.

    Returns
    -------
    (left, right) : tuple of float
        Edge positions (length units); (nan, nan) when no node has gap <= level.
    """
    extent = domain.index_extent(gap <= level)
    if extent is None:
        return np.nan, np.nan
    first, last = extent
    n, dx = domain.n, domain.dx
    if last - first + 1 == n:  # the whole cell is closed
        return domain.position(0) - 0.5 * dx, domain.position(n - 1) + 0.5 * dx
    # the three nodes from each end outward: last, last+1, last+2 and first, first-1, first-2
    right_nodes = domain.segment(gap, last, 3)
    left_nodes = domain.segment(gap, first - 2, 3)[::-1]

    def offset(g_in, g1, g2):
        # distance (in dx) from the last closed node to the edge
        if shape_exponent == 1.0:  # linear interpolation between the closed and open node
            return (level - g_in) / (g1 - g_in) if g1 > g_in else 0.5
        # (g - level)^(1/p) is linear beyond the edge: extrapolate from the two open nodes
        s1 = (g1 - level) ** (1.0 / shape_exponent)
        s2 = (g2 - level) ** (1.0 / shape_exponent)
        return 1.0 - min(max(s1 / (s2 - s1), 0.0), 1.0) if s2 > s1 else 0.5

    right = domain.position(last) + dx * offset(*right_nodes)
    left = domain.position(first) - dx * offset(*left_nodes)
    return left, right
