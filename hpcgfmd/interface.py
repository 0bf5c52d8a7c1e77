"""Real-space interface physics: indenter gap, Dugdale-Maugis adhesion, contact measures.

Dugdale-Maugis law with a hard wall (physics.md, "Interface"; paper Eq. 4): with
sigma_a = dgamma0 / dmax the interface energy per area is

    Phi(g) = -sigma_a max(dmax - g, 0)   for g >= 0,   +infinity for g < 0.

Discretisation (physics.md, numerical notes): Phi is integrated EXACTLY over the piecewise
linear interpolant of the nodal gaps, element by element (node i to node i+1, periodic).
The nodal cohesive traction is then continuous in the gaps, which removes the O(dx)
lattice-trapping bias of the node-by-node law. With the ramp r = max(dmax - g, 0) the mean
of r over an element with end gaps g_a, g_b is

    M = (r_a^2 - r_b^2) / (2 (g_b - g_a))    (= (r_a + r_b)/2 when both ends are in the zone)

and the element energy is -sigma_a dx M. Traction on the substrate is positive upward
(attractive), as in the paper. Pure numpy on full real-space arrays; no MPI.
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

    def traction(self, gap, out=None, work=None):
        """Nodal cohesive traction of the exactly integrated element law (stress units).

        t_i = -(1/dx) dE/du_i = -sigma_a (dM_{i-1}/dg_b + dM_i/dg_a): sigma_a inside the
        zone, 0 beyond it, continuous in between.

        Parameters
        ----------
        gap : ndarray, shape (n,)
            Nodal gaps g >= 0 (length units), periodic.
        out : ndarray, optional
            Output buffer, shape (n,).
        work : ndarray of bool, optional
            Scratch buffer of shape (3, n) reused between calls.
        """
        n = gap.shape[0]
        if out is None:
            out = np.empty(n)
        if self.sigma_a == 0.0:
            out[:] = 0.0
            return out
        if work is None:
            work = np.empty((3, n), dtype=bool)
        inside, both, straddle = work
        np.less(gap, self.dmax, out=inside)  # node in the zone: ramp > 0
        # Elements with both ends inside (trapezoid rule) give sigma_a / 2 to each end.
        np.logical_and(inside[:-1], inside[1:], out=both[:-1])
        both[-1] = inside[-1] and inside[0]
        np.add(both[1:], both[:-1], out=out[1:], dtype=np.float64)  # bool + bool would be OR
        out[0] = float(both[0]) + float(both[-1])
        out *= 0.5 * self.sigma_a
        # Elements with one end in the zone and the other beyond dmax: exact formula,
        # t_a = -sigma_a dM/dg_a, t_b = -sigma_a dM/dg_b with M = (r_a^2 - r_b^2) / (2 dg).
        np.not_equal(inside[:-1], inside[1:], out=straddle[:-1])
        straddle[-1] = inside[-1] != inside[0]
        first = np.flatnonzero(straddle)
        if first.size:
            second = (first + 1) % n
            ga, gb = gap[first], gap[second]
            ra, rb = np.maximum(self.dmax - ga, 0.0), np.maximum(self.dmax - gb, 0.0)
            dg = gb - ga  # nonzero: one gap < dmax <= the other
            mean = (ra * ra - rb * rb) / (2.0 * dg)
            np.add.at(out, first, -self.sigma_a * (mean - ra) / dg)
            np.add.at(out, second, -self.sigma_a * (rb - mean) / dg)
        return out

    def energy(self, gap, dx):
        """Interface energy per unit length of the cylinder, sum_e -sigma_a dx M_e (energy/length)."""
        if self.sigma_a == 0.0:
            return 0.0
        ramp = np.maximum(self.dmax - gap, 0.0)
        ramp_next = np.roll(ramp, -1)
        dg = np.roll(gap, -1) - gap
        straddle = (ramp > 0.0) != (ramp_next > 0.0)
        mean = 0.5 * (ramp + ramp_next)
        mean[straddle] = ((ramp[straddle] ** 2 - ramp_next[straddle] ** 2)
                          / (2.0 * dg[straddle]))
        return -self.sigma_a * dx * float(mean.sum())


def edge_positions(x, gap, level, shape_exponent):
    """Left and right positions where the gap first exceeds ``level`` around the centre.

    For shape_exponent p != 1 the gap beyond the edge is modelled as g - level ~ (x - a)^p
    from the first two open nodes (physics.md, "The contact edge": p = 3/2 for the edge of
    intimate contact); p = 1 interpolates linearly between the last closed and the first
    open node (the cohesive-zone edge, where g crosses dmax with a finite slope).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Node positions, increasing, centred on the indenter axis.
    gap : ndarray, shape (n,)
        Nodal gaps.
    level : float
        Gap level that defines the region (0 for contact, dmax for the cohesive zone).
    shape_exponent : float
        Exponent of the gap profile beyond the edge.

    Returns
    -------
    (left, right) : tuple of float
        Edge positions; (nan, nan) when no node has gap <= level.
    """
    closed = np.flatnonzero(gap <= level)
    if closed.size == 0:
        return np.nan, np.nan
    n = x.shape[0]
    dx = x[1] - x[0]
    first, last = closed[0], closed[-1]
    if last - first + 1 == n:  # the whole cell is closed
        return x[0] - 0.5 * dx, x[-1] + 0.5 * dx

    def offset(g_in, g1, g2):
        # distance (in dx) from the last closed node to the edge
        if shape_exponent == 1.0:  # linear interpolation between the closed and open node
            return (level - g_in) / (g1 - g_in) if g1 > g_in else 0.5
        # (g - level)^(1/p) is linear beyond the edge: extrapolate from the two open nodes
        s1 = (g1 - level) ** (1.0 / shape_exponent)
        s2 = (g2 - level) ** (1.0 / shape_exponent)
        return 1.0 - min(max(s1 / (s2 - s1), 0.0), 1.0) if s2 > s1 else 0.5

    right = x[last] + dx * offset(gap[last], gap[(last + 1) % n], gap[(last + 2) % n])
    left = x[first] - dx * offset(gap[first], gap[first - 1], gap[first - 2])
    return left, right
