"""The SLURM job scripts of jobs/ submitted to a real (private, single-node) SLURM 22.05.

The cluster (munged, slurmctld, slurmd; tests/slurm_cluster.py) is started once for this file.
SLURM and munge come from the Debian packages that scripts/setup.sh installs; when they are
missing or do not start, every test here errors with the reason (no skip): CI must run them.
Each job runs in its own tmp directory (sbatch --chdir) with a small time limit; its state is
polled with `scontrol show job ID -o` (no accounting, so no sacct). Assertion messages carry
the job records, the job's output file and the tail of the slurmctld/slurmd logs.

The reference for the results is the same case run directly (serial, no SLURM), at fixed steps
(adaptive steps follow round-off differences between rank counts). At tolerance
1e-13 runs on different rank counts, or interrupted and resumed, agree to about 1e-12 (see
test_distributed.py); the bounds here (1e-10, contact half-width 1e-9) leave room for that
at the tolerance 1e-12 used here (at nx = 8192, 1e-13 is the round-off floor: a clean-clone
CI run once stalled at a residual of 1.09e-13 after 5000 iterations).
"""

import csv
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
import slurm_cluster
from slurm_cluster import ClusterError

from cases import FIXED_STEPS, case_text

# each job starts real daemons and MPI steps: seconds each; mpirun inside srun too
pytestmark = [pytest.mark.slurm, pytest.mark.mpi, pytest.mark.slow]

REPO = Path(__file__).resolve().parents[1]
JOBS = REPO / "jobs"
# nx = 8192 makes one serial run last about 6 s here: long enough to signal the chain's first
# part after its first checkpoint (step 5 of 217) and well before it ends.
CASE = case_text(FIXED_STEPS + "nx = 8192\ntolerance = 1e-12", "checkpoint_steps = 5")
SWEEP = case_text("nx = 1024", prefix="base.") + "[grid]\nvelocity = [1.0, 2.0]\n"
SERIES = ("time", "indenter", "load", "contact_half_width", "cohesive_half_width")
# minutes; SLURM's own signals come 3 (case, farm, array) or 5 (chain) minutes before the
# limit, so with 10 they cannot arrive during a test (at 5 the chain would be signalled at once)
TIME_LIMIT = "10"


@pytest.fixture(scope="module")
def slurm():
    cluster = slurm_cluster.cluster()
    try:
        running, failure = next(cluster), None
    except ClusterError as err:
        running, failure = None, str(err)
    if failure:  # an error of every test here, never a skip: CI installs SLURM (setup.sh)
        pytest.fail(f"the private SLURM cluster could not be started: {failure}", pytrace=False)
    yield running
    cluster.close()  # cancels leftover jobs, stops the daemons, removes its directory


def job_environment(slurm, python=True):
    """What sbatch exports into the jobs: the cluster's client environment plus the python.

    ``python=False`` leaves HPCGFMD_PYTHON out so the script finds the repository's .venv.
    """
    env = dict(slurm.env, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    env.pop("HPCGFMD_PYTHON", None)
    if python:
        env["HPCGFMD_PYTHON"] = sys.executable
    return env


def submit(slurm, cwd, script, *args, options=(), env=None):
    return slurm.sbatch(
        f"--chdir={cwd}",
        f"--time={TIME_LIMIT}",
        *options,
        str(JOBS / script),
        *map(str, args),
        env=env or job_environment(slurm),
    )


def finish(slurm, job_id, timeout=180):
    """Wait for the job (all array elements) to end; return its records."""
    try:
        return slurm.wait(job_id, timeout=timeout)
    except ClusterError as err:
        pytest.fail(str(err), pytrace=False)


def read_series(path):
    with h5py.File(path, "r") as f:
        finished = bool(f.attrs.get("finished", False))
        return finished, {name: f["series"][name][:] for name in SERIES}


def relative(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(a)))


def assert_same_series(reference, path, context):
    finished, series = read_series(path)
    assert finished, f"{path} not finished\n{context}"
    for name in SERIES:
        assert series[name].shape == reference[name].shape, (name, context)
        limit = 1e-9 if name == "contact_half_width" else 1e-10
        assert relative(reference[name], series[name]) <= limit, (
            name,
            relative(reference[name], series[name]),
            context,
        )


def assert_sane(path, context):
    """A finished result file whose series is complete and physical (detached at the end)."""
    finished, s = read_series(path)
    assert finished, f"{path} not finished\n{context}"
    assert s["load"].size > 10 and all(np.all(np.isfinite(v)) for v in s.values()), context
    assert s["load"].min() < 0 < s["load"][0], context  # compressive, then pull-off
    assert s["contact_half_width"][-1] == 0.0, context  # detached
    assert np.all(np.diff(s["indenter"]) > 0), context  # retracting


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The case run directly, serially, without SLURM."""
    cwd = tmp_path_factory.mktemp("reference")
    (cwd / "case.toml").write_text(CASE)
    done = subprocess.run(
        [sys.executable, "-m", "hpcgfmd", "run", "case.toml", "-o", "ref.h5"],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=300,
        env=dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1"),
    )
    assert done.returncode == 0, done.stdout + done.stderr
    finished, series = read_series(cwd / "ref.h5")
    assert finished
    return series


def test_cluster_runs_an_mpi_step_with_pmix(slurm):
    # the premise of every script: srun --mpi=pmix starts Debian's OpenMPI ranks
    done = slurm.run(
        "srun",
        "--mpi=pmix",
        "-n",
        "2",
        sys.executable,
        "-c",
        "from mpi4py import MPI; c = MPI.COMM_WORLD;"
        " print(c.Get_rank(), c.Get_size(), c.allreduce(1))",
        check=False,
        timeout=120,
        env=job_environment(slurm),
    )
    assert done.returncode == 0, done.stderr + "\n" + slurm.diagnostics()
    assert sorted(done.stdout.split("\n")[:2]) == ["0 2 2", "1 2 2"], done.stdout


def test_case_job_on_two_ranks_matches_the_direct_run(slurm, reference, tmp_path):
    (tmp_path / "case.toml").write_text(CASE)
    # Without HPCGFMD_PYTHON the script takes the .venv of the repository it was submitted
    # from (via scontrol's Command=); check that when the tests run from that .venv.
    own_venv = Path(sys.executable).parent == REPO / ".venv" / "bin"
    job = submit(
        slurm,
        tmp_path,
        "case.sbatch",
        "case.toml",
        "out.h5",
        options=["--ntasks=2"],
        env=job_environment(slurm, python=not own_venv),
    )
    (record,) = finish(slurm, job)
    context = slurm.diagnostics(job)
    assert record["JobState"] == "COMPLETED" and record["ExitCode"] == "0:0", context
    log = Path(record["StdOut"]).read_text()
    assert "on 2 task(s)" in log and "writing out.h5 on 2 rank(s)" in log, context
    if own_venv:
        assert f"{REPO}/.venv/bin/python -m hpcgfmd run" in log, context
    assert not (tmp_path / "out.checkpoint.h5").exists(), context
    assert_same_series(reference, tmp_path / "out.h5", context)


def test_case_job_passes_on_the_bad_input_status(slurm, tmp_path):
    job = submit(slurm, tmp_path, "case.sbatch", "missing.toml", "out.h5")
    (record,) = finish(slurm, job)
    context = slurm.diagnostics(job)
    assert record["JobState"] == "FAILED" and record["ExitCode"] == "2:0", context
    assert "bad input" in Path(record["StdOut"]).read_text(), context
    assert not (tmp_path / "out.h5").exists(), context


def wait_for_checkpoint(slurm, job, tmp_path, timeout=120):
    """Wait until the job's run has written its first checkpoint; the job must be RUNNING."""
    checkpoint = tmp_path / "out.checkpoint.h5"
    deadline = time.monotonic() + timeout
    while not checkpoint.exists():
        if (
            time.monotonic() > deadline
            or slurm.job(job).get("JobState") in slurm_cluster.FINAL_STATES
        ):
            pytest.fail(
                f"job {job} ended or wrote no checkpoint in {timeout} s\n" + slurm.diagnostics(job),
                pytrace=False,
            )
        time.sleep(0.02)
    state = slurm.job(job).get("JobState")
    assert state == "RUNNING", f"{state}\n{slurm.diagnostics(job)}"


def test_chain_continues_in_a_new_job_after_the_signal(slurm, reference, tmp_path):
    (tmp_path / "case.toml").write_text(CASE)
    # options after the files go to every part, but --overwrite to the first only
    first = submit(
        slurm, tmp_path, "chain.sbatch", "case.toml", "out.h5", "--overwrite", "--log", "run.log"
    )
    wait_for_checkpoint(slurm, first, tmp_path)
    # what SLURM does at --signal=B:USR1@margin before the time limit: USR1 to the batch shell
    slurm.run("scancel", "--signal=USR1", "--batch", first)
    (record,) = finish(slurm, first)
    context = slurm.diagnostics(first)
    assert record["JobState"] == "COMPLETED", context  # part 1 ends well: it handed over
    log_path = Path(record["StdOut"])
    log = log_path.read_text()
    assert "SIGUSR1" in log and "stopped by a signal" in log and "checkpoint" in log, context
    with h5py.File(tmp_path / "out.h5", "r") as f:
        stopped_at = int(f.attrs["steps_complete"])
    assert 5 <= stopped_at < reference["load"].size, (stopped_at, context)
    found = re.search(r"submitted part 2 as job (\d+)", log)
    assert found, context
    second = int(found.group(1))
    assert second != first
    (record,) = finish(slurm, second)
    context = slurm.diagnostics(first, second)
    assert record["JobState"] == "COMPLETED" and record["ExitCode"] == "0:0", context
    # the next part carried the options and the arguments
    assert record["TimeLimit"] == "00:10:00" and record["WorkDir"] == str(tmp_path), context
    assert record["StdOut"] == str(log_path), context  # appends to the first part's log
    log = log_path.read_text()
    assert "part 2 of at most 20" in log and "resuming" in log, context
    assert log.count("SIGUSR1") == 1, context  # ours; none from SLURM's --signal margin
    assert "finished in part 2" in log, context
    part_1, part_2 = log.split("part 2 of at most 20")
    assert "run case.toml -o out.h5 --overwrite --log run.log" in part_1, context
    assert "run case.toml -o out.h5 --log run.log" in part_2, context
    run_log = (tmp_path / "run.log").read_text()  # both parts' messages, by the option
    assert "writing out.h5" in run_log and "resuming out.h5" in run_log, context
    assert "finished:" in run_log, context
    assert not (tmp_path / "out.checkpoint.h5").exists(), context
    assert_same_series(reference, tmp_path / "out.h5", context)


@pytest.mark.parametrize(
    "script, variables, name",
    [
        ("case.sbatch", {"HPCGFMD_CASE": "case.toml", "HPCGFMD_OUTPUT": "out.h5"}, "out.h5"),
        ("farm.sbatch", {"HPCGFMD_SWEEP": "sweep.toml", "HPCGFMD_OUTDIR": "study"}, "study"),
    ],
)
def test_files_from_variables_and_options_from_the_command_line(
    slurm, tmp_path, script, variables, name
):
    (tmp_path / "case.toml").write_text(CASE)
    (tmp_path / "sweep.toml").write_text(SWEEP)
    env = dict(job_environment(slurm), **variables)
    job = submit(slurm, tmp_path, script, "--dry-run", options=["--ntasks=1"], env=env)
    (record,) = finish(slurm, job)
    context = slurm.diagnostics(job)
    assert record["JobState"] == "COMPLETED" and record["ExitCode"] == "0:0", context
    assert "chi_ve" in Path(record["StdOut"]).read_text(), context  # the dry run's groups
    assert not (tmp_path / name).exists(), context


def test_cancelled_chain_is_not_continued(slurm, tmp_path):
    (tmp_path / "case.toml").write_text(CASE)
    job = submit(slurm, tmp_path, "chain.sbatch", "case.toml", "out.h5")
    wait_for_checkpoint(slurm, job, tmp_path)
    before = {r["JobId"] for r in slurm.all_jobs()}
    slurm.run("scancel", job)
    (record,) = finish(slurm, job)
    time.sleep(1.0)  # a resubmission would be in the queue by now
    context = slurm.diagnostics(job)
    assert record["JobState"] == "CANCELLED", context
    assert {r["JobId"] for r in slurm.all_jobs()} == before, context
    log = Path(record["StdOut"]).read_text()
    assert "not continuing" in log and "submitting part" not in log, context
    assert (tmp_path / "out.checkpoint.h5").exists(), context  # still resumable


def test_chain_stops_at_its_maximum_length(slurm, tmp_path):
    (tmp_path / "case.toml").write_text(CASE)
    env = dict(job_environment(slurm), HPCGFMD_CHAIN_PART="4", HPCGFMD_CHAIN_MAX="3")
    job = submit(slurm, tmp_path, "chain.sbatch", "case.toml", "out.h5", env=env)
    (record,) = finish(slurm, job)
    context = slurm.diagnostics(job)
    assert record["JobState"] == "FAILED" and record["ExitCode"] == "75:0", context
    assert "HPCGFMD_CHAIN_MAX=3; not running" in Path(record["StdOut"]).read_text(), context
    assert not (tmp_path / "out.h5").exists(), context


def read_summary(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_farm_job_runs_every_case(slurm, tmp_path):
    (tmp_path / "sweep.toml").write_text(SWEEP)
    job = submit(slurm, tmp_path, "farm.sbatch", "sweep.toml", "study", options=["--ntasks=2"])
    (record,) = finish(slurm, job)
    context = slurm.diagnostics(job)
    assert record["JobState"] == "COMPLETED" and record["ExitCode"] == "0:0", context
    rows = read_summary(tmp_path / "study" / "summary.csv")
    assert [r["status"] for r in rows] == ["finished", "finished"], (rows, context)
    assert (tmp_path / "study" / "summary.h5").exists(), context
    for row in rows:
        assert_sane(tmp_path / "study" / row["file"], context)


def test_array_job_runs_one_case_per_element(slurm, tmp_path):
    (tmp_path / "sweep.toml").write_text(SWEEP)
    job = submit(slurm, tmp_path, "array.sbatch", "sweep.toml", "study", options=["--array=0-1"])
    records = finish(slurm, job)
    context = slurm.diagnostics(job)
    assert sorted(r.get("ArrayTaskId") for r in records) == ["0", "1"], context
    assert all(r["JobState"] == "COMPLETED" and r["ExitCode"] == "0:0" for r in records), context
    # the result files are those of the farm (names from the swept values)
    listing = subprocess.run(
        [sys.executable, "-m", "hpcgfmd", "farm", "sweep.toml", "-o", "study", "--dry-run"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=60,
    )
    files = sorted((tmp_path / "study").glob("*.h5"))
    names = sorted(p.name for p in files if p.name != "summary.h5")
    assert names == ["velocity_1.0.h5", "velocity_2.0.h5"], (names, listing.stdout, context)
    for name in names:
        assert name[:-3] in listing.stdout and "finished" in listing.stdout, listing.stdout
        assert_sane(tmp_path / "study" / name, context)


def test_a_sphere_case_job_on_two_ranks_matches_its_serial_run(slurm, tmp_path):
    from test_sphere import SPHERE_CASE

    (tmp_path / "sphere.toml").write_text(SPHERE_CASE)
    direct = subprocess.run(
        [sys.executable, "-m", "hpcgfmd", "run", "sphere.toml", "-o", "serial.h5"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
        env=dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1"),
    )
    assert direct.returncode == 0, direct.stderr
    job = submit(slurm, tmp_path, "case.sbatch", "sphere.toml", "out.h5", options=["--ntasks=2"])
    (record,) = finish(slurm, job)
    context = slurm.diagnostics(job)
    assert record["JobState"] == "COMPLETED" and record["ExitCode"] == "0:0", context
    with h5py.File(tmp_path / "serial.h5") as a, h5py.File(tmp_path / "out.h5") as b:
        assert b.attrs["finished"] and b.attrs["geometry"] == "sphere", context
        assert b["snapshots/gap"].shape[1:] == (64, 64), context
        for name in ("load", "contact_area", "indenter"):
            ref, got = a["series"][name][:], b["series"][name][:]
            assert got.shape == ref.shape and relative(ref, got) <= 1e-10, (name, context)
