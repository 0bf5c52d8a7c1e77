"""Loading protocols: approach, dwell, retraction, cycles, load control (docs/model.md, (M44)).

Independent references:
- the paper's protocol, which a protocol of one retraction until detachment must repeat bit
  for bit;
- Baney-Hui (Maugis-Dugdale for the cylinder, periodic image corrected): an elastic solid
  loaded and unloaded slowly follows it on both branches;
- the energy of the states: along the equilibrium branches the drive's work -L du_z is the
  change of the total energy Pi = elastic + adhesive (Pi' = -L), so the loop's area, the
  dissipated energy of a closed elastic cycle, is the energy the two jumps (into and off
  contact) release, computed here from the fields, not from the load curve;
- the SLS's relaxation at fixed strain, sigma - E0 eps = (sigma_0 - E0 eps) exp(-t/tau): a
  contact held at constant depth after a step-like approach relaxes its load towards the
  relaxed equilibrium at that depth (solved directly, as the preload) with exp(-t/tau);
- Baney-Hui's minimum load, where load control lets go.
"""

import math
import subprocess
import sys

import numpy as np
import pytest
from mpi4py import MPI

from cases import PHYSICAL, case_text, whole_run
from hpcgfmd.case import parse_case
from hpcgfmd.errors import CaseError
from hpcgfmd.model import theory
from hpcgfmd.runs.protocol import Retraction

CYCLE = """
[[protocol]]
approach = 0.03
[[protocol]]
dwell = 1.0
[[protocol]]
retract = inf
"""


def records_of(text, energy=False):
    """(records, total energies Pi per record or None, the finished run) of a serial run."""
    case = parse_case(text)
    sim = Retraction(case, MPI.COMM_SELF, planner_effort="FFTW_ESTIMATE")
    half_q = np.pi * np.fft.rfftfreq(sim.n, d=1.0 / sim.n) / case.cell  # |q| / 2

    def total_energy():
        """Pi = (1/2) int u K u dx + int phi(g) dx, phi = -dgamma0 + sigma_a g in the zone."""
        u = sim.surface.u
        elastic = 0.5 * sim.domain.dx * np.dot(u, np.fft.irfft(half_q * np.fft.rfft(u), n=sim.n))
        gap = sim.equilibrium.gap()
        phi = np.where(gap < case.dmax, -case.adhesion + case.sigma_a * np.maximum(gap, 0.0), 0.0)
        return elastic + sim.domain.dx * phi.sum()

    try:
        records = [sim.preload()]
        energies = [total_energy()] if energy else None
        while not sim.finished():
            records.append(sim.step())
            if energy:
                energies.append(total_energy())
    finally:
        sim.close()
    return records, (np.array(energies) if energy else None), sim


def columns(records, *names):
    return [np.array([getattr(r, name) for r in records]) for name in names]


def test_the_paper_protocol_written_out_is_the_default():
    # one retraction until detachment at the case's velocity: the default, bit for bit
    default, _ = whole_run(case_text())
    written, sim = whole_run(case_text() + "\n[[protocol]]\nretract = inf\n")
    assert len(default) == len(written) > 100
    for a, b in zip(default, written):
        assert (a.time, a.indenter, a.load, a.contact_half_width) == (
            b.time,
            b.indenter,
            b.load,
            b.contact_half_width,
        )
    assert sim.schedule.over


def test_an_elastic_cycle_traces_baney_hui_and_dissipates_only_at_its_jumps():
    # lambda0 = 3.5, k = 1, nx = 2048 (w/dx = 3): approach from out of contact to h0/R =
    # 0.03, dwell, retract until detached
    text = case_text("nx = 2048", modulus_ratio=1.0) + CYCLE
    case = parse_case(text)
    records, energy, sim = records_of(text, energy=True)
    z, load, a, segment = columns(records, "indenter", "load", "contact_half_width", "segment")
    assert (segment[0], segment[-1]) == (0, 2) and np.all(np.diff(segment) >= 0)
    assert z[0] == 2.0 * case.dmax and z[segment == 1].tolist() == [-0.03] * np.sum(segment == 1)
    # the two jumps: into contact on the approach, off it on the retraction
    jumps = np.flatnonzero((a[1:] > 0) != (a[:-1] > 0)) + 1
    assert len(jumps) == 2 and segment[jumps[0]] == 0 and segment[jumps[1]] == 2
    # both branches with contact follow Baney-Hui within 1.5 % of the larger of the load and
    # the pull-off load: the grid's contact edge, located to a fraction of dx, errs by
    # 0.01-0.03 load scales through dL/da (measured 1.1 % at w/dx = 3, 0.86 % at w/dx = 6)
    lbar = load / case.load_scale
    for branch in (0, 2):
        m = (segment == branch) & (a > 0)
        reference = np.array([theory.maugis_dugdale(x, 3.5)[0] for x in a[m] / case.beta])
        reference *= theory.periodic_load_factor(a[m], case.cell)
        scale = np.maximum(np.abs(reference), 1.7)  # |pull-off| is 1.74 load scales
        assert np.max(np.abs(lbar[m] - reference) / scale) < 1.5e-2
    # the drive's work over the closed cycle (the file's loop area) is the energy the jumps
    # released; the equilibrium branches dissipate nothing beyond the trapezoid rule's
    # error and the grid's edge jumps (measured: 0.8 % of the loop's area)
    work = -0.5 * (load[1:] + load[:-1]) * np.diff(z)
    dissipated = work - np.diff(energy)
    released = dissipated[jumps - 1]
    assert energy[0] == 0.0 and abs(energy[-1]) < 1e-30  # flat and detached at both ends
    assert np.all(released > 0.0)
    assert abs(work.sum() / released.sum() - 1.0) < 0.02
    # the jump into contact releases more than the jump off (measured 1.23e-5, 7.6e-6)
    assert released[0] > released[1]


def test_a_dwell_relaxes_the_load_with_the_relaxation_function():
    # SLS k = 0.5; lambda0 = 0.3, alpha = 1e-7: nearly Hertzian (the adhesive load is 4e-5
    # of the load), so the contact keeps its shape while the load relaxes; the approach at
    # V_z = 1e4 takes 0.14 tau, nearly a step: held at constant depth, the stress relaxes
    # towards the relaxed state with exp(-t/tau) (measured within 2.3e-6 of the amplitude)
    groups = dict(modulus_ratio=0.5, adhesion=1e-7, maugis=0.3, velocity=1e4)
    text = (
        case_text("nx = 2048", **groups)
        + "\n[[protocol]]\napproach = 0.03\n[[protocol]]\ndwell = 6.0\n"
    )
    records, _, sim = records_of(text)
    time, load, segment = columns(records, "time", "load", "segment")
    relaxed = Retraction(
        parse_case(case_text("nx = 2048", **groups)), MPI.COMM_SELF, planner_effort="FFTW_ESTIMATE"
    )
    try:
        relaxed_load = relaxed.preload().load  # the relaxed equilibrium at h0 = 0.03 R
    finally:
        relaxed.close()
    dwell = np.flatnonzero(segment == 1)
    start = dwell[0] - 1  # the approach's last step: the dwell's start
    assert time[dwell[-1]] == pytest.approx(time[start] + 6.0, rel=1e-12)
    amplitude = load[start] - relaxed_load
    assert amplitude > 0.4 * relaxed_load  # a real relaxation: 0.95 of the relaxed load
    expected = relaxed_load + amplitude * np.exp(-(time[dwell] - time[start]))
    assert np.max(np.abs(load[dwell] - expected)) < 2e-5 * amplitude


def test_load_control_lets_go_at_the_baney_hui_minimum():
    # drive_stiffness = 0: from the preload the applied load falls at 1e-3 E0 R / tau until
    # the indenter flies off; elastic, nx = 4096 (w/dx = 6)
    text = (
        case_text("nx = 4096", modulus_ratio=1.0, drive_stiffness=0)
        + "\n[[protocol]]\nretract = -inf\nload_rate = 1e-3\n"
    )
    case = parse_case(text)
    records, _, sim = records_of(text)
    load, applied, a, z = columns(records, "load", "drive", "contact_half_width", "indenter")
    attached = a > 0
    assert not attached[-1] and attached[:-1].all()  # one jump: off, at the end
    # the load follows the applied load to the balance's tolerance (0.1 load allowances)
    # away from the fold; within 1 % of the minimum load the balance may end on a bracket
    # narrower than the load's travel (the discrete curve's jumps, runs/drive.py), and the
    # imbalance is held to the load allowance there (over 20 draws of round-off: at most
    # 1.00 tolerances away from the fold, up to 4.2 within 0.4 % of the minimum)
    tolerance = 0.1 * case.numerics.load_tolerance * case.load_scale
    imbalance = np.abs(load[attached] - applied[attached])
    fold = load[attached] - load.min() <= 1e-2 * abs(load.min())
    assert np.max(imbalance[~fold]) <= 1.01 * tolerance
    assert np.max(imbalance[fold]) <= 10.0 * tolerance
    assert z[attached][-1] - z[0] > 0.03  # the indenter rose from the preload's -0.03 R
    abar = np.linspace(0.3, 3.0, 2701)
    curve = np.array([theory.maugis_dugdale(x, 3.5)[0] for x in abar])
    curve *= theory.periodic_load_factor(abar * case.beta, case.cell)
    # within the 1 % the elastic curve keeps on this grid (measured 0.40 %)
    assert abs(load.min() / case.load_scale / curve.min() - 1.0) < 1e-2


def test_cycles_in_the_file_and_info(tmp_path):
    # two approach-retract cycles of the SLS (V_z = 10), a short dwell detached between
    # them: the series' segments, the cycles' pull-offs and loop areas, `info`
    from hpcgfmd import open as open_result
    from hpcgfmd.runs.single_case import run_case

    protocol = (
        "\n[[protocol]]\napproach = 0.03\n[[protocol]]\nretract = inf\n"
        "[[protocol]]\ndwell = 0.5\n[[protocol]]\napproach = 0.03\n"
        "[[protocol]]\nretract = inf\n"
    )
    case = parse_case(case_text("nx = 1024", velocity=10.0) + protocol)
    path = str(tmp_path / "cycles.h5")
    run_case(case, path, MPI.COMM_SELF)
    result = open_result(path)
    s = result.series
    assert sorted(set(s.segment.tolist())) == [0, 1, 2, 3, 4]
    cycles = s.cycles()
    assert [c.index for c in cycles] == [0, 1]
    assert cycles[0].first == 0 and cycles[1].first == cycles[0].last + 1
    assert cycles[1].last == s.time.size - 1
    for c in cycles:
        steps = slice(c.first, c.last + 1)
        assert c.pull_off == s.load[steps].min() < 0
        assert c.work > 0.0  # a closed viscoelastic loop dissipates
    # the dwell between the cycles: detached, the drive held
    dwell = s.segment == 2
    assert np.all(s.contact_half_width[dwell] == 0) and np.ptp(s.indenter[dwell]) == 0
    out = subprocess.run(
        [sys.executable, "-m", "hpcgfmd", "info", path], capture_output=True, text=True, check=True
    ).stdout
    assert "protocol: approach, retract, dwell, approach, retract" in out
    lines = [line for line in out.splitlines() if line.startswith("cycle ")]
    assert len(lines) == 2 and f"{cycles[1].work:.6g}" in lines[1]
    # the second cycle starts while the substrate still recovers from the first: another
    # pull-off (measured -0.0134 and -0.0152 E0 R)
    assert cycles[1].pull_off < cycles[0].pull_off


@pytest.mark.parametrize(
    "protocol, message",
    [
        ("[[protocol]]\nhold = 1.0\n", r"^\[\[protocol\]\] 1: no kind: expected exactly one of"),
        ("[[protocol]]\ndwell = 1.0\nretract = inf\n", r"^\[\[protocol\]\] 1: dwell, retract:"),
        ("[[protocol]]\ndwell = -1.0\n", r"^\[\[protocol\]\] 1 dwell = -1.0: expected a duration"),
        (
            "[[protocol]]\ndwell = 1.0\n[[protocol]]\napproach = inf\n",
            r"^\[\[protocol\]\] 2 approach = inf: expected a finite number$",
        ),
        ("[[protocol]]\nretract = -inf\n", r"retract = -inf: expected a finite number or inf"),
        ("[[protocol]]\nretract = 0.1\nvelocity = 0\n", r"velocity = 0: expected a finite number"),
        (
            "[[protocol]]\nretract = 0.1\nload_rate = 1\n",
            r"load_rate: not accepted with retract"
            r" \(load_rate needs drive_stiffness = 0",
        ),
        ("[[protocol]]\ndwell = 1\nvelocity = 1\n", r"velocity: not accepted with dwell"),
        ("protocol = 3\n", r"^protocol = 3: expected \[\[protocol\]\] tables"),
    ],
)
def test_bad_protocols_are_named(protocol, message):
    with pytest.raises(CaseError, match=message):
        parse_case(
            protocol + case_text()
            if protocol.startswith("protocol")
            else case_text() + "\n" + protocol
        )


@pytest.mark.parametrize(
    "protocol, message",
    [
        ("", r"^\[case\] drive_stiffness = 0: load control needs a \[\[protocol\]\]"),
        ("[[protocol]]\nretract = -inf\n", r"load_rate is missing: under load control"),
        (
            "[[protocol]]\nretract = -0.001\nvelocity = 1\nload_rate = 1e-3\n",
            r"velocity: not accepted with retract \(load control moves the load",
        ),
        ("[[protocol]]\napproach = 0.01\nload_rate = 1e-3\n", r"approach: under load control"),
        (
            "[[protocol]]\nretract = -inf\nload_rate = 1e-3\n[[protocol]]\ndwell = 1\n",
            r"retract = -inf: under load control a retraction until detachment must be the last",
        ),
    ],
)
def test_bad_load_control_protocols_are_named(protocol, message):
    with pytest.raises(CaseError, match=message):
        parse_case(case_text(drive_stiffness=0) + "\n" + protocol)


def test_protocol_units_and_identity():
    case = parse_case(
        case_text() + CYCLE.replace("dwell = 1.0", "dwell = 1.0\n") + "velocity = 2.0\n"
    )
    approach, dwell, retract = case.protocol
    assert approach.target == -0.03 and approach.rate == case.indenter_speed
    assert dwell.target == 1.0 and retract.rate == 2.0 * case.adhesion ** (2.0 / 3.0)
    assert case.identity() != parse_case(case_text()).identity()
    assert parse_case(case.text).identity() == case.identity()
    physical = parse_case(
        PHYSICAL + "\n[[protocol]]\napproach = 1e-5\nvelocity = 1e-6\n"
        "[[protocol]]\ndwell = 2.0\n[[protocol]]\nretract = inf\n"
    )
    approach, dwell, _ = physical.protocol
    assert approach.target == pytest.approx(-1e-5 / 1e-3, rel=1e-15)  # in R = 1 mm
    assert approach.rate == pytest.approx(1e-6 * 1.0 / 1e-3, rel=1e-15)  # R / tau, tau = 1 s
    assert dwell.target == 2.0


def test_a_sweep_over_protocols():
    from hpcgfmd.runs.sweep import parse_sweep

    sweep = parse_sweep(
        case_text(prefix="base.")
        + """
[[cases]]
protocol = [{approach = 0.03}, {retract = inf}]
[[cases]]
protocol = [{approach = 0.03}, {dwell = 2.0}, {retract = inf}]
"""
    )
    assert [len(c.case.protocol) for c in sweep.cases] == [2, 3]
    assert sweep.cases[1].name == "protocol_approach_0.03_dwell_2.0_retract_inf"
    assert math.isinf(sweep.cases[0].case.protocol[-1].target)


def test_a_segment_starts_with_the_linear_step():
    """The quadratic step (M46) spans the step before: across a segment's start the drive's
    kink is no curvature, so each segment's first step is the linear one (M8), exact for a
    drive linear within the step, and the history estimate's window does not span the kink
    either (no estimate, no correction on a segment's first step)."""
    case = parse_case(case_text("nx = 1024", modulus_ratio=0.5, velocity=1.0) + CYCLE)
    sim = Retraction(case, MPI.COMM_SELF, planner_effort="FFTW_ESTIMATE")
    try:
        segments, quadratic, estimated = [sim.preload().segment], [False], [False]
        while not sim.finished():
            segments.append(sim.step().segment)
            quadratic.append(sim.substrate.last_step_quadratic)
            estimated.append(sim.window.error.has_previous)
    finally:
        sim.close()
    steps = range(1, len(segments))
    first = [i for i in steps if i == 1 or segments[i] != segments[i - 1]]
    assert [segments[i] for i in first] == [0, 1, 2]
    assert not any(quadratic[i] or estimated[i] for i in first)
    assert all(quadratic[i] and estimated[i] for i in steps if i not in first)
