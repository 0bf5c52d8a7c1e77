"""The ``[[protocol]]`` tables of a case file checked and turned into segments in internal units
(:class:`~hpcgfmd.model.loading.Segment`; docs/case-file.md, "[[protocol]]")."""

from __future__ import annotations

import math

from ..errors import CaseError
from ..model.loading import KINDS, Segment


def parse_protocol(
    entries,
    *,
    length: float,
    time: float,
    load: float,
    speed: float,
    speed_scale: float,
    load_control: bool,
) -> tuple:
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
    if (
        not isinstance(entries, list)
        or not entries
        or not all(isinstance(entry, dict) for entry in entries)
    ):
        raise CaseError(
            f"protocol = {_shown(entries)}: expected one or more [[protocol]]"
            " tables (approach, dwell or retract)"
        )
    units = dict(
        length=length,
        time=time,
        load=load,
        speed=speed,
        speed_scale=speed_scale,
        load_control=load_control,
    )
    segments = tuple(
        _segment(entry, f"[[protocol]] {number}", **units)
        for number, entry in enumerate(entries, start=1)
    )
    if load_control:
        if segments[0].kind == "approach":
            raise CaseError(
                "[[protocol]] 1 approach: under load control (drive_stiffness = 0)"
                " the run starts from the preload at depth; an approach from out"
                " of contact has no load to follow; start with a dwell or a retract"
            )
        for number, segment in enumerate(segments[:-1], start=1):
            if segment.kind == "retract" and segment.target == -math.inf:
                raise CaseError(
                    f"[[protocol]] {number} retract = -inf: under load control a"
                    " retraction until detachment must be the last segment (a"
                    " detached indenter has no load to follow)"
                )
    return segments


def _segment(entry, where, *, length, time, load, speed, speed_scale, load_control):
    """One ``[[protocol]]`` table -> its Segment (:func:`parse_protocol`)."""
    kinds = [key for key in entry if key in KINDS]
    if len(kinds) != 1:
        raise CaseError(
            f"{where}: {', '.join(kinds) or 'no kind'}: expected exactly one of {', '.join(KINDS)}"
        )
    kind = kinds[0]
    rate_key = "load_rate" if load_control else "velocity"
    allowed = (kind,) if kind == "dwell" else (kind, rate_key)
    for key in entry:
        if key not in allowed:
            why = (
                " (load_rate needs drive_stiffness = 0: load control)"
                if key == "load_rate"
                else " (load control moves the load: give load_rate)"
                if key == "velocity" and load_control
                else ""
            )
            raise CaseError(
                f"{where} {key}: not accepted with {kind}{why}; accepted: {', '.join(allowed)}"
            )
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
        accepted = (
            "a finite number"
            if open_end is None
            else f"a finite number or {open_end} (until detachment)"
        )
        raise CaseError(f"{where} {kind} = {_shown(value)}: expected {accepted}")
    if load_control:
        target = value / load
    else:  # approach = depth below the surface: the drive's position is -depth
        target = (-value if kind == "approach" else value) / length
    if rate_key in entry:
        rate = entry[rate_key]
        if (
            isinstance(rate, bool)
            or not isinstance(rate, (int, float))
            or not 0.0 < rate < math.inf
        ):
            raise CaseError(f"{where} {rate_key} = {_shown(rate)}: expected a finite number > 0")
        rate = rate * (load / time if load_control else speed_scale)
    elif load_control:
        raise CaseError(
            f"{where} load_rate is missing: under load control (drive_stiffness"
            f" = 0) an {kind} needs a load rate > 0"
        )
    else:
        rate = speed
    return Segment(kind, target, float(rate))


def _shown(value) -> str:
    if isinstance(value, bool):
        return str(value).lower()
    return repr(value) if isinstance(value, str) else str(value)
