"""Reading one key of a case file: every problem a :class:`~hpcgfmd.errors.CaseError` of one
line naming the section, the key, the value as written and what is accepted (docs/case-file.md).
"""

from __future__ import annotations

import math
import numbers

from ..errors import CaseError


def quoted_key(name) -> str:
    """A key or section name as written, quoted unless it is a bare TOML key."""
    return (
        name
        if name and all(c.isascii() and (c.isalnum() or c in "_-") for c in name)
        else repr(name)
    )


def as_float(value) -> float:
    """float(value); inf for an integer beyond the float range."""
    try:
        return float(value)
    except OverflowError:
        return math.inf


def shown(value) -> str:
    """A value as the case file writes it (strings quoted, booleans lower case)."""
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, bool):
        return str(value).lower()
    return str(value)


def number(table, section, key):
    """A finite number > 0 from ``table[key]`` (CaseError naming the key otherwise)."""
    if key not in table:
        raise CaseError(f"[{section}] {key} is missing: a number > 0 is required")
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise CaseError(f"[{section}] {key} = {shown(value)}: expected a number")
    result = as_float(value)
    if not math.isfinite(result) or result <= 0.0:
        written = value if isinstance(value, int) and math.isinf(result) else result
        raise CaseError(f"[{section}] {key} = {shown(written)}: expected a finite number > 0")
    return result


def integer(table, section, key, smallest):
    """An integer >= ``smallest`` from ``table[key]``."""
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, int) or value < smallest:
        raise CaseError(f"[{section}] {key} = {shown(value)}: expected an integer >= {smallest}")
    return value


def choice(table, section, key, accepted):
    """One of ``accepted`` from ``table[key]`` (the first when the key is left out)."""
    value = table.get(key, accepted[0])
    if value not in accepted:
        raise CaseError(
            f"[{section}] {key} = {shown(value)}: expected one of"
            f" {', '.join(repr(a) for a in accepted)}"
        )
    return value


def unknown_keys(table, section, allowed):
    """CaseError for the first key of ``table`` not among ``allowed``."""
    for key in table:
        if key not in allowed:
            raise CaseError(
                f"[{section}] {quoted_key(key)}: unknown key; accepted: {', '.join(allowed)}"
            )


def numbers_list(table, section, key, units_scale):
    """A sorted tuple of numbers >= 0 from ``table[key]`` (empty when left out), divided by
    ``units_scale`` (case units -> internal units)."""
    value = table.get(key, [])
    if not isinstance(value, list) or any(
        isinstance(v, bool)
        or not isinstance(v, (int, float))
        or not math.isfinite(as_float(v))
        or v < 0
        for v in value
    ):
        raise CaseError(f"[{section}] {key} = {shown(value)}: expected a list of numbers >= 0")
    return tuple(sorted(float(v) / units_scale for v in value))


def positive_list(value, section, key):
    """A tuple of finite numbers > 0 from a non-empty list (CaseError naming the key)."""
    if value is None:
        raise CaseError(
            f"[{section}] {key} is missing: a Prony series needs"
            " relaxation_moduli and relaxation_times"
        )
    if (
        isinstance(value, (str, bytes))
        or not hasattr(value, "__len__")
        or len(value) == 0
        or any(
            isinstance(v, bool)
            or not isinstance(v, numbers.Real)
            or not 0.0 < as_float(v) < math.inf
            for v in value
        )
    ):
        raise CaseError(
            f"[{section}] {key} = {shown(value)}: expected a non-empty list of finite numbers > 0"
        )
    return tuple(float(v) for v in value)


def prony_series(moduli, times, section):
    """(moduli, times) of a Prony series: two lists of numbers > 0 of one length."""
    moduli = positive_list(moduli, section, "relaxation_moduli")
    times = positive_list(times, section, "relaxation_times")
    if len(moduli) != len(times):
        raise CaseError(
            f"[{section}] relaxation_times = {shown(list(times))}: expected as"
            f" many times as relaxation_moduli ({len(moduli)})"
        )
    return moduli, times


def stiffness(table, section):
    """drive_stiffness: a finite number > 0 (a spring), or 0 (load control)."""
    value = table["drive_stiffness"]
    if isinstance(value, (int, float)) and not isinstance(value, bool) and value == 0:
        return 0.0
    try:
        return number(table, section, "drive_stiffness")
    except CaseError:
        raise CaseError(
            f"[{section}] drive_stiffness = {shown(value)}: expected a finite"
            " number > 0 (a spring) or 0 (load control)"
        ) from None
