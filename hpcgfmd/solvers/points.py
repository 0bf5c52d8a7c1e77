"""Points along a CG line: the gaps of a displacement, its cohesive traction and its spans.

Everything about the wall and the cohesive law is confined to the span of nodes with
gap < level (level = dmax with adhesion: the contact and its cohesive zone, a few % of the
cell), so a point's law is evaluated on that span only.
"""

from __future__ import annotations

import numpy as np

from . import kernels
from .grid_law import GridLaw


class Point:
    """Gaps of one displacement (``halo`` ghost nodes each side), its cohesive traction and
    spans.

    Attributes
    ----------
    gap_ext : ndarray, shape (m + 2 halo,)
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

    def __init__(self, n, halo=1):
        self.gap_ext = np.zeros(n + 2 * halo)
        self.gap = self.gap_ext[halo : halo + n]
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
        self.grid_law = GridLaw(domain, law)
        self._n = domain.local_n
        self.level = 0.0  # gap below which a node interacts (set per solve)

    def evaluate(self, point, d=None):
        """Collective (one ghost exchange): spans and cohesive traction of ``point.gap``.

        Returns (this rank's smallest gap, negative when the point is beyond the wall; the
        traction's dot product with ``d`` on its span, 0 without ``d`` or adhesion).
        """
        first, last, smallest = kernels.near(point.gap, self.level)
        return self._finish(point, first, last, smallest, d)

    def evaluate_scanned(self, point, scan):
        """Collective: :meth:`evaluate` of gaps whose (first, last, smallest) ``scan``, as
        :func:`kernels.near` gives it, was made when they were formed."""
        return self._finish(point, *scan, None)

    def evaluate_shifted(self, point, base, d, length, window=None):
        """Collective: ``point`` at gaps base - length d (the gaps of u + length d when base is
        the gaps of u), evaluated as :meth:`evaluate` with the slope along d.

        ``window = (w0, w1, entry)``: while ``length < entry`` no node outside [w0, w1) comes
        below the level, so the gaps are formed on the window (and the block's ends, for the
        ghosts) only; ``point.gap`` is then valid there alone.
        """
        if window is not None and length < window[2]:
            first, last, smallest = kernels.shifted_window(
                base, d, length, point.gap, self.level, window[0], window[1]
            )
            h = self.grid_law.halo
            if h > 1 and self._n:  # a surface's ghost exchange sends whole end rows
                gap = point.gap
                np.subtract(base[:h], length * d[:h], out=gap[:h])
                np.subtract(base[-h:], length * d[-h:], out=gap[-h:])
        else:
            first, last, smallest = kernels.shifted_gaps(base, d, length, point.gap, self.level)
        return self._finish(point, first, last, smallest, d)

    @staticmethod
    def take(cur, best):
        """Make ``cur`` (whose gaps the caller moves to ``best``'s) take ``best``'s traction
        and spans: the traction buffers are exchanged with their spans, not copied."""
        cur.traction, best.traction = best.traction, cur.traction
        cur.traction_span, best.traction_span = best.traction_span, cur.traction_span
        cur.near = best.near
        cur.ready = True

    def _finish(self, point, first, last, smallest, d):
        """The ghost exchange, the spans, the law on the traction span and t.d there."""
        m = self._n
        self.domain.fill_halo(point.gap_ext)
        if m:
            lo, hi, p, q = self.grid_law.spans(first, last, m, point.gap_ext, self.level)
        else:
            lo = hi = p = q = 0
        point.near = (lo, hi)
        slope = 0.0
        law = self.law
        if law.sigma_a > 0.0:
            old_p, old_q = point.traction_span
            slope = self.grid_law.traction_on_span(
                point.gap_ext,
                point.traction,
                old_p,
                old_q,
                p,
                q,
                point.traction if d is None else d,
            )
            if d is None:
                slope = 0.0
            point.traction_span = (p, q)
        point.ready = True
        return smallest, slope
