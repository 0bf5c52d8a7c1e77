"""Checkpoint completeness: an interrupted and resumed run is the uninterrupted run, bit for bit.

In one process with FFTW_ESTIMATE plans (chosen deterministically) the arithmetic of the
resumed run is the same as that of the uninterrupted one if, and only if, the checkpoint
holds everything the next step reads (displacements of two steps for the predictor, the SLS
history, the contact edges, the statistics...). At the default tolerance 1e-7 a missing piece
changes the iteration path and so the series at about 1e-8: this test would see it.
"""

import numpy as np
import pytest
from mpi4py import MPI

from cases import StopAtStep, case_text
from hpcgfmd.case import parse_case
from hpcgfmd.errors import Interrupted, NonConvergenceError
from hpcgfmd.runs.single_case import run_case
from hpcgfmd.storage.checkpoint import checkpoint_path, read_checkpoint_attrs
from hpcgfmd.storage.reader import read_series

CASE = case_text("nx = 2048", "snapshot_times = [0.0, 3.0, 8.0]\nsnapshot_zero_load = true")
# A fast retraction on a coarse grid (w/dx = 1.5): the history estimate of windows with node
# crossings uses the kept smooth curvature (HistoryError, "Crossings"), which the
# checkpoint must hold too.
COARSE_FAST = case_text("nx = 1024", "snapshot_times = [0.0, 0.2]", velocity=9.0)
# A two-branch Prony series: its branch tractions are state the checkpoint must hold.
PRONY = case_text(
    "nx = 2048",
    "snapshot_times = [0.0, 3.0]",
    modulus_ratio=None,
    relaxation_moduli=[3.0, 6.0],
    relaxation_times=[0.1, 1.45],
)
# A compliant drive: the drive's start, the indenter's rate and slope are state too (with a
# Prony series: the branches' step start).
SPRING = case_text("nx = 2048", "snapshot_times = [0.0, 3.0]", drive_stiffness=0.3)
PRONY_SPRING = case_text(
    "nx = 1024",
    "",
    modulus_ratio=None,
    relaxation_moduli=[3.0, 6.0],
    relaxation_times=[0.1, 1.45],
    drive_stiffness=0.3,
)
# A loading protocol stopped on the step that ends its approach: the segment moves on after
# the restart (the schedule's index, start time and drive value are state)
CYCLE = (
    case_text("nx = 1024", "", velocity=10.0)
    + """
[[protocol]]
approach = 0.03
[[protocol]]
dwell = 0.3
[[protocol]]
retract = inf
"""
)
STOP_CYCLE = 235  # the approach's last step (measured: 571 steps, the dwell 236-265)
# Load control: the applied load is the drive
LOAD_CONTROL = (
    case_text("nx = 1024", "", modulus_ratio=1.0, drive_stiffness=0)
    + """
[[protocol]]
retract = -inf
load_rate = 1e-3
"""
)


# (the coarse case stops after step 41, a window without crossings: steps 42-45 are windows
# with crossings that use its curvature, and step 42's kept history error compares with its
# correction, so the resumed run needs both from the checkpoint)
@pytest.mark.parametrize(
    "text, stop",
    [
        (CASE, 38),
        (COARSE_FAST, 41),
        (PRONY, 57),
        (SPRING, 60),
        (PRONY_SPRING, 45),
        (CYCLE, STOP_CYCLE),
        (LOAD_CONTROL, 60),
    ],
    ids=["default", "coarse-fast", "prony", "spring", "prony-spring", "cycle", "load-control"],
)
def test_interrupted_and_resumed_equals_uninterrupted_bitwise(tmp_path, text, stop):
    case = parse_case(text)
    quiet = {"planner_effort": "FFTW_ESTIMATE"}
    run_case(case, tmp_path / "whole.h5", MPI.COMM_SELF, **quiet)
    # a signal while step ``stop`` is written: the run stops after it, with its checkpoint
    with StopAtStep(stop) as signals, pytest.raises(Interrupted) as err:
        run_case(case, tmp_path / "parts.h5", MPI.COMM_SELF, **quiet, stop=signals)
    assert f"at step {stop} " in str(err.value)
    run_case(case, tmp_path / "parts.h5", MPI.COMM_SELF, **quiet, resume=True)
    whole, parts = read_series(tmp_path / "whole.h5"), read_series(tmp_path / "parts.h5")
    for name in (
        "time",
        "indenter",
        "drive",
        "applied_load",
        "segment",
        "load",
        "contact_half_width",
        "cohesive_half_width",
        "iterations",
        "residual",
    ):
        np.testing.assert_array_equal(getattr(parts, name), getattr(whole, name), err_msg=name)
    for key in (
        "steps",
        "iterations",
        "fft_pairs",
        "projections",
        "cut_steps",
        "moving_edge_predictions",
        "rejected_predictions",
        "spring_solves",
    ):
        assert parts.attrs[key] == whole.attrs[key], key
    import h5py

    with h5py.File(tmp_path / "whole.h5") as a, h5py.File(tmp_path / "parts.h5") as b:
        for name in ("time", "surface", "pressure", "gap"):
            np.testing.assert_array_equal(b["snapshots"][name][:], a["snapshots"][name][:])


def test_a_run_stopped_at_its_iteration_cap_resumes_with_a_higher_cap(tmp_path):
    # The cap's error says "raise [numerics] max_iterations": the run checkpoints its last
    # accepted step as it stops (here its only checkpoint: none by steps, none in 600 s),
    # and the same command with a higher cap continues from it (the cap is not part of the
    # case's identity: it only ends solves that would stop the run); the result is the
    # uncapped run's, bit for bit. A fast retraction on a coarse grid: every step takes at
    # most 23 iterations but the snap-off's last solve some 30-40 (the count depends on the
    # machine's vector width through the compiled sums' round-off), so a cap one below the
    # last solve's count stops the run at its end.
    uncapped = parse_case(case_text("nx = 1024", velocity=9.0))
    quiet = {"planner_effort": "FFTW_ESTIMATE"}
    run_case(uncapped, tmp_path / "whole.h5", MPI.COMM_SELF, **quiet)
    iterations = read_series(tmp_path / "whole.h5").iterations
    cap = int(iterations[-1]) - 1
    assert int(iterations[1:-1].max()) < cap  # only the last solve reaches it
    capped = parse_case(case_text(f"nx = 1024\nmax_iterations = {cap}", velocity=9.0))
    assert capped.identity() == uncapped.identity()
    with pytest.raises(NonConvergenceError, match=f"after {cap} iterations; raise.*checkpoint"):
        run_case(capped, tmp_path / "parts.h5", MPI.COMM_SELF, **quiet)
    stopped = read_series(tmp_path / "parts.h5").load.size
    assert stopped > 100  # stopped late, not at once
    checkpoint = read_checkpoint_attrs(checkpoint_path(tmp_path / "parts.h5"))
    assert checkpoint["surface.step_index"] == stopped - 1
    run_case(uncapped, tmp_path / "parts.h5", MPI.COMM_SELF, **quiet, resume=True)
    whole, parts = read_series(tmp_path / "whole.h5"), read_series(tmp_path / "parts.h5")
    for name in ("time", "load", "contact_half_width", "iterations"):
        np.testing.assert_array_equal(getattr(parts, name), getattr(whole, name), err_msg=name)


def test_the_identity_leaves_out_the_cap_and_the_output():
    # what changes the series changes the identity; the iteration cap (a run stopped by it
    # continues under a raised one) and [output] (what is written) do not
    case = parse_case(case_text("nx = 1024", velocity=9.0))
    same = [
        case_text("nx = 1024\nmax_iterations = 30", velocity=9.0),
        case_text("nx = 1024", "progress_interval = 1.0", velocity=9.0),
    ]
    other = [
        case_text("nx = 1024\ntolerance = 1e-3", velocity=9.0),
        case_text("nx = 1024", velocity=8.0),
        case_text("nx = 2048", velocity=9.0),
        case_text('nx = 1024\nsolver = "paper"', velocity=9.0),
    ]
    assert all(parse_case(text).identity() == case.identity() for text in same)
    assert len({parse_case(text).identity() for text in other} | {case.identity()}) == 5


def test_a_checkpoint_of_another_format_is_refused_in_one_line(tmp_path):
    # written by another version of hpcgfmd: the case starts again (--overwrite)
    import h5py

    from hpcgfmd.errors import UsageError
    from hpcgfmd.runs.resume import prepare_output
    from hpcgfmd.storage.checkpoint import FORMAT_VERSION, checkpoint_path

    case = parse_case(case_text("nx = 1024"))
    out = tmp_path / "case.h5"
    with StopAtStep(3) as signals, pytest.raises(Interrupted):
        run_case(case, out, MPI.COMM_SELF, planner_effort="FFTW_ESTIMATE", stop=signals)
    with h5py.File(checkpoint_path(out), "r+") as f:
        f.attrs["hpcgfmd_checkpoint"] = FORMAT_VERSION - 1
    with pytest.raises(UsageError) as err:
        prepare_output(MPI.COMM_SELF, case, str(out), overwrite=False)
    message = str(err.value)
    assert "\n" not in message
    assert f"checkpoint format {FORMAT_VERSION - 1}, written by another version" in message
    assert "start the case again" in message
