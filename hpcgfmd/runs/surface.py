"""The surface and the indenter at the last step: what a run advances (a part of its state)."""

from __future__ import annotations

import math

import numpy as np

from ..parallel.fft import aligned_empty
from ..state import State


class Surface:
    """Displacement, interface traction, clock and positions of one case on this rank.

    Attributes
    ----------
    u : ndarray
        Surface displacement, upward positive (length), this rank's block (aligned: the
        serial transform reads it in place).
    traction : ndarray
        Traction of the indenter on the substrate, attractive positive (stress).
    time : float
        t (tau).
    indenter : float
        u_z, the indenter's apex above the undeformed surface (length).
    drive : float
        The drive's value: the spring's far end Z, or the applied load under load control
        (the indenter itself under displacement control).
    step_index : int
        Accepted steps since the start.
    dt_previous : float or None
        Length of the last accepted step (None after the start).
    """

    def __init__(self, local_n: int, indenter: float):
        self.u = aligned_empty(local_n)
        self.u[:] = 0.0
        self.traction = np.zeros(local_n)
        self.time = 0.0
        self.indenter = self.drive = indenter
        self.step_index = 0
        self.dt_previous = None

    def state(self) -> State:
        return State(
            {"u": self.u, "traction": self.traction},
            {
                "time": self.time,
                "indenter": self.indenter,
                "drive": self.drive,
                "step_index": self.step_index,
                "dt_previous": math.nan if self.dt_previous is None else self.dt_previous,
            },
        )

    def restore(self, state: State):
        self.u[:] = state.arrays["u"]
        self.traction[:] = state.arrays["traction"]
        s = state.scalars
        self.time, self.indenter, self.drive = (float(s[k]) for k in ("time", "indenter", "drive"))
        self.step_index = int(s["step_index"])
        dt_previous = float(s["dt_previous"])
        self.dt_previous = None if math.isnan(dt_previous) else dt_previous
