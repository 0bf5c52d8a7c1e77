"""The three accepted states the history's time-error estimate reads (docs/numerics.md,
"Time steps").

:class:`~hpcgfmd.solvers.stepping.HistoryError` fits u quadratic in time through the
state before the last accepted step (u_{n-1}), the last accepted one (u_n) and the attempt
(u_{n+1}). :class:`HistoryWindow` keeps u_{n-1} with its time and indenter position, and
the nodes' interaction states (2 on the wall, 1 in the cohesive zone, 0 beyond the range)
of u_{n-1}, u_n and the attempt, so that an accepted step's states are not recomputed by
the next estimate. It is part of the checkpoint: a restored run estimates the next step's
error exactly as the uninterrupted one.

Invariant: after :meth:`accept`, the older state is the one before the accepted step and
the attempt's states are those of (u_n, u_{n+1}); a rejected attempt changes neither.
"""
from __future__ import annotations

import math

import numpy as np

from ..solvers.step_kernels import interaction_state
from ..solvers.stepping import HistoryError


class HistoryWindow:
    """The older accepted state and the interaction states of the time-error estimate.

    Parameters
    ----------
    substrate : ViscoelasticHalfSpace or MaxwellHalfSpace
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

    #: the checkpoint's fields of the window (zeros when it holds none yet)
    FIELDS = ("u_older", "history_curvature", "history_correction")

    def __init__(self, substrate, fft, domain, profile, dmax, crossing_reach=0.0):
        self.error = HistoryError(substrate, fft, domain, crossing_reach)
        self.profile, self.dmax = profile, dmax
        self._older = None  # (u, time, indenter) of the accepted state before the last
        # interaction states of u_{n-1} and u_n when known, and of the last attempt's two
        # latest states, which become them when it is accepted
        self._states = (None, None)
        self._attempt_states = None

    def estimate(self, before, time_before, indenter_before, after, time_after,
                 indenter_after):
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
        return self.error.estimate(older, time_older, state_older, before, time_before,
                                   state_before, after, time_after, state)

    def accept(self, substrate_traction, before, time_before, indenter_before):
        """The attempt was accepted: correct its substrate traction (the exact-for-quadratic
        history, :meth:`HistoryError.correct`) and make u_n (``before``) the older state."""
        self.error.correct(substrate_traction)
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

    # --- checkpoint ----------------------------------------------------------------------
    def fields(self, absent):
        """This rank's checkpoint fields (``absent``, a zero block, for none yet)."""
        return {"u_older": self._older[0] if self._older else absent,
                "history_curvature": self.error.smooth_curvature,
                "history_correction": self.error.previous_correction}

    def attrs(self):
        """The rank-independent scalars of the checkpoint."""
        return dict(
            time_older=self._older[1] if self._older else math.nan,
            indenter_older=self._older[2] if self._older else math.nan,
            curvature_age=self.error.curvature_age,
            curvature_time=self.error.curvature_time,
            has_previous_correction=bool(self.error.has_previous),
            previous_correction_reused=bool(self.error.previous_reused))

    @staticmethod
    def empty_attrs():
        """The checkpoint's scalars of a run without the estimate."""
        return dict(time_older=math.nan, indenter_older=math.nan, curvature_age=math.inf,
                    curvature_time=-math.inf, has_previous_correction=False,
                    previous_correction_reused=False)

    def restore(self, fields, attrs, indenter_at):
        """Continue from :meth:`fields` and :meth:`attrs`. Checkpoints older than a key
        restart the estimate as the run did when the key did not exist: no older indenter
        position (``indenter_at(time)``, the paper's drive, gives it), no smooth curvature,
        no previous correction (the first estimate then bounds the correction's error by
        the step's)."""
        self._states = (None, None)
        self._attempt_states = None
        time_older = float(attrs.get("time_older", math.nan))
        indenter_older = float(attrs.get("indenter_older", indenter_at(time_older)))
        self._older = (None if math.isnan(time_older)
                       else (fields["u_older"].copy(), time_older, indenter_older))
        error = self.error
        error.curvature_age = float(attrs.get("curvature_age", math.inf))
        error.curvature_time = float(attrs.get("curvature_time", -math.inf))
        if "history_curvature" in fields:
            error.smooth_curvature[:] = fields["history_curvature"]
        previous = "history_correction" in fields and bool(
            attrs.get("has_previous_correction", False))
        error.has_previous = previous
        error.previous_reused = bool(attrs.get("previous_correction_reused", False))
        if previous:
            error.previous_correction[:] = fields["history_correction"]
