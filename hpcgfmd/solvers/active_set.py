"""The active set of the hard wall: nodes on the wall that the residual pushes into it.

The search space of CG is the free nodes with zero mean displacement; the uniform traction mu
(the Lagrange multiplier of the zero mean) and the pressed set depend on each other and are
iterated to a fixed point. Only the near span [lo, hi) of the current point holds nodes on
the wall, so every mask here lives on that span (views of the first hi - lo entries).
"""

from __future__ import annotations

import math

import numpy as np

from . import kernels


class ActiveSet:
    """Masks and rules of the wall constraint on this rank's block (Polonsky-Keer).

    Parameters
    ----------
    domain : hpcgfmd.parallel.domain.Domain
    """

    def __init__(self, domain):
        self.domain = domain
        n = domain.local_n
        self._n = n
        self.on_wall = np.empty(n, dtype=bool)
        self.pressed = np.empty(n, dtype=bool)
        self.pushed = np.empty(n, dtype=bool)
        self._held = np.empty(n, dtype=bool)
        self._excluded = np.empty(n, dtype=bool)
        self._pressed_before = np.zeros(n, dtype=bool)  # the active set of the last iteration
        self._before = (0, 0)
        self._contact = (0, -1)  # first and last node on the wall (multiplier)
        self._on_wall_total = 0.0  # nodes on the wall on every rank (multiplier)
        self.held_steps = 0  # iterations whose direction held on-wall nodes

    def begin(self):
        """Forget the last solve's active set."""
        self._pressed_before[:] = False
        self._before = (0, 0)

    def multiplier(self, r, total, gap, lo, hi, on_wall_tolerance, mu):
        """Collective: the pressed set and the uniform traction mu at their fixed point.

        A node on the wall (gap <= tolerance) is pressed when r - mu > 0 pushes it into the
        wall; mu = mean of r over the free nodes. The sum over the free nodes is the total
        (``total``, this rank's sum of r) minus the pressed ones (2-3 passes over the span).
        The nodes on the wall are counted over all ranks in the same reduction
        (:meth:`contact_edges` of a surface). Returns (mu, count, n_free, on_s, pressed_s):
        this rank's pressed count, the global number of free nodes and the masks on the near
        span.
        """
        n = self._n
        on_s = self.on_wall[: hi - lo]
        on_count, *self._contact = kernels.on_wall(gap, lo, hi, on_wall_tolerance, on_s)
        pressed_s = self.pressed[: hi - lo]
        for _ in range(10):
            pressed_sum, count = kernels.press(r, lo, hi, on_s, mu, pressed_s)
            r_free, n_free, self._on_wall_total = self.domain.sums(
                total - pressed_sum if count else total, n - count, on_count
            )
            mu_new = r_free / n_free
            if mu_new == mu:
                break
            mu = mu_new
        return mu, count, n_free, on_s, pressed_s

    def settle(self, r, lo, hi, pressed_s, mu):
        """Local: r = mu on the pressed nodes; returns (max and min of r on the span, whether
        a node joined the pressed set since :meth:`remember`)."""
        return kernels.settle(r, lo, hi, pressed_s, self._pressed_before, mu)

    def remember(self, lo, hi, pressed_s):
        """Keep this iteration's pressed set for the next :meth:`joined`."""
        before = self._pressed_before
        before[self._before[0] : self._before[1]] = False
        before[lo:hi] = pressed_s
        self._before = (lo, hi)

    def pushing(self, d, lo, hi, on_s):
        """Local: the number of on-wall nodes that the direction d pushes into the wall (the
        test of :meth:`hold`, whose reduction the caller makes)."""
        return kernels.pushed(d, lo, hi, on_s, self.pushed[: hi - lo])

    def hold(self, r, mu, d, lo, hi, pressed_s, on_s):
        """Collective: hold the on-wall nodes the direction d pushes into the wall.

        Called when :meth:`pushing` found some on a rank. They cannot move this iteration:
        zero them in d and keep the zero mean on the others (removing the mean can push
        another node in, so repeat). Returns r.d of the projected direction, or, when that
        does not descend, sets d to the projected residual r - mu (zero on the pressed
        nodes) and returns r.d of it.
        """
        dom, n = self.domain, self._n
        d_s = d[lo:hi]
        pushed_s = self.pushed[: hi - lo]
        self.held_steps += 1
        held_s = self._held[: d_s.size]
        excluded_s = self._excluded[: d_s.size]
        held_s[:] = False
        while True:  # removing the mean can push another node in
            held_s |= pushed_s
            np.logical_or(held_s, pressed_s, out=excluded_s)
            excluded = np.count_nonzero(excluded_s)
            d_keep, n_keep = dom.sums(d.sum() - d_s.sum(where=excluded_s), n - excluded)
            if n_keep == 0:  # every free node held: fall back to the residual below
                d[:] = 0.0
                break
            d -= d_keep / n_keep
            np.copyto(d_s, 0.0, where=excluded_s)
            np.greater(d_s, 0.0, out=pushed_s)
            pushed_s &= on_s
            if not dom.any(pushed_s):
                break
        rd = dom.dot(r, d)
        if rd <= 0.0:  # the projected residual lifts on-wall nodes off: descent
            np.subtract(r, mu, out=d)
            rd = dom.dot(d, d)
        return rd

    def contact_edges(self):
        """The iterate's contact edges at the last :meth:`multiplier` (length; +inf, -inf
        without contact), for the solve's edge watch.

        On a line, local: the positions of this rank's first and last node on the wall (the
        caller reduces them). On a surface, the same on every rank: -a and a, a = sqrt(A /
        pi) the equivalent radius of the contact area A (the nodes on the wall, each with
        its cell), as the sphere's contact is measured (:meth:`Sphere.measure`).
        """
        dom = self.domain
        if dom.dimensions == 2:
            if not self._on_wall_total:
                return math.inf, -math.inf
            radius = math.sqrt(self._on_wall_total * dom.node_area / math.pi)
            return -radius, radius
        first, last = self._contact
        if first > last:
            return math.inf, -math.inf
        x = dom.x
        return float(x[first]), float(x[last])

    def strayed(self, watch, left, right):
        """True when an edge of the iterate's contact is farther than ``watch.limit`` away.

        On a line the iterate's edges are nodes, the watched ones interpolated between nodes;
        on a surface both are radii of node counts, a ring of nodes apart at most: two node
        spacings are allowed for the difference. An iterate without contact is no verdict: the
        start of a step (the wall has risen) and the iterates between a projection and the
        next contact have none.
        """
        if not (math.isfinite(left) and math.isfinite(right)):
            return False
        motion = max(abs(left - watch.left), abs(right - watch.right))
        return motion > watch.limit + 2.0 * self.domain.dx
