"""The three accepted states the history's time-error estimate reads (docs/numerics.md,
"Time steps").

:class:`~hpcgfmd.solvers.stepping.HistoryError` fits u quadratic in time through the
state before the last accepted step (u_{n-1}), the last accepted one (u_n) and the attempt
(u_{n+1}). :class:`HistoryWindow` keeps u_{n-1} with its time and indenter position, and
the nodes' interaction states (2 on the wall, 1 in the cohesive zone, 0 beyond the range)
of u_{n-1}, u_n and the attempt, so that an accepted step's states are not recomputed by
the next estimate. It is a part of the run's state (:mod:`hpcgfmd.state`): a restored run
estimates the next step's error exactly as the uninterrupted one.

Invariant: after :meth:`accept`, the older state is the one before the accepted step and
the attempt's states are those of (u_n, u_{n+1}); a rejected attempt changes neither.
"""

from __future__ import annotations

import math

import numpy as np

from ..solvers.history_error import HistoryError
from ..solvers.step_kernels import interaction_state
from ..state import State


class HistoryWindow:
    """The older accepted state and the interaction states of the time-error estimate.

    Parameters
    ----------
    substrate : hpcgfmd.model.halfspace.Substrate
        The substrate whose history is estimated.
    fft : SerialRealFFT, HalvedRealFFT or TransposedRealFFT
        The case's transform (the estimate's one pair per step).
    domain : hpcgfmd.parallel.domain.Domain
        This rank's block of the surface.
    profile : numpy.ndarray
        The indenter's profile h(x) on this rank's nodes (length, R = 1).
    dmax : float
        The interaction range (length).
    crossing_reach : float, optional
        Distance from a crossing within which the estimate reads no curvature (length;
        :class:`HistoryError`).
    """

    def __init__(self, substrate, fft, domain, profile, dmax, crossing_reach=0.0):
        self.error = HistoryError(substrate, fft, domain, crossing_reach)
        self.profile, self.dmax = profile, dmax
        self._older = None  # (u, time, indenter) of the accepted state before the last
        # interaction states of u_{n-1} and u_n when known, and of the last attempt's two
        # latest states, which become them when it is accepted
        self._states = (None, None)
        self._attempt_states = None
        self._absent = np.zeros(domain.local_n)  # the older state before one is known

    def estimate(self, before, time_before, indenter_before, after, time_after, indenter_after):
        """Collective: the attempt's load error and the part of it kept in the history
        after the correction (:meth:`HistoryError.estimate`; (0, 0) before two steps were
        accepted). ``before``: u_n; ``after``: the attempt's u (this rank's blocks)."""
        self.error.forget()
        self._attempt_states = None
        if self._older is None:
            return 0.0, 0.0
        older, time_older, indenter_older = self._older
        state_older, state_before = self._states
        if state_older is None:
            state_older = self._state_at(older, indenter_older)
        if state_before is None:
            state_before = self._state_at(before, indenter_before)
        state = self._state_at(after, indenter_after)
        self._attempt_states = (state_before, state)
        return self.error.estimate(
            older,
            time_older,
            state_older,
            before,
            time_before,
            state_before,
            after,
            time_after,
            state,
        )

    def accept(self, before, time_before, indenter_before):
        """The attempt was accepted: correct the substrate's state (the exact-for-quadratic
        history, :meth:`HistoryError.correct`) and make u_n (``before``) the older state."""
        self.error.correct()
        if self._older is None:
            self._older = (np.empty_like(before), 0.0, 0.0)
        self._older[0][:] = before
        self._older = (self._older[0], float(time_before), float(indenter_before))
        self._states = self._attempt_states or (None, None)

    def restart(self):
        """A protocol segment begins (the drive's rate changes): forget the older state, the
        previous correction and the smooth curvature, so that no window spans the drive's
        kink. The segment's first step then has no estimate (as the first step after the
        preload), its second one a window within the segment."""
        self._older = None
        self._states = (None, None)
        self._attempt_states = None
        self.error.has_previous = False
        self.error.curvature_age = math.inf

    def _state_at(self, u, indenter):
        """Each node's interaction state for displacement u under the indenter at
        ``indenter`` (int8)."""
        state = np.empty(u.shape, dtype=np.int8)
        interaction_state(self.profile, indenter, u, self.dmax, state)
        return state

    # --- state -----------------------------------------------------------------------
    def state(self) -> State:
        """The older state and the estimate's memory (:mod:`hpcgfmd.state`; zeros for an
        older state not known yet)."""
        error, older = self.error, self._older
        return State(
            {
                "u_older": older[0] if older else self._absent,
                "curvature": error.smooth_curvature,
                "correction": error.previous_correction,
            },
            {
                "time_older": older[1] if older else math.nan,
                "indenter_older": older[2] if older else math.nan,
                "curvature_age": error.curvature_age,
                "curvature_time": error.curvature_time,
                "has_previous_correction": bool(error.has_previous),
                "previous_correction_reused": bool(error.previous_reused),
            },
        )

    def restore(self, state: State):
        """Continue from :meth:`state` (the attempt's interaction states are recomputed)."""
        self._states = (None, None)
        self._attempt_states = None
        s, error = state.scalars, self.error
        time_older = float(s["time_older"])
        if math.isnan(time_older):
            self._older = None
        else:
            self._older = (
                _kept(self._older, state.arrays["u_older"]),
                time_older,
                float(s["indenter_older"]),
            )
        error.curvature_age = float(s["curvature_age"])
        error.curvature_time = float(s["curvature_time"])
        error.smooth_curvature[:] = state.arrays["curvature"]
        error.previous_correction[:] = state.arrays["correction"]
        error.has_previous = bool(s["has_previous_correction"])
        error.previous_reused = bool(s["previous_correction_reused"])


def _kept(older, values):
    """``values`` copied into the older state's buffer (made when there is none)."""
    if older is None:
        return values.copy()
    older[0][:] = values
    return older[0]
