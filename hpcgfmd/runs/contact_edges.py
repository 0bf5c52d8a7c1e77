"""The contact edges of the last two accepted steps: the step control's edge criterion and the
solver's watch on a solve's edges read them (docs/numerics.md, "Time steps")."""

from __future__ import annotations

import math

import numpy as np

from ..solvers import EdgeWatch
from ..state import State


class ContactEdges:
    """Left and right edges of intimate contact (g <= 0) after the last accepted step and the
    one before it (length; NaN without contact; ``previous`` None before the first step).

    The edges are measured by the indenter's geometry (:meth:`Cylinder.measure`) for every
    solve; :meth:`advance` makes a step's edges the current ones once the step is done (the
    compliant drive solves a step several times).
    """

    def __init__(self):
        self.current = (math.nan, math.nan)
        self.previous = None

    def advance(self, edges):
        """The step just solved had contact edges ``edges`` (left, right)."""
        self.previous, self.current = self.current, tuple(edges)

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
        or None (no contact or no finite limit). A surface's edges are -a and a, a the
        equivalent radius of its contact (:meth:`Sphere.measure`)."""
        left, right = self.current
        if not (math.isfinite(limit) and math.isfinite(left) and math.isfinite(right)):
            return None
        return EdgeWatch(left, right, limit)

    def state(self) -> State:
        """The edges (:mod:`hpcgfmd.state`)."""
        return State(
            scalars={
                "current": np.array(self.current),
                "previous": np.array(self.previous or (math.nan, math.nan)),
                "has_previous": self.previous is not None,
            }
        )

    def restore(self, state: State):
        """Continue from :meth:`state`."""
        s = state.scalars
        self.current = tuple(float(v) for v in s["current"])
        self.previous = tuple(float(v) for v in s["previous"]) if s["has_previous"] else None
