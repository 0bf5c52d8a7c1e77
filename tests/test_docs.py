"""The documentation is true: its TOML parses, its defaults are the code's, its commands exist.

- Every ```toml block of README.md and docs/*.md is parsed by the case or the sweep parser (a
  block holding only [numerics] or [output] is completed with the default case's [case]).
- docs/case-file.md states each [numerics] and [output] default as a Python expression in a
  table (key | meaning | default); each is evaluated and compared with what the parser makes of
  default_case.toml and of four other cases (the [physical] form, fixed steps, a creeping
  retraction and a compliant drive).
- Every `python -m hpcgfmd ...` in a ```sh block uses a subcommand and options that the
  command's --help lists; every scripts/ and jobs/ path named there is tracked by git (so a
  clone has it; outside a git checkout: exists).
- The Python examples of README.md and docs/api.md print what their comments state.
"""
import math
import re
import shlex
import subprocess
import sys
import tomllib
from functools import lru_cache
from importlib import resources
from pathlib import Path

import pytest

from hpcgfmd.errors import SweepError
from hpcgfmd.case import parse_case
from hpcgfmd.case.numerics import numerics_keys
from hpcgfmd.case.output import OUTPUT_KEYS

NUMERICS_KEYS = numerics_keys()
from hpcgfmd.runs.sweep import parse_sweep

from cases import case_text, physical_text

REPO = Path(__file__).resolve().parents[1]
DOCS = [REPO / "README.md"] + sorted((REPO / "docs").glob("*.md"))
DEFAULT_CASE = resources.files("hpcgfmd").joinpath("default_case.toml").read_text()
PHYSICAL = physical_text(relaxation_time="2.0", interaction_range="1e-6", depth="3e-5",
                         cell_length="2e-3")


def blocks(language):
    """(file, index, text) of every fenced block of ``language`` in the docs."""
    found = []
    for path in DOCS:
        text = path.read_text()
        for i, match in enumerate(re.finditer(rf"^```{language}\n(.*?)^```", text,
                                              re.M | re.S)):
            found.append((path.relative_to(REPO), i, match.group(1)))
    return found


def test_the_docs_exist_and_have_blocks():
    names = {p.name for p in DOCS}
    assert {"README.md", "model.md", "case-file.md", "output.md", "numerics.md",
            "parallel.md", "api.md", "results.md", "testing.md"} <= names
    assert len(blocks("toml")) >= 5 and len(blocks("sh")) >= 5
    assert len((REPO / "README.md").read_text().splitlines()) < 200


TOML = blocks("toml")


@pytest.mark.parametrize("script", sorted(p.name for p in (REPO / "scripts").glob("*.py")))
def test_every_script_answers_help(script):
    # --help prints the usage or the docstring and runs nothing (hand-parsed scripts too)
    done = subprocess.run([sys.executable, str(REPO / "scripts" / script), "--help"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    assert done.stdout.startswith("usage:") or len(done.stdout.splitlines()) > 3


def test_cited_sections_exist():
    # a citation `name.md, "Heading"` in the docs, the package or the scripts names (the
    # start of) a heading of docs/name.md
    headings = {path.name: [re.sub(r"^#+\s*", "", line).strip()
                            for line in path.read_text().splitlines() if line.startswith("#")]
                for path in REPO.glob("docs/*.md")}
    sources = DOCS + sorted(REPO.glob("hpcgfmd/**/*.py")) + sorted(REPO.glob("scripts/*.py"))
    cited, missing = 0, []
    for path in sources:
        for name, title in re.findall(r'([a-z-]+\.md)[,:]?\s*\(?\s*"([^"]+)"',
                                      path.read_text()):
            if name in headings:
                cited += 1
                title = " ".join(title.split())
                if not any(h.startswith(title) for h in headings[name]):
                    missing.append((str(path.relative_to(REPO)), name, title))
    assert cited > 50 and missing == []


def test_python_examples_print_what_their_comments_state():
    # the first ```python block of README.md and of docs/api.md that makes a Case: one case,
    # run once; each print(...) # value[, value] comment holds to the digits it states
    import hpcgfmd
    examples = []
    for source in ("README.md", "docs/api.md"):
        block = next(text for path, _, text in blocks("python")
                     if str(path) == source and "hpcgfmd.Case(" in text)
        case = re.search(r"^case = (hpcgfmd\.Case\(.*?\))\n", block, re.M | re.S).group(1)
        prints = re.findall(r"^print\((.*)\)\s+# (.*)$", block, re.M)
        assert prints, source
        examples.append((source, case, prints))
    assert len({case for _, case, _ in examples}) == 1, "the examples run different cases"
    result = hpcgfmd.run(eval(examples[0][1], {"hpcgfmd": hpcgfmd}))
    names = {"result": result, "p": result.pull_off()}
    for source, _, prints in examples:
        for expression, comment in prints:
            values = eval(f"({expression},)", names)
            stated = [text.strip() for text in comment.split(",")]
            assert len(values) == len(stated), (source, expression)
            for value, text in zip(values, stated):
                digits = len(text.split(".")[1]) if "." in text else 0
                assert round(value, digits) == float(text), (source, expression, value)


@pytest.mark.parametrize("source, index, text", TOML, ids=[f"{s}#{i}" for s, i, _ in TOML])
def test_toml_blocks_parse(source, index, text, tmp_path):
    if re.search(r"^(base|\[grid\]|\[\[cases\]\])", text, re.M):
        (tmp_path / "case.toml").write_text(case_text("nx = 1024"))
        try:
            sweep = parse_sweep(text, str(tmp_path))
        except SweepError as err:
            pytest.fail(f"{source} block {index}: {err}")
        assert sweep.cases
        return
    if not re.search(r"^\[(case|physical)\]", text, re.M):  # a [numerics]/[output] fragment
        assert re.search(r"^\[(numerics|output)\]", text, re.M), text
        text = DEFAULT_CASE.split("[numerics]")[0] + text
    parse_case(text)


def default_rows(section):
    """{key: expression} of the defaults table under '## [section]' in docs/case-file.md."""
    text = (REPO / "docs" / "case-file.md").read_text()
    part = text.split(f"## [{section}]\n", 1)[1].split("\n## ", 1)[0]
    rows = {}
    for line in part.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) >= 3 and cells[0].startswith("`"):
            expression = re.fullmatch(r"`([^`]+)`", cells[-1])
            assert expression, f"[{section}] {cells[0]}: default {cells[-1]!r} is not one `...`"
            rows[cells[0].strip("`")] = expression.group(1)
    return rows


def namespace(case):
    """The names the default expressions use, in the case's units."""
    u, num = case.units, case.numerics
    return {"dmax": case.dmax * u.length, "v_z": case.indenter_speed * u.length / u.time,
            "h0": case.depth * u.length, "tau": u.time, "L": case.cell * u.length, "R": u.length,
            "w": case.zone_width * u.length, "nx": num.nx, "dt": num.dt * u.time,
            "fixed": num.step_control == "fixed", "accuracy": num.accuracy, "k": case.modulus_ratio,
            "chi_ve": case.chi_ve, "lambda0": case.maugis, "compliant": case.compliant,
            "ceil": math.ceil,
            "log2": math.log2, "sqrt": math.sqrt, "min": min, "max": max, "round": round}


def parsed(case, key):
    """The value the parser resolved for ``key``, in the case's units."""
    u, num, out = case.units, case.numerics, case.output
    if key in ("dt", "dt_min", "dt_max"):
        return getattr(num, key) * u.time
    if key in dict(num.solver_settings):
        return num.setting(key)
    if key in NUMERICS_KEYS:
        return getattr(num, key)
    if key == "snapshot_times":
        return [t * u.time for t in out.snapshot_times]
    if key == "snapshot_contact_widths":
        return [a * u.length for a in out.snapshot_contact_widths]
    return getattr(out, key)


CASES = {"default_case.toml": DEFAULT_CASE, "physical": PHYSICAL,
         "fixed steps": case_text('step_control = "fixed"'),
         "creeping": case_text("", maugis=1.0, velocity=0.1, depth=0.1, cell=3.578),
         "compliant": case_text("", drive_stiffness=0.3)}


@pytest.mark.parametrize("section, keys", [("numerics", NUMERICS_KEYS),
                                           ("output", OUTPUT_KEYS)])
def test_every_key_has_a_documented_default(section, keys):
    assert set(default_rows(section)) == set(keys)


@pytest.mark.parametrize("name", CASES)
def test_documented_defaults_are_the_parsed_ones(name):
    text = CASES[name]
    case = parse_case(text)
    document = tomllib.loads(text)
    given = {key for section in ("numerics", "output") for key in document.get(section, {})}
    checked = 0
    for section in ("numerics", "output"):
        for key, expression in default_rows(section).items():
            if key in given:  # set by this case file, not a default
                continue
            want = eval(expression, {"__builtins__": {}, **namespace(case)})  # noqa: S307
            got = parsed(case, key)
            if isinstance(want, float) or isinstance(got, float):
                assert got == pytest.approx(want, rel=1e-12), (name, key, expression)
            else:
                assert list(got) == list(want) if isinstance(want, list) else got == want, \
                    (name, key, expression, got)
            checked += 1
    assert checked >= 10


@lru_cache(maxsize=None)
def help_text(subcommand):
    command = [sys.executable, "-m", "hpcgfmd"] + ([subcommand] if subcommand else []) + ["--help"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120, cwd=REPO)
    assert done.returncode == 0, done.stderr
    return done.stdout


def commands():
    """(file, line) of every shell line of the docs that runs hpcgfmd, a script or a job."""
    found = []
    for source, _, text in blocks("sh"):
        for line in text.splitlines():
            line = line.split(" #")[0].strip()
            if line and not line.startswith("#"):
                found.append((str(source), line))
    return found


COMMANDS = commands()


@lru_cache(maxsize=None)
def tracked_files():
    """The paths git tracks in the repository, or None outside a git checkout (or without git)."""
    if not (REPO / ".git").exists():
        return None
    try:
        done = subprocess.run(["git", "-C", str(REPO), "ls-files", "-z"], capture_output=True,
                              text=True, timeout=60)
    except OSError:
        return None
    return set(done.stdout.split("\0")) - {""} if done.returncode == 0 else None


def in_repository(path):
    """Whether ``path`` (relative to the repository) is a tracked file or holds one; outside a
    git checkout, whether it exists."""
    tracked = tracked_files()
    if tracked is None:
        return (REPO / path).exists()
    path = path.rstrip("/")
    return path in tracked or any(name.startswith(path + "/") for name in tracked)


@pytest.mark.parametrize("source, line", COMMANDS, ids=[f"{s}: {c[:50]}" for s, c in COMMANDS])
def test_shell_commands_exist(source, line):
    words = shlex.split(line)
    for word in words:  # repository paths named in the command
        if re.match(r"(scripts|jobs)/", word):
            assert in_repository(word), f"{source}: {word} is not in the repository (git)"
    if "hpcgfmd" not in words or "-m" not in words:
        return
    rest = words[words.index("hpcgfmd") + 1:]
    subcommand = rest[0] if rest and not rest[0].startswith("-") else None
    if subcommand is not None:
        assert subcommand in ("run", "farm", "info", "plot", "paper", "bench"), (source, line)
    text = help_text(subcommand)
    for word in rest:
        if word.startswith("-") and word != "-":
            option = word.split("=")[0]
            assert re.search(rf"(^|[\s,\[]){re.escape(option)}\b", text), \
                f"{source}: {line}: {option} is not an option of {subcommand or 'hpcgfmd'}"
