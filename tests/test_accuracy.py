"""The accuracy knob's grid (hpcgfmd.model.accuracy): the creep factor, and a creeping
retraction run at the default accuracy against a converged run of the same case."""
import math

import pytest

from hpcgfmd.model import accuracy
from hpcgfmd.model.grid import grid_label, smallest_grid
from hpcgfmd.errors import CaseError
from hpcgfmd.case import parse_case

from cases import case_text, pull_off_run

# lambda0 = 1, k = 0.1, V_z = 0.1 (chi_ve / k = 1) at h0/R = 0.1, L = 8 sqrt(2 R h0): a
# creeping retraction, whose pull-off was 7.2e-3 off on the elastic law's grid (w/dx = 4.1)
CREEPING = dict(maugis=1.0, modulus_ratio=0.1, velocity=0.1, depth=0.1, cell=3.578,
                adhesion=5e-5)

def test_creep_factor_leaves_elastic_and_fast_retractions_alone():
    assert accuracy.creep_factor(0.1, 1.0) == 1.0  # the elastic solid: no rate
    assert accuracy.creep_factor(441.0, 0.1) == 1.0  # lambda0 = 7, V_z = 9
    assert accuracy.creep_factor(2.21, 0.1) == 1.0  # lambda0 = 7, V_z = 0.045: chi/k = 22
    # chi_ve / k = 1: 20^(1/3) more points; slower: at most 3 times (nothing measured there)
    assert accuracy.creep_factor(0.1, 0.1) == pytest.approx(20 ** (1 / 3))
    assert accuracy.creep_factor(0.01, 0.1) == 3.0

def test_fast_widening_resolves_a_glassy_tip_s_wider_zone():
    assert accuracy.fast_widening(441.0, 1.0, 7.0) == 1.0  # the elastic solid
    assert accuracy.fast_widening(1.5, 0.1, 7.0) == 1.0  # creeping: chi_ve / k = 15
    # the default case, chi_ve / k = 220.5: (220.5 / 20)^(1/3)
    assert accuracy.fast_widening(22.05, 0.1, 7.0) == pytest.approx(11.025 ** (1 / 3))
    assert accuracy.fast_widening(441.0, 0.1, 7.0) == pytest.approx(220.5 ** (1 / 3))  # V_z = 9
    assert accuracy.fast_widening(1e5, 0.1, 7.0) == 10.0  # the glassy w / k
    assert accuracy.fast_widening(1e4, 0.5, 7.0) == 2.0  # never wider than the glassy w / k
    # a DMT-like glassy tip (lambda0 k^(2/3) = 0.16 and 0.046): the relaxed zone
    assert accuracy.fast_widening(122.5, 0.01, 3.5) == 1.0
    assert accuracy.fast_widening(100.0, 0.01, 1.0) == 1.0


def test_fast_grid_resolves_the_zone_over_the_widening():
    # lambda0 = 7, V_z = 4.5: (220.5 / 2)^(1/3) = 4.79 times fewer points across w than the
    # elastic law's (9x2^13 without the widening)
    case = parse_case(case_text("accuracy = 5e-3", maugis=7.0, modulus_ratio=0.1,
                                velocity=4.5, depth=0.1, cell=10.0, adhesion=5e-5))
    points = case.zone_width / case.dx
    want = accuracy.zone_points(5e-3) / 110.25 ** (1 / 3)
    assert want <= points < 2 * want and case.numerics.nx == 16384
    assert accuracy.zone_points(5e-3, case.chi_ve, case.modulus_ratio, case.maugis,
                                widen=False) == accuracy.zone_points(5e-3)


def test_a_given_grid_must_resolve_the_widened_zone():
    # lambda0 = 14, V_z = 0.9 (widening 4.45): the knob's 2^16 nodes hold 0.96 points
    # across the relaxed w, 4.3 across the widened zone; a given nx is held to one point
    # across the latter, as the knob's grids resolve it
    groups = dict(maugis=14.0, modulus_ratio=0.1, velocity=0.9, depth=0.1, cell=10.0,
                  adhesion=5e-5)
    chosen = parse_case(case_text("accuracy = 5e-3", **groups))
    assert chosen.numerics.nx == 65536 and 0.9 < chosen.zone_width / chosen.dx < 1.0
    assert parse_case(case_text("nx = 65536", **groups)).dx == chosen.dx
    widened = chosen.zone_width * accuracy.fast_widening(chosen.chi_ve, 0.1, 14.0)
    floor = 2 * math.ceil(10.0 / widened / 2)
    parse_case(case_text(f"nx = {floor}", **groups))
    with pytest.raises(CaseError, match=f"nx = {floor - 2}: .* at least 1 .*nx >= {floor}"):
        parse_case(case_text(f"nx = {floor - 2}", **groups))


def test_creeping_grid_resolves_the_zone_by_the_creep_factor():
    # lambda0 = 3.5, k = 0.2, V_z = 0.01 (chi_ve / k = 0.6: the creep factor's cap)
    case = parse_case(case_text("accuracy = 5e-3", maugis=3.5, modulus_ratio=0.2,
                                velocity=0.01, depth=0.1, cell=3.578, adhesion=5e-5))
    points = case.zone_width / case.dx
    want = accuracy.zone_points(5e-3) * accuracy.creep_factor(case.chi_ve, case.modulus_ratio)
    assert want <= points < 4 / 3 * want
    assert points > 2 * accuracy.zone_points(5e-3)  # finer than the elastic law's grid


def test_grid_resolves_the_contact_where_the_zone_is_wide():
    # lambda0 = 1 at h0/R = 0.02: w is a seventh of sqrt(2 R h0), and the zone's grid (2^8
    # nodes for its 3.8 points across w at 1e-2) leaves 32 nodes across it
    case = parse_case(case_text("accuracy = 1e-2", maugis=1.0, modulus_ratio=0.1,
                                velocity=1.0, depth=0.02, cell=1.6, adhesion=5e-5))
    across = math.sqrt(2.0 * case.depth) / case.dx
    want = accuracy.contact_points(1e-2)
    assert want <= across < 4 / 3 * want and case.numerics.nx == 1536
    assert case.zone_width / case.dx > 5 * accuracy.zone_points(1e-2)
    # where the zone sets the grid the contact rule changes nothing (the paper's cases)
    fast = parse_case(case_text("accuracy = 1e-3", maugis=7.0, modulus_ratio=0.1,
                                velocity=9.0, depth=0.1, cell=10.0, adhesion=5e-5))
    assert math.sqrt(2.0 * fast.depth) / fast.dx > accuracy.contact_points(1e-3)
    assert fast.numerics.nx == 49152


def test_load_area_curve_meets_the_accuracy_where_the_contact_sets_the_grid():
    # The curve error (docs/numerics.md, "The accuracy knob") of the case above at 1e-2
    # against a run at 1e-3 (10.7 times the nodes; its own curve error 1.1e-4 against a 2e-4
    # run, docs/results.md): measured 1.2e-3 on the knob's grid, 3.0e-2 on the zone's
    # grid alone (2^8 nodes), where the contact edge sticks to a node and then jumps one.
    from mpi4py import MPI

    from hpcgfmd.studies import benchmark

    def curve(numerics):
        return benchmark.run(case_text(numerics, maugis=1.0, modulus_ratio=0.1, velocity=1.0,
                                       depth=0.02, cell=1.6, adhesion=5e-5), MPI.COMM_SELF)

    reference = curve("accuracy = 1e-3")
    assert benchmark.curve_error(reference, curve("accuracy = 1e-2")) <= 1e-2 / 4
    assert benchmark.curve_error(reference, curve("accuracy = 1e-2\nnx = 256")) > 2e-2


@pytest.mark.slow
def test_creeping_retraction_meets_the_default_accuracy():
    # The pull-off at the default accuracy (its grid chosen by the knob) against a converged
    # run: accuracy 5e-4 on a grid four times finer. Measured 1.0e-3 on the knob's grid
    # (3072 nodes, set by the contact; 7.2e-3 on the grid of the elastic law alone,
    # docs/results.md, "The accuracy knob").
    run, _ = pull_off_run(case_text("accuracy = 5e-3", **CREEPING))
    nx = parse_case(case_text("accuracy = 5e-3", **CREEPING)).numerics.nx
    converged, _ = pull_off_run(case_text(f"accuracy = 5e-4\nnx = {4 * nx}", **CREEPING))
    assert abs(run / converged - 1) <= 5e-3


def test_automatic_grid_sizes_are_the_smallest_of_their_family():
    sizes = sorted({f * 2**a for f in (1, 3, 9) for a in range(1, 90)})
    for need in (1, 63, 64, 65, 72, 73, 96, 97, 69587.6, 131072, 131073, 2.0**80):
        want = min(s for s in sizes if s >= max(need, 64))
        assert smallest_grid(math.log2(need)) == want, need
    assert [grid_label(n) for n in (131072, 73728, 98304, 100)] == [
        "2^17", "9x2^13", "3x2^15", "100"]


def test_study_references_skip_the_widening_and_runs_are_reused_by_their_code_only(
        tmp_path, monkeypatch):
    import numpy as np
    from mpi4py import MPI

    from hpcgfmd.studies import accuracy_study, benchmark

    spec = (7.0, 0.1, 4.5, 0.1)  # a fast case: its own grid widened 3 times
    reference = parse_case(accuracy_study.reference_text(spec, 1e-3, None, 5e-5))
    assert reference.zone_width / reference.dx >= accuracy.zone_points(1e-3)
    widened = parse_case(accuracy_study.case_text(spec, 1e-3, None, 5e-5))
    assert reference.numerics.nx > 2 * widened.numerics.nx
    made = []

    def fake_run(text, comm, progress=None):
        made.append(text)
        return {**{key: np.zeros(2) for key in ("time", "lbar", "abar", "dt")},
                **{key: 0.0 for key in benchmark.SCALARS}}

    monkeypatch.setattr(benchmark, "run", fake_run)
    text = accuracy_study.case_text(spec, 5e-3, None, 5e-5)
    accuracy_study._cached(text, MPI.COMM_SELF, str(tmp_path), "one code")
    accuracy_study._cached(text, MPI.COMM_SELF, str(tmp_path), "one code")  # saved: reused
    assert len(made) == 1
    accuracy_study._cached(text, MPI.COMM_SELF, str(tmp_path), "another code")  # run anew
    assert len(made) == 2


def test_a_study_keys_its_runs_by_the_code_it_started_with(tmp_path, monkeypatch):
    # the sources change while a study runs (every identity asked for differs): each run is
    # still made once, and the table is assembled from those runs, not from new ones
    import numpy as np
    from mpi4py import MPI

    from hpcgfmd.studies import accuracy_study, benchmark

    made = []

    def fake_run(text, comm, progress=None):
        made.append(text)
        return {"time": np.array([0.0, 1.0]), "lbar": np.array([-1.0, -2.0]),
                "abar": np.array([2.0, 1.0]), "dt": np.ones(2),
                **{key: 0.0 for key in benchmark.SCALARS}}

    versions = iter(range(100))
    monkeypatch.setattr(benchmark, "run", fake_run)
    monkeypatch.setattr(benchmark, "code_identity", lambda: f"code {next(versions)}")
    argv = ["--out", str(tmp_path / "study"), "--cases", "1:0.1:1:0.02", "--accuracies", "1e-2"]
    assert accuracy_study.main(MPI.COMM_SELF, argv) == 0
    assert len(made) == 2  # the reference and the run at 1e-2
