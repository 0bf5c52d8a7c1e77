"""The documentation is true: its TOML parses, its defaults are the code's, its commands exist.

- Every ```toml block of README.md and docs/*.md is parsed by the case or the sweep parser (a
  block holding only [numerics] or [output] is completed with the default case's [case]).
- docs/case-file.md states each [numerics] and [output] default as a Python expression in a
  table (key | meaning | default); each is evaluated and compared with what the parser makes of
  default_case.toml and of four other cases (the [physical] form, fixed steps, a creeping
  retraction and a compliant drive).
- Every `python -m hpcgfmd ...` in a ```sh block uses a subcommand and options that the
  command's --help lists (``bench MODE``: that mode's --help), every `python scripts/x.py`
  options that the script's --help lists; every scripts/ and jobs/ path named there is
  tracked by git (so a clone has it; outside a git checkout: exists). Every command
  docs/results.md names anywhere exists: its scripts/ paths, its ``bench`` modes. Every link
  to a section of a doc names a heading there.
- The Python examples of README.md and docs/api.md print what their comments state.
"""

import math
import re
import shlex
import subprocess
import sys
import tomllib
from functools import cache
from importlib import resources
from pathlib import Path

import pytest

from cases import case_text, physical_text
from hpcgfmd.case import parse_case
from hpcgfmd.case.numerics import numerics_keys
from hpcgfmd.case.output import OUTPUT_KEYS
from hpcgfmd.errors import SweepError
from hpcgfmd.runs.sweep import parse_sweep
from hpcgfmd.solvers import registered, solver_class
from hpcgfmd.studies.bench import MODES

NUMERICS_KEYS = numerics_keys()

REPO = Path(__file__).resolve().parents[1]
DOCS = [REPO / "README.md"] + sorted((REPO / "docs").glob("*.md"))
DEFAULT_CASE = resources.files("hpcgfmd").joinpath("default_case.toml").read_text()
PHYSICAL = physical_text(
    relaxation_time="2.0", interaction_range="1e-6", depth="3e-5", cell_length="2e-3"
)


def blocks(language):
    """(file, index, text) of every fenced block of ``language`` in the docs."""
    found = []
    for path in DOCS:
        text = path.read_text()
        for i, match in enumerate(
            re.finditer(rf"^```{language}\n(.*?)^```", text, re.MULTILINE | re.DOTALL)
        ):
            found.append((path.relative_to(REPO), i, match.group(1)))
    return found


def test_the_docs_exist_and_have_blocks():
    names = {p.name for p in DOCS}
    assert {
        "README.md",
        "model.md",
        "case-file.md",
        "output.md",
        "numerics.md",
        "parallel.md",
        "api.md",
        "results.md",
        "testing.md",
    } <= names
    assert len(blocks("toml")) >= 5 and len(blocks("sh")) >= 5
    assert len((REPO / "README.md").read_text().splitlines()) < 200


TOML = blocks("toml")


@pytest.mark.parametrize("script", sorted(p.name for p in (REPO / "scripts").glob("*.py")))
def test_every_script_answers_help(script):
    # --help prints the usage or the docstring and runs nothing (hand-parsed scripts too)
    done = subprocess.run(
        [sys.executable, str(REPO / "scripts" / script), "--help"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0 and done.stderr == "", done.stderr
    assert done.stdout.startswith("usage:") or len(done.stdout.splitlines()) > 3


@pytest.mark.parametrize("mode", sorted(MODES))
def test_every_bench_mode_answers_help(mode):
    # each table of docs/results.md comes from a mode; --help runs nothing and exits 0
    assert help_text("bench", mode).startswith("usage: python -m hpcgfmd bench")


def test_every_command_of_the_results_page_exists():
    # docs/results.md names its commands in ```sh blocks and in its text: every scripts/
    # path is in the repository and every `hpcgfmd bench WORD` is a mode
    text = (REPO / "docs" / "results.md").read_text()
    paths = set(re.findall(r"\bscripts/[\w./-]+", text))
    modes = set(re.findall(r"hpcgfmd bench ([a-z][\w-]*)", text))
    assert paths and modes
    assert [p for p in sorted(paths) if not in_repository(p.rstrip("."))] == []
    assert modes - set(MODES) == set()
    assert len(text.splitlines()) < 760  # a page of current measurements, line and surface


def anchor(heading):
    """GitHub's anchor of a Markdown heading."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def test_linked_anchors_exist():
    # every [text](name.md#anchor) of the docs names a heading of that file
    anchors = {}
    for path in DOCS:
        text = re.sub(r"^```.*?^```", "", path.read_text(), flags=re.MULTILINE | re.DOTALL)
        anchors[path.resolve()] = {
            anchor(line.lstrip("#")) for line in text.splitlines() if line.startswith("#")
        }
    linked, missing = 0, []
    for path in DOCS:
        for name, target in re.findall(r"\]\(([\w./-]*\.md)?#([\w-]+)\)", path.read_text()):
            linked_file = (path.parent / name).resolve() if name else path.resolve()
            if linked_file in anchors:
                linked += 1
                if target not in anchors[linked_file]:
                    missing.append((str(path.relative_to(REPO)), name, target))
    assert linked > 20 and missing == []


def test_cited_sections_exist():
    # a citation `name.md, "Heading"` in the docs, the package or the scripts names (the
    # start of) a heading of docs/name.md
    headings = {
        path.name: [
            re.sub(r"^#+\s*", "", line).strip()
            for line in path.read_text().splitlines()
            if line.startswith("#")
        ]
        for path in REPO.glob("docs/*.md")
    }
    sources = DOCS + sorted(REPO.glob("hpcgfmd/**/*.py")) + sorted(REPO.glob("scripts/*.py"))
    cited, missing = 0, []
    for path in sources:
        for name, title in re.findall(r'([a-z-]+\.md)[,:]?\s*\(?\s*"([^"]+)"', path.read_text()):
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
        block = next(
            text
            for path, _, text in blocks("python")
            if str(path) == source and "hpcgfmd.Case(" in text
        )
        case = re.search(
            r"^case = (hpcgfmd\.Case\(.*?\))\n", block, re.MULTILINE | re.DOTALL
        ).group(1)
        prints = re.findall(r"^print\((.*)\)\s+# (.*)$", block, re.MULTILINE)
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
    if re.search(r"^(base|\[grid\]|\[\[cases\]\])", text, re.MULTILINE):
        (tmp_path / "case.toml").write_text(case_text("nx = 1024"))
        try:
            sweep = parse_sweep(text, str(tmp_path))
        except SweepError as err:
            pytest.fail(f"{source} block {index}: {err}")
        assert sweep.cases
        return
    if not re.search(r"^\[(case|physical)\]", text, re.MULTILINE):  # a [numerics]/[output] fragment
        assert re.search(r"^\[(numerics|output)\]", text, re.MULTILINE), text
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
    return {
        "dmax": case.dmax * u.length,
        "v_z": case.indenter_speed * u.length / u.time,
        "h0": case.depth * u.length,
        "tau": u.time,
        "L": case.cell * u.length,
        "R": u.length,
        "w": case.zone_width * u.length,
        "nx": num.nx,
        "dt": num.dt * u.time,
        "fixed": num.step_control == "fixed",
        "accuracy": num.accuracy,
        "k": case.modulus_ratio,
        "chi_ve": case.chi_ve,
        "lambda0": case.maugis,
        "compliant": case.compliant,
        "sphere": case.sphere,
        "ceil": math.ceil,
        "log2": math.log2,
        "sqrt": math.sqrt,
        "min": min,
        "max": max,
        "round": round,
    }


def parsed(case, key):
    """The value the parser resolved for ``key``, in the case's units."""
    u, num, out = case.units, case.numerics, case.output
    if key in ("dt", "dt_min", "dt_max"):
        return getattr(num, key) * u.time
    if key in dict(num.solver_settings):
        return num.setting(key)
    own = {k.name: k for name in registered() for k in solver_class(name).KEYS}
    if key in own:  # another solver's key: the default that solver would take
        return own[key].default(num.nx)
    if key in NUMERICS_KEYS:
        return getattr(num, key)
    if key == "snapshot_times":
        return [t * u.time for t in out.snapshot_times]
    if key == "snapshot_contact_widths":
        return [a * u.length for a in out.snapshot_contact_widths]
    return getattr(out, key)


CASES = {
    "default_case.toml": DEFAULT_CASE,
    "physical": PHYSICAL,
    "fixed steps": case_text('step_control = "fixed"'),
    "creeping": case_text("", maugis=1.0, velocity=0.1, depth=0.1, cell=3.578),
    "compliant": case_text("", drive_stiffness=0.3),
    "sphere": case_text("n = 256", geometry='"sphere"', maugis=1.0, depth=0.01, cell=1.5),
    # a fast retraction at large lambda0: the relaxed floor sets its grid
    "fast, large lambda0": case_text(
        "", maugis=30.0, modulus_ratio=0.2, velocity=0.26, depth=0.005, cell=0.64
    ),
}


@pytest.mark.parametrize("section, keys", [("numerics", NUMERICS_KEYS), ("output", OUTPUT_KEYS)])
def test_every_key_has_a_documented_default(section, keys):
    assert set(default_rows(section)) == set(keys)


@pytest.mark.parametrize("name", CASES)
def test_documented_defaults_are_the_parsed_ones(name):
    text = CASES[name]
    case = parse_case(text)
    document = tomllib.loads(text)
    given = {key for section in ("numerics", "output") for key in document.get(section, {})}
    if "n" in given:  # a sphere's n is its nx
        given.add("nx")
    checked = 0
    for section in ("numerics", "output"):
        for key, expression in default_rows(section).items():
            if key in given:  # set by this case file, not a default
                continue
            want = eval(expression, {"__builtins__": {}, **namespace(case)})
            got = parsed(case, key)
            if isinstance(want, float) or isinstance(got, float):
                assert got == pytest.approx(want, rel=1e-12), (name, key, expression)
            else:
                assert list(got) == list(want) if isinstance(want, list) else got == want, (
                    name,
                    key,
                    expression,
                    got,
                )
            checked += 1
    assert checked >= 10


@cache
def help_text(*words):
    """The --help of ``python -m hpcgfmd WORDS`` (a subcommand, ``bench``'s mode), or of the
    script ``scripts/x.py`` when that is the one word."""
    words = [word for word in words if word]
    if words and words[0].startswith("scripts/"):
        command = [sys.executable, str(REPO / words[0]), "--help"]
    else:
        command = [sys.executable, "-m", "hpcgfmd", *words, "--help"]
    done = subprocess.run(
        command, capture_output=True, text=True, timeout=120, cwd=REPO, check=False
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


def assert_options_listed(source, line, words, text, what):
    for word in words:
        if word.startswith("-") and word != "-":
            option = word.split("=")[0]
            assert re.search(rf"(^|[\s,\[]){re.escape(option)}\b", text), (
                f"{source}: {line}: {option} is not an option of {what}"
            )


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


@cache
def tracked_files():
    """The paths git tracks in the repository, or None outside a git checkout (or without git)."""
    if not (REPO / ".git").exists():
        return None
    try:
        done = subprocess.run(
            ["git", "-C", str(REPO), "ls-files", "-z"],
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
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
    script = next((word for word in words if re.fullmatch(r"scripts/\w+\.py", word)), None)
    if script is not None and "python" in " ".join(words[: words.index(script)]):
        rest = words[words.index(script) + 1 :]
        assert_options_listed(source, line, rest, help_text(script), script)
        return
    if "hpcgfmd" not in words or "-m" not in words:
        return
    rest = words[words.index("hpcgfmd") + 1 :]
    subcommand = rest[0] if rest and not rest[0].startswith("-") else None
    if subcommand is not None:
        assert subcommand in ("run", "farm", "info", "plot", "paper", "bench"), (source, line)
    mode = rest[1] if subcommand == "bench" and len(rest) > 1 and rest[1] in MODES else None
    text = help_text(subcommand, mode)
    assert_options_listed(
        source, line, rest, text, " ".join(w for w in ("hpcgfmd", subcommand, mode) if w)
    )


def test_the_glass_on_pdms_example_is_what_its_comments_say():
    # docs/examples/glass-on-pdms.toml: its groups, its grid and memory at 1e-2 and at the
    # default 5e-3 (the estimate of hpcgfmd/runs/cost.py that --dry-run prints)
    from hpcgfmd.case import load_case, parse_case
    from hpcgfmd.runs.cost import estimated_memory

    path = REPO / "docs" / "examples" / "glass-on-pdms.toml"
    case = load_case(str(path))
    g = case.groups()
    assert round(g["lambda0"]) == 390 and g["k"] == pytest.approx(0.2)
    assert round(g["Vz"], 2) == 0.26 and round(g["chi_ve"], -3) == 39000
    assert g["alpha"] == pytest.approx(7.7e-6, rel=1e-2)
    assert case.numerics.nx == 2**25 and round(g["zone_points"] / 1.3, 1) >= 1.0
    assert estimated_memory(case) == pytest.approx(24e9, rel=0.05)
    default = parse_case(path.read_text().replace("accuracy = 1e-2", "accuracy = 5e-3"))
    assert default.numerics.nx == 3 * 2**24
    assert estimated_memory(default) == pytest.approx(36e9, rel=0.05)
