"""A stop signal in every phase of a run: SIGTERM, SIGUSR1 and SIGINT, each sent for real
(``os.kill``) while the transforms are planned, during a coarse and the fine preload level,
during a step's solve and while a step is written.

Before the result file exists the run stops with nothing written; after, with the checkpoint
of the last accepted step, from which the same call continues to the uninterrupted series,
bit for bit (one process, FFTW_ESTIMATE plans: the arithmetic is the same). The status is 75
after SIGTERM and SIGUSR1, 130 after SIGINT. The solvers look at the flag in every iteration
(it rides on a reduction they make anyway), so a stop comes within one iteration, and a step
cut short in its solve is undone.
"""

import os
import signal

import numpy as np
import pytest
from mpi4py import MPI

from cases import SignalInPhase, StopAtStep, case_text
from hpcgfmd.case import parse_case
from hpcgfmd.errors import EXIT_INTERRUPTED, EXIT_RESUMABLE, Interrupted
from hpcgfmd.runs.coarse_start import preload_grids
from hpcgfmd.runs.single_case import run_case
from hpcgfmd.storage.checkpoint import checkpoint_path, read_checkpoint_attrs
from hpcgfmd.storage.reader import read_series

COMM = MPI.COMM_SELF
QUICK = {"planner_effort": "FFTW_ESTIMATE"}
SIGNALS = [signal.SIGTERM, signal.SIGUSR1, signal.SIGINT]
STATUS = {signal.SIGTERM: EXIT_RESUMABLE, signal.SIGUSR1: EXIT_RESUMABLE}
STATUS[signal.SIGINT] = EXIT_INTERRUPTED
# the preload on two levels (2^12 and 2^13 nodes); stopped in it, the run is short
LEVELS = case_text("nx = 8192")
# a whole run of about 150 steps, 1-2 s
CASE = case_text("nx = 1024")
STEP = 5  # the step stopped in its solve, or while it is written


@pytest.fixture(scope="module")
def whole(tmp_path_factory):
    out = tmp_path_factory.mktemp("whole") / "whole.h5"
    run_case(parse_case(CASE), out, COMM, **QUICK)
    return read_series(out)


def test_the_level_case_has_two_preload_levels():
    assert preload_grids(parse_case(LEVELS)) == [4096, 8192]


@pytest.mark.parametrize("signum", SIGNALS, ids=lambda s: signal.Signals(s).name)
@pytest.mark.parametrize(
    "phase, said",
    [
        ("planning", "planning of the transforms of 2^13 nodes"),
        ("preload, level 1", "preload, level 1 of 2 (2^12 nodes)"),
        ("preload, level 2", "preload, level 2 of 2 (2^13 nodes)"),
    ],
    ids=["planning", "coarse-preload", "fine-preload"],
)
def test_a_signal_before_the_first_step_writes_nothing(tmp_path, phase, said, signum):
    out = tmp_path / "case.h5"
    with SignalInPhase(phase, signum) as signals, pytest.raises(Interrupted) as err:
        run_case(parse_case(LEVELS), out, COMM, **QUICK, stop=signals)
    assert signals.sent  # the signal was sent, in that phase
    assert err.value.status == STATUS[signum]
    assert str(err.value) == f"stopped by a signal during the {said}; nothing was written"
    assert not out.exists() and not os.path.exists(checkpoint_path(out))


def resumed_equals_whole(out, whole):
    """The same call continues from the checkpoint to the uninterrupted series, bitwise."""
    run_case(parse_case(CASE), out, COMM, **QUICK, resume=True)
    parts = read_series(out)
    assert parts.attrs["finished"]
    for name in ("time", "load", "contact_half_width", "indenter", "iterations"):
        np.testing.assert_array_equal(getattr(parts, name), getattr(whole, name), err_msg=name)


@pytest.mark.parametrize("signum", SIGNALS, ids=lambda s: signal.Signals(s).name)
def test_a_signal_in_a_solve_undoes_the_step_and_resumes_bitwise(tmp_path, whole, signum):
    out = tmp_path / "case.h5"
    with (
        SignalInPhase(f"solve of step {STEP}", signum) as signals,
        pytest.raises(Interrupted) as err,
    ):
        run_case(parse_case(CASE), out, COMM, **QUICK, stop=signals)
    assert err.value.status == STATUS[signum]
    assert str(err.value).startswith(
        f"stopped by a signal during the solve of step {STEP}; checkpoint"
        f" {checkpoint_path(out)} holds step {STEP - 1} (t = "
    )
    assert read_checkpoint_attrs(checkpoint_path(out))["surface.step_index"] == STEP - 1
    assert read_series(out).time.size == STEP  # the preload and steps 1 .. STEP - 1
    resumed_equals_whole(out, whole)


@pytest.mark.parametrize("signum", SIGNALS, ids=lambda s: signal.Signals(s).name)
def test_a_signal_while_a_step_is_written_keeps_it_and_resumes_bitwise(tmp_path, whole, signum):
    out = tmp_path / "case.h5"
    with StopAtStep(STEP, signum) as signals, pytest.raises(Interrupted) as err:
        run_case(parse_case(CASE), out, COMM, **QUICK, stop=signals)
    assert err.value.status == STATUS[signum]
    assert str(err.value).startswith(f"stopped by a signal at step {STEP} (t = ")
    assert read_checkpoint_attrs(checkpoint_path(out))["surface.step_index"] == STEP
    resumed_equals_whole(out, whole)


def test_sigint_outside_a_run_is_keyboard_interrupt():
    # no run listening: Ctrl-C is Python's, which the entry point turns into one line
    with SignalInPhase("never") as signals:
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)
        with signals.listening():
            os.kill(os.getpid(), signal.SIGINT)  # a run listens: only a request to stop
            assert signals.interrupted
            with pytest.raises(KeyboardInterrupt):  # the user insists
                os.kill(os.getpid(), signal.SIGINT)
