"""Case files (TOML, docs/case-file.md): read and checked section by section into the keyword
arguments of a :class:`~.case.Case` (which checks the values)."""

from __future__ import annotations

import tomllib

from ..errors import CaseError
from .groups import DRIVE_KEYS, GEOMETRY_KEYS, GROUP_KEYS, PRONY_KEYS
from .keys import number, quoted_key, shown, stiffness, unknown_keys
from .numerics import numerics_keys
from .output import OUTPUT_KEYS
from .units import PHYSICAL_KEYS, Units, groups_from_physical


def sections() -> dict:
    """The sections of a case file and their keys (``[[protocol]]`` apart)."""
    return {
        "case": GEOMETRY_KEYS + GROUP_KEYS + PRONY_KEYS + DRIVE_KEYS,
        "physical": GEOMETRY_KEYS + PHYSICAL_KEYS + PRONY_KEYS + DRIVE_KEYS,
        "numerics": numerics_keys(),
        "output": OUTPUT_KEYS,
    }


def read_case_file(path) -> str:
    """The text of a case file (raises :class:`CaseError`, also for unreadable files)."""
    try:
        with open(path, "rb") as fh:
            raw = fh.read()
    except OSError as err:
        raise CaseError(f"cannot read case file: {err.strerror}") from None
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        raise CaseError("case file is not UTF-8 text") from None


def case_arguments(text: str) -> dict:
    """The keyword arguments of the :class:`~.case.Case` of a case file's text, its sections
    and keys checked (raises :class:`CaseError`)."""
    try:
        doc = tomllib.loads(text)
    except RecursionError:
        raise CaseError("not valid TOML: arrays or inline tables nested too deeply") from None
    except ValueError as err:  # TOMLDecodeError, or int()'s limit of 4300 digits
        raise CaseError(f"not valid TOML: {err}") from None
    known = sections()
    for name, value in doc.items():
        if name == "protocol":  # [[protocol]]: checked with the case (case/protocol.py)
            continue
        if name not in known:
            raise CaseError(
                f"[{quoted_key(name)}]: unknown section; accepted: [case] or"
                " [physical], [numerics], [output], [[protocol]]"
            )
        if not isinstance(value, dict):
            raise CaseError(f"{name} = {shown(value)}: expected a section [{name}]")
    if ("case" in doc) == ("physical" in doc):
        raise CaseError(
            "exactly one of [case] (dimensionless groups) or [physical] (SI values) is required"
        )
    form = "case" if "case" in doc else "physical"
    unknown_keys(doc[form], form, known[form])
    if form == "case":
        groups, units = _case_groups(doc["case"]), Units()
    else:
        geometry = doc["physical"].get("geometry", "cylinder")
        groups, units = groups_from_physical(doc["physical"], geometry)
        if "geometry" in doc["physical"]:
            groups["geometry"] = geometry
    protocol = doc.get("protocol", ())
    if "protocol" in doc and (not isinstance(protocol, list) or not protocol):
        raise CaseError(
            f"protocol = {shown(protocol)}: expected [[protocol]] tables"
            " (approach, dwell or retract)"
        )
    return dict(
        groups,
        numerics=doc.get("numerics", {}),
        output=doc.get("output", {}),
        units=units,
        text=text,
        form=form,
        protocol=protocol,
    )


def _case_groups(table) -> dict:
    """The ``[case]`` table's groups, each present and a number (a Prony series in place of
    modulus_ratio)."""
    prony = any(key in table for key in PRONY_KEYS)
    groups = {
        key: number(table, "case", key)
        for key in GROUP_KEYS
        if not (prony and key == "modulus_ratio")
    }
    if prony:
        groups.update(
            modulus_ratio=table.get("modulus_ratio"),
            relaxation_moduli=table.get("relaxation_moduli"),
            relaxation_times=table.get("relaxation_times"),
        )
    if "drive_stiffness" in table:
        groups["drive_stiffness"] = stiffness(table, "case")
    if "geometry" in table:
        groups["geometry"] = table["geometry"]
    return groups
