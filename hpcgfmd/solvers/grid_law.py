"""The interface law on the grid of a domain: the one place where a line and a surface differ
for the solvers.

The solvers hold the gaps of their block with ``halo`` ghost nodes each side (a node on a
line, a row on a surface: :meth:`hpcgfmd.parallel.domain.Domain.fill_halo`) and ask this
object for the law's traction, its energy and the spans a traction can reach. On a line the
element law couples a node to its two neighbours (docs/model.md, (M35); :mod:`.kernels`); on
a surface the triangle law couples it to the eight around it, which are at most 2 nx - 1
flat nodes away across the periodic seam along x ((M60); :mod:`.surface_kernels`).
"""

from __future__ import annotations

import numpy as np

from . import kernels, surface_kernels


class GridLaw:
    """The Dugdale-Maugis law of ``law`` on the grid of ``domain`` (local: no MPI).

    Parameters
    ----------
    domain : hpcgfmd.parallel.domain.Domain
    law : hpcgfmd.model.interface.DugdaleMaugis

    Attributes
    ----------
    halo : int
        Ghost nodes each side of a block.
    reach : int
        How many flat nodes beyond a node with gap < dmax the law's traction reaches.
    window_margin : int
        How many flat nodes beyond the near span the gaps must be known for the traction on
        the span the law reaches (twice the reach: the law at a node reads its neighbours).
    """

    def __init__(self, domain, law):
        self.law = law
        self.halo = domain.halo
        self.surface = domain.dimensions == 2
        self.nx = domain.shape[-1]
        self.reach = 2 * self.nx if self.surface else 1
        self.window_margin = 2 * self.reach

    def extended(self, m):
        """A zeroed gap buffer for a block of m nodes and its ghosts."""
        return np.zeros(m + 2 * self.halo)

    def inner(self, gap_ext):
        """The block's own nodes of an extended buffer (a view)."""
        return gap_ext[self.halo : gap_ext.shape[0] - self.halo]

    def spans(self, first, last, m, gap_ext, level):
        """(lo, hi, p, q): [lo, hi) holds every node of the block with gap < level (the
        ghosts, when near, stretch it to the block's ends); [p, q) every node the law's
        traction can reach from them. ``first``, ``last``: the block's first and last node
        with gap < level (m, -1 for none)."""
        if not self.surface:
            return kernels.spans(first, last, m, gap_ext[0] < level, gap_ext[-1] < level)
        before, after = surface_kernels.ghosts_near(gap_ext, self.halo, level)
        if before:
            first = -1
        if after:
            last = m
        if first > last:
            return 0, 0, 0, 0
        reach = self.reach
        return max(first, 0), min(last + 1, m), max(first - reach, 0), min(last + 1 + reach, m)

    def traction(self, gap_ext, out, p, q):
        """The law's nodal traction on the nodes [p, q) into ``out`` (stress)."""
        law = self.law
        if self.surface:
            surface_kernels.cohesive_traction(gap_ext, out, p, q, self.nx, law.dmax, law.sigma_a)
        else:
            kernels.cohesive_traction(gap_ext, out, p, q, law.dmax, law.sigma_a)

    def traction_on_span(self, gap_ext, traction, old_p, old_q, p, q, d):
        """Zero the old span outside [p, q), the law's traction on [p, q); return t.d there."""
        law = self.law
        if self.surface:
            return surface_kernels.traction_on_span(
                gap_ext, traction, old_p, old_q, p, q, self.nx, law.dmax, law.sigma_a, d
            )
        return kernels.traction_on_span(
            gap_ext, traction, old_p, old_q, p, q, law.dmax, law.sigma_a, d
        )

    def ramp_sum(self, gap_ext):
        """The sum over the block's elements (squares) of the ramp's mean: the interface
        energy per node area is -sigma_a times it."""
        if self.surface:
            return surface_kernels.cohesive_energy(gap_ext, self.nx, self.law.dmax)
        return kernels.cohesive_energy(gap_ext, self.law.dmax)
