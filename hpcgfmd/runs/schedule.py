"""Where a run is in its loading protocol: the drive's value at a time, the segment's end.

docs/model.md, "Protocol", (M44): within segment s, started at time t_s with the drive's
value D_s, the drive moves as D(t) = D_s + r_s (t - t_s) (a position under displacement or
spring control, the applied load under load control; r_s = 0 in a dwell) until its target
is reached, at t_end = t_s + |target - D_s| / |r_s| (a dwell: t_s + duration), or, in a
retraction, until complete detachment. Steps are cut to end exactly at t_end, so a kink of
the drive never falls inside a step.

The paper's protocol is one retraction with an infinite target: D(t) = -h0 + v_z (t - 0),
bit for bit the u_z(t) = -h0 + v_z t of (M13).
"""

from __future__ import annotations

import math

from ..state import State


class Schedule:
    """The protocol's state: segment index, its start time, step and drive value.

    Parameters
    ----------
    segments : tuple of Segment
        The case's segments (:attr:`hpcgfmd.case.Case.segments`).
    load_control : bool
        The drive is the applied load (``drive_stiffness = 0``).
    """

    def __init__(self, segments, load_control=False):
        self.segments = segments
        self.load_control = load_control
        self.index = 0
        self.start_time = 0.0
        self.start_step = 0
        self.start_value = math.nan

    def begin(self, value: float):
        """The drive's value at t = 0 (after the start: the preload or out of contact)."""
        self.start_value = value

    @property
    def over(self) -> bool:
        """True after the last segment."""
        return self.index >= len(self.segments)

    @property
    def segment(self):
        return self.segments[min(self.index, len(self.segments) - 1)]

    def rate(self) -> float:
        """dD/dt of the current segment (R / tau, or E0 R / tau under load control)."""
        return self.segment.signed_rate(self.load_control)

    def end_time(self) -> float:
        """When the current segment reaches its target (inf: only detachment ends it)."""
        segment = self.segment
        if segment.kind == "dwell":
            return self.start_time + segment.target
        travel = (segment.target - self.start_value) * math.copysign(1.0, self.rate())
        if travel == math.inf:
            return math.inf
        return self.start_time + max(travel, 0.0) / segment.rate

    def value(self, time: float) -> float:
        """The drive's value D(t) in the current segment (its target from t_end on)."""
        segment = self.segment
        if segment.kind == "dwell":
            return self.start_value
        if time >= self.end_time():
            return segment.target
        return self.start_value + self.rate() * (time - self.start_time)

    def cut(self, time: float, dt: float):
        """(step, end): the step from ``time`` cut to the segment's end, and the end time
        when the step reaches it (else None)."""
        end = self.end_time()
        if time + dt < end:
            return dt, None
        return end - time, end

    def fixed_time(self, step_index: int, dt: float) -> float:
        """The time after fixed step ``step_index`` (no round-off accumulated over equal
        steps: counted from the segment's start)."""
        return self.start_time + (step_index - self.start_step) * dt

    def after_step(self, time: float, step_index: int, detached: bool) -> bool:
        """Move past the segments a step ending at ``time`` completed; True when the
        protocol is over. A retraction ends at its target or at complete detachment; under
        load control a detached indenter ends the protocol (no load to follow)."""
        while not self.over:
            segment = self.segment
            if not (time >= self.end_time() or (segment.kind == "retract" and detached)):
                return False
            if detached and self.load_control:
                self.index = len(self.segments)
                break
            value = self.value(time)
            self.index += 1
            self.start_time, self.start_step, self.start_value = time, step_index, value
        return True

    def state(self) -> State:
        """The schedule's position in the protocol (:mod:`hpcgfmd.state`)."""
        return State(
            scalars={
                "index": self.index,
                "start_time": self.start_time,
                "start_step": self.start_step,
                "start_value": self.start_value,
            }
        )

    def restore(self, state: State):
        """Continue from :meth:`state`."""
        s = state.scalars
        self.index, self.start_step = int(s["index"]), int(s["start_step"])
        self.start_time, self.start_value = float(s["start_time"]), float(s["start_value"])
