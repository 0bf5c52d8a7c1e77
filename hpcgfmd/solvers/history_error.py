"""The load error of a step's history integration, estimated from the last three accepted
states, and the correction of the substrate's state that removes most of it
(docs/numerics.md, "Time steps"; docs/model.md, (M46)).
"""

from __future__ import annotations

import math

import numpy as np

from ..parallel.fft import aligned_empty
from .step_kernels import clear_near_crossings, contact_sums, curvature

CURVATURE_AGE = 8  # steps a smooth curvature stands in for windows with crossings ...
CURVATURE_LIFETIME = 0.05  # ... and time, in relaxation times tau (u_tt changes over tau)


class HistoryError:
    """The load error of a step's history integration, estimated from the last three states,
    and the correction of the substrate traction that removes most of it.

    The SLS step is exact for u linear in time within it (docs/model.md, (M8)); the quadratic
    through u_{n-1}, u_n and u_{n+1} gives the curvature c = u_tt / 2, and the traction the
    step missed is dp = (|q|/2) (Einf - E0) c F(dt) per mode
    (:meth:`~hpcgfmd.model.material.GeneralizedMaxwell.curvature_response`). Its share on the
    contact is carried by the indenter: the estimate is |sum of dp over the contact| dx. Once
    the step is accepted, dp is added to the substrate traction p_{n+1} (:meth:`correct`), so
    the history the next steps start from is exact for u quadratic in time through the last
    three states; the equilibrium of the step itself keeps its one-step error, which no
    longer accumulates over the memory time. Nodes whose contact state changed over the
    three states are left out (c = 0 there), and so are those that entered or left the
    cohesive zone, whose traction switches on or off: their u(t) has a kink, not a
    curvature, the quadratic does not describe them, and the edge criterion bounds their
    error. After a quadratic step (M46), which holds dp in its own equilibrium, nothing is
    added and the step's error is the correction's (:meth:`estimate`). Cost: one
    FFT pair per step (docs/numerics.md and docs/results.md have the measured errors).

    Crossings (the linear step's correction; a quadratic step has put the window's own
    curvature in its traction, and the estimate after it reads the smooth curvature only
    for its size). A node that changes its state switches its traction on or off and moves
    every node near it by a jump of the discrete solution, which the quadratic reads as a curvature
    of size jump / dt^2: in a window that holds a crossing the estimate does not fall with
    dt, and on coarse grids (the edge takes several steps per node) the step control would
    shrink the steps without end. u_tt is smooth in time, so such a window takes the
    curvature of the last window without a crossing, when that is at most ``CURVATURE_AGE``
    accepted steps and ``CURVATURE_LIFETIME`` relaxation times old, for its estimate and its
    correction. On fine grids, where nearly every step crosses nodes, the window's own
    curvature is used: there the jumps are small. On creeping retractions, whose steps are a
    good part of tau, the kept curvature is stale and the window's own is used too. Where
    the window's own curvature is used in a window with a crossing, it is set to 0 on every
    node within ``crossing_reach`` of a node that changed its state, not only on those
    nodes: the jump spreads over the zone of the passing tip (up to the glassy w / k), and
    read as curvature it gives errors of either sign, 20-80 times a smooth window's, whose
    signed sum walks to the kept errors' allowance on grids of a few nodes per zone and
    holds the steps at a small fraction of tau (docs/results.md, "Rules of the steps and the
    grid").

    Parameters
    ----------
    substrate : hpcgfmd.model.halfspace.Substrate
    fft : SerialRealFFT, HalvedRealFFT or TransposedRealFFT
    domain : hpcgfmd.parallel.domain.Domain
    crossing_reach : float, optional
        Distance from a node that changed its state within which the window's curvature is
        not read (length; the package uses w / (2 k), half the glassy zone width; 0: the
        changed nodes only).
    """

    def __init__(self, substrate, fft, domain, crossing_reach=0.0):
        self.substrate, self.fft, self.domain = substrate, fft, domain
        # in nodes (0: the changed nodes alone)
        self.reach = min(domain.n, max(0, math.ceil(crossing_reach / domain.dx - 1e-9)))
        n = domain.local_n
        self._curvature = aligned_empty(n)
        self._traction = aligned_empty(n)
        self._estimated = False  # _traction holds the last estimate's dp
        self.smooth_curvature = aligned_empty(n)  # c of the last window without a crossing
        self.smooth_curvature[:] = 0.0
        self.curvature_age = math.inf  # accepted steps since it was estimated
        self.curvature_time = -math.inf  # end time of its window
        self._lifetime = CURVATURE_LIFETIME * substrate.material.shortest_time
        self._smooth = False  # the last estimate's window had no crossing
        self._reused = False  # the last estimate took the smooth curvature
        self.previous_reused = False  # ... and so did the previous accepted one
        self._time = -math.inf  # end time of the last estimate's window
        self._response = 0.0  # curvature_response of the last estimate's step
        self._step = 0.0  # ... and its length
        # K c of the last accepted estimate's curvature c, per unit curvature response
        # (dp / response), for the error of the correction (estimate's docstring)
        self.previous_correction = aligned_empty(n)
        self.previous_correction[:] = 0.0
        self.has_previous = False  # set by correct(); restored from checkpoints

    def estimate(
        self,
        older,
        time_older,
        state_older,
        before,
        time_before,
        state_before,
        after,
        time_after,
        state,
    ):
        """Collective (one FFT pair): the step's load error and the error its correction
        leaves in the history (load per unit length, signed: the kept errors of successive
        steps add up with their signs).

        The step's error |sum of dp over the contact| dx is that of this step's equilibrium
        only: :meth:`correct` removes it from the history the next steps start from. What
        stays in the history is the correction's own error, the change of the curvature
        over the step (u_ttt dt, which the quadratic through the last three states does not
        see): estimated as the difference of this estimate's dp and the previous accepted
        estimate's, taken at this step's curvature response,
        |sum over the contact of (dp - response K c_prev)| dx (an embedded third-order
        estimate: for u cubic in time it is about twice the corrected step's local error,
        tests/test_history_error.py). Where either curvature is not the window's own (the
        smooth curvature stood in for a crossing) or no accepted estimate came before, the
        step's error stands in for it.

        ``older``, ``before``, ``after``: this rank's u at the three times; ``state_*``:
        their nodes' interaction states (2 on the wall, 1 in the cohesive zone, 0 beyond;
        ``state``: after the step).

        Returns
        -------
        (float, float)
            The step's load error and the correction's (load per unit length).
        """
        h1, h0 = time_after - time_before, time_before - time_older
        c = self._curvature
        kinks, first, last = curvature(
            older, before, after, h0, h1, state_older, state_before, state, c
        )
        crossings, left, right = self.domain.marks_around(kinks, first, last)
        self._smooth = crossings == 0
        reuse = (
            not self._smooth
            and self.curvature_age <= CURVATURE_AGE
            and time_after - self.curvature_time <= self._lifetime
        )
        if not self._smooth and not reuse and self.reach > 0:
            clear_near_crossings(state_older, state_before, state, self.reach, left, right, c)
        self._time = time_after
        # the missed traction (|q|/2) response c per mode (one FFT pair)
        self._response = self.substrate.material.curvature_response(h1)
        self.fft.apply_diagonal(
            self.smooth_curvature if reuse else c,
            self.substrate.half_q * (self._response / self.substrate.n),
            self._traction,
        )
        self._estimated = True
        self._step = h1
        comparable = self.has_previous and not reuse and not self.previous_reused
        self._reused = reuse
        # (0 on a rank without nodes)
        step_part, previous = contact_sums(self._traction, self.previous_correction, state)
        kept = previous * self._response if comparable else 0.0
        step_error, change = self.domain.sums(step_part, step_part - kept)
        dx = self.domain.node_area
        kept_error = (change if comparable else step_error) * dx
        if self.substrate.last_step_quadratic:
            # the quadratic step (M46) held dp in its own equilibrium: its error, in the
            # step's load and kept in the history alike, is the correction's
            return kept_error, kept_error
        return step_error * dx, kept_error

    def correct(self):
        """Add the last estimate's missed traction to the accepted step's substrate traction
        (nothing when the step had no estimate), and keep its curvature when its window had
        no crossing, and its dp per unit curvature response for the next estimate's error of
        the correction; the estimate is used up."""
        if self._estimated:
            self.substrate.correct(self._traction, self._step)
            if self._response > 0.0:
                np.multiply(self._traction, 1.0 / self._response, out=self.previous_correction)
                self.has_previous, self.previous_reused = True, self._reused
            if self._smooth:
                self.smooth_curvature[:] = self._curvature
                self.curvature_age = 0
                self.curvature_time = self._time
            else:
                self.curvature_age += 1
        self._estimated = False

    def forget(self):
        """Drop the last estimate (its step was rejected or abandoned)."""
        self._estimated = False
