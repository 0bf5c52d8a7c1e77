"""The distributed engine as a user runs it: `mpirun -n P python -m hpcgfmd run ...`.

Independent references: the serial run of the same case. The runs use tolerance 1e-13 (the
floor): the transforms of P ranks round differently from the serial rfft (and so do the
reductions), the iteration paths then differ slightly, and two runs can only agree to about
the solver tolerance times the conditioning; at the default 1e-7 they agree to about 1e-8
(measured 3.9e-9 in the load), at 1e-13 to 8.5e-13 (load) and 2.6e-12 (contact half-width),
which is also what two serial runs differ by (FFTW_MEASURE plans are chosen by timing).
"""

import os
import random
import shutil
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest

from cases import case_text

MPIRUN = shutil.which("mpirun")
pytestmark = [
    pytest.mark.mpi,
    pytest.mark.slow,
    pytest.mark.skipif(MPIRUN is None, reason="OpenMPI's mpirun is not installed"),
]


def case(nx=2048, checkpoint_steps=0, tolerance="1e-13", more="", **groups):
    """The tests' case at the solver's round-off floor, with snapshots and checkpoints."""
    return case_text(
        f"nx = {nx}\ntolerance = {tolerance}{more}",
        "snapshot_times = [0.0, 3.0, 8.0, 12.0]\nsnapshot_zero_load = true\n"
        f"checkpoint_steps = {checkpoint_steps}",
        **groups,
    )


SERIES = ("time", "indenter", "load", "contact_half_width", "cohesive_half_width")
CYCLE = "\n[[protocol]]\napproach = 0.03\n[[protocol]]\ndwell = 0.3\n[[protocol]]\nretract = inf\n"
LOAD_RAMP = "\n[[protocol]]\nretract = -inf\nload_rate = 1e-3\n"


def command(ranks, *args):
    launcher = [] if ranks == 0 else [MPIRUN, "--oversubscribe", "-n", str(ranks)]
    return [*launcher, sys.executable, "-m", "hpcgfmd", *map(str, args)]


def environment():
    env = dict(
        os.environ,
        OMPI_ALLOW_RUN_AS_ROOT="1",
        OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
        OMPI_MCA_rmaps_base_oversubscribe="1",
        OPENBLAS_NUM_THREADS="1",
    )
    return env


def run(ranks, *args, cwd, timeout=240):
    return subprocess.run(
        command(ranks, *args),
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=timeout,
        env=environment(),
    )


def read(path):
    with h5py.File(path, "r") as f:
        assert f.attrs["finished"]
        series = {name: f["series"][name][:] for name in SERIES + ("iterations",)}
        snaps = {name: f["snapshots"][name][:] for name in ("time", "surface", "pressure", "gap")}
        snaps["x"] = f["snapshots/x"][:]
    return series, snaps


EDGE = 1e-9  # the contact half-width between rank counts (assert_same)


def relative(a, b):
    """max |a - b| / max |a|; max |b| when a is zero (a detached snapshot's pressure)."""
    scale = np.max(np.abs(a))
    return float(np.max(np.abs(a - b)) / scale if scale else np.max(np.abs(b)))


def assert_same(reference, other, tolerance, edge_tolerance=None, field_tolerance=None):
    """Series and snapshots equal to ``tolerance`` (relative to each quantity's maximum).

    ``edge_tolerance`` for the contact half-width: the (x - a)^(3/2) extrapolation from the
    two first open nodes amplifies round-off; two uninterrupted serial runs of this case
    differ by 2.0e-12 there (FFTW_MEASURE picks its plans by timing), against 5.9e-13 in
    the load (measured). Since each solve's K u is the running one (its increments carry
    the rank count's transform round-off, no transform at the solve's end), the serial and
    the 3-rank run of the 9 x 2^8 grid differed by 1.5e-10 there (measured once in CI).
    ``field_tolerance`` for the snapshots (default ``tolerance``): the
    contact pressure is the reaction K u + H + mu, whose multiplier mu is converged to the
    solver tolerance (measured between rank counts: 6e-12 to 2.5e-11 of the peak pressure).
    """
    (s0, p0), (s1, p1) = reference, other
    for name in SERIES:
        assert s1[name].shape == s0[name].shape, name
        limit = edge_tolerance if name == "contact_half_width" and edge_tolerance else tolerance
        assert relative(s0[name], s1[name]) <= limit, (name, relative(s0[name], s1[name]))
    np.testing.assert_array_equal(p1["time"], p0["time"])
    np.testing.assert_array_equal(p1["x"], p0["x"])
    limit = field_tolerance or tolerance
    for name in ("surface", "pressure", "gap"):
        assert relative(p0[name], p1[name]) <= limit, (name, relative(p0[name], p1[name]))
    # contact sets (nodes on the wall) identical in every snapshot
    np.testing.assert_array_equal(p1["gap"] <= 0.0, p0["gap"] <= 0.0)


@pytest.fixture(scope="module")
def serial_run(tmp_path_factory):
    cwd = tmp_path_factory.mktemp("serial")
    (cwd / "case.toml").write_text(case())
    done = run(0, "run", "case.toml", "-o", "serial.h5", cwd=cwd)
    assert done.returncode == 0, done.stderr
    return cwd, read(cwd / "serial.h5")


@pytest.mark.parametrize("ranks", [1, 2, 3])
def test_same_answer_on_any_rank_count(serial_run, tmp_path, ranks):
    # P = 3 splits the 2048 nodes unevenly (the transposed layout has 32 rows of 64 nodes).
    cwd, reference = serial_run
    shutil.copy(cwd / "case.toml", tmp_path / "case.toml")
    done = run(ranks, "run", "case.toml", "-o", "out.h5", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert f"on {ranks} rank(s)" in done.stdout
    assert_same(reference, read(tmp_path / "out.h5"), 1e-10, edge_tolerance=EDGE)


def test_same_answer_on_a_grid_of_nine_times_a_power_of_two(tmp_path):
    # the automatic grids are f 2^a, f in {1, 3, 9} (hpcgfmd.model.grid): 2304 = 9 2^8 is
    # laid out as 48 rows of 48 nodes, split over 3 ranks as 16 rows each
    answers = []
    for ranks in (0, 3):  # serial, then 3 ranks
        cwd = tmp_path / str(ranks)
        cwd.mkdir()
        (cwd / "case.toml").write_text(case(nx=2304))
        done = run(ranks, "run", "case.toml", "-o", "out.h5", cwd=cwd)
        assert done.returncode == 0, done.stderr
        answers.append(read(cwd / "out.h5"))
    assert_same(answers[0], answers[1], 1e-10, edge_tolerance=EDGE)


@pytest.mark.parametrize(
    "groups",
    [
        # the branch tractions are real-space blocks of each rank (hpcgfmd.model.halfspace)
        dict(modulus_ratio=None, relaxation_moduli=[3.0, 6.0], relaxation_times=[0.1, 1.45]),
        # the indenter's search: every rank takes the same decisions from reduced loads
        dict(drive_stiffness=0.3),
        # a protocol: the jump into contact, a dwell, the retraction
        dict(velocity=10.0, protocol=CYCLE),
        # load control: the search for the indenter under a falling load
        dict(modulus_ratio=1.0, drive_stiffness=0, protocol=LOAD_RAMP),
    ],
    ids=["prony", "spring", "cycle", "load-control"],
)
def test_prony_spring_and_protocols_same_answer_on_two_ranks(tmp_path, groups):
    answers = []
    groups = dict(groups)
    protocol = groups.pop("protocol", "")
    for ranks in (0, 2):
        cwd = tmp_path / str(ranks)
        cwd.mkdir()
        (cwd / "case.toml").write_text(case(**groups) + protocol)
        done = run(ranks, "run", "case.toml", "-o", "out.h5", cwd=cwd)
        assert done.returncode == 0, done.stderr
        answers.append(read(cwd / "out.h5"))
    assert_same(answers[0], answers[1], 1e-10, edge_tolerance=EDGE)


def interrupt(tmp_path, ranks, signum, text=None, delay=0.4):
    """Start a run of ``text`` (the tests' case by default), signal it at a random step after
    its first checkpoint (at most ``delay`` s later), return (status, stdout, stderr)."""
    (tmp_path / "case.toml").write_text(text or case(checkpoint_steps=5))
    process = subprocess.Popen(
        command(ranks, "run", "case.toml", "-o", "out.h5"),
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=environment(),
    )
    deadline = time.monotonic() + 120
    while not (tmp_path / "out.checkpoint.h5").exists():
        assert process.poll() is None and time.monotonic() < deadline, process.communicate()
        time.sleep(0.02)
    time.sleep(random.uniform(0.0, delay))
    process.send_signal(signum)  # mpirun forwards SIGUSR1 to every rank
    stdout, stderr = process.communicate(timeout=120)
    return process.returncode, stdout, stderr


@pytest.mark.parametrize(
    "first, second, signum",
    [
        (0, 0, signal.SIGTERM),
        (2, 3, signal.SIGUSR1),
        (0, 2, signal.SIGUSR1),
        (0, 2, signal.SIGINT),  # Ctrl-C on a run in a terminal
    ],
)
def test_interrupted_run_resumes_to_the_uninterrupted_series(
    serial_run, tmp_path, first, second, signum
):
    cwd, reference = serial_run
    status, stdout, stderr = interrupt(tmp_path, first, signum)
    assert status == (130 if signum == signal.SIGINT else 75), (stdout, stderr)
    assert "run the same command again to continue" in stdout
    assert "Traceback" not in stderr
    with h5py.File(tmp_path / "out.h5", "r") as f:
        assert not f.attrs["finished"]
        stopped_at = int(f.attrs["steps_complete"]) - 1  # the preload is entry 0
    assert stopped_at < reference[0]["time"].size - 1  # interrupted mid-run
    # "at step k (t = ...)" after a step, "... holds step k (t = ...)" in the next one's solve
    assert "stopped by a signal" in stdout and f"step {stopped_at} (t = " in stdout
    # the same command continues (automatic resume), here on another rank count, from the
    # checkpoint the signal wrote (not the last scheduled one)
    done = run(second, "run", "case.toml", "-o", "out.h5", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert f"at step {stopped_at} " in done.stdout
    assert not (tmp_path / "out.checkpoint.h5").exists()  # removed once finished
    resumed = read(tmp_path / "out.h5")
    # What any two runs of this case on different rank counts differ by, interrupted or not
    # (FFTW_MEASURE plans are chosen by timing, and P ranks round differently; the CG path
    # and so its round-off differ): up to 3.6e-12 in the load and 1.0e-11 in the contact
    # half-width (seen; see assert_same), so the bound of the uninterrupted runs on P ranks
    # (test above). That the restart itself adds nothing is checked bit for bit in
    # tests/test_restart.py.
    assert_same(reference, resumed, 1e-10, field_tolerance=1e-10)


def test_checkpoint_of_another_case_is_refused(serial_run, tmp_path):
    cwd, _ = serial_run
    status, stdout, stderr = interrupt(tmp_path, 0, signal.SIGTERM)
    assert status == 75, stderr
    other = case(checkpoint_steps=5, velocity=2.0)
    (tmp_path / "other.toml").write_text(other)
    before = (tmp_path / "out.h5").read_bytes()
    done = run(2, "run", "other.toml", "-o", "out.h5", cwd=tmp_path)
    assert done.returncode == 2
    # one line from rank 0 (mpirun adds its own banner about the non-zero status)
    lines = [line for line in done.stderr.splitlines() if line.startswith("hpcgfmd:")]
    assert len(lines) == 1 and "checkpoint of a different case" in lines[0], done.stderr
    assert (tmp_path / "out.h5").read_bytes() == before  # nothing touched


def test_failure_on_one_rank_stops_all_ranks(tmp_path):
    # An unexpected error on rank 1 only (an OSError raised by a stand-in for the command
    # line, while rank 0 waits in a barrier) must make hpcgfmd's entry point abort the job
    # with a message, not hang rank 0 in the collective.
    script = tmp_path / "fail.py"
    script.write_text(
        "from mpi4py import MPI\n"
        "import hpcgfmd.entry as entry, hpcgfmd.cli as cli\n"
        "def boom(comm, argv=None, stop=None):\n"
        "    if comm.Get_rank() == 1:\n"
        "        raise OSError('disk gone on rank 1')\n"
        "    comm.Barrier()\n"
        "    return 0\n"
        "cli.main = boom\n"
        "raise SystemExit(entry.main())\n"
    )
    started = time.monotonic()
    done = subprocess.run(
        [MPIRUN, "-n", "2", sys.executable, str(script)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=60,
        env=environment(),
    )
    assert done.returncode != 0
    assert "disk gone on rank 1" in done.stderr
    assert "aborting all 2 ranks" in done.stderr
    assert time.monotonic() - started < 30


@pytest.mark.parametrize("ranks", [0, 2])
def test_sigint_outside_a_run_ends_every_rank_with_one_line_and_130(tmp_path, ranks):
    # Ctrl-C while no run listens (start-up, info, plot): KeyboardInterrupt, which the entry
    # point turns into one line and status 130; with two ranks it aborts both with 130
    # while the other waits in a collective. A stand-in for the command line sends the real
    # signal on the last rank.
    script = tmp_path / "interrupted.py"
    script.write_text(
        "import os, signal, time\n"
        "import hpcgfmd.entry as entry, hpcgfmd.cli as cli\n"
        "def interrupted(comm, argv=None, stop=None):\n"
        "    if comm.Get_rank() == comm.Get_size() - 1:\n"
        "        os.kill(os.getpid(), signal.SIGINT)\n"
        "        time.sleep(30)\n"
        "    comm.Barrier()\n"
        "    return 0\n"
        "cli.main = interrupted\n"
        "raise SystemExit(entry.main())\n"
    )
    launcher = [] if ranks == 0 else [MPIRUN, "-n", str(ranks)]
    started = time.monotonic()
    done = subprocess.run(
        [*launcher, sys.executable, str(script)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=60,
        env=environment(),
    )
    assert done.returncode == 130, done.stderr
    assert "Traceback" not in done.stderr
    assert [line for line in done.stderr.splitlines() if line.startswith("hpcgfmd:")] == [
        "hpcgfmd: interrupted"
    ]
    assert time.monotonic() - started < 20


def test_non_convergence_stops_every_rank_with_status_1(tmp_path):
    # A failure every rank detects alike (from reduced values): status 1 from all ranks and
    # one line from rank 0, no hang. Here the preload fails, before the file is created.
    text = case(more="\nmax_iterations = 3")
    (tmp_path / "case.toml").write_text(text)
    done = run(2, "run", "case.toml", "-o", "out.h5", cwd=tmp_path)
    assert done.returncode == 1, done.stderr
    lines = [line for line in done.stderr.splitlines() if line.startswith("hpcgfmd:")]
    assert len(lines) == 1 and "NonConvergenceError" in lines[0], done.stderr
    assert not (tmp_path / "out.h5").exists()


def test_ranks_that_own_no_nodes(tmp_path):
    # nx = 64 is split as 8 rows of 8 nodes (and 5 mode rows): on 10 ranks, ranks 8 and 9 own
    # no nodes and ranks 5 to 9 no modes; they take part in every collective, halo and write.
    text = case(nx=64, maugis=1.0)
    (tmp_path / "case.toml").write_text(text)
    serial = run(0, "run", "case.toml", "-o", "serial.h5", cwd=tmp_path)
    assert serial.returncode == 0, serial.stderr
    done = run(10, "run", "case.toml", "-o", "ten.h5", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert_same(read(tmp_path / "serial.h5"), read(tmp_path / "ten.h5"), 1e-10, edge_tolerance=EDGE)


def test_signal_during_set_up_exits_75_with_nothing_written(tmp_path):
    # FFTW planning and the preload at 2^16 take seconds: a signal then must not kill the run
    # (SLURM's warning can come at any moment); nothing was computed, so nothing is written.
    text = case(nx=65536, tolerance="1e-7")
    (tmp_path / "case.toml").write_text(text)
    process = subprocess.Popen(
        command(2, "run", "case.toml", "-o", "out.h5"),
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=environment(),
    )
    for line in process.stdout:  # the run starts planning right after this line
        if line.startswith("writing out.h5"):
            break
    process.send_signal(signal.SIGUSR1)
    stdout, stderr = process.communicate(timeout=120)
    assert process.returncode == 75, stdout + stderr
    assert "stopped by a signal during the " in stdout and "nothing was written" in stdout
    assert not (tmp_path / "out.h5").exists() and not (tmp_path / "out.checkpoint.h5").exists()
