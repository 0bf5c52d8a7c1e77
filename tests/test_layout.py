"""The package's layers (README, "Layout"): which part may import which, read from the imports.

Every module of hpcgfmd is parsed (ast, nothing is run) and each import of another hpcgfmd
module, at the top or inside a function, is checked against the rules below.
"""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "hpcgfmd"

# Which parts each part may import (besides itself). The foundation (``errors``, ``signals``,
# ``state``, ``atomic``, the package's ``__version__``) may be imported by every part. The bare
# package is not: a ``from hpcgfmd import x`` counts as an import of ``hpcgfmd.x``, and an
# ``import hpcgfmd`` (whose attribute uses cannot be followed here) only its own __init__ may
# make.
FOUNDATION = {"errors", "signals", "state", "atomic", "__version__"}
ALLOWED = {
    "errors": set(),
    "signals": set(),
    "state": set(),
    "atomic": set(),
    "model": set(),
    "parallel": set(),
    "solvers": {"model", "parallel"},
    "case": {"model", "solvers"},
    "storage": {"model"},
    "runs": {"model", "parallel", "solvers", "case", "storage"},
    "studies": {"model", "parallel", "solvers", "case", "storage", "runs"},
    "paper": {"model", "case", "runs", "storage", "studies"},
    "api": {"model", "case", "storage", "runs"},
    "logs": set(),
    "cli": {"model", "case", "runs", "storage", "studies", "paper", "logs"},
    "entry": {"cli"},
    "__main__": {"entry"},
    "hpcgfmd": {"api", "case", "storage"},  # __init__: the lazy API names
}


def part(module):
    """The part of a dotted module name inside hpcgfmd ('hpcgfmd.solvers.cg.x' -> 'solvers')."""
    names = module.split(".")
    return names[1] if len(names) > 1 else "hpcgfmd"


def module_name(path):
    relative = path.relative_to(PACKAGE.parent).with_suffix("")
    names = list(relative.parts)
    if names[-1] == "__init__":
        names.pop()
    return ".".join(names)


def imported(path, source=None):
    """Absolute names of the hpcgfmd modules a file imports (relative imports resolved);
    ``source`` stands in for the file's text."""
    tree = ast.parse(path.read_text() if source is None else source)
    here = module_name(path).split(".")
    package = here if path.name == "__init__.py" else here[:-1]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [a.name for a in node.names if a.name.split(".")[0] == "hpcgfmd"]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "hpcgfmd":
                continue
            if node.module is None or target == "hpcgfmd":
                # from . import x, from .. import x, from hpcgfmd import x: each x is a module
                # or a name of that package, so x decides the part (hpcgfmd.runs, not hpcgfmd)
                found += [f"{target}.{a.name}" for a in node.names]
            else:
                found.append(target)
    # __init__'s lazy table names its modules as strings
    if path == PACKAGE / "__init__.py":
        table = next(
            n
            for n in tree.body
            if isinstance(n, ast.Assign) and getattr(n.targets[0], "id", "") == "_API"
        )
        found += [f"hpcgfmd.{value.elts[0].value}" for value in table.value.values]
    return found


MODULES = sorted(PACKAGE.rglob("*.py"))


def test_every_part_has_rules():
    parts = {part(module_name(p)) for p in MODULES}
    assert parts <= set(ALLOWED), parts - set(ALLOWED)
    assert {"model", "parallel", "solvers", "storage", "runs"} <= parts


def violations(path, source=None):
    """The imports of ``path`` that its part may not make."""
    mine = part(module_name(path))
    wrong = []
    for target in imported(path, source):
        name = part(target)
        if name == mine or name in FOUNDATION:
            continue
        if name not in ALLOWED[mine]:
            wrong.append(target)
    return wrong


@pytest.mark.parametrize("path", MODULES, ids=[module_name(p) for p in MODULES])
def test_imports_follow_the_layers(path):
    wrong = violations(path)
    assert not wrong, f"{module_name(path)} ({part(module_name(path))}) may not import {wrong}"


def test_an_upward_import_is_caught():
    # The checker itself: the model importing the protocol, or the storage a solver.
    material = PACKAGE / "model" / "material.py"
    upward = material.read_text() + "\nfrom ..runs.protocol import Retraction\n"
    assert violations(material, upward) == ["hpcgfmd.runs.protocol"]
    result_file = PACKAGE / "storage" / "result_file.py"
    assert violations(result_file, "from hpcgfmd.solvers import cg\n") == ["hpcgfmd.solvers"]
    assert violations(result_file, "def f():\n    from ..runs import farm\n") == ["hpcgfmd.runs"]


def test_an_import_through_the_package_root_is_caught():
    # From the package root, the names imported decide the part: the root itself is not the
    # foundation, only its __version__ is.
    case = PACKAGE / "model" / "material.py"
    assert violations(case, "from hpcgfmd import runs\n") == ["hpcgfmd.runs"]
    assert violations(case, "from hpcgfmd import errors, runs as r, solvers\n") == [
        "hpcgfmd.runs",
        "hpcgfmd.solvers",
    ]
    assert violations(PACKAGE / "model" / "x.py", "from .. import runs\n") == ["hpcgfmd.runs"]
    assert violations(case, "import hpcgfmd.runs\n") == ["hpcgfmd.runs"]
    assert violations(case, "import hpcgfmd\n") == ["hpcgfmd"]
    assert violations(case, "from hpcgfmd import __version__\n") == []
    assert violations(case, "from .. import __version__, errors, signals\n") == []
    assert violations(case, "from ..atomic import write_csv\n") == []
    assert violations(case, "from hpcgfmd.model import theory\n") == []
