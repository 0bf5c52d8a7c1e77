"""A case and its files: the groups checked, the protocol, numerics and output resolved.

Imports :mod:`hpcgfmd.model` and :mod:`hpcgfmd.solvers` (the solvers declare their own
``[numerics]`` keys) only.
"""

from .case import Case, load_case, parse_case
from .text import case_file_text
from .units import Units

__all__ = ["Case", "Units", "case_file_text", "load_case", "parse_case"]
