"""SIGTERM, SIGUSR1 and SIGINT as requests to stop cleanly.

SIGTERM and SIGUSR1 (what SLURM and ``timeout`` send before a limit) ask a run to stop after
a checkpoint (exit status 75); SIGINT (Ctrl-C) asks it to stop the same way with status 130.
While a run listens (:meth:`StopSignals.listening`) every signal only sets a flag, which the
run looks at in every phase (planning, preload, a step's solve, the output) through one
reduction, so that all ranks stop together within a few seconds. Outside a run, SIGINT is
Python's KeyboardInterrupt, which the entry point turns into one line (and a second SIGINT
while a run is stopping is too).

No heavy imports: the entry point installs the handler first thing, so a signal that arrives
while Python, numpy or FFTW are still starting up is recorded instead of killing the process.
"""

from __future__ import annotations

import contextlib
import signal

STOP_SIGNALS = (signal.SIGTERM, signal.SIGUSR1)
HANDLED = (*STOP_SIGNALS, signal.SIGINT)
EXIT_INTERRUPTED = 130  # 128 + SIGINT, the shell's status of a Ctrl-C


class StopSignals:
    """Context manager that records SIGTERM, SIGUSR1 and SIGINT instead of dying on them.

    Attributes
    ----------
    received : int or None
        The last stop signal received (None: none).
    """

    def __enter__(self):
        self.received = None
        self._listening = 0
        self._previous = {s: signal.signal(s, self._handle) for s in HANDLED}
        return self

    def _handle(self, signum, frame):
        if signum == signal.SIGINT and (not self._listening or self.received == signal.SIGINT):
            raise KeyboardInterrupt  # no run to stop cleanly, or the user insists
        self.received = signum

    @contextlib.contextmanager
    def listening(self):
        """A run in progress: SIGINT, too, only asks it to stop."""
        self._listening += 1
        try:
            yield self
        finally:
            self._listening -= 1

    @property
    def interrupted(self) -> bool:
        """SIGINT was received (the stop's exit status is 130, not 75)."""
        return self.received == signal.SIGINT

    def __exit__(self, *exc):
        for s, handler in self._previous.items():
            signal.signal(s, handler)
        return False
