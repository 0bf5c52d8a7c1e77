"""Loading protocols: the segments the drive follows (docs/model.md, "Protocol", (M44)).

A case file may list segments, in order, as an array of tables::

    [[protocol]]
    approach = 0.1     # the drive descends to u_z = -0.1 R (from out of contact)
    velocity = 0.45    # at V_z = 0.45 (optional: [case] velocity)
    [[protocol]]
    dwell = 2.0        # held for 2 tau
    [[protocol]]
    retract = inf      # the drive rises to u_z = +inf R: until complete detachment

``approach = depth`` moves the drive down to u_z = -depth at ``velocity``, ``retract =
height`` up to u_z = height (``inf``: until complete detachment), ``dwell = duration`` holds
it. A retraction also ends at complete detachment; the next segment (an approach of the next
cycle) starts from there. Under load control (``drive_stiffness = 0``) the drive is the
applied load: ``approach = load`` raises it and ``retract = load`` (``-inf``: until
detachment) lowers it at ``load_rate``, ``dwell`` holds it.

Units: [case] lengths in R, times in tau (tau_r for a Prony series), velocities in V_z
units (v_z = V_z beta^2 R / tau), loads in E0 R and load rates in E0 R / tau; [physical]
m, s, m/s, N/m, N/(m s); :func:`hpcgfmd.case.protocol.parse_protocol` turns them into
internal units (R = E0 = tau = 1).

Where the run starts: with an approach first, out of contact, the relaxed flat substrate
with the cylinder's apex one interaction range out of reach (u_z = 2 dmax); otherwise the
relaxed preload at ``depth`` (the paper's start). No ``[[protocol]]`` is the paper's
protocol: the preload, then one retraction at ``velocity`` until complete detachment.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

KINDS = ("approach", "dwell", "retract")
START_HEIGHT = 2.0  # an approach from out of contact starts at u_z = 2 dmax (in dmax)


@dataclass(frozen=True)
class Segment:
    """One segment of a loading protocol (internal units).

    Attributes
    ----------
    kind : {"approach", "dwell", "retract"}
    target : float
        approach: the drive's end position -depth (R) or, under load control, its end load
        (E0 R); retract: the end height (R; +inf: until detachment) or end load (E0 R; -inf);
        dwell: the duration (tau).
    rate : float
        The drive's speed |dZ/dt| (R / tau) or the load's |dF/dt| (E0 R / tau); 0 for a dwell.
    """

    kind: str
    target: float
    rate: float

    @property
    def direction(self) -> int:
        """The sign of the indenter's motion: -1 down (approach), +1 up (retract), 0 held.
        Under load control the load moves the other way (:meth:`signed_rate`)."""
        return {"approach": -1, "dwell": 0, "retract": 1}[self.kind]

    def signed_rate(self, load_control: bool) -> float:
        """dZ/dt (R / tau) or, under load control, dF/dt (E0 R / tau) during the segment."""
        sign = -self.direction if load_control else self.direction
        return sign * self.rate


def cycle_of(segments, index: int) -> int:
    """The cycle of segment ``index``: the number of retractions before it (a cycle ends with
    its retraction; dwells after it belong to the next cycle). ``segments``: Segments or
    their kinds."""
    return sum(1 for segment in segments[:index] if getattr(segment, "kind", segment) == "retract")


def paper_protocol(speed: float) -> tuple:
    """The paper's protocol after the preload: one retraction at ``speed`` until detachment."""
    return (Segment("retract", math.inf, speed),)
