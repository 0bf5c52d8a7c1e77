"""Sweep files: one base case plus grids or lists of values -> the cases of a parameter study.

A sweep file is TOML::

    base = "case.toml"        # a case file (relative to the sweep file), or inline:
    [base.case]               # the sections of a case file under [base.*]
    maugis = 7.0
    ...
    [grid]                    # every combination of these values, first key slowest
    velocity = [0.045, 0.45, 4.5, 9.0]
    depth = [0.1, 0.05]
    [[cases]]                 # and/or an explicit list; each entry overrides base keys
    maugis = 14.0             # (with [grid] too: every entry times every grid point)
    velocity = 0.9
    [farm]                    # optional
    ranks_per_case = 1        # ranks sharing one case (a split communicator)
    output = "study"          # directory of the case files and the summary

A key is a key of any section of the base (``velocity``, ``nx``, ``checkpoint_steps``) or
``section.key`` (``numerics.nx``, a TOML dotted key), or ``protocol``: a whole loading
protocol, a list of segment tables (``protocol = [{approach = 0.1}, {dwell = 1.0},
{retract = inf}]`` in a ``[[cases]]`` entry, a list of such lists in ``[grid]``). Each
combination becomes a complete case file, validated like any other; a case that does not
validate is kept and reported as failed with its error, so one bad value does not stop the
study. Each case's output file is named from the swept values
(``velocity_0.45-depth_0.1.h5``).
"""

from __future__ import annotations

import itertools
import os
import re
import tomllib
from dataclasses import dataclass

import tomli_w

from ..case import Case, parse_case
from ..case.files import sections
from ..case.keys import quoted_key
from ..errors import CaseError, SweepError
from .cost import estimated_cost

FARM_KEYS = ("ranks_per_case", "output")


@dataclass
class SweepCase:
    """One case of a sweep.

    Attributes
    ----------
    index : int
        Position in the sweep (the order ``farm --dry-run`` lists; ``farm --case INDEX``).
    values : dict
        The swept keys (``section.key``) and their values for this case.
    text : str
        The complete case file.
    name : str
        File stem made from the swept values.
    case : Case or None
        The validated case; None when it did not validate.
    error : str or None
        The validation error.
    """

    index: int
    values: dict
    text: str
    name: str
    case: Case | None = None
    error: str | None = None

    def cost(self) -> float:
        """Estimated single-core seconds (:func:`hpcgfmd.runs.cost.estimated_cost`; 0 for
        an invalid case)."""
        return 0.0 if self.case is None else estimated_cost(self.case)


@dataclass
class Sweep:
    """The cases of a sweep file and its farm settings."""

    cases: list
    swept: list  # the swept keys, section.key, in order
    ranks_per_case: int = 1
    output: str | None = None
    path: str = ""


def to_toml(doc: dict) -> str:
    """A case document (sections of scalars and lists) as TOML text."""
    try:
        return tomli_w.dumps(doc)
    except TypeError as err:
        raise SweepError(f"{err}: only numbers, booleans, strings and lists can be swept") from None


def _dotted(key) -> str:
    """A swept key for a message: each part as written, quoted unless it is a bare key."""
    return ".".join(quoted_key(part) for part in key.split("."))


def _resolve(key, base):
    """('section', 'key') of a swept key, looked up in the base's sections (('protocol',)
    for the loading protocol, an array of tables)."""
    if key == "protocol":
        return ("protocol",)
    if "." in key:
        section, name = key.split(".", 1)
        present = section in base or section in ("numerics", "output")  # optional sections
        if not present or name not in sections().get(section, ()):
            raise SweepError(
                f"{_dotted(key)}: no key {name!r} in section"
                f" [{quoted_key(section)}] of this base case"
            )
        return section, name
    known = sections()
    owners = [s for s in known if (s in base or s in ("numerics", "output")) and key in known[s]]
    if not owners:
        form = "case" if "case" in base else "physical"
        accepted = ", ".join((*known[form], *known["numerics"], *known["output"]))
        raise SweepError(f"{_dotted(key)}: not a key of the base case; accepted: {accepted}")
    return owners[0], key


def _flatten(table):
    """TOML's dotted keys (numerics.nx = ...) arrive as sub-tables: back to 'numerics.nx'."""
    flat = {}
    for key, value in table.items():
        if isinstance(value, dict):
            flat.update({f"{key}.{k}": v for k, v in value.items()})
        else:
            flat[key] = value
    return flat


def _label(value) -> str:
    """A file-name part from a swept value: TOML's spelling, only [A-Za-z0-9.+-_] kept; the
    entries of a list joined by "_" (so that [1, 2] and [12] differ)."""
    if isinstance(value, list):
        return "_".join(_label(entry) for entry in value)
    if isinstance(value, dict):  # a protocol's segment
        return "_".join(f"{key}_{_label(entry)}" for key, entry in value.items())
    text = tomli_w.dumps({"v": value})[len("v = ") :].strip()
    return re.sub(r"[^A-Za-z0-9.+_-]", "", text)


def parse_sweep(text: str, directory: str = ".", path: str = "") -> Sweep:
    """Validate a sweep file's text and build its cases (raises :class:`SweepError`)."""
    try:
        doc = tomllib.loads(text)
    except RecursionError:
        raise SweepError("not valid TOML: arrays or inline tables nested too deeply") from None
    except ValueError as err:  # TOMLDecodeError, or int()'s limit of 4300 digits
        raise SweepError(f"not valid TOML: {err}") from None
    for key in doc:
        if key not in ("base", "grid", "cases", "farm"):
            raise SweepError(
                f"{quoted_key(key)}: unknown key or section; accepted: base, [grid],"
                " [[cases]], [farm]"
            )
    if "base" not in doc:
        raise SweepError("base: missing; give a case file name or [base.case] / [base.physical]")
    base = _read_base(doc["base"], directory)
    grid = doc.get("grid", {})
    if not isinstance(grid, dict):
        raise SweepError("grid: expected a section [grid] of key = [values]")
    entries = doc.get("cases", [{}])
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise SweepError("cases: expected [[cases]] tables")
    if not entries:
        raise SweepError("cases = []: expected at least one [[cases]] table (or none at all)")
    entries = [_flatten(e) for e in entries]
    axes = []
    for key, values in _flatten(grid).items():
        if not isinstance(values, list) or not values:
            raise SweepError(
                f"[grid] {_dotted(key)} = {values!r}: expected a non-empty list of values"
            )
        axes.append((_resolve(key, base), values))
    ranks, output = _read_farm(doc.get("farm", {}))
    cases, swept = _expand(base, entries, axes)
    if all(c.case is None for c in cases):  # the base itself is wrong: say so at once
        raise SweepError(f"no valid case; the first one: {cases[0].error}")
    return Sweep(cases=cases, swept=swept, ranks_per_case=ranks, output=output, path=path)


def _read_base(base, directory):
    """The sweep's base case as a TOML table: given inline, or read from the case file it
    names (relative to the sweep file's ``directory``)."""
    given = base
    if isinstance(base, str):
        base_path = os.path.join(directory, base)
        try:
            with open(base_path, "rb") as fh:
                raw = fh.read()
        except OSError as err:
            raise SweepError(f"base = {given!r}: cannot read it ({err.strerror})") from None
        except ValueError:  # a NUL character
            raise SweepError(f"base = {given!r}: not a file name") from None
        try:
            base = tomllib.loads(raw.decode("utf-8"))
        except UnicodeDecodeError:
            raise SweepError(f"base = {given!r}: not UTF-8 text") from None
        except RecursionError:
            raise SweepError(
                f"base = {given!r}: not valid TOML: arrays or inline tables nested too deeply"
            ) from None
        except ValueError as err:  # TOMLDecodeError, or int()'s limit of 4300 digits
            raise SweepError(f"base = {given!r}: not valid TOML: {err}") from None
    if not isinstance(base, dict) or not ({"case", "physical"} & set(base)):
        raise SweepError("base: needs a [base.case] or [base.physical] section (or a case file)")
    return base


def _read_farm(farm):
    """([farm] ranks_per_case, [farm] output or None), checked."""
    if not isinstance(farm, dict):
        raise SweepError(f"farm = {farm!r}: expected a section [farm] of ranks_per_case, output")
    for key in farm:
        if key not in FARM_KEYS:
            raise SweepError(
                f"[farm] {quoted_key(key)}: unknown key; accepted: {', '.join(FARM_KEYS)}"
            )
    ranks = farm.get("ranks_per_case", 1)
    if isinstance(ranks, bool) or not isinstance(ranks, int) or ranks < 1:
        raise SweepError(f"[farm] ranks_per_case = {ranks!r}: expected an integer >= 1")
    output = farm.get("output")
    if output is not None and not isinstance(output, str):
        raise SweepError(f"[farm] output = {output!r}: expected a directory name")
    return ranks, output


def _expand(base, entries, axes):
    """(the sweep's cases, the swept keys in order of appearance): every [[cases]] entry
    crossed with every point of the [grid] axes, each validated (an invalid case keeps its
    error, the others run)."""
    cases, names, swept = [], {}, []
    for entry, point in itertools.product(entries, itertools.product(*[v for _, v in axes])):
        values = {}
        for key, value in entry.items():
            values[".".join(_resolve(key, base))] = value
        for (parts, _), value in zip(axes, point):
            if ".".join(parts) in values:
                raise SweepError(
                    f"{parts[-1]}: in both [grid] and [[cases]]; give it in one of them"
                )
            values[".".join(parts)] = value
        for key in values:
            if key not in swept:
                swept.append(key)
        case_doc = {s: dict(t) for s, t in base.items() if isinstance(t, dict)}
        if "protocol" in base:
            case_doc["protocol"] = base["protocol"]
        for key, value in values.items():
            if key == "protocol":  # the whole array of tables
                case_doc["protocol"] = value
                continue
            section, name = key.split(".", 1)
            case_doc.setdefault(section, {})[name] = value
        text_case = to_toml(case_doc)
        name = "-".join(f"{k.split('.')[-1]}_{_label(v)}" for k, v in values.items()) or "base"
        if name in names:
            raise SweepError(f"cases {names[name]} and {len(cases)} are the same case ({name})")
        names[name] = len(cases)
        item = SweepCase(index=len(cases), values=values, text=text_case, name=name)
        try:
            item.case = parse_case(text_case)
        except CaseError as err:
            item.error = str(err)
        cases.append(item)
    return cases, swept


def load_sweep(path) -> Sweep:
    """Read and validate a sweep file (raises :class:`SweepError`)."""
    try:
        with open(path, "rb") as fh:
            text = fh.read().decode("utf-8")
    except OSError as err:
        raise SweepError(f"cannot read sweep file: {err.strerror}") from None
    except UnicodeDecodeError:
        raise SweepError("sweep file is not UTF-8 text") from None
    return parse_sweep(text, os.path.dirname(os.path.abspath(path)), path=path)
