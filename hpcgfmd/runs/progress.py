"""Progress lines of a running case, through the ``hpcgfmd`` logger (rank 0 prints them)."""

from __future__ import annotations

import logging
import math
import time

from .cost import plan

logger = logging.getLogger(__name__)
MIN_DONE = 0.01  # the share of the protocol done before the time left is extrapolated
MAX_SEGMENT_SHARE = 0.99  # a segment is never taken as done before the next one starts


def duration_text(seconds) -> str:
    """Seconds as a person reads them: "42 s", "12 min 05 s", "3 h 07 min"; "?" for None
    or a non-finite value."""
    if seconds is None or not math.isfinite(seconds):
        return "?"
    seconds = max(0.0, seconds)
    if seconds < 60.0:
        return f"{seconds:.0f} s"
    minutes, rest = divmod(round(seconds), 60)
    if minutes < 60:
        return f"{minutes} min {rest:02d} s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours} h {minutes:02d} min"


class Progress:
    """Logs one line every ``interval`` seconds of wall time: step, time, load, contact width,
    the step's iterations, the time elapsed and the time left.

    The time left extrapolates the share of the protocol done since the first line's step
    (until 1 % is done, "?" and the cost model's core-hours of the whole protocol):
    each segment weighs its estimated cost (:func:`hpcgfmd.runs.cost.plan`), and the current
    one counts the share of its travel the drive has made (from its start to its target, or
    to the estimated detachment of a retraction "until detachment"; a dwell: its time), and,
    for the share of its steps the contact edge's motion sets (``edge_weight``), the share of
    the contact half-width's estimated travel made: a retraction whose steps follow its
    peeling edge has done little while the edge still stands, however far the drive went.
    Every protocol has one, from the paper's retraction to an approach, dwell and cycles.

    Parameters
    ----------
    interval : float
        Wall seconds between lines.
    units : hpcgfmd.case.Units
        The case's units (the line shows time, load and width in them).
    case : hpcgfmd.case.Case, optional
        The case, for its protocol's plan; without it the time left is "?".
    """

    def __init__(self, interval, units, case=None):
        self.interval = interval
        self.units = units
        # a sphere's load is a force (E0 R^2), a cylinder's a load per length (E0 R)
        self.load_unit = case.load_unit if case is not None else units.load
        self.start = time.monotonic()
        self.last = self.start
        try:
            self.plan = plan(case) if case is not None else None
        except (ArithmeticError, ValueError):  # an estimate must never stop a run
            self.plan = None
        self.segment = 0
        # (time, drive, contact half-width) where the current segment started; the first
        # width is the first record's
        self.segment_start = (0.0, self.plan[0].start if self.plan else math.nan, math.nan)
        self.previous = self.segment_start
        self.first_done = None

    def done(self, record) -> float:
        """The share of the protocol's estimated cost done at ``record`` (0 to 1; NaN
        without a plan). Call with every record in order (segment starts are tracked)."""
        if record.segment != self.segment:
            self.segment, self.segment_start = record.segment, self.previous
        if math.isnan(self.segment_start[2]):
            self.segment_start = (*self.segment_start[:2], record.contact_half_width)
        self.previous = (record.time, record.drive, record.contact_half_width)
        if not self.plan or self.segment >= len(self.plan):
            return math.nan
        weights = [max(segment.seconds, 1e-12) for segment in self.plan]
        current = self.plan[self.segment]
        start_time, start_value, start_width = self.segment_start
        if current.kind == "dwell":
            share = (record.time - start_time) / current.duration if current.duration else 1.0
        else:
            if math.isnan(start_value):
                start_value = current.start
            # a retraction until detachment: the estimated travel from where it started
            end = start_value + current.end - current.start if current.detaches else current.end
            span = end - start_value
            share = _clipped((record.drive - start_value) / span if span else 1.0)
            # the edge's travel from the half-width measured at the segment's start (the
            # estimate's is the geometric contact, without the adhesive neck)
            travel = current.end_width - start_width
            if current.edge_weight > 0.0 and travel != 0.0:
                edge = (record.contact_half_width - start_width) / travel
                weight = current.edge_weight
                share = (1.0 - weight) * share + weight * _clipped(edge)
        share = min(max(share, 0.0), MAX_SEGMENT_SHARE)
        return (math.fsum(weights[: self.segment]) + share * weights[self.segment]) / math.fsum(
            weights
        )

    def left(self, done, elapsed):
        """Seconds left, extrapolated from the share done since the first line, or None."""
        if self.first_done is None or not math.isfinite(done):
            return None
        gained = done - self.first_done
        if gained < MIN_DONE:
            return None
        return elapsed * (1.0 - done) / gained

    def update(self, step, record):
        """Called after every accepted step with its :class:`~.protocol.StepRecord`."""
        now = time.monotonic()
        done = self.done(record)
        if self.first_done is None:
            self.first_done = done if math.isfinite(done) else None
        if now - self.last < self.interval:
            return
        self.last = now
        elapsed = now - self.start
        u = self.units
        left = self.left(done, elapsed)
        share = f" ({done:.0%} of the protocol)" if math.isfinite(done) else ""
        if left is None and self.plan and share:  # too little done: the model's total
            total = math.fsum(segment.seconds for segment in self.plan) / 3600.0
            share = share[:-1] + f", {total:.3g} core-hours in all by the cost model)"
        logger.info(
            f"step {step:6d}  t = {record.time * u.time:.5g}"
            f"  load = {record.load * self.load_unit:.5g}"
            f"  a_c = {record.contact_half_width * u.length:.5g}"
            f"  iterations = {record.iterations:4d}"
            f"  elapsed {duration_text(elapsed)}, left ~"
            f"{duration_text(left)}{share}"
        )


def _clipped(share) -> float:
    return min(max(share, 0.0), 1.0)
