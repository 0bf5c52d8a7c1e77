"""Progress lines of a running case, through the ``hpcgfmd`` logger (rank 0 prints them)."""
from __future__ import annotations

import logging
import time

logger = logging.getLogger(__name__)


class Progress:
    """Logs one line every ``interval`` seconds of wall time: step, time, load, contact width.

    The estimate of the time left extrapolates the fraction of the initial contact width
    that has been peeled off.

    Parameters
    ----------
    interval : float
        Wall seconds between lines.
    units : hpcgfmd.case.Units
        The case's units (the line shows time, load and width in them).
    """

    def __init__(self, interval, units):
        self.interval = interval
        self.units = units
        self.start = time.monotonic()
        self.last = self.start
        self.first_width = None

    def update(self, step, record):
        """Called after every accepted step with its :class:`~.protocol.StepRecord`."""
        now = time.monotonic()
        if self.first_width is None:
            self.first_width = record.contact_half_width
        if now - self.last < self.interval:
            return
        self.last = now
        elapsed = now - self.start
        done = 1.0 - record.contact_half_width / self.first_width if self.first_width else 0.0
        eta = f"{elapsed * (1.0 - done) / done:.0f} s" if done > 0.02 else "?"
        u = self.units
        logger.info(f"step {step:6d}  t = {record.time * u.time:.5g}"
                    f"  load = {record.load * u.load:.5g}"
                    f"  a_c = {record.contact_half_width * u.length:.5g}"
                    f"  iterations = {record.iterations:4d}"
                    f"  elapsed {elapsed:.0f} s, left ~{eta} (from contact width)")
