"""CG steps that reach the wall, taken so that the energy still decreases.

First choice: the Euclidean projection (zero mean, gap >= 0) of u + a d, which sets many
nodes on the wall at once, accepted for the first a in alpha, alpha/8, ..., alpha/8^5 that
lowers the energy (projected backtracking: a full CG step can push thousands of nodes in).
Otherwise the step is cut where the first node touches the wall: that length lies inside
(0, alpha], where the quadratic upper bound guarantees descent. When the direction presses
on a node already on the wall (only round-off gets there, held nodes being excluded from d),
the step is taken along the projected residual instead, whose first contact is at a positive
length. Every such step restarts CG.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg.blas import daxpy

from ...parallel.fft import aligned_empty
from ..projection import project_feasible


class WallSteps:
    """Projected and cut steps on this rank's block (module docstring).

    Parameters
    ----------
    domain : hpcgfmd.parallel.domain.Domain
    fft : SerialRealFFT, HalvedRealFFT or TransposedRealFFT
    problem : hpcgfmd.solvers.step_problem.StepProblem
        The step's energy (the projected steps are accepted only if it drops).

    Attributes
    ----------
    projections, cut_steps, residual_steps : int
        Projected steps accepted, steps cut at the first contact, and of those the ones
        taken along the projected residual.
    """

    def __init__(self, domain, fft, problem):
        self.domain, self.fft, self.problem = domain, fft, problem
        n = domain.local_n
        self._n = n
        self._spare = np.empty(n)
        self._scratch = np.empty(n)
        self._projected = aligned_empty(n)
        self._k_projected = aligned_empty(n)
        self._mask = np.empty(n, dtype=bool)
        self.projections = 0
        self.cut_steps = 0
        self.residual_steps = 0

    def take(self, u, point, wall, wall_scale, load, linear, r, mu, d, k_d, alpha, ops):
        """Collective: a step from u along d that reaches the wall (module docstring).

        ``point.gap`` is wall - u; u and the running K u + H - p_applied (``load``) are
        updated in place, the point's gaps recomputed; r - mu is the projected residual;
        ``k_d`` is K d (overwritten when the residual direction is taken).
        """
        dom, fft, gap = self.domain, self.fft, point.gap
        k_u = np.subtract(load, linear, out=self._scratch)
        energy = self.problem.energy_linear(u, k_u, wall, linear)
        spare = self._spare
        for trial in range(6):  # projected backtracking along the arc P(u + a d)
            step = alpha * 0.125**trial
            np.multiply(d, step, out=spare)
            spare += u
            project_feasible(dom, spare, wall, self._projected, wall_scale=wall_scale)
            fft.apply_diagonal(self._projected, ops.stiffness, self._k_projected)
            if (
                self.problem.energy_linear(self._projected, self._k_projected, wall, linear)
                < energy
            ):
                np.copyto(u, self._projected)
                np.subtract(wall, u, out=gap)
                point.ready = False
                np.add(self._k_projected, linear, out=load)
                self.projections += 1
                return
        cut = self._first_contact(gap, d)
        if cut <= 0.0:  # d presses on a node on the wall: the projected residual instead
            np.subtract(r, mu, out=d)
            fft.apply_diagonal(d, ops.stiffness, k_d)
            rd, d_kd = dom.sums(d @ d, d @ k_d)
            alpha = rd / d_kd
            cut = min(alpha, self._first_contact(gap, d))
            self.residual_steps += 1
        np.multiply(d, cut, out=spare)
        u += spare
        np.minimum(u, wall, out=u)  # the touching node lands on the wall exactly
        np.subtract(wall, u, out=gap)
        point.ready = False
        if self._n:
            daxpy(k_d, load, a=cut)
        self.cut_steps += 1

    def _first_contact(self, gap, d):
        """Collective: largest step length along d before a node reaches the wall (gap / d)."""
        rising, room = self._mask, self._projected
        np.greater(d, 0.0, out=rising)
        local = np.inf
        if rising.any():
            with np.errstate(divide="ignore", invalid="ignore"):
                np.divide(gap, d, out=room)
            np.logical_not(rising, out=rising)
            np.copyto(room, np.inf, where=rising)
            local = float(room.min())
        return self.domain.min(local)
