"""The run's watch: the stop signals looked at in every phase, and a line at least every so
often whatever the phase (docs/parallel.md, "Signals, checkpoints, resuming").

A run goes through phases: planning the transforms, the preload (its coarse levels, then the
fine grid), the steps (each a solve), the output. The solvers call :meth:`Watch.flag` in each
iteration and put it into the reduction they make anyway, so a signal on any rank stops
every rank at the same iteration within a fraction of a second; between phases the run
calls :meth:`Watch.check`. A stop raises :class:`StopRequested` on every rank alike; the run
then keeps what is worth keeping (the last accepted step's checkpoint) and ends with the
signal's status. :meth:`Watch.beat`, called by the solvers each iteration, logs the phase,
the iteration and the residual when nothing was logged for ``interval`` seconds.
"""

from __future__ import annotations

import logging
import time

from mpi4py import MPI

logger = logging.getLogger(__name__)

HEARTBEAT = 30.0  # wall seconds: the longest a run stays silent, whatever the phase


class StopRequested(Exception):
    """A stop signal was seen in a phase (raised on every rank alike: the flag is reduced)."""


class Watch:
    """The stop flag and the heartbeat of one run (module docstring).

    Parameters
    ----------
    stop : hpcgfmd.signals.StopSignals or None
        The process's signals (None: never stops).
    interval : float
        Wall seconds of silence after which :meth:`beat` logs a line (at most HEARTBEAT).
    """

    def __init__(self, stop=None, interval=HEARTBEAT):
        self.stop = stop
        self.interval = min(interval, HEARTBEAT)
        self.phase = "set-up"
        self.levels = None  # the preload's grids, coarsest first (the finest level sets them)
        self.started_iterations = None  # of the last preload level started from the one below
        self._last = self._phase_start = time.monotonic()

    def flag(self) -> float:
        """Local: 1.0 when a stop signal was received by this process, else 0.0 (to reduce)."""
        return 1.0 if self.stop is not None and self.stop.received is not None else 0.0

    def enter(self, phase: str):
        """A new phase begins (its name heads the heartbeat's lines; its start counts as a
        sign of life: between steps the run's progress lines speak)."""
        self.phase = phase
        self._last = self._phase_start = time.monotonic()

    def beat(self, iteration: int, residual: float | None = None):
        """A solver's iteration: a line when nothing was logged for ``interval`` seconds."""
        now = time.monotonic()
        if now - self._last >= self.interval:
            measure = "" if residual is None else f", residual {residual:.3g}"
            self.note(
                f"{self.phase}: iteration {iteration}{measure},"
                f" {now - self._phase_start:.0f} s in it"
            )

    def note(self, line: str):
        """Log ``line`` (rank 0 prints) and restart the heartbeat's clock."""
        logger.info(line)
        self._last = time.monotonic()

    def check(self, comm):
        """Collective: raise :class:`StopRequested` on every rank when any rank received a
        stop signal (between phases)."""
        if comm.allreduce(self.flag(), op=MPI.MAX) > 0.0:
            raise StopRequested(self.phase)
