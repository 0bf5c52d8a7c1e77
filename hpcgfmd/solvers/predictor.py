"""The start of a step's solve: the lowest-energy of three feasible guesses.

The path is defined by descent from the previous equilibrium u_n (feasible for the new step,
the wall having risen); a guess replaces it only if its energy is lower, so the solve still
ends on the branch the previous step was on:

- linear extrapolation u_n + r (u_n - u_{n-1}) (r = dt_{n+1} / dt_n), with the contact nodes
  of step n put exactly on the new wall (extrapolation lands there only to round-off, and a
  gap of 1e-18 would free the whole patch);
- the same with the gap profile around each contact edge translated by the edge's last
  displacement (a peeling edge moves with its shape), which frees the nodes the edge will
  pass instead of leaving the solver to unzip them one by one.

After the preload, u_{n-1} is taken as u_n with the contact lowered by the rise.
"""
from __future__ import annotations

import numpy as np

from ..parallel.fft import aligned_empty
from .projection import project_feasible
from .step_kernels import linear_guess


class Predictor:
    """Guesses of the next equilibrium from the last two (this rank's block).

    Parameters
    ----------
    domain : hpcgfmd.parallel.domain.Domain
    window : float
        Half-width around a contact edge whose gap profile moves with the edge (length): the
        widest cohesive zone, 4 w / k.

    Attributes
    ----------
    u_previous : ndarray or None
        u_{n-1}, None right after the preload.
    choices : list of int
        Steps started from the (linear, moving-edge) guess.
    rejected : int
        Steps started from u_n itself (no guess had a lower energy).
    """

    def __init__(self, domain, window):
        self.domain = domain
        self.window = window
        self.u_previous = None
        self.choices = [0, 0]
        self.rejected = 0
        n = domain.local_n
        # the guesses, their feasible projections (aligned: the energy transforms them in
        # place) and the moving edges' gap: nothing of the block's size is allocated per step
        self._linear = np.empty(n)
        self._moved = np.empty(n)
        self._gap = np.empty(n)
        self._starts = (aligned_empty(n), aligned_empty(n))

    def start(self, u, wall, gap_before, contact, rise, ratio, edges, edges_previous,
              energy, stiffness_u):
        """Collective: replace ``u`` (u_n) by the lowest-energy feasible guess, if lower.

        Parameters
        ----------
        u : ndarray
            u_n, overwritten by the start of the solve.
        wall : ndarray
            The new step's wall h + u_z (length).
        gap_before : ndarray
            The gap of u_n under the old wall.
        contact : ndarray of bool
            The nodes of u_n on the old wall.
        rise : float
            The wall's rise over the step (length).
        ratio : float
            dt_{n+1} / dt_n.
        edges, edges_previous : tuple of float or None
            Contact edges of steps n and n - 1 (length); None or NaN when unknown.
        energy : callable
            ``energy(v, k_v=None)``: the step's energy of a displacement v (collective), with
            K v when it is known (u_n's: no transform).
        stiffness_u : ndarray
            K u_n under the new step's stiffness.
        """
        if self.u_previous is None:
            self.u_previous = u - rise * contact
            ratio = 1.0
        linear = self._linear
        linear_guess(u, self.u_previous, ratio, wall, contact, linear)
        guesses = (linear, self._moving_edges(linear, wall, gap_before, ratio, edges,
                                              edges_previous))
        candidates = {}
        for kind, guess in enumerate(guesses):
            if guess is None:
                continue
            start = self._starts[kind]
            try:
                project_feasible(self.domain, guess, wall, start)
            except FloatingPointError:  # no feasible point of that form (tiny grids): skip it
                continue
            candidates[kind] = start
        self.u_previous[:] = u
        energies = {kind: energy(c) for kind, c in candidates.items()}
        best = min(energies, key=energies.get) if energies else None
        if best is not None and energies[best] <= energy(u, stiffness_u):
            u[:] = candidates[best]
            self.choices[best] += 1
        else:
            self.rejected += 1

    def _moving_edges(self, linear, wall, gap_before, ratio, edges, edges_previous):
        """Guess with the gap near each contact edge translated by the edge's last motion."""
        if edges_previous is None or not np.all(np.isfinite(edges)):
            return None
        dom = self.domain
        n, dx, x = dom.n, dom.dx, dom.x
        gap = np.subtract(wall, linear, out=self._gap)
        for edge, previous in zip(edges, edges_previous):
            shift = ratio * (edge - previous)
            if not np.isfinite(shift) or shift == 0.0:
                continue
            half = self.window + abs(shift)
            # this rank's nodes within half of the edge: a slice found by index arithmetic
            # (one node more each side), then the exact test on it
            a = max(int(np.floor((edge - half) / dx)) + n // 2 - 1 - dom.x_start, 0)
            b = min(int(np.ceil((edge + half) / dx)) + n // 2 + 2 - dom.x_start, x.size)
            block = slice(a, max(a, b))
            near = np.abs(x[block] - edge) < half
            # the shifted positions x - shift of the window's nodes lie in this segment
            reach = self.window + 2.0 * abs(shift)
            first = int(np.floor((edge - reach) / dx)) + n // 2 - 1
            last = int(np.ceil((edge + reach) / dx)) + n // 2 + 1
            length = min(last - first + 1, n)
            values = dom.segment(gap_before, first, length)
            window = gap[block]
            window[near] = np.interp(x[block][near] - shift,
                                     dom.position(first + np.arange(length)), values)
        np.maximum(gap, 0.0, out=gap)
        return np.subtract(wall, gap, out=self._moved)

    def state(self, u):
        """(field, attrs) for a checkpoint: u_{n-1} (zeros when unknown) and the counters."""
        field = self.u_previous if self.u_previous is not None else np.zeros_like(u)
        return field, {"has_previous": self.u_previous is not None,
                       "rejected_predictions": self.rejected,
                       "predictor_choice": np.array(self.choices)}

    def restore(self, field, attrs):
        self.u_previous = field.copy() if attrs["has_previous"] else None
        self.rejected = int(attrs["rejected_predictions"])
        self.choices = [int(v) for v in attrs["predictor_choice"]]
