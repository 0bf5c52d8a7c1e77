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
m, s, m/s, N/m, N/(m s). :func:`parse_protocol` returns internal units (R = E0 = tau = 1).

Where the run starts: with an approach first, out of contact, the relaxed flat substrate
with the cylinder's apex one interaction range out of reach (u_z = 2 dmax); otherwise the
relaxed preload at ``depth`` (the paper's start). No ``[[protocol]]`` is the paper's
protocol: the preload, then one retraction at ``velocity`` until complete detachment.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import CaseError

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
    return sum(1 for segment in segments[:index]
               if getattr(segment, "kind", segment) == "retract")


def paper_protocol(speed: float) -> tuple:
    """The paper's protocol after the preload: one retraction at ``speed`` until detachment."""
    return (Segment("retract", math.inf, speed),)


def parse_protocol(entries, *, length: float, time: float, load: float,
                   speed: float, speed_scale: float, load_control: bool) -> tuple:
    """Validate the ``[[protocol]]`` tables of a case file -> segments in internal units.

    Parameters
    ----------
    entries : list of dict
        The array of tables as TOML gives it.
    length, time, load : float
        The case's units of length, time and load per length (1 for [case]: R, tau, E0 R).
    speed : float
        The retraction speed of ``[case] velocity`` (internal units): a segment's default.
    speed_scale : float
        Internal speed of a velocity of 1 in the case's units: beta^2 for [case] (V_z
        units), 1 / (length / time) for [physical] (m/s).
    load_control : bool
        ``drive_stiffness = 0``: the segments move the applied load, not the drive.

    Raises
    ------
    CaseError
        One line naming the segment, the key, the value and what is accepted.
    """
    if not isinstance(entries, list) or not entries or not all(
            isinstance(entry, dict) for entry in entries):
        raise CaseError(f"protocol = {_shown(entries)}: expected one or more [[protocol]]"
                        " tables (approach, dwell or retract)")
    units = dict(length=length, time=time, load=load, speed=speed, speed_scale=speed_scale,
                 load_control=load_control)
    segments = tuple(_segment(entry, f"[[protocol]] {number}", **units)
                     for number, entry in enumerate(entries, start=1))
    if load_control:
        if segments[0].kind == "approach":
            raise CaseError("[[protocol]] 1 approach: under load control (drive_stiffness = 0)"
                            " the run starts from the preload at depth; an approach from out"
                            " of contact has no load to follow; start with a dwell or a retract")
        for number, segment in enumerate(segments[:-1], start=1):
            if segment.kind == "retract" and segment.target == -math.inf:
                raise CaseError(f"[[protocol]] {number} retract = -inf: under load control a"
                                " retraction until detachment must be the last segment (a"
                                " detached indenter has no load to follow)")
    return segments


def _segment(entry, where, *, length, time, load, speed, speed_scale, load_control):
    """One ``[[protocol]]`` table -> its Segment (:func:`parse_protocol`)."""
    kinds = [key for key in entry if key in KINDS]
    if len(kinds) != 1:
        raise CaseError(f"{where}: {', '.join(kinds) or 'no kind'}: expected exactly one of"
                        f" {', '.join(KINDS)}")
    kind = kinds[0]
    rate_key = "load_rate" if load_control else "velocity"
    allowed = (kind,) if kind == "dwell" else (kind, rate_key)
    for key in entry:
        if key not in allowed:
            why = (" (load_rate needs drive_stiffness = 0: load control)" if key == "load_rate"
                   else " (load control moves the load: give load_rate)"
                   if key == "velocity" and load_control else "")
            raise CaseError(f"{where} {key}: not accepted with {kind}{why}; accepted:"
                            f" {', '.join(allowed)}")
    value = entry[kind]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or math.isnan(value):
        raise CaseError(f"{where} {kind} = {_shown(value)}: expected a number")
    value = float(value)
    if kind == "dwell":
        if not 0.0 < value < math.inf:
            raise CaseError(f"{where} dwell = {_shown(value)}: expected a duration > 0")
        return Segment("dwell", value / time, 0.0)
    # the infinite end a retraction may have: until detachment
    open_end = (-math.inf if load_control else math.inf) if kind == "retract" else None
    if not (math.isfinite(value) or value == open_end):
        accepted = ("a finite number" if open_end is None
                    else f"a finite number or {open_end} (until detachment)")
        raise CaseError(f"{where} {kind} = {_shown(value)}: expected {accepted}")
    if load_control:
        target = value / load
    else:  # approach = depth below the surface: the drive's position is -depth
        target = (-value if kind == "approach" else value) / length
    if rate_key in entry:
        rate = entry[rate_key]
        if (isinstance(rate, bool) or not isinstance(rate, (int, float))
                or not 0.0 < rate < math.inf):
            raise CaseError(f"{where} {rate_key} = {_shown(rate)}: expected a finite number > 0")
        rate = rate * (load / time if load_control else speed_scale)
    elif load_control:
        raise CaseError(f"{where} load_rate is missing: under load control (drive_stiffness"
                        f" = 0) an {kind} needs a load rate > 0")
    else:
        rate = speed
    return Segment(kind, target, float(rate))


def _shown(value) -> str:
    if isinstance(value, bool):
        return str(value).lower()
    return repr(value) if isinstance(value, str) else str(value)
