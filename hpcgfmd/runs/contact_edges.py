"""The contact edges of the last two steps: the step control's edge criterion and the
solver's watch on a solve's edges read them (docs/numerics.md, "Time steps")."""
from __future__ import annotations

import math

import numpy as np

from ..model.interface import edge_positions
from ..solvers import EdgeWatch


class ContactEdges:
    """Left and right edges of intimate contact (g <= 0) after the last step and the one
    before it (length; NaN without contact; ``previous`` None before the first step).

    The edge positions are extrapolated with the (x - a)^(3/2) gap profile of an intimate
    contact edge, the cohesive zone's with a linear one (docs/model.md, "Discretisation").
    """

    def __init__(self):
        self.current = (math.nan, math.nan)
        self.previous = None

    def record(self, domain, gap, dmax):
        """Collective: make the edges of ``gap`` (this rank's block) the current ones.

        Returns
        -------
        (float, float)
            The contact and cohesive-zone half-widths (0 without contact or zone).
        """
        left, right = edge_positions(domain, gap, 0.0, 1.5)
        self.previous, self.current = self.current, (left, right)
        zone_left, zone_right = edge_positions(domain, gap, dmax, 1.0)
        return (0.5 * (right - left) if left == left else 0.0,
                0.5 * (zone_right - zone_left) if zone_left == zone_left else 0.0)

    def motion(self):
        """Largest edge displacement of the last step; inf if the contact (dis)appeared,
        NaN when there is nothing to compare."""
        if self.previous is None:
            return math.nan
        before = np.isfinite(self.previous)
        after = np.isfinite(self.current)
        if not before.any() and not after.any():
            return math.nan
        if not (before.all() and after.all()):
            return math.inf
        return float(np.max(np.abs(np.subtract(self.current, self.previous))))

    def watch(self, limit):
        """The solver's watch on a solve's edges (at most ``limit`` from the current ones),
        or None (no contact, or no finite limit)."""
        left, right = self.current
        if not (math.isfinite(limit) and math.isfinite(left) and math.isfinite(right)):
            return None
        return EdgeWatch(left, right, limit)

    def attrs(self):
        """The checkpoint's scalars."""
        return dict(edges=np.array(self.current),
                    edges_previous=np.array(self.previous or (math.nan, math.nan)),
                    has_edges_previous=self.previous is not None)

    def restore(self, attrs):
        """Continue from :meth:`attrs`."""
        self.current = tuple(float(v) for v in attrs["edges"])
        self.previous = (tuple(float(v) for v in attrs["edges_previous"])
                         if attrs["has_edges_previous"] else None)
