"""Sweep files and the task farm (`mpirun -n 2 python -m hpcgfmd farm sweep.toml`)."""

import csv
import os
import re
import shutil
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest

from cases import FIXED_STEPS, case_text
from hpcgfmd.case import parse_case
from hpcgfmd.errors import SweepError
from hpcgfmd.runs.sweep import parse_sweep
from hpcgfmd.storage.reader import read_series

MPIRUN = shutil.which("mpirun")
BASE = case_text("nx = 1024", prefix="base.")


def test_grid_times_cases_and_overrides():
    sweep = parse_sweep(
        BASE + "[grid]\nvelocity = [0.5, 2.0]\ndepth = [0.03, 0.02]\n"
        "[[cases]]\n[[cases]]\nmaugis = 1.0\nnumerics.nx = 2048\n"
    )
    assert len(sweep.cases) == 8
    assert sweep.swept == ["case.velocity", "case.depth", "case.maugis", "numerics.nx"]
    first, last = sweep.cases[0], sweep.cases[-1]
    assert first.name == "velocity_0.5-depth_0.03"
    assert last.name == "maugis_1.0-nx_2048-velocity_2.0-depth_0.02"
    # each case file is the base with its values: the same Case as writing it by hand
    by_hand = parse_case(case_text("nx = 2048", velocity=2.0, depth=0.02, maugis=1.0))
    assert last.case.identity() == by_hand.identity()
    assert all(c.error is None for c in sweep.cases)


def test_a_file_of_the_same_case_under_another_cap_is_its_own(tmp_path):
    # the farm's file states: a finished file of the case is skipped whatever the cap it ran
    # under (the cap is not in the identity: tests/test_restart.py); another case's file,
    # or one of another version's identity, is not touched
    from hpcgfmd.runs.farm import file_status

    base = case_text("nx = 1024\ntolerance = 1e-3", prefix="base.", velocity=9.0)
    capped = parse_sweep(base + "[grid]\nnumerics.max_iterations = [30, 20000]\n").cases
    default = parse_sweep(base + "[[cases]]\n").cases
    path = str(tmp_path / "case.h5")

    def states(identity, items):
        with h5py.File(path, "w") as f:
            f.attrs["finished"], f.attrs["case_identity"] = True, identity
        return [file_status(path, item) for item in items]

    assert states(capped[0].case.identity(), capped + default) == ["finished"] * 3
    assert states("dbd0e40dc01236e4", default) == ["other case"]
    assert (
        states(parse_case(case_text("nx = 2048")).identity(), capped + default)
        == ["other case"] * 3
    )


def test_an_invalid_case_is_kept_with_its_error():
    sweep = parse_sweep(BASE + "[grid]\nnx = [1024, 64]\n")
    assert sweep.cases[0].error is None
    assert sweep.cases[1].case is None and "nx = 64" in sweep.cases[1].error


@pytest.mark.parametrize(
    "text, words",
    [
        (BASE + "[grid]\ncolour = [1, 2]\n", ["colour", "not a key"]),
        (BASE + "[grid]\nvelocity = 0.5\n", ["velocity", "non-empty list"]),
        (BASE + "[grid]\nphysical.radius = [1.0]\n", ["physical.radius", "no key"]),
        (BASE + "[farm]\nranks_per_case = 0\n", ["ranks_per_case", "integer >= 1"]),
        (BASE + "[sweep]\n", ["sweep", "unknown"]),
        ("[grid]\nvelocity = [1.0]\n", ["base", "missing"]),
        (BASE + "[[cases]]\nvelocity = 1.0\n[[cases]]\nvelocity = 1.0\n", ["same case"]),
        ("cases = []\n" + BASE, ["cases = []", "at least one"]),
        (BASE + "[grid]\nvelocity = [1.0]\n[[cases]]\nvelocity = 3.0\n", ["velocity", "both"]),
        (
            case_text("nx = 1024", prefix="base.", maugis='"x"')
            + "[grid]\nvelocity = [1.0, 2.0]\n",
            ["no valid case", "maugis"],
        ),
    ],
)
def test_bad_sweep_files_are_rejected(text, words):
    with pytest.raises(SweepError) as err:
        parse_sweep(text)
    assert all(w in str(err.value) for w in words), str(err.value)


def test_base_from_a_case_file(tmp_path):
    (tmp_path / "case.toml").write_text(case_text("nx = 1024"))
    sweep = parse_sweep('base = "case.toml"\n[grid]\nvelocity = [1.0, 2.0]\n', str(tmp_path))
    assert [c.case.velocity for c in sweep.cases] == [1.0, 2.0]


# --- the farm as a user runs it ------------------------------------------------------------
def environment():
    return dict(
        os.environ,
        OMPI_ALLOW_RUN_AS_ROOT="1",
        OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
        OPENBLAS_NUM_THREADS="1",
    )


def farm_command(ranks, *args):
    return [
        MPIRUN,
        "--oversubscribe",
        "-n",
        str(ranks),
        sys.executable,
        "-m",
        "hpcgfmd",
        "farm",
        *map(str, args),
    ]


def summary(path):
    with open(path) as fh:
        return {int(row["index"]): row for row in csv.DictReader(fh)}


@pytest.mark.slow
@pytest.mark.mpi
def test_farm_records_failures_goes_on_and_resumes(tmp_path):
    # 4 cases: two fine, one invalid (too coarse a grid), one that cannot converge
    (tmp_path / "sweep.toml").write_text(
        BASE + "[[cases]]\nvelocity = 1.0\n[[cases]]\nvelocity = 2.0\n"
        "[[cases]]\nnx = 64\n[[cases]]\nvelocity = 0.5\nmax_iterations = 2\n"
    )
    run = subprocess.run(
        farm_command(2, "sweep.toml", "-o", "out"),
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
        env=environment(),
        check=False,
    )
    assert run.returncode == 102, run.stdout + run.stderr  # 100 + 2 failed
    rows = summary(tmp_path / "out" / "summary.csv")
    assert [rows[i]["status"] for i in range(4)] == ["finished", "finished", "failed", "failed"]
    assert "nx = 64" in rows[2]["error"] and "NonConvergenceError" in rows[3]["error"]
    for i in (0, 1):
        s = read_series(tmp_path / "out" / rows[i]["file"])
        assert s.attrs["finished"]
        assert float(rows[i]["pull_off_load"]) == s.load.min()
        assert float(rows[i]["steps"]) == s.attrs["steps"]
    with h5py.File(tmp_path / "out" / "summary.h5", "r") as f:
        assert [v.decode() for v in f["status"][:]] == [rows[i]["status"] for i in range(4)]
        np.testing.assert_array_equal(f["index"][:], [0, 1, 2, 3])
        units = {
            name: f[name].attrs.get("units")
            for name in (
                "pull_off_load",
                "detachment_indenter",
                "wall_time",
                "steps",
                "lambda0",
                "case.velocity",
                "status",
            )
        }
        assert units == {
            "pull_off_load": "E0 R",
            "detachment_indenter": "R",
            "wall_time": "s",
            "steps": "1",
            "lambda0": "1",
            "case.velocity": "as in the sweep file",
            "status": None,
        }
    before = os.path.getmtime(tmp_path / "out" / rows[0]["file"])
    again = subprocess.run(
        farm_command(2, "sweep.toml", "-o", "out"),
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
        env=environment(),
        check=False,
    )
    assert again.returncode == 102
    assert again.stdout.count("finished before, skipped") == 2
    assert os.path.getmtime(tmp_path / "out" / rows[0]["file"]) == before  # not rewritten


@pytest.mark.slow
def test_ctrl_c_stops_a_farm_with_130_and_the_same_command_finishes(tmp_path):
    # SIGINT on a farm in a terminal (one process): the running case checkpoints, no new
    # case starts, one line per case and no traceback, status 130; the same command
    # resumes the interrupted case and runs the rest.
    (tmp_path / "sweep.toml").write_text(
        case_text("nx = 1024", "checkpoint_steps = 5", prefix="base.")
        + "[grid]\nvelocity = [0.6, 0.8]\n"
    )
    command = [sys.executable, "-m", "hpcgfmd", "farm", "sweep.toml", "-o", "out"]
    process = subprocess.Popen(
        command,
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=environment(),
    )
    out = tmp_path / "out"
    deadline = time.monotonic() + 120
    while not (out.exists() and any(p.endswith(".checkpoint.h5") for p in os.listdir(out))):
        assert process.poll() is None and time.monotonic() < deadline, process.communicate()
        time.sleep(0.02)
    process.send_signal(signal.SIGINT)
    stdout, stderr = process.communicate(timeout=120)
    assert process.returncode == 130, stdout + stderr
    assert "Traceback" not in stderr and "interrupted, checkpointed" in stdout
    rows = summary(out / "summary.csv")
    assert [r["status"] for r in rows.values()].count("interrupted") == 1, rows
    done = subprocess.run(
        command, cwd=tmp_path, capture_output=True, text=True, timeout=300, env=environment()
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert all(r["status"] == "finished" for r in summary(out / "summary.csv").values())


@pytest.mark.slow
@pytest.mark.mpi
def test_farm_signal_checkpoints_and_the_same_command_finishes(tmp_path):
    # Three cases on two single-rank groups; SIGUSR1 (forwarded by mpirun) stops them with
    # checkpoints (status 75); the same command on one group of two ranks finishes them,
    # each equal to a direct serial run of its case.
    base = case_text(
        FIXED_STEPS + "nx = 2048\ntolerance = 1e-13", "checkpoint_steps = 5", prefix="base."
    )
    (tmp_path / "sweep.toml").write_text(base + "[grid]\nvelocity = [0.6, 0.8, 1.0]\n")
    process = subprocess.Popen(
        farm_command(2, "sweep.toml", "-o", "out"),
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=environment(),
    )
    out = tmp_path / "out"
    deadline = time.monotonic() + 120
    while not (out.exists() and any(p.endswith(".checkpoint.h5") for p in os.listdir(out))):
        assert process.poll() is None and time.monotonic() < deadline, process.communicate()
        time.sleep(0.02)
    process.send_signal(signal.SIGUSR1)
    stdout, stderr = process.communicate(timeout=120)
    assert process.returncode == 75, stdout + stderr
    rows = summary(tmp_path / "out" / "summary.csv")
    interrupted = [i for i, r in rows.items() if r["status"] == "interrupted"]
    assert interrupted, rows
    done = subprocess.run(
        farm_command(2, "sweep.toml", "-o", "out", "--ranks-per-case", 2),
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
        env=environment(),
        check=False,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert "resuming" in done.stdout
    rows = summary(tmp_path / "out" / "summary.csv")
    assert all(r["status"] == "finished" for r in rows.values())
    assert not [p for p in os.listdir(tmp_path / "out") if p.endswith(".checkpoint.h5")]
    # the interrupted-and-resumed case against a direct serial run of the same case file
    sweep = parse_sweep(base + "[grid]\nvelocity = [0.6, 0.8, 1.0]\n")
    item = sweep.cases[interrupted[0]]
    (tmp_path / "direct.toml").write_text(item.text)
    direct = subprocess.run(
        [sys.executable, "-m", "hpcgfmd", "run", "direct.toml", "-o", "direct.h5"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
        env=environment(),
        check=False,
    )
    assert direct.returncode == 0, direct.stderr
    a = read_series(tmp_path / "direct.h5")
    b = read_series(tmp_path / "out" / (item.name + ".h5"))
    assert a.load.shape == b.load.shape
    assert np.max(np.abs(a.load - b.load)) <= 1e-10 * np.max(np.abs(a.load))


@pytest.mark.slow
@pytest.mark.mpi
def test_group_leaders_count_k_of_n_and_both_reach_the_log_file(tmp_path):
    # two groups of one rank, four cases: after each case its group's leader prints k of 4
    # with the ETA, k counted over both groups; --log receives both leaders' lines, whole
    (tmp_path / "sweep.toml").write_text(BASE + "[grid]\nvelocity = [0.5, 1.0, 2.0, 4.0]\n")
    run = subprocess.run(
        farm_command(2, "sweep.toml", "-o", "out", "--log", "farm.log"),
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
        env=environment(),
        check=False,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    progress = re.compile(
        r"^farm: (\d) of 4 cases done, \d+ s elapsed, ETA"
        r" (\d+ s|\d+ min \d+ s) \(\S+ estimated core-s left over 2"
        r" group\(s\), x \d+\.\d\d measured/estimated\)$"
    )
    counts = [int(m.group(1)) for m in map(progress.match, run.stdout.splitlines()) if m]
    assert sorted(counts) == [1, 2, 3, 4], run.stdout
    stamp = re.compile(r"^\d{4}-\d\d-\d\d \d\d:\d\d:\d\d,\d{3} rank (\d) hpcgfmd\.\S+ INFO ")
    lines = (tmp_path / "farm.log").read_text().splitlines()
    assert lines and all(stamp.match(line) for line in lines), lines  # no line broken or mixed
    by_rank = {}
    for line in lines:
        found = progress.match(line[stamp.match(line).end() :])
        if found:
            by_rank.setdefault(stamp.match(line).group(1), []).append(int(found.group(1)))
    assert sorted(by_rank) == ["0", "1"], lines  # both group leaders reached the file
    assert sorted(by_rank["0"] + by_rank["1"]) == [1, 2, 3, 4]
    assert all(ks == sorted(ks) for ks in by_rank.values())  # each leader's k only grows
    started = [line for line in lines if ": starting on 1 rank(s)" in line]
    assert len(started) == 4 and {stamp.match(x).group(1) for x in started} == {"0", "1"}


@pytest.mark.slow
@pytest.mark.mpi
def test_one_case_of_the_sweep_for_a_job_array(tmp_path):
    (tmp_path / "sweep.toml").write_text(BASE + "[grid]\nvelocity = [1.0, 2.0]\n")
    run = subprocess.run(
        farm_command(2, "sweep.toml", "-o", "out", "--case", 1),
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
        env=environment(),
        check=False,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    assert sorted(p for p in os.listdir(tmp_path / "out") if p.endswith(".h5")) == [
        "summary.h5",
        "velocity_2.0.h5",
    ]
    rows = summary(tmp_path / "out" / "summary.csv")  # the whole sweep, from the files
    assert [rows[0]["status"], rows[1]["status"]] == ["pending", "finished"]


def test_dry_run_lists_cases_groups_and_cost(tmp_path):
    (tmp_path / "sweep.toml").write_text(BASE + "[grid]\nvelocity = [0.045, 0.45, 4.5]\n")
    run = subprocess.run(
        [sys.executable, "-m", "hpcgfmd", "farm", "sweep.toml", "--dry-run"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert lines[0].startswith("3 cases")
    assert "chi_ve" in lines[1] and "cost" in lines[1]
    assert " 55.12 " in run.stdout  # chi_ve = V_z lambda0^2 = 4.5 * 3.5^2
    # the total is the sum of the cases' costs in their 3 digits (small cases: not 0)
    costs = [float(line.split()[8]) for line in lines[2:5]]
    total = float(lines[5].split("estimated cost:")[1].split()[0])
    assert total == pytest.approx(sum(costs), rel=2e-3) and total > 0
    assert not (tmp_path / "sweep").exists()  # nothing written
    assert run.stderr == ""  # no warning, no error


def test_quiet_farm_still_reports_its_failed_cases(tmp_path):
    # --quiet keeps warnings and errors: a failed case is an error
    (tmp_path / "sweep.toml").write_text(
        BASE + "[[cases]]\nnx = 64\n[[cases]]\nmax_iterations = 2\n"
    )
    run = subprocess.run(
        [sys.executable, "-m", "hpcgfmd", "farm", "sweep.toml", "--quiet"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert run.returncode == 102, run.stderr
    failed = sorted(line for line in run.stderr.splitlines() if ": failed: " in line)
    assert len(failed) == 2, run.stderr
    assert "[0] nx_64" in failed[0] and "nx = 64" in failed[0]
    assert "[1] max_iterations_2" in failed[1] and "NonConvergenceError" in failed[1]
    assert run.stdout == ""
    # neither wrote a result file (refused; failed in the preload): the summary names none
    rows = summary(tmp_path / "sweep" / "summary.csv")
    assert [rows[i]["file"] for i in (0, 1)] == ["", ""]
    assert sorted(p.name for p in (tmp_path / "sweep").glob("*.h5")) == ["summary.h5"]


def test_summary_text_columns_are_strings_without_failures(tmp_path):
    # no case failed: the error column is empty text, not NaN; numbers stay numbers
    from hpcgfmd.runs.farm import _write_tables

    rows = [
        {
            "index": i,
            "name": f"velocity_{v}",
            "status": "finished",
            "error": "",
            "file": f"velocity_{v}.h5",
            "case.velocity": v,
            "pull_off_load": -0.1 * i,
            "steps": 10 + i,
            "ranks": 1,
        }
        for i, v in enumerate((1.0, 2.0))
    ]
    _write_tables(str(tmp_path), rows, ["case.velocity"], "case")
    with h5py.File(tmp_path / "summary.h5", "r") as f:
        for column in ("name", "status", "error", "file"):
            assert h5py.check_string_dtype(f[column].dtype), column
        assert [v.decode() for v in f["error"][:]] == ["", ""]
        np.testing.assert_array_equal(f["pull_off_load"][:], [0.0, -0.1])
        np.testing.assert_array_equal(f["case.velocity"][:], [1.0, 2.0])


@pytest.mark.mpi
@pytest.mark.parametrize(
    "args, words",
    [
        (["--case", "5"], ["--case 5", "0 to 1"]),
        (["--ranks-per-case", "0"], ["--ranks-per-case 0", "divisor"]),
        (["--ranks-per-case", "3"], ["--ranks-per-case 3", "divisor", "1, 2"]),
    ],
)
def test_bad_farm_arguments_one_line_status_2(tmp_path, args, words):
    (tmp_path / "sweep.toml").write_text(BASE + "[grid]\nvelocity = [1.0, 2.0]\n")
    run = subprocess.run(
        [MPIRUN, "-n", "2", sys.executable, "-m", "hpcgfmd", "farm", "sweep.toml", *args],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=60,
        env=environment(),
        check=False,
    )
    assert run.returncode == 2
    lines = [line for line in run.stderr.splitlines() if line.startswith("hpcgfmd:")]
    assert len(lines) == 1 and all(w in lines[0] for w in words), run.stderr
    assert not (tmp_path / "sweep").exists()  # nothing written
