"""One time step's minimisation problem, whatever solves it: its energy, its interface traction
and how far a state is from its equilibrium.

Each step (docs/model.md, "Interface", (M12) and (M34)) minimises over the surface
displacement u, with zero mean and the hard wall u <= h + u_z,

    E(u) / dx = 1/2 u.K u + (H - p_applied).u - sigma_a sum_e M_e,

K the step's stiffness (|q|/2) Eeff per mode, H the history traction and M_e the mean of
the cohesive ramp max(dmax - g, 0) over element e of the piecewise-linear gap (M35). At a
minimum the traction of the indenter on the surface is the cohesive traction on the free
nodes and the wall's reaction K u + H + mu - p_applied on the contact (mu the uniform
traction, the multiplier of the zero mean); the residual is the largest projected
imbalance (:meth:`StepProblem.measure`). These are properties of the step, not of a solver:
every solver (:mod:`.base`) uses them.
"""

from __future__ import annotations

import numpy as np

from ..parallel.fft import aligned_empty
from . import kernels
from .active_set import ActiveSet
from .base import SolveResult
from .grid_law import GridLaw
from .points import Point, PointEvaluator
from .projection import project_in_place
from .step_kernels import energy_terms, equal


class StepProblem:
    """Energy, interface traction and residual of one step on this rank's block.

    Parameters
    ----------
    domain : hpcgfmd.parallel.domain.Domain
    fft : hpcgfmd.parallel.real_fft.RealFFT
    law : hpcgfmd.model.interface.DugdaleMaugis
    traction_scale : float
        Traction that makes the residual dimensionless (stress; sigma_a).
    """

    def __init__(self, domain, fft, law, traction_scale):
        self.domain, self.fft, self.law = domain, fft, law
        self.traction_scale = traction_scale
        n = domain.local_n
        self._n = n
        self.grid_law = GridLaw(domain, law)
        self._gap_ext = self.grid_law.extended(n)
        self._gap = self.grid_law.inner(self._gap_ext)
        self._k_u = aligned_empty(n)
        # The lowest-energy vector passed to energy() since the last solve began (the
        # predictor's start of the next solve) and its K: see recall.
        self._guess = np.empty(n)
        self._k_guess = np.empty(n)
        self._guess_stiffness = None
        self._guess_energy = np.inf
        self._measure = None  # the buffers of measure(), made on its first use

    # --- the energy --------------------------------------------------------------------
    def energy(self, u, wall, ops, history, applied=None, stiffness_u=None):
        """Collective: energy of the step per unit length, divided by dx (one FFT pair to
        form K u, none when it is given as ``stiffness_u``).

        The lowest-energy vector evaluated since the last solve began is kept with its K
        (:meth:`recall`: the next solve starts from it without a transform).
        """
        k_u = stiffness_u
        if k_u is None:
            k_u = self._k_u
            self.fft.apply_diagonal(u, ops.stiffness, k_u)
        value = self.energy_with(u, k_u, wall, history, applied)
        if value < self._guess_energy:
            np.copyto(self._guess, u)
            np.copyto(self._k_guess, k_u)
            self._guess_stiffness = _keep(self._guess_stiffness, ops.stiffness)
            self._guess_energy = value
        return value

    def energy_with(self, u, k_u, wall, history, applied=None):
        """Collective: energy (per unit length, divided by dx) of u with K u given."""
        value = energy_terms(u, k_u, history, wall, self._gap)
        if applied is not None:
            value -= float(applied @ u)
        return self._interface_energy(value)

    def energy_linear(self, u, k_u, wall, linear):
        """:meth:`energy_with` with the linear term H - p_applied given as one vector."""
        return self._interface_energy(energy_terms(u, k_u, linear, wall, self._gap))

    def _interface_energy(self, value):
        """Collective: ``value`` plus the cohesive energy of the gaps in the buffer, summed
        (the law's energy with dx = 1, in one compiled loop over the zone)."""
        gap_ext = self._gap_ext
        self.domain.fill_halo(gap_ext)
        law = self.law
        if law.sigma_a > 0.0 and self._n:
            value -= law.sigma_a * self.grid_law.ramp_sum(gap_ext)
        return self.domain.sum(value)

    def forget(self):
        """Drop the kept vector: the memory lives within one step (see :meth:`recall`)."""
        self._guess_energy = np.inf

    def recall(self, u, stiffness, out):
        """Collective: True (and K u in ``out``) when K u is known for these exact bits.

        Kept: the lowest-energy vector passed to :meth:`energy` since the last solve began,
        with its K. The protocol's predictor evaluates its guesses and the previous solution
        and starts the solve from the lowest, so the solve's first transform is saved. A
        match needs the same stiffness values and the same bits of u on every rank, so the
        result is bitwise the transform's. The solver forgets the vector when a solve
        begins, so it never carries over from one step to the next: a run resumed from a
        checkpoint does the same transforms as an uninterrupted one. A miss costs a sample
        comparison, a match a full one (~0.1 pair).
        """
        kept = self.recalled(u, stiffness)
        if kept is None:
            return False
        np.copyto(out, kept)
        return True

    def recalled(self, u, stiffness):
        """Collective: :meth:`recall` without the copy: the kept K u (valid until the next
        :meth:`energy`), or None."""
        same = self._guess_energy < np.inf and self._matches(
            u, self._guess, self._guess_stiffness, stiffness
        )
        if self.domain.max(0.0 if same else 1.0) > 0.0:
            return None
        return self._k_guess

    def _matches(self, u, kept_u, kept_stiffness, stiffness):
        """Local: u and the stiffness are bitwise the kept ones (a sample of u first)."""
        if kept_stiffness is None or kept_stiffness.shape != stiffness.shape:
            return False
        sample = max(1, self._n // 256)
        if np.not_equal(u[::sample], kept_u[::sample]).any():
            return False
        return equal(u, kept_u) and equal(kept_stiffness.ravel(), stiffness.ravel())

    # --- the traction at equilibrium -----------------------------------------------------
    def interface_traction(self, u, k_u, wall, history, mean_traction, out, applied=None):
        """Collective: traction of the indenter on the surface at equilibrium (stress, upward).

        Cohesive traction on free nodes; on the wall the total reaction
        K u + H + mean_traction - applied (``k_u``: K u), which balances the substrate. One
        pass forms the gaps and finds the span of nodes within the interaction range; the
        law and the reaction are evaluated on that span, the rest of ``out`` is zero.
        """
        gap_ext, gap = self._gap_ext, self._gap
        law = self.law
        # gap < level: in the zone, or on the wall (a contact node's gap is 0 exactly)
        level = law.dmax if law.sigma_a > 0.0 else np.nextafter(0.0, 1.0)
        first, last, _ = kernels.shifted_gaps(wall, u, 1.0, gap, level)  # wall - 1.0 u
        self.domain.fill_halo(gap_ext)
        lo = hi = p = q = 0
        if self._n:
            lo, hi, p, q = self.grid_law.spans(first, last, self._n, gap_ext, level)
        out[:p] = 0.0
        out[q:] = 0.0
        if law.sigma_a > 0.0:
            self.grid_law.traction(gap_ext, out, p, q)
        else:
            out[p:q] = 0.0
        kernels.contact_reaction(gap, lo, hi, k_u, history, mean_traction, out)
        if applied is not None:
            on_wall = np.less_equal(gap[lo:hi], 0.0)
            out[lo:hi][on_wall] -= applied[lo:hi][on_wall]
        return out

    # --- how far from equilibrium ----------------------------------------------------------
    def measure(self, u, wall, ops, history, applied=None) -> tuple[SolveResult, np.ndarray]:
        """Collective: project ``u`` exactly onto the feasible set (zero mean, u <= wall; the
        nodes counted as contact put on the wall) and measure its equilibrium: the uniform
        traction mu (the pressed set and mu at their fixed point) and the residual, max
        |projected residual traction| / traction_scale over the free nodes, as the active-set
        CG defines them (:mod:`.cg.solver`). Returns (the result, K u of the projected u).
        """
        if self._measure is None:
            n = self._n
            self._measure = (
                np.empty(n),
                np.empty(n),
                aligned_empty(n),
                Point(n, self.domain.halo),
                PointEvaluator(self.domain, self.law),
                ActiveSet(self.domain),
            )
        start, linear_buffer, k_u, point, evaluator, active = self._measure
        dom = self.domain
        wall_scale = project_in_place(dom, u, wall, start)
        linear = history if applied is None else np.subtract(history, applied, out=linear_buffer)
        if not self.recall(u, ops.stiffness, k_u):
            self.fft.apply_diagonal(u, ops.stiffness, k_u)
        self.forget()
        load = np.add(k_u, linear)
        tolerance = 1e-14 * wall_scale
        evaluator.level = max(
            self.law.dmax if self.law.sigma_a > 0.0 else 0.0, np.nextafter(tolerance, np.inf)
        )
        np.subtract(wall, u, out=point.gap)
        evaluator.evaluate(point)
        active.begin()
        r = start  # (the projection is in u now)
        total, high, low = kernels.residual(
            load, point.traction, *point.traction_span, *point.near, r
        )
        lo, hi = point.near
        mu, _, _, _, pressed = active.multiplier(r, total, point.gap, lo, hi, tolerance, 0.0)
        span_high, span_low, _ = active.settle(r, lo, hi, pressed, mu)
        local = max(max(high, span_high) - mu, mu - min(low, span_low)) if self._n else 0.0
        residual = dom.max(local) / self.traction_scale
        np.copyto(u[lo:hi], wall[lo:hi], where=active.on_wall[: hi - lo])
        np.subtract(load, linear, out=k_u)
        return SolveResult(iterations=0, residual=residual, converged=True, mean_traction=mu), k_u


def _keep(kept, stiffness):
    """Copy of ``stiffness`` in the buffer ``kept`` (reallocated only on a shape change)."""
    if kept is None or kept.shape != stiffness.shape:
        kept = np.empty_like(stiffness)
    np.copyto(kept, stiffness)
    return kept
