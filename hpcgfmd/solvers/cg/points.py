"""Points along a CG line: the gaps of a displacement, its cohesive traction and its spans.

Everything about the wall and the cohesive law is confined to the span of nodes with
gap < level (level = dmax with adhesion: the contact and its cohesive zone, a few % of the
cell), so a point is evaluated on that span only.
"""
from __future__ import annotations

import numpy as np

from ...model.interface import true_span


class Point:
    """Gaps of one displacement (a ghost node each side), its cohesive traction and spans.

    Attributes
    ----------
    gap_ext : ndarray, shape (m + 2,)
        Gaps of this rank's m nodes with the neighbours' ghost nodes (length).
    gap : ndarray, shape (m,)
        The view of this rank's gaps.
    traction : ndarray, shape (m,)
        Cohesive traction (stress), zero outside ``traction_span``.
    traction_span : (int, int)
        Node range [p, q) outside which ``traction`` is zero.
    near : (int, int)
        Node range [lo, hi) holding every node with gap < level: the zone of interaction,
        which contains every node on or below the wall.
    ready : bool
        ``traction``, ``traction_span`` and ``near`` match ``gap``.
    """

    __slots__ = ("gap_ext", "gap", "traction", "traction_span", "near", "ready")

    def __init__(self, n):
        self.gap_ext = np.zeros(n + 2)
        self.gap = self.gap_ext[1:-1]
        self.traction = np.zeros(n)
        self.traction_span = (0, 0)
        self.near = (0, 0)
        self.ready = False


class PointEvaluator:
    """Spans and cohesive traction of points on this rank's block (one ghost exchange each).

    Parameters
    ----------
    domain : hpcgfmd.parallel.domain.Domain
    law : hpcgfmd.model.interface.DugdaleMaugis
    """

    def __init__(self, domain, law):
        self.domain = domain
        self.law = law
        n = domain.local_n
        self._n = n
        self._near = np.empty(n + 2, dtype=bool)
        self._work = np.empty((3, n + 2), dtype=bool)
        self.level = 0.0  # gap below which a node interacts (set per solve)

    def evaluate(self, point):
        """Collective (one ghost exchange): spans and cohesive traction of ``point.gap``.

        One comparison pass finds the node range ``near`` holding every node with
        gap < level; the law is evaluated on that range and one node more each side (a
        straddling element reaches them), the ghosts included, and the rest of the traction
        buffer is zeroed where it was not zero. Returns this rank's smallest gap on ``near``
        (+inf if empty): negative when the point is beyond the wall.
        """
        m = self._n
        self.domain.fill_halo(point.gap_ext)
        near = self._near
        np.less(point.gap_ext, self.level, out=near)
        span = true_span(near) if m else None
        if span is None:
            lo = hi = p = q = 0
        else:  # near[e] is node e - 1
            lo, hi = max(span[0] - 1, 0), min(span[1], m)
            p, q = max(span[0] - 2, 0), min(span[1] + 1, m)
        point.near = (lo, hi)
        if self.law.sigma_a > 0.0:
            t = point.traction
            po, qo = point.traction_span
            if p < q:
                t[po:max(po, min(qo, p))] = 0.0
                t[min(qo, max(q, po)):qo] = 0.0
                self.law.traction(point.gap_ext[p:q + 2], out=t[p:q],
                                  work=self._work[:, :q - p + 2])
            else:
                t[po:qo] = 0.0
            point.traction_span = (p, q)
        point.ready = True
        return point.gap[lo:hi].min() if hi > lo else np.inf
