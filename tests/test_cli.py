"""The command line as a user meets it: subprocesses of `python -m hpcgfmd`."""

import re
import signal
import subprocess
import sys

import h5py
import numpy as np
import pytest

import cases
from hpcgfmd.storage.reader import read_series


def case_text(numerics="nx = 1024", output="", **changes):
    """The tests' case made elastic with lambda = 1 (fast), changed by ``changes``."""
    return cases.case_text(numerics, output, **{"maugis": 1.0, "modulus_ratio": 1.0, **changes})


def hpcgfmd(*args, cwd, timeout=300):
    return subprocess.run(
        [sys.executable, "-m", "hpcgfmd", *map(str, args)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


BAD = [
    ("unknown key", case_text(colour="1"), ["colour", "unknown key"]),
    ("missing key", case_text(adhesion=None), ["adhesion", "missing"]),
    ("wrong type", case_text(maugis='"seven"'), ["maugis", "'seven'", "number"]),
    ("zero", case_text(velocity="0"), ["velocity", "0.0", "> 0"]),
    ("negative", case_text(depth="-0.1"), ["depth", "-0.1", "> 0"]),
    ("k above one", case_text(modulus_ratio="1.5"), ["modulus_ratio", "1.5", "(0, 1]"]),
    ("cell too small", case_text(cell="0.5"), ["cell", "0.5", "too small"]),
    (
        "nx unresolved",
        case_text(maugis="7.0", numerics="nx = 64"),
        ["nx", "64", "points", "at least", "nx >= "],
    ),
    ("nx odd", case_text(numerics="nx = 1001"), ["nx", "1001", "even integer"]),
    ("tolerance", case_text(numerics="nx = 1024\ntolerance = 0.5"), ["tolerance", "0.5"]),
    ("tolerance floor", case_text(numerics="nx = 1024\ntolerance = 1e-20"), ["tolerance", "1e-20"]),
    ("nx memory", case_text(numerics="nx = 1099511627776"), ["nx", "1099511627776", "GiB"]),
    ("nx beyond any machine", case_text(numerics=f"nx = {2**52}"), ["nx", str(2**52), "2^50"]),
    (
        "grid beyond any machine",
        case_text(maugis="1e16", cell="1e270", numerics=""),
        ["accuracy", "2^1010 nodes", "at most 2^50"],
    ),
    ("not a table", "output = 3\n" + case_text(), ["output = 3", "section"]),
    # passes the static check (L >= 6 sqrt(2 R h0)) but the adhesive contact found by the
    # preload is wider than L/4
    (
        "cell after preload",
        case_text(maugis="1.0", adhesion="1e-2", depth="0.005", cell="0.61"),
        ["cell", "0.61", "after the preload"],
    ),
    ("both forms", case_text() + "[physical]\nradius = 1.0\n", ["exactly one of"]),
    ("unknown section", case_text() + "[solver]\nx = 1\n", ["[solver]", "unknown section"]),
    ("not toml", "[case\nmaugis = ", ["not valid TOML"]),
    (
        "physical moduli",
        cases.physical_text(
            modulus_relaxed="2e6", modulus_instantaneous="1e6", interaction_range="1e-8"
        ),
        ["modulus_instantaneous", "1000000.0", "modulus_relaxed"],
    ),
    ("snapshot list", case_text(output="snapshot_times = [1, -2]"), ["snapshot_times", "list"]),
    (
        "checkpoint steps",
        case_text(output="checkpoint_steps = -1"),
        ["checkpoint_steps", "-1", "integer >= 0"],
    ),
    (
        "checkpoint interval",
        case_text(output="checkpoint_interval = 0"),
        ["checkpoint_interval", "0", "> 0"],
    ),
    (
        "solver",
        case_text(numerics='nx = 1024\nsolver = "fire"'),
        ["solver", "'fire'", "'cg'", "'paper'"],
    ),
    (
        "step control",
        case_text(numerics='nx = 1024\nstep_control = "auto"'),
        ["step_control", "'auto'", "'adaptive'", "'fixed'"],
    ),
    ("edge fraction", case_text(numerics="nx = 1024\nedge_fraction = 0"), ["edge_fraction", "> 0"]),
    (
        "load tolerance",
        case_text(numerics="nx = 1024\nload_tolerance = -1"),
        ["load_tolerance", "-1", "> 0"],
    ),
    (
        "dt bounds",
        case_text(numerics="nx = 1024\ndt_min = 2.0\ndt_max = 1.0"),
        ["dt_min", "2", "dt_max"],
    ),
    (
        "equilibration steps",
        case_text(numerics="nx = 1024\nequilibration_steps = 0"),
        ["equilibration_steps", "0", "integer >= 1"],
    ),
]


@pytest.mark.parametrize("name, text, words", BAD, ids=[b[0] for b in BAD])
def test_bad_input_one_line_status_2_nothing_touched(tmp_path, name, text, words):
    (tmp_path / "case.toml").write_text(text)
    existing = tmp_path / "out.h5"
    existing.write_bytes(b"previous results")
    before = existing.stat().st_mtime_ns
    res = hpcgfmd("run", "case.toml", "-o", "out.h5", "--overwrite", cwd=tmp_path)
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in res.stderr, res.stderr
    for word in words:
        assert word in lines[0], (word, lines[0])
    assert existing.read_bytes() == b"previous results"
    assert existing.stat().st_mtime_ns == before


def test_output_path_that_is_a_directory(tmp_path):
    (tmp_path / "case.toml").write_text(case_text())
    (tmp_path / "out").mkdir()
    res = hpcgfmd("run", "case.toml", "-o", "out", "--overwrite", cwd=tmp_path)
    assert res.returncode == 2 and "directory" in res.stderr and "Traceback" not in res.stderr


def test_non_convergence_is_one_line_status_1_and_keeps_the_file(tmp_path):
    (tmp_path / "case.toml").write_text(case_text(numerics="nx = 1024\nmax_iterations = 2"))
    res = hpcgfmd("run", "case.toml", cwd=tmp_path)
    assert res.returncode == 1
    assert len(res.stderr.strip().splitlines()) == 1 and "NonConvergenceError" in res.stderr


def test_existing_output_is_refused(tmp_path):
    (tmp_path / "case.toml").write_text(case_text())
    (tmp_path / "case.h5").write_bytes(b"keep me")
    res = hpcgfmd("run", "case.toml", cwd=tmp_path)
    assert res.returncode == 2 and "exists" in res.stderr
    assert (tmp_path / "case.h5").read_bytes() == b"keep me"


def test_run_info_plot_end_to_end(tmp_path):
    (tmp_path / "case.toml").write_text(
        case_text(output="snapshot_contact_widths = [0.1]\nsnapshot_zero_load = true")
    )
    res = hpcgfmd("run", "case.toml", "-o", "out.h5", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "chi_ve = 1" in res.stdout and "w/dx" in res.stdout and "finished" in res.stdout
    with h5py.File(tmp_path / "out.h5", "r") as f:
        a = f.attrs
        assert a["finished"] and a["config"] == (tmp_path / "case.toml").read_text()
        for key in (
            "hpcgfmd_version",
            "lambda0",
            "lambda_inf",
            "k",
            "Vz",
            "chi_ve",
            "alpha",
            "beta",
            "load_scale",
            "zone_points",
        ):
            assert key in a
        assert a["beta"] == pytest.approx(1e-4 ** (1 / 3))
        assert a["load_scale"] == pytest.approx(1e-4 ** (2 / 3))
        series = f["series"]
        n = series["time"].shape[0]
        assert n == a["steps"] + 1
        for name in (
            "indenter",
            "load",
            "contact_half_width",
            "cohesive_half_width",
            "iterations",
            "residual",
        ):
            assert series[name].shape == (n,)
        assert series["time"][0] == 0 and series["indenter"][0] == pytest.approx(-0.03)
        assert series["load"][0] > 0 and series["load"][:].min() < 0
        assert np.all(series["cohesive_half_width"][:] >= series["contact_half_width"][:])
        snaps = f["snapshots"]
        assert snaps["surface"].shape == (4, 1024)  # t = 0, a_c = 0.1, zero load, final
        assert snaps["x"].shape == (1024,)
        gap = snaps["gap"][0]
        assert gap.min() == 0.0
    res = hpcgfmd("info", "out.h5", cwd=tmp_path)
    assert res.returncode == 0 and "pull-off" in res.stdout and "detachment" in res.stdout
    res = hpcgfmd("plot", "out.h5", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    png = (tmp_path / "out.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 20000
    # an existing PNG is kept (one line, status 2) unless --overwrite; no temporary left
    (tmp_path / "out.png").write_bytes(b"mine")
    res = hpcgfmd("plot", "out.h5", cwd=tmp_path)
    assert res.returncode == 2 and (tmp_path / "out.png").read_bytes() == b"mine"
    assert res.stderr.count("\n") == 1 and "out.png" in res.stderr
    assert "--overwrite" in res.stderr
    assert hpcgfmd("plot", "out.h5", "--overwrite", cwd=tmp_path).returncode == 0
    assert (tmp_path / "out.png").read_bytes() == png
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.toml", "out.h5", "out.png"]
    # info into a reader that has already gone (| head -1): status 1, no traceback
    proc = subprocess.Popen(
        [sys.executable, "-m", "hpcgfmd", "info", "out.h5"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    proc.stdout.close()  # before the interpreter has started (about 0.5 s): info writes after
    assert proc.wait(timeout=60) == 1
    assert proc.stderr.read() == b""


def test_physical_form_equals_case_form_in_si_units(tmp_path):
    # R = 2 mm, E0 = 1.5 MPa, k = 0.1, tau = 0.3 s; groups as the [case] file below.
    R, E0, tau, lam, alpha, Vz = 2e-3, 1.5e6, 0.3, 3.5, 1e-4, 1.0
    work = alpha * E0 * R
    beta = (R**2 * work / E0) ** (1 / 3)
    dmax = (work**2 * R / (E0**2 * lam**3)) ** (1 / 3)
    phys = cases.physical_text(
        'nx = 1024\nstep_control = "fixed"\ntolerance = 1e-9',
        radius=R,
        modulus_relaxed=E0,
        modulus_instantaneous=E0 / 0.1,
        relaxation_time=tau,
        work_of_adhesion=work,
        interaction_range=dmax,
        velocity=Vz * beta**2 / (R * tau),
        depth=0.03 * R,
        cell_length=2 * R,
    )
    (tmp_path / "p.toml").write_text(phys)
    # fixed steps: adaptive decisions may round differently between the two unit systems
    (tmp_path / "c.toml").write_text(
        case_text(
            'nx = 1024\nstep_control = "fixed"\ntolerance = 1e-9', maugis="3.5", modulus_ratio="0.1"
        )
    )
    for name in ("p", "c"):
        assert hpcgfmd("run", f"{name}.toml", cwd=tmp_path).returncode == 0
    with h5py.File(tmp_path / "p.h5") as p, h5py.File(tmp_path / "c.h5") as c:
        for key in ("lambda0", "k", "Vz", "alpha", "chi_ve"):
            assert p.attrs[key] == pytest.approx(c.attrs[key], rel=1e-12)
        assert p.attrs["beta"] == pytest.approx(beta, rel=1e-12)
        np.testing.assert_allclose(
            p["series/load"][:], c["series/load"][:] * E0 * R, rtol=1e-6, atol=1e-9 * E0 * R
        )
        np.testing.assert_allclose(p["series/time"][:], c["series/time"][:] * tau, rtol=1e-12)
        np.testing.assert_allclose(
            p["series/contact_half_width"][:],
            c["series/contact_half_width"][:] * R,
            rtol=1e-6,
            atol=1e-12,
        )


def test_killed_run_leaves_a_readable_file(tmp_path):
    # Progress lines (one per step at this interval) tell when steps have been written.
    (tmp_path / "case.toml").write_text(
        case_text(maugis="3.5", numerics="nx = 4096", output="progress_interval = 1e-6")
    )
    proc = subprocess.Popen(
        [sys.executable, "-m", "hpcgfmd", "run", "case.toml"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        steps = 0
        while steps < 10:
            line = proc.stdout.readline()
            assert line, "the run ended before it could be killed"
            steps += line.startswith("step")
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        proc.kill()
    with h5py.File(tmp_path / "case.h5", "r") as f:
        assert not f.attrs["finished"]
        n = int(f.attrs["steps_complete"])
        assert n >= 10
        for name in ("load", "indenter", "contact_half_width", "iterations"):
            assert f["series"][name].shape[0] in (n, n + 1)  # killed between two appends
    s = read_series(tmp_path / "case.h5")  # truncates to the complete steps
    assert s.time.size == n and np.all(np.diff(s.time) > 0) and np.all(s.iterations > 0)
    info = hpcgfmd("info", "case.h5", cwd=tmp_path).stdout  # its loads so far, said so
    assert "NOT finished" in info and "steps so far" in info
    assert (
        "pull-off (the most tensile load so far): load = " in info
        or "pull-off: none, no tensile load recorded" in info
    ), info


def test_bench_takes_the_common_options(tmp_path):
    """--quiet and --log before or after `bench`: a log file that cannot be opened is a
    one-line usage error, and bench's own argument errors still come through."""
    missing = hpcgfmd("bench", "--log", tmp_path / "no" / "such" / "x.log", cwd=tmp_path)
    assert missing.returncode == 2 and "--log" in missing.stderr
    assert "Traceback" not in missing.stderr and len(missing.stderr.splitlines()) == 1
    for args in (("--quiet", "bench", "--nx", "3"), ("bench", "--nx", "3", "--quiet")):
        bad = hpcgfmd(*args, cwd=tmp_path)
        assert bad.returncode == 2 and "--nx [3]" in bad.stderr, bad.stderr
    assert "--log FILE" in hpcgfmd("bench", "--help", cwd=tmp_path).stdout


def test_the_default_command_runs_the_embedded_case_into_a_dated_file(tmp_path):
    # `python -m hpcgfmd` (what scripts/main.sh runs): the README names the file it writes
    res = hpcgfmd(cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    files = [p.name for p in tmp_path.iterdir()]
    assert len(files) == 1 and re.fullmatch(r"hpcgfmd-default-\d{8}-\d{6}\.h5", files[0]), files
    result = read_series(tmp_path / files[0])
    assert result.attrs["finished"] and result.attrs["lambda0"] == 7.0
    assert result.attrs["Vz"] == 0.45 and result.load.min() < 0 < result.load[0]


@pytest.mark.parametrize("dt, warned", [(1e4, True), (1.0, True), (0.1, False)])
def test_fixed_steps_too_long_for_the_pull_off_are_warned(tmp_path, dt, warned):
    # one step from the preload to detachment (1e4: past u_z = 1 R, yet detached, so
    # finished) or an edge moving 7.6 zone widths a step (1.0): the pull-off is not resolved
    # and the run says so; at 0.1 the edge moves within the allowance (Lbar -6.3635 against
    # -6.358 with adaptive steps)
    (tmp_path / "case.toml").write_text(
        cases.case_text(f'accuracy = 1e-2\nstep_control = "fixed"\ndt = {dt}', "")
    )
    res = hpcgfmd("run", "case.toml", "--quiet", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    lines = [line for line in res.stderr.splitlines() if "fixed steps" in line]
    assert len(lines) == (1 if warned else 0), res.stderr
    if warned:
        assert lines[0].startswith("hpcgfmd: case.h5: fixed steps: a contact edge moved")
        assert "cohesive-zone widths in one step before the pull-off" in lines[0]
    assert read_series(tmp_path / "case.h5").attrs["finished"]
    # without a tensile load there is no pull-off to report
    info = hpcgfmd("info", "case.h5", cwd=tmp_path).stdout
    assert ("pull-off: none, no tensile load recorded" in info) == (dt == 1e4), info


def test_an_approach_into_contact_is_not_an_unresolved_pull_off(tmp_path):
    # fixed steps through an approach, a dwell and the retraction: the jump into contact
    # (9.2 zone widths in one step) belongs to the approach; the retraction's edge moves
    # 0.28 zone widths a step at most, within the allowance (2.24), so no warning
    (tmp_path / "case.toml").write_text(
        cases.case_text('nx = 2048\nstep_control = "fixed"\ndt = 0.05', "")
        + "\n[[protocol]]\napproach = 0.03\n[[protocol]]\ndwell = 0.3\n[[protocol]]\n"
        "retract = inf\n"
    )
    res = hpcgfmd("run", "case.toml", cwd=tmp_path)
    assert res.returncode == 0 and "fixed steps" not in res.stderr, res.stderr
