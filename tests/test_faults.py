"""Faults injected for real: damaged checkpoints.

A checkpoint is sealed with a digest of its state and the one it replaces is kept as the
previous generation (hpcgfmd/storage/checkpoint.py). A truncated checkpoint, one with flipped
bytes, or one whose seal is missing is detected by its digest, not by being readable; the run
then resumes from the previous generation and says so, and finishes equal to the uninterrupted
run; with no usable generation the command refuses in one line and touches nothing.
"""

import hashlib
import os
import shutil
import signal
import subprocess
import sys

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from cases import FIXED_STEPS, StopAtStep, case_text
from hpcgfmd.case import parse_case
from hpcgfmd.errors import Interrupted
from hpcgfmd.runs.single_case import run_case
from hpcgfmd.storage.checkpoint import (
    checkpoint_path,
    checkpoint_problem,
    previous_path,
    usable_checkpoint,
    write_checkpoint,
)
from hpcgfmd.storage.reader import read_series

COMM = MPI.COMM_SELF
# fixed steps: the resumed run repeats the uninterrupted one bit for bit; a checkpoint every
# 5 steps, so that a stop after step 12 leaves generations at steps 10 and 12
# the solver's tolerance given: resumed parts are compared with the whole run to round-off
# amplified by the solves, which a solve stopped at the default 2.5e-3 amplifies to 2e-6
TEXT = case_text(
    "nx = 1024\ntolerance = 1e-3\n" + FIXED_STEPS + "dt = 0.05", "checkpoint_steps = 5"
)


def flip_bytes(path, dataset="fields/surface.u", at=100):
    """Invert 8 bytes of a dataset's stored values in place (a bit rot the file still reads)."""
    with h5py.File(path, "r") as f:
        offset = f[dataset].id.get_offset()
    with open(path, "r+b") as fh:
        fh.seek(offset + 8 * at)
        data = fh.read(8)
        fh.seek(offset + 8 * at)
        fh.write(bytes(b ^ 0xFF for b in data))


def truncate(path, fraction=0.5):
    os.truncate(path, int(os.path.getsize(path) * fraction))


def digest_of(path):
    return hashlib.sha256(open(path, "rb").read()).hexdigest()


def small_checkpoint(path, value):
    fields = {"surface.u": np.full(300, value), "w": np.arange(300.0)}
    write_checkpoint(path, COMM, 300, 0, fields, {"step_index": int(value)})


@pytest.mark.parametrize("damage", ["flip", "truncate", "unsealed"])
def test_damaged_checkpoint_is_detected_and_the_previous_generation_chosen(tmp_path, damage):
    path = str(tmp_path / "a.checkpoint.h5")
    small_checkpoint(path, 1.0)
    small_checkpoint(path, 2.0)  # the first becomes the previous generation
    assert os.path.exists(previous_path(path))
    assert checkpoint_problem(path) is None and checkpoint_problem(previous_path(path)) is None
    if damage == "flip":
        flip_bytes(path)
    elif damage == "truncate":
        truncate(path)
    else:  # a write that died before its seal: readable, but no digest
        with h5py.File(path, "r+") as f:
            del f.attrs["state_digest"]
    problem = checkpoint_problem(path)
    assert problem is not None and "\n" not in problem
    chosen, problems = usable_checkpoint(path)
    assert chosen == previous_path(path)
    assert len(problems) == 1 and path in problems[0]
    with h5py.File(chosen, "r") as f:  # the older state, intact
        assert f.attrs["step_index"] == 1


def test_both_generations_damaged_leaves_none(tmp_path):
    path = str(tmp_path / "a.checkpoint.h5")
    small_checkpoint(path, 1.0)
    small_checkpoint(path, 2.0)
    flip_bytes(path)
    flip_bytes(previous_path(path), dataset="fields/w", at=7)
    chosen, problems = usable_checkpoint(path)
    assert chosen is None and len(problems) == 2


def interrupted_run(directory, stop=12):
    case = parse_case(TEXT)
    out = directory / "case.h5"
    with StopAtStep(stop) as signals, pytest.raises(Interrupted):
        run_case(case, out, COMM, planner_effort="FFTW_ESTIMATE", stop=signals)
    return case, out


@pytest.fixture(scope="module")
def whole(tmp_path_factory):
    out = tmp_path_factory.mktemp("whole") / "whole.h5"
    run_case(parse_case(TEXT), out, COMM, planner_effort="FFTW_ESTIMATE")
    return read_series(out)


def assert_same_run(path, whole):
    """The resumed run against the uninterrupted one: the same fixed steps; loads and widths
    to round-off amplified by the solves (the command plans FFTW_MEASURE, the reference
    FFTW_ESTIMATE, and a part may run on 2 ranks: measured 5e-8 apart in loads of 3e-2, and
    1.2e-6 R in contact half-widths, which are interpolated between nodes 2e-3 R apart)."""
    parts = read_series(path)
    np.testing.assert_array_equal(parts.time, whole.time)
    np.testing.assert_allclose(parts.load, whole.load, rtol=0, atol=1e-6)
    np.testing.assert_allclose(
        parts.contact_half_width, whole.contact_half_width, rtol=0, atol=1e-5
    )


@pytest.mark.parametrize("damage", [flip_bytes, truncate])
def test_resume_passes_over_a_damaged_checkpoint_and_finishes_equal(tmp_path, damage, whole):
    case, out = interrupted_run(tmp_path)
    newest = checkpoint_path(out)
    damage(newest)
    # through the command line: one warning naming both files, then the run finishes
    (tmp_path / "case.toml").write_text(TEXT)
    proc = subprocess.run(
        [sys.executable, "-m", "hpcgfmd", "run", "case.toml", "-o", "case.h5"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    warnings = [line for line in proc.stderr.splitlines() if "previous checkpoint" in line]
    names = os.path.basename(newest), os.path.basename(previous_path(newest))
    assert len(warnings) == 1 and all(name in warnings[0] for name in names)
    assert "resuming from" in proc.stdout + proc.stderr
    # the damaged one was set aside as *.corrupt (out of the rotation) and, with the other
    # checkpoints, removed once the case finished
    for left in (newest, previous_path(newest), newest + ".corrupt"):
        assert not os.path.exists(left)
    assert_same_run(out, whole)


def test_no_usable_checkpoint_refuses_in_one_line_and_touches_nothing(tmp_path):
    case, out = interrupted_run(tmp_path)
    newest = checkpoint_path(out)
    flip_bytes(newest)
    truncate(previous_path(newest))
    before = {p: digest_of(p) for p in (out, newest, previous_path(newest))}
    (tmp_path / "case.toml").write_text(TEXT)
    proc = subprocess.run(
        [sys.executable, "-m", "hpcgfmd", "run", "case.toml", "-o", "case.h5"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "cannot resume" in lines[0] and "Traceback" not in proc.stderr
    assert {p: digest_of(p) for p in before} == before


# --- one writer per output, and output directories that cannot be written -----------------


def hpcgfmd_run(*args, cwd, timeout=300):
    return subprocess.run(
        [sys.executable, "-m", "hpcgfmd", "run", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def started_run(tmp_path, *args, steps=5):
    """A run in the background that has written ``steps`` steps (its progress lines)."""
    (tmp_path / "slow.toml").write_text(case_text("nx = 4096", "progress_interval = 1e-6"))
    proc = subprocess.Popen(
        [sys.executable, "-m", "hpcgfmd", "run", "slow.toml", "-o", "out.h5", *args],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    seen = 0
    while seen < steps:
        line = proc.stdout.readline()
        assert line, "the run ended before it was running: " + proc.stderr.read()
        seen += line.startswith("step")
    return proc


def test_second_run_on_the_same_output_refuses_and_the_first_is_unharmed(tmp_path):
    first = started_run(tmp_path)
    try:
        first.send_signal(signal.SIGSTOP)  # still running (and holding its lock) meanwhile
        # even with --overwrite, which would replace a finished file
        second = hpcgfmd_run("slow.toml", "-o", "out.h5", "--overwrite", cwd=tmp_path)
        first.send_signal(signal.SIGCONT)
        assert second.returncode == 2
        lines = second.stderr.strip().splitlines()
        assert len(lines) == 1 and "being written by pid" in lines[0] and "out.h5" in lines[0]
        assert str(first.pid) in lines[0]
        first.stdout.read()
        assert first.wait(timeout=300) == 0, first.stderr.read()
    finally:
        first.kill()
    s = read_series(tmp_path / "out.h5")
    assert s.attrs["finished"] and s.time.size == s.attrs["steps"] + 1
    assert not os.path.exists(tmp_path / "out.h5.lock")  # released at the end


def test_the_lock_of_a_killed_run_is_free_for_the_next_one(tmp_path):
    first = started_run(tmp_path)
    first.kill()  # SIGKILL: no cleanup ran
    first.wait(timeout=30)
    assert os.path.exists(tmp_path / "out.h5.lock")  # left behind, but not held
    again = hpcgfmd_run("slow.toml", "-o", "out.h5", "--overwrite", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert read_series(tmp_path / "out.h5").attrs["finished"]


def mount_tmpfs(where, options):
    where.mkdir()
    if (
        subprocess.run(
            ["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(where)], capture_output=True
        ).returncode
        != 0
    ):
        pytest.skip("cannot mount a tmpfs here (needs root)")


def test_missing_and_read_only_output_directories_refused_before_any_work(tmp_path):
    (tmp_path / "case.toml").write_text(TEXT)
    missing = hpcgfmd_run("case.toml", "-o", "nowhere/out.h5", cwd=tmp_path)
    assert missing.returncode == 2
    assert missing.stderr.strip().splitlines() == [
        f"hpcgfmd: error: -o nowhere/out.h5: directory {tmp_path / 'nowhere'} does not exist"
    ]
    mount_tmpfs(tmp_path / "ro", "ro,size=1m")
    try:
        refused = hpcgfmd_run("case.toml", "-o", "ro/out.h5", cwd=tmp_path)
        assert refused.returncode == 2
        lines = refused.stderr.strip().splitlines()
        assert len(lines) == 1 and "cannot write in" in lines[0], refused.stderr
        assert "Read-only file system" in lines[0]
        # before any computation: no preload was solved (its log line) and nothing written
        assert "writing" not in refused.stdout and os.listdir(tmp_path / "ro") == []
        (tmp_path / "sweep.toml").write_text(
            case_text("nx = 1024", prefix="base.") + "[grid]\nvelocity = [1.0, 2.0]\n"
        )
        farm = subprocess.run(
            [sys.executable, "-m", "hpcgfmd", "farm", "sweep.toml", "-o", "ro/out"],
            cwd=tmp_path,
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert farm.returncode == 2
        assert farm.stderr.strip().splitlines() == [
            "hpcgfmd: error: -o ro/out: cannot write there (Read-only file system)"
        ]
    finally:
        subprocess.run(["umount", str(tmp_path / "ro")])


# --- a full disk ------------------------------------------------------------------------------

SNAPSHOTS = ", ".join(f"{0.1 * i:.1f}" for i in range(200))
FILLING = case_text(
    "nx = 1024\n" + FIXED_STEPS + "dt = 0.05",
    f"checkpoint_steps = 5\nprogress_interval = 1e-6\nsnapshot_times = [{SNAPSHOTS}]",
)


@pytest.fixture(scope="module")
def filling_whole(tmp_path_factory):
    out = tmp_path_factory.mktemp("filling") / "whole.h5"
    run_case(parse_case(FILLING), out, COMM)
    return read_series(out)


def test_disk_full_while_writing_the_output_stops_and_the_same_command_finishes(
    tmp_path, filling_whole
):
    disk = tmp_path / "disk"
    mount_tmpfs(disk, "size=900k")  # room to start; 200 snapshots of 24 KiB do not fit
    try:
        (tmp_path / "case.toml").write_text(FILLING)
        full = hpcgfmd_run("case.toml", "-o", "disk/out.h5", cwd=tmp_path)
        assert full.returncode == 1
        lines = full.stderr.strip().splitlines()
        assert len(lines) == 1 and "disk full" in lines[0] and str(disk) in lines[0]
        assert "with checkpoint disk/out.checkpoint.h5" in lines[0]
        # written while there was room
        assert checkpoint_problem(checkpoint_path(disk / "out.h5")) is None
        subprocess.run(["mount", "-o", "remount,size=20m", str(disk)], check=True)
        again = hpcgfmd_run("case.toml", "-o", "disk/out.h5", cwd=tmp_path)
        assert again.returncode == 0, again.stderr
        assert "resuming from" in again.stdout
        assert_same_run(disk / "out.h5", filling_whole)
    finally:
        subprocess.run(["umount", str(disk)])


def test_disk_full_while_writing_a_checkpoint_keeps_the_previous_one(tmp_path, filling_whole):
    disk = tmp_path / "disk"
    mount_tmpfs(disk, "size=20m")
    try:
        (tmp_path / "case.toml").write_text(FILLING)
        run = subprocess.Popen(
            [sys.executable, "-m", "hpcgfmd", "run", "case.toml", "-o", "disk/out.h5"],
            cwd=tmp_path,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        seen = 0
        while seen < 12:  # checkpoints at steps 5 and 10 are written
            line = run.stdout.readline()
            assert line, run.stderr.read()
            seen += line.startswith("step")
        run.send_signal(signal.SIGSTOP)
        # another job fills the disk: less room than a checkpoint needs
        checkpoint = checkpoint_path(disk / "out.h5")
        kept = digest_of(checkpoint)
        free = os.statvfs(disk).f_bavail * os.statvfs(disk).f_frsize
        with open(disk / "filler", "wb") as fh:
            fh.write(b"\0" * (free - 100 * 1024))
        run.send_signal(signal.SIGCONT)
        out, err = run.communicate(timeout=300)
        assert run.returncode == 1, err
        lines = err.strip().splitlines()
        assert len(lines) == 1 and "no space for checkpoint" in lines[0], err
        assert digest_of(checkpoint) == kept and checkpoint_problem(checkpoint) is None
        assert not os.path.exists(checkpoint + ".tmp")
        os.remove(disk / "filler")
        again = hpcgfmd_run("case.toml", "-o", "disk/out.h5", cwd=tmp_path)
        assert again.returncode == 0, again.stderr
        assert_same_run(disk / "out.h5", filling_whole)
    finally:
        subprocess.run(["umount", str(disk)])


# --- a non-finite value inside a solve ----------------------------------------------------------


def poison(monkeypatch, at_step, velocity=None):
    """The test hook: a NaN written into the SLS history's state before step ``at_step`` (of
    the case with ``velocity``, or of every case), as a memory fault or a numerical blow-up
    would leave it."""
    from hpcgfmd.runs.protocol import Retraction

    advance = Retraction._advance

    def poisoned(self, dt, end=None):
        if self.surface.step_index + 1 == at_step and velocity in (None, self.case.velocity):
            self.substrate.traction[5] = np.nan
        return advance(self, dt, end)

    monkeypatch.setattr(Retraction, "_advance", poisoned)


def test_non_finite_value_fails_the_case_naming_step_and_quantity(tmp_path, monkeypatch):
    poison(monkeypatch, at_step=7)
    with pytest.raises(FloatingPointError) as err:
        run_case(parse_case(TEXT), tmp_path / "case.h5", COMM, planner_effort="FFTW_ESTIMATE")
    message = str(err.value)
    assert "\n" not in message and message.startswith("step 7 (t = 0.35 tau)")
    assert "non-finite values in: u, history, substrate traction" in message
    s = read_series(tmp_path / "case.h5")  # the steps before it are kept, unfinished
    assert not s.attrs["finished"] and s.time.size == 7


def test_farm_records_a_non_finite_case_and_goes_on(tmp_path, monkeypatch):
    from hpcgfmd.runs.farm import run_farm
    from hpcgfmd.runs.sweep import load_sweep

    poison(monkeypatch, at_step=4, velocity=2.0)
    (tmp_path / "sweep.toml").write_text(
        case_text("nx = 1024", prefix="base.") + "[grid]\nvelocity = [1.0, 2.0, 3.0]\n"
    )
    status = run_farm(load_sweep(str(tmp_path / "sweep.toml")), COMM, str(tmp_path / "out"))
    assert status == 101  # EXIT_FAILED_BASE + one failed case
    import csv

    with open(tmp_path / "out" / "summary.csv") as fh:
        rows = {row["name"]: row for row in csv.DictReader(fh)}
    assert [rows[f"velocity_{v}"]["status"] for v in ("1.0", "2.0", "3.0")] == [
        "finished",
        "failed",
        "finished",
    ]
    assert rows["velocity_2.0"]["error"].startswith("FloatingPointError: step 4 ")


# --- one rank of a parallel run killed --------------------------------------------------------

MPIRUN = shutil.which("mpirun")
MPI_ENV = dict(
    os.environ,
    OMPI_ALLOW_RUN_AS_ROOT="1",
    OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
    OMPI_MCA_rmaps_base_oversubscribe="1",
)


def rank_pid(launcher, rank):
    """The pid of MPI rank ``rank`` among the children of the ``mpirun`` process."""
    for child in subprocess.run(
        ["pgrep", "-P", str(launcher)], capture_output=True, text=True
    ).stdout.split():
        try:
            with open(f"/proc/{child}/environ", "rb") as fh:
                env = dict(item.split(b"=", 1) for item in fh.read().split(b"\0") if b"=" in item)
        except OSError:
            continue
        if env.get(b"OMPI_COMM_WORLD_RANK") == str(rank).encode():
            return int(child)
    raise AssertionError(f"no rank {rank} under mpirun {launcher}")


@pytest.mark.slow
@pytest.mark.mpi
@pytest.mark.skipif(MPIRUN is None, reason="OpenMPI's mpirun is not installed")
def test_killed_rank_ends_the_job_and_the_run_resumes_on_one_rank(tmp_path, whole):
    (tmp_path / "case.toml").write_text(TEXT + "progress_interval = 1e-6\n")
    job = subprocess.Popen(
        [MPIRUN, "-n", "2", sys.executable, "-m", "hpcgfmd", "run", "case.toml", "-o", "out.h5"],
        cwd=tmp_path,
        env=MPI_ENV,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        seen = 0
        while seen < 12:
            line = job.stdout.readline()
            assert line, job.stderr.read()
            seen += line.startswith("step")
        os.kill(rank_pid(job.pid, 1), signal.SIGKILL)  # rank 1 only, in the middle of a step
        job.communicate(timeout=120)  # the job ends: mpirun takes the other rank down
        assert job.returncode != 0
    finally:
        job.kill()
    with h5py.File(tmp_path / "out.h5", "r") as f:  # readable, every flushed step in it
        assert not f.attrs["finished"] and int(f.attrs["steps_complete"]) >= 12
    assert checkpoint_problem(checkpoint_path(tmp_path / "out.h5")) is None
    again = hpcgfmd_run("case.toml", "-o", "out.h5", cwd=tmp_path)  # the same command, 1 rank
    assert again.returncode == 0, again.stderr
    assert "resuming from" in again.stdout
    assert_same_run(tmp_path / "out.h5", whole)


# --- a farm killed and started again --------------------------------------------------------


@pytest.mark.slow
def test_farm_killed_and_started_again_finishes_every_case_once(tmp_path):
    import csv
    import time

    base = case_text(
        FIXED_STEPS + "nx = 2048\ntolerance = 1e-13", "checkpoint_steps = 5", prefix="base."
    )
    grid = "[grid]\nvelocity = [0.6, 0.8, 1.0]\n"
    (tmp_path / "sweep.toml").write_text(base + grid)
    command = [sys.executable, "-m", "hpcgfmd", "farm", "sweep.toml", "-o", "out"]
    farm = subprocess.Popen(
        command, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    out = tmp_path / "out"
    deadline = time.monotonic() + 200

    def finished(path):
        try:
            return bool(read_series(path).attrs.get("finished", False))
        except Exception:  # being created
            return False

    try:  # killed once a case has finished and another has a checkpoint, seen while frozen
        while True:
            assert farm.poll() is None and time.monotonic() < deadline, farm.communicate()
            if out.exists():
                farm.send_signal(signal.SIGSTOP)
                names = [p for p in os.listdir(out) if p.endswith(".h5") and ".checkpoint" not in p]
                done = [p for p in names if finished(out / p)]
                resumable = [
                    p for p in names if p not in done and os.path.exists(checkpoint_path(out / p))
                ]
                if done and resumable:
                    farm.kill()
                    break
                farm.send_signal(signal.SIGCONT)
            time.sleep(0.05)
        farm.wait(timeout=30)
    finally:
        farm.kill()
    finished_before = {
        p: os.path.getmtime(out / p)
        for p in os.listdir(out)
        if p.endswith(".h5")
        and ".checkpoint" not in p
        and read_series(out / p).attrs.get("finished", False)
    }
    assert finished_before and len(finished_before) < 3
    again = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stdout + again.stderr
    assert again.stdout.count("finished before, skipped") == len(finished_before)
    assert "resuming" in again.stdout
    for name, mtime in finished_before.items():  # none run twice
        assert os.path.getmtime(out / name) == mtime
    with open(out / "summary.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["status"] for r in rows] == ["finished"] * 3
    for item in parse_sweep_text(base + grid).cases:  # each equal to a direct run
        (tmp_path / "direct.toml").write_text(item.text)
        direct = hpcgfmd_run("direct.toml", "-o", "direct.h5", "--overwrite", cwd=tmp_path)
        assert direct.returncode == 0, direct.stderr
        a, b = read_series(tmp_path / "direct.h5"), read_series(out / (item.name + ".h5"))
        assert a.load.shape == b.load.shape
        assert np.max(np.abs(a.load - b.load)) <= 1e-10 * np.max(np.abs(a.load))
        row = next(r for r in rows if r["name"] == item.name)
        assert float(row["pull_off_load"]) == b.load.min()


def parse_sweep_text(text):
    from hpcgfmd.runs.sweep import parse_sweep

    return parse_sweep(text)


# --- names from swept values, and no input reaching eval, pickle or a shell -------------------


def test_swept_values_cannot_name_a_file_outside_the_output_directory(tmp_path):
    from hpcgfmd.runs.farm import case_file

    hostile = [
        "../../etc/passwd",
        "/tmp/x",
        "..",
        "a/../../b",
        "~root",
        "$(rm -rf x)",
        "`id`",
        "..\\\\..\\\\w",
        "\u202e\u0000evil",
    ]
    base = case_text("nx = 1024", prefix="base.")
    quoted = ", ".join(
        '"' + v.replace("\\\\", "\\\\\\\\").replace('"', '\\\\"') + '"'
        for v in hostile
        if "\u0000" not in v
    )
    sweep = parse_sweep_text(base + f'[grid]\nsolver = ["cg", {quoted}]\n')
    out = tmp_path / "out"
    assert len(sweep.cases) == len(hostile)  # "cg" and all but the one with a NUL
    for item in sweep.cases[1:]:
        assert item.case is None  # not a solver: each case is kept with its error
        path = os.path.realpath(case_file(str(out), item))
        assert os.path.dirname(path) == os.path.realpath(out), (item.name, path)
        assert set(item.name) <= set(
            "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789.+-_"
        )


def test_no_input_reaches_eval_pickle_or_a_shell():
    import ast
    import pathlib

    package = pathlib.Path(__file__).resolve().parents[1] / "hpcgfmd"
    found = []
    for path in package.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call):
                func = node.func
                name = (
                    func.id
                    if isinstance(func, ast.Name)
                    else func.attr
                    if isinstance(func, ast.Attribute)
                    else ""
                )
                if name in ("eval", "exec", "system", "popen", "loads") and not (
                    name == "loads"
                    and isinstance(func, ast.Attribute)
                    and getattr(func.value, "id", "") in ("tomllib", "json")
                ):
                    found.append(f"{path.name}:{node.lineno} {name}")
                for kw in node.keywords:
                    if kw.arg == "shell" or (
                        kw.arg == "allow_pickle" and getattr(kw.value, "value", False)
                    ):
                        found.append(f"{path.name}:{node.lineno} {kw.arg}")
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                names = [a.name for a in node.names] + [getattr(node, "module", "") or ""]
                # (the benchmarks launch hpcgfmd and git with fixed argument lists, no shell)
                allowed = ("subprocess",) if "studies" in path.parts else ()
                if any(
                    n.split(".")[0] in ("pickle", "marshal", "shelve", "subprocess")
                    and n not in allowed
                    for n in names
                ):
                    found.append(f"{path.name}:{node.lineno} import {names}")
    assert found == []


def test_too_little_space_to_start_is_refused_before_any_work(tmp_path):
    disk = tmp_path / "disk"
    mount_tmpfs(disk, "size=300k")
    try:
        (tmp_path / "case.toml").write_text(TEXT)
        refused = hpcgfmd_run("case.toml", "-o", "disk/out.h5", cwd=tmp_path)
        assert refused.returncode == 2
        lines = refused.stderr.strip().splitlines()
        assert len(lines) == 1 and "bytes free on its file system" in lines[0], refused.stderr
        assert os.listdir(disk) == []
    finally:
        subprocess.run(["umount", str(disk)])


def test_list_values_keep_their_separators_in_case_names():
    # [1, 2] and [12] are different values: different names (the "_" was dropped once)
    base = case_text("nx = 1024", prefix="base.")
    sweep = parse_sweep_text(
        base + "[[cases]]\noutput.snapshot_times = [1, 2]\n"
        "[[cases]]\noutput.snapshot_times = [12]\n"
    )
    names = [item.name for item in sweep.cases]
    assert names == ["snapshot_times_1_2", "snapshot_times_12"]


def test_damaged_checkpoint_attributes_are_reported_not_raised(tmp_path):
    # metadata damage that makes h5py raise TypeError: still a verdict, never an exception
    path = str(tmp_path / "a.checkpoint.h5")
    small_checkpoint(path, 1.0)
    with h5py.File(path, "r+") as f:
        f.attrs["hpcgfmd_checkpoint"] = np.array([2, 2])
    assert checkpoint_problem(path).startswith("unreadable")
    small_checkpoint(str(tmp_path / "b.checkpoint.h5"), 1.0)
    with h5py.File(tmp_path / "b.checkpoint.h5", "r+") as f:
        f["fields"].create_group("junk")
    assert checkpoint_problem(str(tmp_path / "b.checkpoint.h5")).startswith("unreadable")


def test_farm_passes_over_a_damaged_checkpoint_and_refuses_when_none_is_usable(tmp_path):
    from hpcgfmd.runs.farm import case_file, run_farm

    sweep_text = (
        case_text("nx = 1024\n" + FIXED_STEPS + "dt = 0.05", "checkpoint_steps = 5", prefix="base.")
        + "[grid]\nvelocity = [1.0, 2.0]\n"
    )
    sweep = parse_sweep_text(sweep_text)
    out = tmp_path / "out"
    out.mkdir()
    paths = [case_file(str(out), item) for item in sweep.cases]
    for item, path in zip(sweep.cases, paths):  # both cases interrupted after step 12
        with StopAtStep(12) as signals, pytest.raises(Interrupted):
            run_case(item.case, path, COMM, planner_effort="FFTW_ESTIMATE", stop=signals)
    flip_bytes(checkpoint_path(paths[0]))  # the first: its previous generation is usable
    flip_bytes(checkpoint_path(paths[1]))  # the second: none is
    truncate(previous_path(checkpoint_path(paths[1])))
    kept = {p: digest_of(p) for p in (paths[1], checkpoint_path(paths[1]))}
    status = run_farm(sweep, COMM, str(out))
    assert status == 101
    import csv

    with open(out / "summary.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["status"] for r in rows] == ["finished", "failed"]
    assert rows[1]["error"].startswith("cannot resume:")
    assert {p: digest_of(p) for p in kept} == kept  # nothing touched


def test_a_file_system_without_flock_runs_unlocked_with_a_warning(tmp_path, monkeypatch, caplog):
    # Lustre mounted noflock answers ENOSYS, NFSv3 without lockd ENOLCK: the run goes on
    import errno
    import fcntl

    from hpcgfmd.storage import lock as lock_module

    def no_flock(fd, operation):
        raise OSError(errno.ENOSYS, os.strerror(errno.ENOSYS))

    monkeypatch.setattr(fcntl, "flock", no_flock)
    with caplog.at_level("WARNING"):
        held = lock_module.acquire_output_lock(COMM, str(tmp_path / "out.h5"))
    assert held is not None
    assert any("does not support flock" in r.getMessage() for r in caplog.records)
    held.release()  # nothing to release; no error
    assert not os.path.exists(tmp_path / "out.h5.lock")
