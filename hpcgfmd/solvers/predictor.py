"""The start of a step's solve: the lowest-energy of three feasible guesses.

The path is defined by descent from the previous equilibrium u_n (feasible for the new step,
the wall having risen); a guess replaces it only if its energy is lower, so the solve still
ends on the branch the previous step was on:

- extrapolation in time, quadratic through u_{n-2}, u_{n-1}, u_n once three accepted states
  are known (Lagrange weights of the unequal steps, error O(dt^3 u_ttt) where u is smooth in
  time), linear u_n + r (u_n - u_{n-1}) (r = dt_{n+1} / dt_n) before, with the contact nodes
  of step n put exactly on the new wall (extrapolation lands there only to round-off, and a
  gap of 1e-18 would free the whole patch), where the projection onto zero mean keeps them
  (it shifts the free nodes only);
- the linear extrapolation with the gap profile around each contact edge translated by the
  edge's last displacement (a peeling edge moves with its shape), which frees the nodes the
  edge will pass instead of leaving the solver to unzip them one by one (a quadratic base
  here lets more guesses lose to the first, measured in docs/results.md). A sphere's
  contact is a disc: its gap profile within ``radial_window`` of the contact's radius a is
  translated radially by a's last change s, g(r) <- g_n(r - s) along each node's ray,
  bilinear between the nodes of u_n's gap (rows a ray crosses on other ranks come with one
  exchange, :meth:`~hpcgfmd.parallel.domain.Domain.rows_around`). Its energy costs a
  transform pair a step, and on a viscoelastic sphere it loses to the extrapolation at every
  step (measured, docs/results.md): after RADIAL_TRIES losses in a row it rests RADIAL_REST
  steps between tries, until it wins again.

After the preload, u_{n-1} is taken as u_n with the contact lowered by the rise (not a
state: the quadratic guess waits for three accepted ones).
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import map_coordinates

from ..parallel.fft import aligned_empty
from ..state import State
from .projection import project_feasible
from .step_kernels import linear_guess, quadratic_guess

RADIAL_TRIES = 4  # losses in a row after which a sphere's radial guess rests ...
RADIAL_REST = 8  # ... this many steps before each next try (module docstring)


class Predictor:
    """Guesses of the next equilibrium from the last two (this rank's block).

    Parameters
    ----------
    domain : hpcgfmd.parallel.domain.Domain
    window : float
        Half-width around a contact edge whose gap profile moves with the edge (length): the
        widest cohesive zone, 4 w / k.
    radial_window : float, optional
        A sphere's: the half-width around the contact's radius whose gap moves radially
        (length); None: no such guess on a surface (a contact that is no disc).

    Attributes
    ----------
    u_previous : ndarray or None
        u_{n-1}, None right after the preload.
    u_before_previous : ndarray or None
        u_{n-2}, None until three accepted states are known.
    ratio_previous : float
        dt_n / dt_{n-1}, the step length ratio of the last start (NaN: none).
    choices : list of int
        Steps started from the (extrapolated, moving-edge) guess.
    rejected : int
        Steps started from u_n itself (no guess had a lower energy).
    """

    def __init__(self, domain, window, radial_window=None):
        self.domain = domain
        self.window = window
        self.radial_window = radial_window
        # a sphere's nodes' distances from its axis (length), for the radial guess
        self._radius = (
            None if radial_window is None or domain.y is None else np.hypot(domain.x, domain.y)
        )
        self.u_previous = None
        self.u_before_previous = None
        self.ratio_previous = np.nan
        self.choices = [0, 0]
        self.rejected = 0
        self.radial_losses = 0  # the radial guess's losses in a row, and the steps it rests
        self.radial_rest = 0
        n = domain.local_n
        # the guesses, their feasible projections (aligned: the energy transforms them in
        # place) and the moving edges' gap: nothing of the block's size is allocated per step
        self._linear = np.empty(n)
        self._extrapolated = np.empty(n)
        self._moved = np.empty(n)
        self._gap = np.empty(n)
        self._starts = (aligned_empty(n), aligned_empty(n))
        self._absent = np.zeros(n)  # a state not known yet

    def start(
        self, u, wall, gap_before, contact, rise, ratio, edges, edges_previous, energy, stiffness_u
    ):
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
        stand_in = self.u_previous is None  # right after the preload: not a state
        if stand_in:
            self.u_previous = u - rise * contact
            ratio = 1.0
        linear = self._linear
        linear_guess(u, self.u_previous, ratio, wall, contact, linear)
        extrapolated = linear
        if self.u_before_previous is not None and np.isfinite(self.ratio_previous):
            extrapolated = self._extrapolated
            quadratic_guess(
                u,
                self.u_previous,
                self.u_before_previous,
                *lagrange_weights(ratio, self.ratio_previous),
                wall,
                contact,
                extrapolated,
            )
        guesses = (
            extrapolated,
            self._moving_edges(linear, wall, gap_before, ratio, edges, edges_previous),
        )
        candidates = {}
        for kind, guess in enumerate(guesses):
            if guess is None:
                continue
            start = self._starts[kind]
            try:
                project_feasible(self.domain, guess, wall, start, hold_contact=True)
            except FloatingPointError:  # no feasible point of that form (tiny grids): skip it
                continue
            candidates[kind] = start
        self._shift(u, ratio, keep_previous=not stand_in)
        energies = {kind: energy(c) for kind, c in candidates.items()}
        best = min(energies, key=energies.get) if energies else None
        won = best is not None and energies[best] <= energy(u, stiffness_u)
        if won:
            u[:] = candidates[best]
            self.choices[best] += 1
        else:
            self.rejected += 1
        if self._radius is not None and 1 in candidates:  # the radial guess was tried
            self.radial_losses = 0 if won and best == 1 else self.radial_losses + 1
            if self.radial_losses >= RADIAL_TRIES:
                self.radial_rest = RADIAL_REST

    def _shift(self, u, ratio, keep_previous):
        """u_n becomes u_{n-1}, and u_{n-1} u_{n-2} when it is a state (``keep_previous``);
        the step ratio r becomes the previous one."""
        if keep_previous:
            self.u_before_previous = _kept(self.u_before_previous, self.u_previous)
        self.u_previous[:] = u
        self.ratio_previous = ratio

    def _moving_edges(self, linear, wall, gap_before, ratio, edges, edges_previous):
        """Guess with the gap near each contact edge translated by the edge's last motion (a
        line's contact; a sphere's radius, :meth:`_moving_radius`; None on another surface)."""
        if edges_previous is None or not np.all(np.isfinite(edges)):
            return None
        if self.domain.dimensions == 2:
            if self._radius is None:
                return None
            if self.radial_rest:  # (the same on every rank: a state of reduced values)
                self.radial_rest -= 1
                return None
            return self._moving_radius(linear, wall, gap_before, ratio, edges, edges_previous)
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
            window[near] = np.interp(
                x[block][near] - shift, dom.position(first + np.arange(length)), values
            )
        np.maximum(gap, 0.0, out=gap)
        return np.subtract(wall, gap, out=self._moved)

    def _moving_radius(self, linear, wall, gap_before, ratio, edges, edges_previous):
        """Collective: a sphere's guess, the gap within the radial window of the contact's
        radius a taken from u_n's at r - s along each node's ray, s = ratio (a_n - a_{n-1})
        (module docstring); None without a motion, or for one beyond a quarter of the rows."""
        dom = self.domain
        radius = edges[1]
        shift = ratio * (radius - edges_previous[1])
        ny, nx = dom.shape
        if not np.isfinite(shift) or shift == 0.0:
            return None
        depth = int(np.ceil(abs(shift) / dom.dy)) + 2  # the rows a ray may cross, and one
        if depth > ny // 4:  # (the same verdict on every rank: edges are reduced values)
            return None
        rows = dom.rows_around(gap_before, depth)
        gap = np.subtract(wall, linear, out=self._gap)
        reach = radius + self.radial_window + abs(shift)
        # this block's rows within the window's reach of the axis, as a flat slice
        first = dom.first_axis_block[0]
        low = max(int(np.floor(-reach / dom.dy)) + ny // 2 - first, 0) * nx
        high = min(int(np.ceil(reach / dom.dy)) + ny // 2 + 1 - first, dom.local_n // nx) * nx
        if high <= low:
            return np.subtract(wall, np.maximum(gap, 0.0, out=gap), out=self._moved)
        r = self._radius[low:high]
        near = np.abs(r - radius) < self.radial_window + abs(shift)
        near &= r > abs(shift) + 2.0 * dom.dx  # (the ray's start point beyond the axis)
        nodes = low + np.flatnonzero(near)
        scale = (r[near] - shift) / r[near]
        # the start points in index units of ``rows`` (its row 0: this block's first - depth)
        column = dom.x[nodes] * scale / dom.dx + nx // 2
        row = dom.y[nodes] * scale / dom.dy + ny // 2 - (first - depth)
        # bilinear between the four nodes around each start point (columns periodic)
        gap[nodes] = map_coordinates(rows, (row, column), order=1, mode="grid-wrap")
        np.maximum(gap, 0.0, out=gap)
        return np.subtract(wall, gap, out=self._moved)

    def state(self) -> State:
        """u_{n-1} and u_{n-2} (zeros when unknown) and the last step ratio
        (:mod:`hpcgfmd.state`)."""
        arrays = {
            name: self._absent if kept is None else kept
            for name, kept in (
                ("u_previous", self.u_previous),
                ("u_before_previous", self.u_before_previous),
            )
        }
        return State(
            arrays,
            {
                "has_previous": self.u_previous is not None,
                "has_before_previous": self.u_before_previous is not None,
                "ratio_previous": self.ratio_previous,
                "radial_losses": self.radial_losses,
                "radial_rest": self.radial_rest,
            },
        )

    def restore(self, state: State):
        """Continue from :meth:`state`."""
        s = state.scalars
        self.u_previous = (
            _kept(self.u_previous, state.arrays["u_previous"]) if s["has_previous"] else None
        )
        self.u_before_previous = (
            _kept(self.u_before_previous, state.arrays["u_before_previous"])
            if s["has_before_previous"]
            else None
        )
        self.ratio_previous = float(s["ratio_previous"])
        # (checkpoints of earlier versions: the radial guess tried at once)
        self.radial_losses = int(s.get("radial_losses", 0))
        self.radial_rest = int(s.get("radial_rest", 0))

    def counters(self) -> dict:
        """Steps started from each guess and from u_n itself."""
        return {
            "rejected_predictions": self.rejected,
            "extrapolated_predictions": self.choices[0],
            "moving_edge_predictions": self.choices[1],
        }

    def restore_counters(self, counters: dict):
        self.rejected = int(counters["rejected_predictions"])
        self.choices = [
            int(counters["extrapolated_predictions"]),
            int(counters["moving_edge_predictions"]),
        ]


def _kept(buffer, values):
    """``values`` copied into ``buffer`` (a new array when there is none yet)."""
    if buffer is None or buffer.shape != values.shape:
        return values.copy()
    buffer[:] = values
    return buffer


def lagrange_weights(ratio, ratio_previous):
    """Weights (w0, w1, w2) of u_n, u_{n-1}, u_{n-2} in the quadratic through them at
    t_n + dt_{n+1}, for ratio = dt_{n+1} / dt_n and ratio_previous = dt_n / dt_{n-1}.

    With times in units of dt_n (t_n = 0, t_{n-1} = -1, t_{n-2} = -1 - b, b = 1 /
    ratio_previous) and s = ratio: w0 = (s + 1)(s + 1 + b) / (1 + b), w1 = -s (s + 1 + b) / b,
    w2 = s (s + 1) / ((1 + b) b); they sum to 1 and reproduce t and t^2 exactly.
    """
    s, b = ratio, 1.0 / ratio_previous
    return (
        (s + 1.0) * (s + 1.0 + b) / (1.0 + b),
        -s * (s + 1.0 + b) / b,
        s * (s + 1.0) / ((1.0 + b) * b),
    )
