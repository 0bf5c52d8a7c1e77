"""Generalized Maxwell (Prony series) substrate: docs/model.md (M38)-(M42).

Independent references: the standard linear solid (one branch, or branches of one time), the
convolution integral of the relaxation modulus in closed form (a uniform strain history), the
eigenvalues of the creep problem (the retardation times), and the limits of the
Persson-Brener effective work of adhesion.
"""

import math

import numpy as np
import pytest
from mpi4py import MPI

from cases import case_text, physical_text, whole_run
from hpcgfmd.case import Case, parse_case
from hpcgfmd.errors import CaseError
from hpcgfmd.model import theory
from hpcgfmd.model.accuracy import STEP_SHARE
from hpcgfmd.model.halfspace import MaxwellHalfSpace
from hpcgfmd.model.material import GeneralizedMaxwell
from hpcgfmd.parallel.fft import plan_real_fft
from hpcgfmd.solvers.stepping import KEPT_SHARE

SLS = GeneralizedMaxwell.standard_linear(1.0, 10.0, 1.0)

# A genuine two-branch solid of k = 0.1: E_i / E0 = 3, 6 and tau_i = 0.1, 1.45 tau_r
# (weighted mean (3 x 0.1 + 6 x 1.45) / 9 = 1).
TWO_BRANCHES = {
    "modulus_ratio": None,
    "relaxation_moduli": [3.0, 6.0],
    "relaxation_times": [0.1, 1.45],
}


@pytest.mark.parametrize("dt", [1e-4, 3e-3, 0.3, 5.0, math.inf])
def test_one_branch_and_equal_times_are_the_sls_step(dt):
    # against the SLS's step, which test_material.py checks against the convolution integral
    sls = SLS.step_factors(dt)
    for prony in (
        GeneralizedMaxwell(1.0, (9.0,), (1.0,)),
        GeneralizedMaxwell(1.0, (4.5, 2.5, 2.0), (1.0, 1.0, 1.0)),
    ):
        factors = prony.step_factors(dt)
        assert factors.e_eff == pytest.approx(sls.e_eff, rel=1e-15)
        np.testing.assert_allclose(factors.decays, sls.decays[0], rtol=1e-15)
        assert factors.e_history == pytest.approx(sls.e_history, rel=1e-14, abs=1e-300)
        if math.isfinite(dt):
            assert prony.curvature_response(dt) == pytest.approx(
                SLS.curvature_response(dt), rel=1e-14
            )
    assert GeneralizedMaxwell(1.0, (9.0,), (1.0,)).retardation_time == SLS.retardation_time


def uniform_strain_traction(material, strain_rate_history, times):
    """sigma(t) = E0 eps(t) + sum_i E_i int_0^t exp(-(t - s)/tau_i) eps'(s) ds, for
    eps(t) = sin(t): the closed form of the convolution (M38)."""
    t = np.asarray(times)
    sigma = material.e_relaxed * np.sin(t)
    for e, tau in zip(material.branch_moduli, material.branch_times):
        # int_0^t exp(-(t-s)/tau) cos(s) ds = tau / (1 + tau^2) (cos t + tau sin t - exp(-t/tau))
        sigma += e * tau / (1.0 + tau**2) * (np.cos(t) + tau * np.sin(t) - np.exp(-t / tau))
    return sigma


def step_uniform_strain(material, strain, times, n=64, mode=3):
    """The half-space's steps (M40) for u(x, t) = strain(t) cos(q x), solved exactly (the
    traction is K u + H): the traction amplitude p(x = 0) / (|q|/2) at each time."""
    fft = plan_real_fft(MPI.COMM_SELF, n, planner_effort="FFTW_ESTIMATE")
    try:
        cell = 2.0 * np.pi
        half_q = np.pi * np.abs(fft.wavenumber) / cell
        half = MaxwellHalfSpace(material, half_q, n, n)
        x = np.arange(n) * cell / n
        shape = np.cos(2.0 * np.pi * mode * x / cell)
        u = np.zeros(n)
        history, elastic = np.zeros(n), np.zeros(n)
        amplitude = [0.0]
        for t_before, t_after in zip(times[:-1], times[1:]):
            dt = t_after - t_before
            half.history(dt, history)
            u[:] = strain(t_after) * shape
            fft.apply_diagonal(u, half.operators(dt).stiffness, elastic)
            half.update(elastic, history, dt)
            amplitude.append(half.traction[0] / (np.pi * mode / cell))
        return np.array(amplitude)
    finally:
        fft.close()


def test_two_branches_follow_the_convolution_integral_to_second_order():
    # exact for u linear within each step, so the error of a smooth history is the
    # curvature's, O(dt^2) over a fixed time: halving dt divides it by 4
    material = GeneralizedMaxwell(1.0, (3.0, 6.0), (0.1, 1.45))
    errors = []
    for steps in (20, 40, 80, 160):
        times = np.linspace(0.0, 4.0, steps + 1)
        traction = step_uniform_strain(material, np.sin, times)
        reference = uniform_strain_traction(material, None, times)
        errors.append(np.max(np.abs(traction - reference)) / np.max(np.abs(reference)))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert errors[-1] < 1e-3, errors
    np.testing.assert_allclose(orders, 2.0, atol=0.15)


@pytest.mark.parametrize(
    "material", [SLS, GeneralizedMaxwell(1.0, (3.0, 6.0), (0.1, 1.45))], ids=["SLS", "two branches"]
)
def test_the_steps_are_exact_for_a_piecewise_linear_history(material):
    # a ramp up, a faster ramp down and a hold, with kinks on step boundaries: (M40) is exact
    # for one branch (the SLS's (M8), whose first branch is implied by p) and for several
    kinks = np.array([0.0, 1.0, 1.5, 3.0])
    values = np.array([0.0, 1.0, -0.5, -0.5])
    times = np.linspace(0.0, 3.0, 61)  # dt = 0.05: the kinks are step ends
    traction = step_uniform_strain(material, lambda t: np.interp(t, kinks, values), times)
    rates = np.diff(values) / np.diff(kinks)
    reference = material.e_relaxed * np.interp(times, kinks, values)
    for e, tau in zip(material.branch_moduli, material.branch_times):
        for start, rate, end in zip(kinks[:-1], rates, kinks[1:]):  # each ramp's stress
            inside = np.clip(times, start, end) - start
            reference += (
                e
                * rate
                * tau
                * (np.exp(-(times - start - inside) / tau) - np.exp(-(times - start) / tau))
            )
    np.testing.assert_allclose(traction, reference, rtol=0, atol=1e-13)


def retraction(text):
    """The series (time, load, contact half-width) of a whole serial run of ``text``."""
    records, _ = whole_run(text)
    return np.array([(r.time, r.load, r.contact_half_width) for r in records])


@pytest.mark.parametrize("steps", ['step_control = "fixed"', 'step_control = "adaptive"'])
def test_one_branch_and_equal_times_retract_as_the_sls(steps):
    # Solved to tolerance 1e-10: the histories differ by round-off only (the SLS's comes
    # from p and (|q|/2) u, the Prony series' from its branch tractions), and the solutions
    # by what the solves leave, at most about the tolerance (measured up to 3.6e-13 of the
    # largest load, next to the snap-off); at the default tolerance the solves stop on
    # iterates that differ by about it (measured 3e-8 in the load of the fixed-step run).
    numerics = f"nx = 2048\ntolerance = 1e-10\n{steps}"
    sls = retraction(case_text(numerics))
    for moduli, times in (([9.0], [1.0]), ([4.5, 3.0, 1.5], [1.0, 1.0, 1.0])):
        prony = retraction(
            case_text(
                numerics, modulus_ratio=None, relaxation_moduli=moduli, relaxation_times=times
            )
        )
        assert prony.shape == sls.shape
        np.testing.assert_array_equal(prony[:, 0], sls[:, 0])
        scale = np.abs(sls[:, 1]).max()
        assert np.abs(prony[:, 1] - sls[:, 1]).max() <= 1e-10 * scale
        assert np.abs(prony[:, 2] - sls[:, 2]).max() <= 1e-8 * sls[:, 2].max()


def test_two_branch_adaptive_steps_reach_the_accuracy():
    # the step control (the history estimate split over the branches, the tip's lag bounded
    # for each time) at the default accuracy 5e-3 against fixed steps of dt_max / 100 on the
    # same grid (the time error only; dt_max / 400 moves that reference by 1e-6), within
    # half the steps' share of the accuracy (1.25e-3): the kept errors this two-branch case
    # accumulates are held to half their allowance (KEPT_SHARE), and holding them to the
    # whole of it is 2.2e-3 off on every draw (below). Measured over 21 draws of round-off
    # (alpha (1 + j 3e-12) and (1 + j 7e-12)): 4.7e-5 to 1.0e-3 in 656-801 steps, against 5301
    # fixed steps. The errors fall in two groups, 5e-5 to 2e-4 and 5e-4 to 1e-3: near the pull-off
    # the load jitters as nodes leave the contact one by one (2048 nodes), and the sampled
    # minimum does or does not catch a dip. With the kept history errors' signed sum held to
    # the whole allowance instead of half, 2.2e-3 in 241-270 steps on all 18 draws measured
    # (docs/results.md, "Rules of the steps and the grid"). Both runs are solved to 1e-3, the
    # tolerance of those measurements (the default 2.5e-3 adds its own 2e-4 or so to what is
    # compared here, the time error).
    adaptive = retraction(case_text("nx = 2048\ntolerance = 1e-3", **TWO_BRANCHES))
    case = parse_case(case_text("nx = 2048", **TWO_BRANCHES))
    fine = retraction(
        case_text(
            f'nx = 2048\ntolerance = 1e-3\nstep_control = "fixed"\n'
            f"dt = {case.numerics.dt_max / 100!r}",
            **TWO_BRANCHES,
        )
    )
    pull_off, reference = adaptive[:, 1].min(), fine[:, 1].min()
    assert abs(pull_off / reference - 1.0) <= STEP_SHARE * KEPT_SHARE * case.numerics.accuracy
    assert adaptive.shape[0] < fine.shape[0] / 4


def test_case_keys_and_groups():
    text = case_text(**TWO_BRANCHES)
    case = parse_case(text)
    assert case.relaxation_moduli and case.modulus_ratio == pytest.approx(0.1, rel=1e-15)
    assert case.groups()["relaxation_times"] == [0.1, 1.45]
    assert case.material().relaxation_time == pytest.approx(1.0, rel=1e-15)
    assert parse_case(case.text).identity() == case.identity()
    sls = parse_case(case_text())
    assert sls.identity() != case.identity() and not sls.relaxation_moduli
    # built from keywords: the text it writes is the same case
    built = Case(
        maugis=3.5,
        velocity=1.0,
        depth=0.03,
        cell=2.0,
        adhesion=1e-4,
        modulus_ratio=None,
        relaxation_moduli=(3.0, 6.0),
        relaxation_times=(0.1, 1.45),
    )
    assert parse_case(built.text).identity() == built.identity()


def test_a_consistent_modulus_ratio_may_stay():
    # the tests' GROUPS give k = 0.1, and 1 / (1 + 3 + 6) is 0.1
    case = parse_case(case_text(relaxation_moduli=[3.0, 6.0], relaxation_times=[0.1, 1.45]))
    assert case.relaxation_moduli and case.modulus_ratio == 0.1


@pytest.mark.parametrize(
    "groups, message",
    [
        (
            dict(relaxation_moduli=[3.0, 6.0], relaxation_times=[0.1, 10.0]),
            "[case] relaxation_times = [0.1, 10.0]: expected times in units of the reference time",
        ),
        (
            dict(relaxation_moduli=[3.0, 6.0], relaxation_times=[1.0]),
            "[case] relaxation_times = [1.0]: expected as many times as relaxation_moduli (2)",
        ),
        (
            dict(relaxation_moduli=[3.0, -6.0], relaxation_times=[1.0, 1.0]),
            "[case] relaxation_moduli = [3.0, -6.0]: expected a non-empty list of finite"
            " numbers > 0",
        ),
        (dict(relaxation_moduli=[9.0]), "[case] relaxation_times is missing"),
        (
            dict(modulus_ratio=0.2, relaxation_moduli=[9.0], relaxation_times=[1.0]),
            "[case] modulus_ratio = 0.2: a Prony series sets k = 1 / (1 + sum of relaxation_moduli)"
            " = 0.1; leave modulus_ratio out",
        ),
    ],
)
def test_bad_prony_keys_are_named(groups, message):
    with pytest.raises(CaseError) as err:
        parse_case(case_text(**{"modulus_ratio": None, **groups}))
    assert str(err.value).startswith(message), str(err.value)


# The [physical] form with a two-term Prony series in place of the SLS's modulus and time
PHYSICAL = physical_text(
    modulus_instantaneous=None,
    relaxation_time=None,
    relaxation_moduli="[3e6, 6e6]",
    relaxation_times="[0.01, 0.145]",
)


def test_physical_prony_series_forms_the_groups_with_its_reference_time():
    case = parse_case(PHYSICAL)
    assert case.units.time == pytest.approx(0.1, rel=1e-15)  # (3 x 0.01 + 6 x 0.145) / 9
    np.testing.assert_allclose(case.relaxation_moduli, (3.0, 6.0), rtol=1e-15)
    np.testing.assert_allclose(case.relaxation_times, (0.1, 1.45), rtol=1e-14)
    assert case.modulus_ratio == pytest.approx(0.1, rel=1e-15)
    beta = (1e-3**2 * 0.05 / 1e6) ** (1.0 / 3.0)
    assert case.velocity == pytest.approx(
        1e-6 * 0.1 * 1e-3 / beta**2, rel=1e-12
    )  # v_z tau_r R / beta^2
    with pytest.raises(CaseError, match=r"^\[physical\] relaxation_time: a Prony series"):
        parse_case(PHYSICAL + "relaxation_time = 1.0\n")


def test_persson_brener_quadrature_of_a_prony_series():
    lam, beta = 7.0, 1.0
    c0 = beta / (np.pi * lam**2)
    sls = SLS
    two = GeneralizedMaxwell(1.0, (3.0, 6.0), (0.1, 1.45))
    equal = GeneralizedMaxwell(1.0, (4.5, 4.5), (1.0, 1.0))
    for rhodot in (1e-4, 1e-2, 1.0):
        closed = theory.persson_brener(theory.peel_velocity(rhodot, 1.0, 0.1, lam, beta), 0.1)
        assert theory.persson_brener_modulus(rhodot, c0, sls.complex_modulus) == pytest.approx(
            closed, rel=1e-10
        )
        assert theory.persson_brener_modulus(rhodot, c0, equal.complex_modulus) == pytest.approx(
            closed, rel=1e-10
        )
    # the limits: relaxed (1) at rest, glassy (Einf / E0 = 10) fast
    assert theory.persson_brener_modulus(1e-9, c0, two.complex_modulus) == pytest.approx(
        1.0, rel=1e-5
    )
    assert theory.persson_brener_modulus(1e5, c0, two.complex_modulus) == pytest.approx(
        10.0, rel=1e-3
    )
    # the fast branch relaxes first: at any speed less dissipation than the SLS of tau_r
    for rhodot in (1e-3, 1e-2, 1e-1):
        assert theory.persson_brener_modulus(
            rhodot, c0, two.complex_modulus
        ) < theory.persson_brener_modulus(rhodot, c0, sls.complex_modulus)


def test_a_sweep_over_prony_series():
    from hpcgfmd.runs.sweep import parse_sweep

    base = case_text(
        modulus_ratio=None,
        relaxation_moduli=[3.0, 6.0],
        relaxation_times=[0.1, 1.45],
        prefix="base.",
    )
    sweep = parse_sweep(
        base + "[grid]\nrelaxation_times = [[0.1, 1.45], [1.0, 1.0],"
        " [0.1, 10.0]]\nvelocity = [0.5, 2.0]\n"
    )
    assert [c.name for c in sweep.cases[:2]] == [
        "relaxation_times_0.1_1.45-velocity_0.5",
        "relaxation_times_0.1_1.45-velocity_2.0",
    ]
    valid = [c for c in sweep.cases if c.case is not None]
    assert len(valid) == 4 and all(
        c.case.relaxation_moduli and c.case.modulus_ratio == 0.1 for c in valid
    )
    # the third series does not average 1: those two cases fail alone, with the key named
    failed = [c for c in sweep.cases if c.case is None]
    assert len(failed) == 2 and all(
        "[case] relaxation_times = [0.1, 10.0]" in c.error for c in failed
    )


def test_the_paper_solver_steps_a_prony_series():
    # the damped Verlet solves the same elastic problem plus history (any substrate): its
    # pull-off against the CG's on the same grid and steps, within what 1000 pseudo steps
    # per step leave of the equilibration (measured 9.6e-8; 4000 steps give the same), both
    # preloads and the CG's steps solved to 1e-3 (the default 2.5e-3 leaves the CG 1.6e-5 off)
    numerics = 'nx = 1024\ntolerance = 1e-3\nstep_control = "fixed"\ndt = 0.05\n'
    cg = retraction(case_text(numerics, **TWO_BRANCHES))
    paper = retraction(
        case_text(numerics + 'solver = "paper"\nequilibration_steps = 1000', **TWO_BRANCHES)
    )
    assert abs(paper[:, 1].min() / cg[:, 1].min() - 1.0) < 1e-5


@pytest.mark.parametrize("dt, moved", [(0.01, 0.3), (0.3, 1.0), (5.0, 2.0)])
def test_step_control_of_branches_of_one_time_is_the_sls(dt, moved):
    from hpcgfmd.solvers.tip_lag import _prony_tip_lag_error, tip_lag_error

    sls = tip_lag_error(dt, moved * 0.02, 0.02, 0.1)
    assert sls > 0.0
    # the Prony expression (sensitivity summed over the branches): one branch of
    # m = (1 - k) / k = 9, and three of one time
    assert _prony_tip_lag_error(dt, moved, (9.0,), (1.0,)) == pytest.approx(sls, rel=1e-12)
    assert tip_lag_error(
        dt, moved * 0.02, 0.02, 0.1, ((4.5, 3.0, 1.5), (1.0, 1.0, 1.0))
    ) == pytest.approx(sls, rel=1e-12)
    # the memory of the kept history error: the slowest retardation time, tau / k for the
    # SLS and for branches of one time
    sls_time = SLS.retardation_time
    assert GeneralizedMaxwell(1.0, (4.5, 4.5), (1.0, 1.0)).retardation_time == sls_time


def test_the_tip_lag_bound_of_one_relaxation_time_and_of_several():
    """The quadratic step's tip-lag bound (LAG_PER_LOAD) holds for one relaxation time: the
    SLS and branches of one time share it; several times keep the linear step's, four times
    tighter (docs/numerics.md, "Time steps")."""
    from hpcgfmd.solvers.stepping import make_step_control

    def allowance(**groups):
        return make_step_control(parse_case(case_text("nx = 1024", **groups))).lag_allowance

    sls = allowance(modulus_ratio=0.1)
    assert allowance(relaxation_moduli=[4.5, 4.5], relaxation_times=[1.0, 1.0]) == sls
    assert allowance(relaxation_moduli=[3.0, 6.0], relaxation_times=[0.1, 1.45]) == pytest.approx(
        sls / 4, rel=1e-15
    )


def test_retardation_times_are_the_creep_problem_s_eigenvalues():
    # Another derivation than the zeros of s E~(s) the code solves for: under a constant
    # stress E0 eps + sum_i s_i the branch stresses obey s_i' = -s_i / tau_i + E_i eps' with
    # E0 eps' = -sum_j s_j', i.e. (I + e 1^T / E0) s' = -D s; the creep compliance decays
    # with the eigenvalues -1 / lambda_j of that system. The retardation times interlace the
    # relaxation times, the slowest within (tau_max, tau_max Einf / E0].
    for moduli, times in (
        ((3.0, 6.0), (0.1, 1.45)),
        ((1.0, 2.0, 3.0), (0.01, 0.3, 2.0)),
        ((9.0,), (1.0,)),
    ):
        material = GeneralizedMaxwell(1.0, moduli, times)
        coupling = np.eye(len(moduli)) + np.outer(moduli, np.ones(len(moduli))) / material.e_relaxed
        system = -np.linalg.solve(coupling, np.diag(1.0 / np.asarray(times)))
        rates = np.linalg.eigvals(system)
        assert np.all(np.abs(rates.imag) <= 1e-12 * np.abs(rates)) and np.all(rates.real < 0.0)
        retardation = np.sort(-1.0 / rates.real)
        assert material.retardation_time == pytest.approx(retardation[-1], rel=1e-12)
        relaxation = np.sort(times)
        assert np.all(relaxation < retardation)
        assert np.all(retardation[:-1] < relaxation[1:])
        assert retardation[-1] <= relaxation[-1] * material.e_instantaneous


# --- on a sphere -----------------------------------------------------------------------------
# The sphere of tests/test_sphere.py (lambda0 = 1 on a cell of 1.5 R, alpha = 1e-3: a_s =
# 0.133 R, the contact starts at 1.4 a_s), k = 0.5
SPHERE = dict(maugis=1.0, depth=0.01, cell=1.5, adhesion=1e-3, geometry="sphere")
# A genuine two-branch solid of k = 0.5: E_i / E0 = 0.4, 0.6 and tau_i = 0.1, 1.6 tau_r
# (weighted mean 0.4 x 0.1 + 0.6 x 1.6 = 1)
SPHERE_BRANCHES = dict(
    modulus_ratio=None, relaxation_moduli=[0.4, 0.6], relaxation_times=[0.1, 1.6]
)


def sphere_run(velocity, numerics, **groups):
    """The series of a whole serial retraction of :data:`SPHERE` at ``velocity`` (V_z)."""
    import hpcgfmd

    case = Case(**SPHERE, velocity=velocity, numerics=numerics, **groups)
    return case, hpcgfmd.run(case, planner_effort="FFTW_ESTIMATE").series


def test_one_branch_and_equal_times_retract_a_sphere_as_the_sls():
    # the line's test_one_branch_and_equal_times_retract_as_the_sls on the surface, with its
    # tolerances (the solves stop within 1e-10; measured 0.0 apart: the same values to the
    # last bit)
    numerics = {"n": 64, "tolerance": 1e-10}
    _, sls = sphere_run(1.0, numerics, modulus_ratio=0.5)
    for moduli, times in (([1.0], [1.0]), ([0.5, 0.3, 0.2], [1.0, 1.0, 1.0])):
        _, prony = sphere_run(
            1.0, numerics, modulus_ratio=None, relaxation_moduli=moduli, relaxation_times=times
        )
        assert prony.time.shape == sls.time.shape
        np.testing.assert_array_equal(prony.time, sls.time)
        assert np.abs(prony.load - sls.load).max() <= 1e-10 * np.abs(sls.load).max()
        radius = sls.contact_half_width.max()
        assert np.abs(prony.contact_half_width - sls.contact_half_width).max() <= 1e-8 * radius


def test_a_slow_two_branch_sphere_follows_the_relaxed_curve():
    # as the SLS's test_a_slow_viscoelastic_retraction_follows_the_relaxed_curve
    # (tests/test_sphere.py): the pull-off of V_z = 1e-3 (chi_ve = 1e-3; the slowest
    # retardation time 2.6 tau_r) is the relaxed Maugis-Dugdale sphere's (E0, dgamma0) in the
    # cell within the accuracy (measured 1.3e-4); ten times faster the tip's dissipation
    # raises it (2.4 % measured, more than the accuracy's 4 times)
    from hpcgfmd.model import sphere_theory

    pull_offs = []
    for velocity in (1e-3, 1e-2):
        case, series = sphere_run(velocity, {"n": 128}, **SPHERE_BRANCHES)
        pull_offs.append(series.load.min() / case.load_scale)
    radii = np.linspace(0.02, 2.0, 300)
    relaxed = sphere_theory.periodic_cell(radii, case.cell / case.beta, 1.0)[0].min()
    assert pull_offs[0] == pytest.approx(relaxed, rel=case.numerics.accuracy)
    assert pull_offs[1] < relaxed * (1.0 + 4.0 * case.numerics.accuracy)


def sphere_physical_text(alpha, radius, e0, tau_r):
    """:data:`SPHERE` with :data:`SPHERE_BRANCHES` at V_z = 1 in the [physical] form, for
    ``alpha`` with h0 and L 9 and 3 times SPHERE's (equal H0 and L / a_s when alpha is 27
    times larger), in SI: the branches' E_i = (E_i / E0) E0, tau_i = (tau_i / tau_r) tau_r,
    dgamma0 = alpha E0 R (M24), sigma_a from lambda0 = 1 (M52), v_z = V_z a_s^2 / (R tau_r)
    (M49), a_s = R (3 pi alpha / 4)^(1/3) (M52)."""
    work = alpha * e0 * radius
    sigma_a = 0.5 * (16.0 * math.pi * alpha / 9.0) ** (1.0 / 3.0) * e0
    a_s = radius * (3.0 * math.pi * alpha / 4.0) ** (1.0 / 3.0)
    moduli = [r * e0 for r in SPHERE_BRANCHES["relaxation_moduli"]]
    times = [r * tau_r for r in SPHERE_BRANCHES["relaxation_times"]]
    return (
        f'[physical]\ngeometry = "sphere"\nradius = {radius!r}\nmodulus_relaxed = {e0!r}\n'
        f"relaxation_moduli = {moduli!r}\nrelaxation_times = {times!r}\n"
        f"work_of_adhesion = {work!r}\ninteraction_range = {work / sigma_a!r}\n"
        f"velocity = {a_s**2 / (radius * tau_r)!r}\ndepth = {0.09 * radius!r}\n"
        f"cell_length = {4.5 * radius!r}\n[numerics]\nn = 64\ntolerance = 1e-12\n"
    )


def test_a_two_branch_sphere_s_scaled_response_is_similar():
    # The sphere's similarity with a Prony series (M41), (M51): the case in R = E0 = tau_r = 1
    # against the same groups in SI with R = 1 mm, E0 = 2 MPa, tau_r = 0.1 s (the branches'
    # times 10 and 160 ms) and alpha 27 times larger, h0 and L scaled alike. The scaled
    # series (t / tau_r, Pbar, u_z / delta_s, Abar) agree to round-off (measured 2.3e-13 of
    # the largest load, the same steps), far below the solver's tolerance (1e-12): V_z is
    # formed with tau_r, the weighted mean (M41) (the times' plain mean, 85 ms, would move
    # V_z by 15 %).
    import hpcgfmd

    cases = [
        Case(**SPHERE, velocity=1.0, numerics={"n": 64, "tolerance": 1e-12}, **SPHERE_BRANCHES),
        parse_case(sphere_physical_text(2.7e-2, 1e-3, 2e6, 0.1)),
    ]
    assert cases[1].units.time == pytest.approx(0.1, rel=1e-15)
    scaled = []
    for case in cases:
        s = hpcgfmd.run(case, planner_effort="FFTW_ESTIMATE").series
        depth_scale = s.attrs["beta"] ** 2 / s.attrs["length_unit"]  # delta_s = a_s^2 / R
        scaled.append((s.time / s.attrs["time_unit"], s.lbar, s.indenter / depth_scale, s.abar))
    for a, b in zip(*scaled):
        assert a.shape == b.shape
        np.testing.assert_allclose(b, a, rtol=1e-8, atol=1e-10 * np.abs(a).max())
