"""The snap-off placed to its share of the work of separation (hpcgfmd/solvers/snap_off.py):
the bound against the work integrated independently, the step control's verdicts on a
vanishing contact, and a run whose jump it places: the same run up to the pull-off, bit for
bit, the work within its share, in fewer iterations."""

import math

import numpy as np
import pytest

from cases import case_text, sphere_case, whole_run
from hpcgfmd.case import parse_case
from hpcgfmd.model.accuracy import load_tolerance, snap_off_share
from hpcgfmd.solvers import stepping
from hpcgfmd.solvers.snap_off import SnapOff
from hpcgfmd.solvers.stepping import AdaptiveSteps, StepOutcome, make_step_control

SHARE, ALLOWANCE, RATE = 1e-3, 1e-3, 0.5


def tensile_curve(times):
    """A retraction's load past its preload: most tensile (-1) at t = 1, rising after."""
    return -1.0 + 0.4 * (times - 1.0) ** 2


def test_the_share_is_a_quarter_of_the_steps_share_of_the_accuracy():
    # accuracy.load_tolerance is a quarter of the steps' share (one half) times the
    # sampling factor 8, in units of the relaxed pull-off (1.74 load scales)
    assert snap_off_share(load_tolerance(5e-3)) == pytest.approx(0.25 * 0.5 * 5e-3)


def test_the_bound_is_the_work_share_past_the_pull_off():
    times = np.linspace(0.0, 1.8, 37)
    loads, drives = tensile_curve(times), RATE * times
    snap = SnapOff(SHARE, ALLOWANCE)
    for k, (t, load, drive) in enumerate(zip(times, loads, drives)):
        snap.accept(t, load, drive)
        # the tensile work so far, the trapezoids of -L dD (all loads here are tensile)
        work = np.trapezoid(-loads[: k + 1], drives[: k + 1])
        past = load > loads[: k + 1].min() + ALLOWANCE
        expected = 2.0 * SHARE * work / (-load * RATE) if past else 0.0
        assert snap.bound == pytest.approx(expected, rel=1e-12, abs=0.0), (k, t)
    assert snap.bound > 0.0  # (the curve's end is past its minimum)
    # a new segment forgets the pull-off and the work: no bound until it has its own
    snap.new_segment()
    assert snap.bound == 0.0
    snap.accept(2.0, loads[-1], RATE * 2.0)
    assert snap.bound == 0.0 and snap.work == 0.0


def test_no_bound_on_a_falling_drive_a_compressive_load_or_a_zero_share():
    for share, loads, rate in (
        (SHARE, [-1.0, -0.5], -RATE),  # an approach: the drive falls
        (SHARE, [-1.0, 0.5], RATE),  # the load went compressive
        (0.0, [-1.0, -0.5], RATE),  # a compliant drive's (no share)
    ):
        snap = SnapOff(share, ALLOWANCE)
        snap.accept(0.0, -0.9, 0.0)
        for t, load in zip((1.0, 2.0), loads):
            snap.accept(t, load, rate * t)
        assert snap.bound == 0.0


def test_a_displacement_controlled_case_has_the_share_and_a_spring_none():
    rigid = make_step_control(parse_case(case_text("accuracy = 5e-3")))
    assert rigid.snap_off.share == pytest.approx(5e-3 / 8)
    # a spring's jumps are its own (load control is the spring of stiffness 0: the same test)
    text = case_text("accuracy = 5e-3", drive_stiffness=1e-2)
    assert make_step_control(parse_case(text)).snap_off.share == 0.0


def test_a_vanished_contact_is_taken_up_to_the_bound_and_repeated_beyond():
    # (a share that puts the bound, 0.086, some grid points above dt_min = 1/64)
    c = AdaptiveSteps(1.0, 1.0 / 64, 16.0, 1.0, ALLOWANCE, snap_off_share=20 * SHARE)
    assert c.jump_dt() == c.dt_min
    times = np.linspace(0.0, 1.8, 37)
    for t, load in zip(times, tensile_curve(times)):
        c.accept(t, load, drive=RATE * t)
    jump = c.jump_dt()
    # the bound, rounded down to the grid dt_min 2^(j/4)
    assert c.dt_min < jump <= c.snap_off.bound < jump * 2.0**0.25
    assert c.edge_limit(jump) == math.inf and c.edge_limit(2.0 * jump) < math.inf
    t = times[-1]
    for dt, taken in ((jump, True), (2.0 * jump, False)):
        vanished = StepOutcome(dt, t + dt, 0.0, math.inf)
        assert c.judge(vanished).accepted == taken
    # an abandoned solve (no load) is repeated whatever its length
    assert not c.judge(StepOutcome(jump, t + jump, None, math.inf)).accepted
    other = AdaptiveSteps(1.0, 1.0 / 64, 16.0, 1.0, ALLOWANCE, snap_off_share=20 * SHARE)
    other.restore(c.state())
    assert other.jump_dt() == jump and vars(other.snap_off) == vars(c.snap_off)


def elastic_sphere():
    """An elastic sphere (lambda0 = 3) on 96 x 96 at accuracy 2e-2: its contact shrinks past
    the pull-off to the fold of the attached branch (measured: with the jump placed to dt_min
    6 steps past the pull-off repeated, 619 iterations; placed to its share none, 515)."""
    return sphere_case(96)


def tensile_work(records):
    """(M45)'s work of the tensile loads, trapezoids over the indenter's rise."""
    loads = np.array([r.load for r in records])
    rise = np.diff([r.indenter for r in records])
    return float(np.sum(np.maximum(0.0, -0.5 * (loads[1:] + loads[:-1])) * rise))


def test_a_jump_placed_to_its_share_changes_nothing_to_the_pull_off(monkeypatch):
    case = elastic_sphere()
    placed, sim = whole_run(case.text)
    monkeypatch.setattr(stepping, "snap_off_share", lambda tolerance: 0.0)
    fine, plain = whole_run(case.text)
    # the same run, bit for bit, up to the pull-off (and beyond it while no step vanished)
    pull_off = int(np.argmin([r.load for r in fine]))
    same = [(r.time, r.load) for r in placed[: pull_off + 1]]
    assert same == [(r.time, r.load) for r in fine[: pull_off + 1]]
    # the jump came later, within the bound of the last attached step, and the work moved
    # by at most its share (the bound is the trapezoid's: |L| v dt / 2 against share W)
    share = snap_off_share(case.numerics.load_tolerance)
    work, reference = tensile_work(placed), tensile_work(fine)
    assert abs(work / reference - 1.0) <= share
    assert placed[-1].time >= fine[-1].time - sim.steps.dt_min
    assert plain.rejected_steps > sim.rejected_steps
    assert sim.equilibrium.iterations < plain.equilibrium.iterations
