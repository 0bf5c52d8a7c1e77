"""The accuracy knob's grid (hpcgfmd.model.accuracy): the grid a case gets against the error
model the knob inverts, evaluated forward (docs/numerics.md, "The accuracy knob"); the creep
factor and the fast widening where the two regimes meet and at the glassy zone's width; and
runs at an accuracy against converged runs of the same case (the laws' own reference: their
constants are measured, docs/results.md)."""

import math

import numpy as np
import pytest

from cases import case_text, pull_off_run
from hpcgfmd.case import parse_case
from hpcgfmd.errors import CaseError
from hpcgfmd.model import accuracy, theory
from hpcgfmd.model.grid import grid_label, smallest_grid

# lambda0 = 1, k = 0.1, V_z = 0.1 (chi_ve / k = 1) at h0/R = 0.1, L = 8 sqrt(2 R h0): a
# creeping retraction, whose pull-off was 7.2e-3 off on the elastic law's grid (w/dx = 4.1)
CREEPING = dict(maugis=1.0, modulus_ratio=0.1, velocity=0.1, depth=0.1, cell=3.578, adhesion=5e-5)
# every size the knob may choose, f 2^a with f = 1, 3, 9 (hpcgfmd.model.grid)
SIZES = sorted({f * 2**a for f in (1, 3, 9) for a in range(1, 40)})


def predicted_errors(case, nx):
    """The error model the knob inverts, evaluated forward on an nx grid (docs/numerics.md,
    "The accuracy knob"): the grid's pull-off error GRID_ERROR (dx / w)^GRID_ORDER, w/dx
    taken over the creep factor and times the fast widening; the contact's staircase
    CONTACT_ERROR dx / sqrt(2 R h0) in the load-area curve; and a widened grid's relaxed
    start, C (dx / w)^RELAXED_ORDER with C = relaxed_error(lambda0), unless the unwidened
    grid is coarser than that floor (0 then, and 0 for a grid that is not widened)."""
    dx = case.cell / nx
    widening = accuracy.fast_widening(case.chi_ve, case.modulus_ratio, case.maugis)
    creep = accuracy.creep_factor(case.chi_ve, case.modulus_ratio)
    points = case.zone_width / dx * widening / creep
    floored = widening > 1.0 and accuracy.relaxed_points(
        case.numerics.accuracy, case.maugis
    ) < accuracy.zone_points(case.numerics.accuracy, case.chi_ve, case.modulus_ratio, widen=False)
    relaxed = accuracy.relaxed_error(case.maugis) * (dx / case.zone_width) ** accuracy.RELAXED_ORDER
    return (
        accuracy.GRID_ERROR * points**-accuracy.GRID_ORDER,
        accuracy.CONTACT_ERROR * dx / math.sqrt(2.0 * case.depth),
        relaxed if floored else 0.0,
    )


def assert_smallest_grid_meeting_the_shares(case):
    """The knob's nx meets the grid's, the contact's and the relaxed start's shares of the
    accuracy, and the next smaller size does not; returns (zone, contact, relaxed start):
    which of them the next smaller size misses."""
    knob, nx = case.numerics.accuracy, case.numerics.nx
    assert case.numerics.nx_automatic and nx in SIZES
    shares = (
        accuracy.GRID_SHARE * knob,
        accuracy.CONTACT_SHARE * knob,
        accuracy.RELAXED_SHARE * knob,
    )
    errors = predicted_errors(case, nx)
    assert all(error <= share * (1 + 1e-12) for error, share in zip(errors, shares)), errors
    smaller = max(size for size in SIZES if size < nx)
    missed = tuple(error > share for error, share in zip(predicted_errors(case, smaller), shares))
    assert any(missed), (nx, smaller)
    return missed


def test_creep_factor_and_fast_widening_meet_continuously_where_the_regimes_meet():
    assert accuracy.creep_factor(0.1, 1.0) == 1.0  # the elastic solid: no rate
    assert accuracy.fast_widening(441.0, 1.0, 7.0) == 1.0
    for k in (0.01, 0.1, 0.5):
        lambda0 = 2.0 / k ** (2 / 3)  # a JKR-like glassy tip, lambda_inf = 2
        chi = k * np.logspace(-4, 6, 401)  # chi_ve / k from 1e-4 to 1e6
        creep = np.array([accuracy.creep_factor(c, k) for c in chi])
        widening = np.array([accuracy.fast_widening(c, k, lambda0) for c in chi])
        # a retraction creeps (more points across w) or is fast (a wider zone), never both
        assert np.all((creep == 1.0) | (widening == 1.0))
        assert creep[0] > 1.0 and widening[-1] > 1.0
        # the slower, the more points; the faster, the wider the zone
        assert np.all(np.diff(creep) <= 0.0) and np.all(np.diff(widening) >= 0.0)
        # and the two meet continuously (both 1) where the regimes meet
        meet = accuracy.CREEP_RATE * k
        assert accuracy.creep_factor(meet * (1 - 1e-9), k) == pytest.approx(1.0, abs=1e-9)
        assert accuracy.fast_widening(meet * (1 + 1e-9), k, lambda0) == pytest.approx(1.0, abs=1e-9)
        # at most CREEP_CAP times the points, reached by the slowest
        assert creep.max() == accuracy.CREEP_CAP


def test_the_fast_widening_is_at_most_the_glassy_zone():
    # The zone is as wide as the modulus the tip sees (M23): the glassy tip's, of lambda_inf
    # = lambda0 k^(2/3) ((M20) with Einf, (M21)) on beta_inf = k^(1/3) beta, is 1/k times
    # the relaxed one. The fastest retractions reach it.
    for k, lambda0 in ((0.5, 7.0), (0.1, 7.0), (0.01, 30.0)):
        glassy = (
            k ** (1 / 3)
            * theory.cohesive_width(lambda0 * k ** (2 / 3))
            / theory.cohesive_width(lambda0)
        )
        assert accuracy.fast_widening(1e12, k, lambda0) == pytest.approx(glassy, rel=1e-12)
        assert 1.0 < accuracy.fast_widening(100 * accuracy.CREEP_RATE * k, k, lambda0) <= glassy
    # a creeping retraction and the paper's default case (chi_ve / k = 15, 220.5)
    assert accuracy.fast_widening(1.5, 0.1, 7.0) == 1.0
    assert accuracy.fast_widening(22.05, 0.1, 7.0) > 1.0
    # a DMT-like glassy tip (lambda0 k^(2/3) = 0.16 and 0.046): the relaxed zone
    assert accuracy.fast_widening(122.5, 0.01, 3.5) == 1.0
    assert accuracy.fast_widening(100.0, 0.01, 1.0) == 1.0


def test_fast_grid_resolves_the_zone_over_the_widening():
    # lambda0 = 7, V_z = 4.5: the widened zone sets the grid (9x2^13 without the widening)
    case = parse_case(
        case_text(
            "accuracy = 5e-3",
            maugis=7.0,
            modulus_ratio=0.1,
            velocity=4.5,
            depth=0.1,
            cell=10.0,
            adhesion=5e-5,
        )
    )
    # its relaxed start's floor sets it (1.31 points across w at 5e-3 at lambda0 <= 14; the
    # widened zone's own law asks for 0.86)
    assert assert_smallest_grid_meeting_the_shares(case) == (False, False, True)
    relaxed = parse_case(
        case_text(
            "accuracy = 5e-3",
            maugis=7.0,
            modulus_ratio=1.0,
            velocity=4.5,
            depth=0.1,
            cell=10.0,
            adhesion=5e-5,
        )
    )
    assert relaxed.numerics.nx == 3 * case.numerics.nx
    assert accuracy.zone_points(
        5e-3, case.chi_ve, case.modulus_ratio, case.maugis, widen=False
    ) == accuracy.zone_points(5e-3)


def test_a_given_grid_must_resolve_the_widened_zone():
    # lambda0 = 14, V_z = 0.9 (widening 4.45): the knob's 3x2^15 nodes hold 1.45 points
    # across the relaxed w (its floor at 5e-3: 1.31), 6.5 across the widened zone; a given
    # nx is held to one point across the latter, as the knob's grids resolve it
    groups = dict(maugis=14.0, modulus_ratio=0.1, velocity=0.9, depth=0.1, cell=10.0, adhesion=5e-5)
    chosen = parse_case(case_text("accuracy = 5e-3", **groups))
    assert chosen.numerics.nx == 98304 and 1.31 < chosen.zone_width / chosen.dx < 1.5
    assert parse_case(case_text("nx = 98304", **groups)).dx == chosen.dx
    widened = chosen.zone_width * accuracy.fast_widening(chosen.chi_ve, 0.1, 14.0)
    floor = 2 * math.ceil(10.0 / widened / 2)
    parse_case(case_text(f"nx = {floor}", **groups))
    with pytest.raises(CaseError, match=f"nx = {floor - 2}: .* at least 1 .*nx >= {floor}"):
        parse_case(case_text(f"nx = {floor - 2}", **groups))


def test_creeping_grid_resolves_the_zone_by_the_creep_factor():
    # lambda0 = 3.5, k = 0.2, V_z = 0.01 (chi_ve / k = 0.6: the creep factor's cap, 3): the
    # zone sets the grid, with more than twice the points of the same case's elastic grid
    groups = {"maugis": 3.5, "velocity": 0.01, "depth": 0.1, "cell": 3.578, "adhesion": 5e-5}
    case = parse_case(case_text("accuracy = 5e-3", modulus_ratio=0.2, **groups))
    assert assert_smallest_grid_meeting_the_shares(case) == (True, False, False)
    elastic = parse_case(case_text("accuracy = 5e-3", modulus_ratio=1.0, **groups))
    assert case.zone_width / case.dx > 2 * elastic.zone_width / elastic.dx


def test_grid_resolves_the_contact_where_the_zone_is_wide():
    # lambda0 = 1 at h0/R = 0.02: w is a seventh of sqrt(2 R h0); the contact sets the grid,
    # and the zone's predicted error is a thirtieth of its share there (over 5 times its
    # points across w)
    case = parse_case(
        case_text(
            "accuracy = 1e-2",
            maugis=1.0,
            modulus_ratio=0.1,
            velocity=1.0,
            depth=0.02,
            cell=1.6,
            adhesion=5e-5,
        )
    )
    assert assert_smallest_grid_meeting_the_shares(case) == (False, True, False)
    assert predicted_errors(case, case.numerics.nx)[0] < accuracy.GRID_SHARE * 1e-2 / 30
    # where the zone sets the grid the contact rule changes nothing: the paper's lambda0 = 7
    # at h0/R = 0.1, slow at 1e-3 (the zone) and fast at 5e-3 and 1e-3 (its zone widened 6
    # times: the relaxed start's floor)
    for velocity, knob, sets_it in (
        (0.045, 1e-3, (True, False, False)),
        (9.0, 5e-3, (False, False, True)),
        (9.0, 1e-3, (False, False, True)),
    ):
        paper = parse_case(
            case_text(
                f"accuracy = {knob}",
                maugis=7.0,
                modulus_ratio=0.1,
                velocity=velocity,
                depth=0.1,
                cell=10.0,
                adhesion=5e-5,
            )
        )
        assert assert_smallest_grid_meeting_the_shares(paper) == sets_it, (velocity, knob)


@pytest.mark.parametrize("knob", [1e-2, 5e-3, 1e-3])
def test_automatic_nx_is_the_smallest_grid_size_meeting_the_grid_s_share(knob):
    # an elastic lambda = 7 case (the command line's tests' own): the zone sets the grid
    case = parse_case(case_text(f"accuracy = {knob}", maugis=7.0, modulus_ratio=1.0))
    assert assert_smallest_grid_meeting_the_shares(case)[0]


def test_finer_accuracy_asks_for_more_work():
    coarse, fine = (
        parse_case(case_text(f"accuracy = {a}", maugis=1.0, modulus_ratio=1.0)).numerics
        for a in (1e-2, 1e-3)
    )
    assert fine.nx > coarse.nx
    assert fine.edge_fraction < coarse.edge_fraction
    assert fine.load_tolerance < coarse.load_tolerance
    assert fine.time_tolerance < coarse.time_tolerance
    assert fine.tolerance < coarse.tolerance


def test_load_area_curve_meets_the_accuracy_where_the_contact_sets_the_grid():
    # The curve error (docs/numerics.md, "The accuracy knob") of the case above at 1e-2
    # against a run at 1e-3 (10.7 times the nodes; its own curve error 1.1e-4 against a 2e-4
    # run, docs/results.md): measured 1.2e-3 on the knob's grid, 3.0e-2 on the zone's
    # grid alone (2^8 nodes), where the contact edge sticks to a node and then jumps one.
    from mpi4py import MPI

    from hpcgfmd.studies import benchmark

    def curve(numerics):
        return benchmark.run(
            case_text(
                numerics,
                maugis=1.0,
                modulus_ratio=0.1,
                velocity=1.0,
                depth=0.02,
                cell=1.6,
                adhesion=5e-5,
            ),
            MPI.COMM_SELF,
        )

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
        "2^17",
        "9x2^13",
        "3x2^15",
        "100",
    ]


def test_study_references_skip_the_widening_and_runs_are_reused_by_their_code_only(
    tmp_path, monkeypatch
):
    import numpy as np
    from mpi4py import MPI

    from hpcgfmd.studies import accuracy_study, benchmark

    spec = (7.0, 0.1, 4.5, 0.1)  # a fast case: its own grid widened to the relaxed floor
    reference = parse_case(accuracy_study.reference_text(spec, 1e-3, None, 5e-5))
    assert reference.zone_width / reference.dx >= accuracy.zone_points(1e-3)
    widened = parse_case(accuracy_study.case_text(spec, 1e-3, None, 5e-5))
    assert reference.numerics.nx > widened.numerics.nx
    assert widened.zone_width / widened.dx >= accuracy.relaxed_points(1e-3, 7.0)
    # on the knob's own grid when asked (--reference-widened)
    assert accuracy_study.reference_text(
        spec, 1e-3, None, 5e-5, widened=True
    ) == accuracy_study.case_text(spec, 1e-3, None, 5e-5)
    made = []

    def fake_run(text, comm, progress=None):
        made.append(text)
        return {
            **{key: np.zeros(2) for key in ("time", "lbar", "abar", "dt")},
            **{key: 0.0 for key in benchmark.SCALARS},
        }

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
        return {
            "time": np.array([0.0, 1.0]),
            "lbar": np.array([-1.0, -2.0]),
            "abar": np.array([2.0, 1.0]),
            "dt": np.ones(2),
            **{key: 0.0 for key in benchmark.SCALARS},
        }

    versions = iter(range(100))
    monkeypatch.setattr(benchmark, "run", fake_run)
    monkeypatch.setattr(benchmark, "code_identity", lambda: f"code {next(versions)}")
    argv = ["--out", str(tmp_path / "study"), "--cases", "1:0.1:1:0.02", "--accuracies", "1e-2"]
    assert accuracy_study.main(MPI.COMM_SELF, argv) == 0
    assert len(made) == 2  # the reference and the run at 1e-2


@pytest.mark.parametrize("maugis", [1.0, 7.0])
def test_the_sphere_study_s_cell_holds_its_preload_s_zone(maugis):
    # a sphere's cell: the least whose relaxed preload's cohesive zone (Maugis-Dugdale in the
    # cell, (M56), (M59)) reaches 0.23 L, rounded up to 1e-3 R, at least the least a case
    # accepts (6 sqrt(2 h0/R) = 0.8485 at h0/R = 0.01); a run of the case (n = 256 at 1e-2,
    # lambda0 = 1, the widest zone) is not refused (its zone beyond 0.25 L: a CaseError)
    from hpcgfmd.model import sphere_theory
    from hpcgfmd.studies import accuracy_study

    spec = (maugis, 1.0, 1.0, 0.01)
    case = parse_case(accuracy_study.case_text(spec, 1e-2, None, 1e-3, sphere=True))
    assert case.cell >= 6 * math.sqrt(0.02)

    def zone_share(cell):
        H0, L = case.depth / case.depth_scale, cell / case.beta
        return sphere_theory.preload_in_cell(H0, L, maugis)[1] * case.beta / cell

    assert zone_share(case.cell) <= 0.23
    assert zone_share(case.cell - 1e-3) > 0.23 or case.cell - 1e-3 < 6 * math.sqrt(0.02)
    if maugis == 1.0:
        import hpcgfmd

        hpcgfmd.run(case, planner_effort="FFTW_ESTIMATE")


def test_the_sphere_study_s_case_texts():
    # --geometry sphere: the case carries the sphere and its cell; the knob picks n; a
    # reference names its unwidened grid n (a fast lambda0 = 7 at 1e-3: 4096, twice the
    # widened knob's)
    from hpcgfmd.case.numerics import automatic_nx
    from hpcgfmd.studies import accuracy_study

    spec = (7.0, 0.1, 10.0, 0.01)
    text = accuracy_study.case_text(spec, 1e-3, None, 1e-3, sphere=True)
    case = parse_case(text)
    cell = accuracy_study.default_cell(spec, 1e-3, sphere=True)
    assert 'geometry = "sphere"' in text and case.sphere and case.cell == cell
    n = case.numerics.nx
    assert case.numerics.nx_automatic and case.numerics.shape == (n, n)
    assert n * math.sqrt(case.depth) / case.cell >= accuracy.sphere_contact_points(1e-3)
    reference = accuracy_study.reference_text(spec, 1e-3, None, 1e-3, sphere=True)
    unwidened = automatic_nx(case, 1e-3, widen=False)
    assert f"n = {unwidened}" in reference and unwidened == 2 * n == 4096
    assert parse_case(reference).numerics.shape == (unwidened, unwidened)
    # the cylinder's texts are as before: no geometry key, L = 8 sqrt(2 h0/R)
    cylinder = accuracy_study.case_text(spec, 1e-3, None, 5e-5)
    assert "geometry" not in cylinder and parse_case(cylinder).cell == 1.131


def test_the_sphere_study_judges_an_elastic_run_against_maugis_dugdale_in_its_cell(tmp_path):
    # The elastic sphere at lambda0 = 1 (n = 256 at 1e-2) against the Maugis-Dugdale sphere in
    # its cell (M56), (M59): the pull-off of the table is the run's against the curve's least
    # force, computed here from the theory apart, and both errors are within the accuracy
    # (measured: pull-off 8.6e-5, load-depth curve 4.6e-4 off; the table's curve, drawn at 1201
    # radii, has its least force within 1e-6 of this one's)
    from mpi4py import MPI

    from hpcgfmd.model import sphere_theory
    from hpcgfmd.studies import accuracy_study

    out = tmp_path / "sphere"
    argv = ["--geometry", "sphere", "--out", str(out), "--cases", "1:1:1:0.01"]
    assert accuracy_study.main(MPI.COMM_SELF, [*argv, "--accuracies", "1e-2"]) == 0
    (row,) = accuracy_study.read_rows(f"{out}.csv")
    assert row["reference"] == "Maugis-Dugdale in the cell" and row["nx"] == 256
    case = parse_case(accuracy_study.case_text((1.0, 1.0, 1.0, 0.01), 1e-2, None, 1e-3, True))
    radii = np.linspace(0.3, 1.5, 2401)  # the load minimum near 1.1 a_s, to 1e-7
    least = sphere_theory.periodic_cell(radii, case.cell / case.beta, 1.0)[0].min()
    assert row["pulloff_error"] == pytest.approx(abs(row["pulloff_Lbar"] / least - 1), abs=1e-6)
    assert row["pulloff_error"] <= 1e-2 and row["curve_error"] <= 1e-2 and row["within"]
    table = (tmp_path / "sphere.md").read_text()
    assert "| n |" in table and "pull-off Pbar" in table


def test_the_relaxed_floor_grows_with_lambda0_over_its_measurements():
    # the widened grids' load-area curve errors at lambda0 <= 14 without the floor
    # (docs/results.md, git history: (lambda0, w/dx, curve error)), whole errors, so upper
    # bounds of the relaxed start's: the law lies above each
    for lambda0, points, error in (
        (7, 0.85, 4.0e-3),
        (7, 1.13, 4.4e-3),
        (14, 1.13, 4.3e-3),
        (14, 1.51, 3.0e-3),
    ):
        assert accuracy.relaxed_error(lambda0) * points**-accuracy.RELAXED_ORDER >= error
    # the large-lambda0 constant from lambda0 = 30 on, the low one up to 14, continuous and
    # increasing between
    low, high = accuracy.RELAXED_MAUGIS
    assert accuracy.relaxed_error(high) == accuracy.relaxed_error(1e3) == accuracy.RELAXED_ERROR
    assert accuracy.relaxed_error(low) == accuracy.relaxed_error(1.0) == accuracy.RELAXED_ERROR_LOW
    between = [accuracy.relaxed_error(v) for v in np.linspace(low, high, 50)]
    assert np.all(np.diff(between) > 0.0)
    assert between[0] == pytest.approx(accuracy.RELAXED_ERROR_LOW, rel=1e-12)
    assert between[-1] == pytest.approx(accuracy.RELAXED_ERROR, rel=1e-12)
    # the paper's fast cases keep 1.31 points across w at 5e-3 (2.05 from lambda0 = 30)
    assert accuracy.relaxed_points(5e-3, 14.0) == pytest.approx(1.31, abs=0.01)
    # never below the coarsest measured grid (0.58 points) where the large-lambda0 law keeps
    # that many: the accuracy beyond which the knob refuses a fast grid stays where it was
    assert accuracy.relaxed_points(2e-2, 7.0) == accuracy.MIN_RELAXED_POINTS
    for knob in (2e-2, 3.2e-2, 3.4e-2, 4e-2):
        refused = [
            accuracy.unvalidated(knob, 1e4, 0.1, lambda0) is not None for lambda0 in (7, 14, 30)
        ]
        assert refused == [knob > 0.033] * 3


def test_a_fast_retraction_at_large_lambda0_keeps_the_relaxed_floor():
    # lambda0 = 30, k = 0.2, V_z = 0.26 (widening 3.9): the widened zone's law asks for 1.06
    # points across w at 5e-3, the relaxed start's floor for 2.05 (measured: the load-area
    # curve 7.5e-3 off at 1.56 points, 3.4e-3 at 2.33; docs/results.md)
    groups = dict(maugis=30.0, modulus_ratio=0.2, velocity=0.26, depth=0.005, cell=0.64)
    case = parse_case(case_text("accuracy = 5e-3", **groups, adhesion=1e-4))
    assert assert_smallest_grid_meeting_the_shares(case) == (False, False, True)
    assert (
        case.zone_width / case.dx >= accuracy.relaxed_points(5e-3) == pytest.approx(2.05, abs=0.01)
    )
    # never above the grid without the widening: a creeping retraction keeps its own
    for knob in (1e-2, 5e-3, 1e-3):
        assert accuracy.zone_points(knob, 1e-3, 0.2, 30.0) == accuracy.zone_points(
            knob, 1e-3, 0.2, 30.0, widen=False
        )
        assert accuracy.zone_points(knob, 1e6, 0.2, 30.0) <= accuracy.zone_points(knob)


@pytest.mark.parametrize(
    "groups, knob, message",
    [
        # an elastic case: 1.4 points across w at 0.05, its law measured from 1.5 on
        (dict(modulus_ratio=1.0), 0.05, "1.4 points across the cohesive zone, fewer than the 1.5"),
        # a fast one at lambda0 = 30: the floor would be 0.51 points, measured from 0.58 on
        (
            dict(maugis=30.0, modulus_ratio=0.2, velocity=0.26, depth=0.005, cell=0.64),
            0.04,
            "0.51 points across the relaxed cohesive zone w .* fewer than the 0.58",
        ),
    ],
)
def test_the_knob_refuses_a_grid_its_laws_were_not_measured_on(groups, knob, message):
    with pytest.raises(CaseError, match=f"accuracy = {knob:g}: its grid would have {message}"):
        parse_case(case_text(f"accuracy = {knob}", **groups))
    # the coarsest accuracy it names is accepted, and an explicit grid is the user's
    coarsest = float(
        str(pytest.raises(CaseError, parse_case, case_text(f"accuracy = {knob}", **groups)).value)
        .split("accuracy <= ")[1]
        .split(" ")[0]
    )
    parse_case(case_text(f"accuracy = {coarsest * 0.999}", **groups))
    parse_case(case_text(f"accuracy = {knob}\nnx = 65536", **groups))


def test_persson_brener_ratio_is_one_on_a_jkr_curve_with_their_work():
    # a retraction whose points lie on the JKR curve (Eq. 10) with Persson and Brener's work
    # at its edge's constant speed: the ratio at its pull-off is 1, for an SLS; NaN elastic
    from hpcgfmd.studies import accuracy_study

    case = parse_case(case_text("nx = 16384", maugis=30.0, modulus_ratio=0.2))
    beta = case.adhesion ** (1 / 3)
    rate = 0.01  # R / tau: the contact half-width's shrinking speed
    work = theory.persson_brener(theory.peel_velocity(rate, 1.0, 0.2, 30.0, beta), 0.2)
    assert 1.5 < work < 5.0  # between the relaxed and the glassy work
    abar = np.linspace(3.0, 0.2, 2801)
    result = {
        "case": case,
        "abar": abar,
        "lbar": theory.jkr_load(abar, work),
        "time": (abar[0] - abar) * beta / rate,
    }
    assert accuracy_study.persson_brener_ratio(result) == pytest.approx(1.0, abs=1e-9)
    elastic = dict(result, case=parse_case(case_text("nx = 1024", modulus_ratio=1.0)))
    assert math.isnan(accuracy_study.persson_brener_ratio(elastic))
    # the same curve reached within the retardation time tau / k = 5: no relaxed far field
    i = int(np.argmin(result["lbar"]))
    assert 5.0 < result["time"][i] < 50.0
    hurried = dict(result, time=result["time"] * (4.9 / result["time"][i]))
    assert math.isnan(accuracy_study.persson_brener_ratio(hurried))
