"""SIGTERM and SIGUSR1 as requests to stop after a checkpoint (what SLURM sends before the limit).

No heavy imports: the entry point installs the handler first thing, so a signal that arrives
while Python, numpy or FFTW are still starting up is recorded instead of killing the process.
"""

from __future__ import annotations

import signal

STOP_SIGNALS = (signal.SIGTERM, signal.SIGUSR1)


class StopSignals:
    """Context manager that records SIGTERM/SIGUSR1 instead of dying on them.

    The handler only sets a flag; the run acts on it at the end of the current step, after
    the ranks agreed on it (one reduction), so all of them stop at the same step.
    """

    def __enter__(self):
        self.received = None
        self._previous = {s: signal.signal(s, self._handle) for s in STOP_SIGNALS}
        return self

    def _handle(self, signum, frame):
        self.received = signum

    def __exit__(self, *exc):
        for s, handler in self._previous.items():
            signal.signal(s, handler)
        return False
