"""A case file's text written from its keys (TOML through tomli_w): the text of a case built
from Python keywords, and of the cases of a sweep."""

from __future__ import annotations

import numpy as np
import tomli_w


def plain(value):
    """A value as TOML writes it: numpy scalars as the numbers they hold, tuples as lists."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, dict):
        return {key: plain(v) for key, v in value.items()}
    return value


def case_file_text(
    case: dict, numerics: dict | None = None, protocol=None, output: dict | None = None
) -> str:
    """A case file's text (docs/case-file.md) from its ``[case]`` keys, its ``[numerics]``
    and ``[output]`` keys and its ``[[protocol]]`` segments (a list of dicts)."""
    doc = {"case": plain(case)}
    if protocol:
        doc["protocol"] = [plain(dict(segment)) for segment in protocol]
    if numerics:
        doc["numerics"] = plain(numerics)
    if output:
        doc["output"] = plain(output)
    return tomli_w.dumps(doc)
