"""Property-based fuzzing of the two input parsers: case files and sweep files (hypothesis).

The generated files mix valid keys and values with mutations: wrong types, NaN, inf, huge and
tiny numbers, zero and negative values, empty, very long and non-ASCII strings, arrays and
inline tables where scalars belong, unknown and duplicated keys, unknown sections, files cut
at a random point, random bytes. The property: each input is either accepted or rejected with
exactly the project's :class:`~hpcgfmd.errors.CaseError` / :class:`~hpcgfmd.errors.SweepError`
whose message is one non-empty line; any other exception fails. An accepted case also passes
cheap invariants (finite, positive groups and steps; what ``run --dry-run`` prints).

The bulk goes through the parser functions (``HPCGFMD_FUZZ_EXAMPLES`` per parser, default
2000, fixed seed); a sample goes through the real commands ``run --dry-run`` and
``farm --dry-run`` (exit 0 or 2 with one line on stderr, no traceback, no file written).
``python scripts/fuzz.py --examples 10000`` runs the bulk properties with another budget.
"""

import collections
import functools
import json
import math
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import pytest

hypothesis = pytest.importorskip("hypothesis", reason="pip install 'hpcgfmd[test]'")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import cases  # noqa: E402
from hpcgfmd.case import parse_case  # noqa: E402
from hpcgfmd.case.groups import GROUP_KEYS as CASE_KEYS  # noqa: E402
from hpcgfmd.case.numerics import MIN_TOLERANCE, numerics_keys  # noqa: E402
from hpcgfmd.case.output import OUTPUT_KEYS  # noqa: E402
from hpcgfmd.case.units import PHYSICAL_KEYS  # noqa: E402
from hpcgfmd.errors import CaseError, SweepError  # noqa: E402
from hpcgfmd.runs.single_case import describe  # noqa: E402
from hpcgfmd.runs.sweep import parse_sweep  # noqa: E402

EXAMPLES = int(os.environ.get("HPCGFMD_FUZZ_EXAMPLES", "2000"))
CLI_EXAMPLES = int(os.environ.get("HPCGFMD_FUZZ_CLI_EXAMPLES", "30"))
FUZZ_SETTINGS = dict(
    derandomize=True,
    deadline=None,
    database=None,
    print_blob=False,
    suppress_health_check=list(HealthCheck),
)
# inputs tried and their outcome ("valid" / "invalid") per parser, read by scripts/fuzz.py
OUTCOMES = {"case": collections.Counter(), "sweep": collections.Counter()}

# --- TOML values -----------------------------------------------------------------------------


def toml_float(x: float) -> str:
    """A float as TOML spells it (nan, inf, -inf, 1e+308)."""
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return repr(x)


def toml_string(s: str) -> str:
    """A basic TOML string (JSON's escapes are TOML's; non-ASCII kept as it is)."""
    return json.dumps(s, ensure_ascii=False)


def positive(low, high):
    return st.floats(low, high, allow_nan=False, allow_infinity=False).map(toml_float)


LONG = "x" * 10_000
SPECIAL_NUMBERS = [
    "nan",
    "+nan",
    "-nan",
    "inf",
    "+inf",
    "-inf",
    "1e308",
    "-1e308",
    "1.7976931348623157e308",
    "1e400",
    "1e-308",
    "5e-324",
    "-1e-308",
    "1e-400",
    "0",
    "0.0",
    "-0.0",
    "+0",
    "-1",
    "-7.5",
    "9223372036854775807",
    "-9223372036854775808",
    "9223372036854775808",
    "9" * 30,
    "0x7fffffff",
    "0o755",
    "0b1010",
    "1_000_000",
    "1e3",
    "65536.0",
    "65537",
    "2048",
    "1",
    "true",
    "false",
]
SPECIAL_STRINGS = [
    '""',
    "''",
    toml_string("λ₀ = 7 · Ångström · 日本語 · 🙂"),
    toml_string("7.0"),
    toml_string("cg"),
    toml_string("paper"),
    toml_string("adaptive"),
    toml_string("case.toml"),
    toml_string("a\nb\r\nc\u2028d\x0c"),
    toml_string("\x00"),
    '"""multi\nline"""',
    "'literal \\ string'",
    toml_string("../../etc/passwd"),
]
# built when drawn: a strategy holding them would have a repr of many kB
HUGE_INTEGERS = st.sampled_from([400, 4301]).map(lambda n: "9" * n)  # 4301: int()'s limit
LONG_STRING = st.just(None).map(lambda _: toml_string(LONG))
DATES = ["1979-05-27T07:32:00Z", "1979-05-27", "07:32:00", "1979-05-27T00:32:00.999999-07:00"]


@functools.cache
def scalar_values():
    """Any TOML scalar, mostly of the wrong kind somewhere."""
    return st.one_of(
        st.sampled_from(SPECIAL_NUMBERS),
        HUGE_INTEGERS,
        st.floats().map(toml_float),
        st.integers().map(str),
        st.sampled_from(SPECIAL_STRINGS),
        LONG_STRING,
        st.text(max_size=30).map(toml_string),
        st.booleans().map(lambda b: "true" if b else "false"),
        st.sampled_from(DATES),
    )


@functools.cache
def any_values():
    """Scalars, arrays (also mixed and nested) and inline tables; now and then raw text."""
    values = st.recursive(
        scalar_values(),
        lambda inner: st.one_of(
            st.lists(inner, max_size=4).map(lambda v: "[" + ", ".join(v) + "]"),
            st.lists(st.tuples(any_keys(), inner), max_size=3).map(
                lambda kv: "{" + ", ".join(f"{k} = {v}" for k, v in kv) + "}"
            ),
        ),
        max_leaves=8,
    )
    return st.integers(0, 9).flatmap(lambda i: st.text(max_size=12) if i == 0 else values)


@functools.cache
def any_keys():
    """Keys the parsers do not know: bare, quoted (any characters), dotted, empty."""
    return st.one_of(
        st.from_regex(r"[A-Za-z0-9_-]{1,12}", fullmatch=True),
        st.text(max_size=12).map(toml_string),
        st.sampled_from(
            [
                '""',
                "colour",
                "a.b",
                "case.maugis",
                "numerics.nx",
                "base",
                "grid",
                toml_string("key\nwith newline"),
                toml_string("ключ"),
                "'lit'",
            ]
        ),
    )


# valid values of every key (some combinations are still rejected, e.g. dt_min > dt_max)
VALID = {
    "case": {
        "maugis": positive(1.0, 8.0),
        "modulus_ratio": positive(0.02, 1.0),
        "velocity": positive(0.05, 10.0),
        "depth": positive(0.01, 0.1),
        "cell": positive(3.0, 10.0),
        "adhesion": positive(1e-5, 1e-3),
    },
    "physical": {
        "radius": positive(5e-4, 2e-3),
        "modulus_relaxed": positive(5e5, 2e6),
        "modulus_instantaneous": positive(5e6, 2e7),
        "relaxation_time": positive(0.5, 2.0),
        "work_of_adhesion": positive(0.02, 0.1),
        "interaction_range": positive(1e-7, 4e-7),
        "velocity": positive(5e-7, 2e-6),
        "depth": positive(5e-5, 1.5e-4),
        "cell_length": positive(8e-3, 2e-2),
    },
    "numerics": {
        "accuracy": positive(1e-3, 0.05),
        "nx": st.sampled_from(["1024", "2048", "4096", "8192", "65536"]),
        "n": st.sampled_from(["64", "128"]),  # a sphere's (a cylinder refuses it)
        "ny": st.sampled_from(["2", "4"]),  # a cylinder's rows on a surface
        "dt": positive(1e-4, 0.1),
        "tolerance": positive(1e-10, 1e-3),
        "max_iterations": st.integers(1, 20000).map(str),
        "solver": st.sampled_from(['"cg"', '"paper"']),
        "step_control": st.sampled_from(['"adaptive"', '"fixed"']),
        "dt_min": positive(1e-6, 1e-3),
        "dt_max": positive(0.01, 1.0),
        "edge_fraction": positive(0.25, 4.0),
        "load_tolerance": positive(1e-3, 0.1),
        "time_tolerance": positive(1e-3, 0.1),
        "equilibration_steps": st.integers(1, 100000).map(str),
    },
    "output": {
        "snapshot_times": st.lists(positive(0.0, 10.0), max_size=3).map(
            lambda v: "[" + ", ".join(v) + "]"
        ),
        "snapshot_contact_widths": st.lists(positive(0.0, 1.0), max_size=3).map(
            lambda v: "[" + ", ".join(v) + "]"
        ),
        "snapshot_zero_load": st.sampled_from(["true", "false"]),
        "progress_interval": positive(0.1, 100.0),
        "checkpoint_interval": positive(1.0, 3600.0),
        "checkpoint_steps": st.integers(0, 1000).map(str),
    },
}
assert set(VALID["case"]) == set(CASE_KEYS) and set(VALID["physical"]) == set(PHYSICAL_KEYS)
assert set(VALID["numerics"]) == set(numerics_keys()) and set(VALID["output"]) == set(OUTPUT_KEYS)
ALL_KEYS = sorted({k for keys in VALID.values() for k in keys})


def chance(draw, percent):
    return draw(st.integers(0, 99)) < percent


def extreme_numbers():
    """Numbers of the right type at the edges: any float (huge, tiny, subnormal, negative,
    NaN, inf), huge and negative integers."""
    return st.one_of(
        st.sampled_from(SPECIAL_NUMBERS[:27]),
        HUGE_INTEGERS,
        st.floats(min_value=0.0, exclude_min=True, allow_infinity=False).map(toml_float),
        st.floats().map(toml_float),
        st.integers(min_value=-(2**70), max_value=2**1100).map(str),
    )


def mutation(draw, valid):
    """A mutated value: a wrong kind of value or an extreme number; None: leave the key out;
    a pair: the key twice."""
    how = draw(st.sampled_from(["drop", "any", "any", "extreme", "extreme", "duplicate"]))
    if how == "drop":
        return None
    value = draw(any_values() if how == "any" else extreme_numbers())
    return (draw(valid), value) if how == "duplicate" else value


def foreign_line(draw):
    """A key the section does not have (or has under another section), any value."""
    key = draw(st.one_of(any_keys(), st.sampled_from(ALL_KEYS)))
    return f"{key} = {draw(any_values())}"


# positive numbers of any magnitude for the keys that take one: valid one by one, they may
# over- or underflow in combination
EXTREME_KEYS = {
    *CASE_KEYS,
    *PHYSICAL_KEYS,
    "accuracy",
    "dt",
    "tolerance",
    "dt_min",
    "dt_max",
    "edge_fraction",
    "load_tolerance",
    "time_tolerance",
    "progress_interval",
    "checkpoint_interval",
}
ANY_POSITIVE = st.one_of(
    st.floats(min_value=5e-324, max_value=1.7976931348623157e308).map(toml_float),
    st.integers(-323, 308).map(lambda e: f"1e{e}"),
)
EXTREME_NX = st.integers(32, 2**1100).map(lambda n: str(2 * n))


@st.composite
def section_lines(draw, name, rate, required, target=None, extreme=False):
    """``key = value`` lines of one section: its keys (all when ``required``, else a few) with
    valid values, each mutated with probability ``rate`` percent (and the key ``target``
    surely; "+": a foreign key added); ``extreme``: numbers of any magnitude half the time."""
    keys = list(VALID[name])
    if not required:
        keys = draw(st.lists(st.sampled_from(keys), unique=True, max_size=3))
        if target in VALID[name] and target not in keys:
            keys.append(target)
    lines = []
    for key in keys:
        if key == target or chance(draw, rate):
            value = mutation(draw, VALID[name][key])
            if value is None:
                continue
            if isinstance(value, tuple):
                lines.append(f"{key} = {value[0]}")
                value = value[1]
        elif extreme and key in EXTREME_KEYS and chance(draw, 50):
            value = draw(ANY_POSITIVE)
        elif extreme and key == "nx" and chance(draw, 50):
            value = draw(EXTREME_NX)
        else:
            value = draw(VALID[name][key])
        lines.append(f"{key} = {value}")
    if target == "+" or chance(draw, rate):
        lines.insert(draw(st.integers(0, len(lines))), foreign_line(draw))
    return lines


@st.composite
def case_sections(draw, prefix="", mode=None):
    """The sections of a case file (headers with ``prefix``, "base." in a sweep file): valid,
    or with exactly one mutation, or with a few or many, or numbers of any magnitude."""
    mode = mode or draw(
        st.sampled_from(
            ["valid", "valid", "one", "one", "one", "few", "many", "extreme", "extreme"]
        )
    )
    rate = {"valid": 0, "one": 0, "few": 5, "many": 40, "extreme": 0}[mode]
    form = draw(
        st.sampled_from(
            ["case", "case", "case", "physical", "physical", "both", "neither"]
            if mode not in ("valid", "extreme")
            else ["case", "physical"]
        )
    )
    forms = {
        "case": ["case"],
        "physical": ["physical"],
        "both": ["case", "physical"],
        "neither": [],
    }[form]
    names = forms + [name for name in ("numerics", "output") if chance(draw, 50)]
    target = (None, None)
    if mode == "one":
        section = draw(st.sampled_from(names + ["file"]))
        if section != "file":
            target = (section, draw(st.sampled_from([*VALID[section], "+"])))
    blocks = [
        (
            f"[{prefix}{name}]",
            draw(
                section_lines(
                    name,
                    rate,
                    name in forms,
                    target[1] if name == target[0] else None,
                    mode == "extreme",
                )
            ),
        )
        for name in names
    ]
    whole = mode == "one" and target == (None, None)
    if (whole and chance(draw, 50)) or chance(draw, rate):
        # an unknown section, an array of tables, a table where a value belongs
        header = draw(
            st.sampled_from(
                [
                    "[solver]",
                    "[[case]]",
                    "[numerics.nx]",
                    "[case.maugis]",
                    "[output.extra]",
                    f"[{prefix}physical]",
                    f"[{prefix}numerics]",
                    "[]",
                    "[ case ]",
                    '["case"]',
                    "[case",
                    "[[numerics]]",
                    "[" + toml_string("sec\ntion") + "]",
                    '["λ"]',
                ]
            )
        )
        blocks.insert(draw(st.integers(0, len(blocks))), (header, [foreign_line(draw)]))
    elif whole or chance(draw, rate):  # a value where a section belongs
        blocks.insert(
            0,
            (
                "",
                [f"{draw(st.sampled_from(['numerics', 'output', 'case']))} = {draw(any_values())}"],
            ),
        )
    if not prefix and chance(draw, 50):
        draw(st.randoms(use_true_random=False)).shuffle(blocks)
    return blocks


def render(blocks) -> str:
    return "".join(
        (f"{header}\n" if header else "") + "".join(f"{line}\n" for line in lines)
        for header, lines in blocks
    )


@st.composite
def mutated(draw, texts):
    """A text, cut at a random point, with a slice removed or garbage inserted, or a random
    byte changed (decoded with errors="replace")."""
    text = draw(texts)
    how = draw(st.sampled_from(["cut", "delete", "insert", "byte", "line"]))
    i = draw(st.integers(0, len(text)))
    if how == "cut":
        return text[:i]
    if how == "delete":
        return text[:i] + text[i + draw(st.integers(1, 40)) :]
    if how == "insert":
        garbage = st.one_of(
            st.text(max_size=8),
            st.sampled_from(
                ["\x00", "\ufeff", "\r", '"', "[", "]", "=", "\n=\n", "#", "\\", "[[", "{"]
            ),
        )
        return text[:i] + draw(garbage) + text[i:]
    if how == "line":  # a line duplicated
        lines = text.splitlines(keepends=True) or [""]
        j = draw(st.integers(0, len(lines) - 1))
        return "".join(lines[: j + 1] + lines[j:])
    raw = bytearray(text.encode())
    if raw:
        raw[min(i, len(raw) - 1)] = draw(st.integers(0, 255))
    return raw.decode("utf-8", errors="replace")


def random_text():
    """Random bytes decoded with errors="replace", random text, absurd nesting."""
    return st.one_of(
        st.binary(max_size=300).map(lambda b: b.decode("utf-8", errors="replace")),
        st.text(max_size=200),
        st.integers(1, 5000).map(lambda n: "[case]\nmaugis = " + "[" * n + "1" + "]" * n),
        st.integers(1, 5000).map(lambda n: "a = " + "{b = " * n + "1" + "}" * n),
    )


def case_files():
    structured = case_sections().map(render)
    return st.one_of(structured, structured, mutated(structured), random_text())


# --- sweep files ---------------------------------------------------------------------------

# the files of the directory of the sweep file (parse_sweep's ``directory``)
BASE_FILES = {
    "case.toml": cases.case_text().encode(),
    "bad.toml": b"[case\nmaugis = ",
    "binary.toml": bytes(range(256)) * 4,
    "empty.toml": b"",
    "utf16.toml": cases.case_text().encode("utf-16"),
}


def make_sweep_directory(path):
    for name, content in BASE_FILES.items():
        with open(os.path.join(path, name), "wb") as fh:
            fh.write(content)
    os.mkdir(os.path.join(path, "sub"))


# base = ... other than the valid "case.toml"
BASE_NAMES = [
    '"missing.toml"',
    '"bad.toml"',
    '"binary.toml"',
    '"empty.toml"',
    '"utf16.toml"',
    '"sub"',
    '""',
    '"."',
    '"/"',
    toml_string("case.toml\x00"),
    '"/proc/self/mem"',
    '"/dev/null"',
    toml_string("λ.toml"),
    toml_string("sub/../case.toml"),
]


def sweep_keys(form):
    """Swept keys (section, spelling) valid for a base of ``form``: bare or section.key."""
    pairs = [(section, key) for section in (form, "numerics", "output") for key in VALID[section]]
    return st.sampled_from(pairs).flatmap(
        lambda pair: st.sampled_from([pair[1], f"{pair[0]}.{pair[1]}"]).map(
            lambda spelling: (pair[0], spelling)
        )
    )


def list_text(values):
    return "[" + ", ".join(values) + "]"


@st.composite
def sweep_sections(draw):
    """The sections of a sweep file: valid, or with exactly one mutation, or a few or many."""
    mode = draw(st.sampled_from(["valid", "valid", "one", "one", "one", "few", "many"]))
    rate = {"valid": 0, "one": 0, "few": 5, "many": 40}[mode]
    target = (
        draw(
            st.sampled_from(
                [
                    "base",
                    "base case",
                    "grid key",
                    "grid value",
                    "grid",
                    "cases key",
                    "cases value",
                    "cases",
                    "farm",
                    "top",
                ]
            )
        )
        if mode == "one"
        else None
    )

    def hit(part):
        return target == part or chance(draw, rate)

    blocks = []
    base = draw(st.sampled_from(["inline", "inline", "file"]))
    base_blocks = []
    if hit("base"):
        other = draw(st.one_of(st.sampled_from(BASE_NAMES), LONG_STRING, any_values()))
        blocks.append(("", [f"base = {other}"]))
    elif base == "file":
        blocks.append(("", ['base = "case.toml"']))
    else:
        base_mode = (
            "one" if target == "base case" else "valid" if mode in ("valid", "one") else None
        )  # few, many: any base
        base_blocks = draw(case_sections(prefix="base.", mode=base_mode))
    form = "physical" if any(h == "[base.physical]" for h, _ in base_blocks) else "case"
    keys = sweep_keys(form)
    lines = []
    for _ in range(draw(st.integers(0 if target not in ("grid key", "grid value") else 1, 2))):
        section, key = draw(keys)
        if hit("grid key"):
            key = draw(any_keys())
        values = draw(
            st.lists(
                VALID[section][key.split(".")[-1]]
                if key.split(".")[-1] in VALID[section]
                else any_values(),
                min_size=1,
                max_size=3,
            )
        )
        if hit("grid value"):
            values[draw(st.integers(0, len(values) - 1))] = draw(
                st.one_of(any_values(), extreme_numbers())
            )
        value = list_text(values)
        if hit("grid value") and chance(draw, 30):
            value = draw(st.one_of(st.just("[]"), any_values(), extreme_numbers()))
        lines.append(f"{key} = {value}")
    if lines or hit("grid"):
        if hit("grid"):
            lines.insert(draw(st.integers(0, len(lines))), foreign_line(draw))
        blocks.append(("[grid]", lines))
    for _ in range(draw(st.integers(1 if target and target.startswith("cases") else 0, 2))):
        lines = []
        for _ in range(draw(st.integers(0, 2))):
            section, key = draw(keys)
            if hit("cases key"):
                key = draw(any_keys())
            value = (
                draw(VALID[section][key.split(".")[-1]])
                if key.split(".")[-1] in VALID[section]
                else draw(any_values())
            )
            if hit("cases value"):
                value = draw(st.one_of(any_values(), extreme_numbers()))
            lines.append(f"{key} = {value}")
        if hit("cases"):
            lines.append(foreign_line(draw))
        blocks.append(("[[cases]]", lines))
    farm = hit("farm")
    if farm or chance(draw, 40):
        lines = []
        if chance(draw, 70):
            ranks = (
                draw(st.one_of(st.integers(-3, 0).map(str), scalar_values()))
                if farm and chance(draw, 50)
                else str(draw(st.integers(1, 4)))
            )
            lines.append(f"ranks_per_case = {ranks}")
        if chance(draw, 50):
            output = draw(scalar_values()) if farm and chance(draw, 50) else '"study"'
            lines.append(f"output = {output}")
        if farm and chance(draw, 30):
            lines.append(foreign_line(draw))
        blocks.append(("[farm]", lines))
    if hit("top"):  # a top-level key or a section where it does not belong
        if chance(draw, 33):
            blocks.insert(0, ("", [f"{draw(any_keys())} = {draw(any_values())}"]))
        elif chance(draw, 50):  # a value for a section
            blocks.insert(
                0,
                (
                    "",
                    [
                        f"{draw(st.sampled_from(['farm', 'grid', 'cases']))}"
                        f" = {draw(st.one_of(any_values(), extreme_numbers()))}"
                    ],
                ),
            )
        else:
            blocks.append(
                (
                    draw(
                        st.sampled_from(
                            [
                                "[colour]",
                                "[[grid]]",
                                "[farm.output]",
                                "[cases]",
                                "[[farm]]",
                                "[base]",
                                "[grid.x]",
                                "[" + toml_string("sec\ntion") + "]",
                            ]
                        )
                    ),
                    [foreign_line(draw)],
                )
            )
    return blocks + base_blocks


def sweep_files():
    structured = sweep_sections().map(render)
    return st.one_of(structured, structured, mutated(structured), random_text())


# --- the properties ---------------------------------------------------------------------------


def one_line(message: str) -> bool:
    return bool(message.strip()) and len(message.splitlines()) == 1


def check_case(case, where="case"):
    """Cheap invariants of an accepted case (docs/case-file.md), and its dry-run listing."""
    for key in CASE_KEYS:
        value = getattr(case, key)
        assert isinstance(value, float) and math.isfinite(value) and value > 0, (where, key, value)
    assert case.modulus_ratio <= 1.0, where
    assert case.cell >= 6.0 * math.sqrt(2.0 * case.depth) * (1 - 1e-12), where
    for name in (
        "beta",
        "load_scale",
        "sigma_a",
        "dmax",
        "zone_width",
        "chi_ve",
        "indenter_speed",
        "lambda_inf",
    ):
        value = getattr(case, name)
        assert math.isfinite(value) and value > 0, (where, name, value)
    n = case.numerics
    assert isinstance(n.nx, int) and n.nx >= 64 and n.nx % 2 == 0, (where, n.nx)
    for name in ("dt", "dt_min", "tolerance", "edge_fraction", "load_tolerance", "time_tolerance"):
        value = getattr(n, name)
        assert math.isfinite(value) and value > 0, (where, name, value)
    assert 0 < n.dt_min <= n.dt_max, where
    assert 0 < n.accuracy < 0.1 and MIN_TOLERANCE <= n.tolerance < 0.01, where
    assert n.max_iterations >= 1 and all(v >= 1 for _, v in n.solver_settings), where
    assert n.solver in ("cg", "paper") and n.step_control in ("adaptive", "fixed"), where
    o = case.output
    # (inf: a time beyond the float range in units of tau, never reached)
    assert all(t >= 0 for t in o.snapshot_times + o.snapshot_contact_widths), where
    assert o.progress_interval > 0 and o.checkpoint_interval > 0 and o.checkpoint_steps >= 0
    assert describe(case)  # what run --dry-run prints
    assert len(case.identity()) == 16


def case_outcome(text: str) -> str:
    """'valid' or 'invalid'; any other exception, a message of several lines or none fails."""
    try:
        case = parse_case(text)
    except CaseError as err:
        assert type(err) is CaseError
        assert one_line(str(err)), f"CaseError message not one non-empty line: {str(err)!r}"
        return "invalid"
    check_case(case)
    return "valid"


def sweep_outcome(text: str, directory: str) -> str:
    try:
        sweep = parse_sweep(text, directory, os.path.join(directory, "sweep.toml"))
    except SweepError as err:
        assert type(err) is SweepError
        assert one_line(str(err)), f"SweepError message not one non-empty line: {str(err)!r}"
        return "invalid"
    assert sweep.cases and any(c.case is not None for c in sweep.cases)
    assert isinstance(sweep.ranks_per_case, int) and sweep.ranks_per_case >= 1
    assert sweep.output is None or isinstance(sweep.output, str)
    for item in sweep.cases:
        if item.case is None:
            assert one_line(item.error), item.error
        else:
            check_case(item.case, f"sweep case {item.index}")
            assert item.cost() >= 0  # the dry run's cost estimate
    return "valid"


@pytest.fixture(scope="module")
def sweep_directory(tmp_path_factory):
    path = tmp_path_factory.mktemp("sweep")
    make_sweep_directory(path)
    return str(path)


@settings(max_examples=EXAMPLES, **FUZZ_SETTINGS)
@given(text=case_files())
def test_case_parser_fuzz(text):
    """parse_case: a Case passing the invariants, or a one-line CaseError; nothing else."""
    OUTCOMES["case"][case_outcome(text)] += 1


@settings(max_examples=EXAMPLES, **FUZZ_SETTINGS)
@given(text=sweep_files())
def test_sweep_parser_fuzz(sweep_directory, text):
    """parse_sweep: a Sweep of valid/invalid cases, or a one-line SweepError; nothing else."""
    OUTCOMES["sweep"][sweep_outcome(text, sweep_directory)] += 1


# --- a sample through the real commands ----------------------------------------------------


def sample(strategy, n):
    """``n`` different examples of ``strategy``, the same every time (derandomized): spread
    over 10 n generated ones (hypothesis's first examples are the simplest)."""
    found = []

    @settings(max_examples=10 * n, **FUZZ_SETTINGS)
    @given(strategy)
    def collect(text):
        if text not in found:
            found.append(text)

    collect()
    return found[:: max(1, len(found) // n)][:n]


def run_command(command, text, directory):
    """``python -m hpcgfmd COMMAND f.toml --dry-run`` in ``directory``: the failures found."""
    path = os.path.join(directory, "f.toml")
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(text)
    before = sorted(os.listdir(directory))
    proc = subprocess.run(
        [sys.executable, "-m", "hpcgfmd", command, "f.toml", "--dry-run"],
        cwd=directory,
        capture_output=True,
        text=True,
        errors="replace",
        timeout=120,
    )
    problems = []
    if proc.returncode not in (0, 2):
        problems.append(f"exit status {proc.returncode}")
    if "Traceback" in proc.stderr:
        problems.append("a traceback")
    if proc.returncode == 2 and not (
        proc.stderr.endswith("\n") and proc.stderr.count("\n") == 1 and proc.stderr.strip()
    ):
        problems.append("not one line on stderr")
    if sorted(os.listdir(directory)) != before:
        problems.append(f"files written: {set(os.listdir(directory)) - set(before)}")
    return (
        f"{command} {text[:300]!r}: {', '.join(problems)}; stderr {proc.stderr[-2000:]!r}"
        if problems
        else None
    ), proc.returncode


@pytest.mark.slow
def test_commands_fuzz(tmp_path):
    """A derandomized sample through ``run --dry-run`` and ``farm --dry-run`` (subprocesses,
    one per core at a time): exit 0 or 2, for 2 one non-empty line on stderr, no traceback,
    no file written."""
    jobs = []
    case_inputs = [cases.case_text()] + sample(case_files(), CLI_EXAMPLES)
    sweep_inputs = ['base = "case.toml"\n[grid]\nvelocity = [0.5, 1.0]\n'] + sample(
        sweep_files(), CLI_EXAMPLES
    )
    for command, inputs in (("run", case_inputs), ("farm", sweep_inputs)):
        for i, text in enumerate(inputs):
            directory = tmp_path / f"{command}{i}"
            directory.mkdir()
            if command == "farm":
                make_sweep_directory(directory)
            jobs.append((command, text, str(directory)))
    with ThreadPoolExecutor(max(2, os.cpu_count() or 1)) as pool:
        results = list(pool.map(lambda job: run_command(*job), jobs))
    failures = [problem for problem, _ in results if problem]
    assert not failures, "\n".join(failures)
    statuses = collections.Counter((job[0], status) for job, (_, status) in zip(jobs, results))
    assert statuses[("run", 0)] and statuses[("run", 2)], statuses
    assert statuses[("farm", 0)] and statuses[("farm", 2)], statuses
