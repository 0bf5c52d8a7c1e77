"""The predictor's extrapolation in time (hpcgfmd/solvers/predictor.py): Lagrange weights
exact for quadratics, the quadratic guess from three accepted states, and its state across
a checkpoint and a rejected attempt."""

import dataclasses
import shutil

import numpy as np
import pytest
from mpi4py import MPI
from test_fft import mpi_check

from cases import case_text, sphere_case, whole_run
from hpcgfmd.case import parse_case
from hpcgfmd.parallel.domain import Domain
from hpcgfmd.runs.protocol import Retraction
from hpcgfmd.solvers.predictor import RADIAL_REST, RADIAL_TRIES, Predictor, lagrange_weights
from hpcgfmd.solvers.projection import project_feasible
from hpcgfmd.solvers.step_kernels import quadratic_guess
from hpcgfmd.state import State

N, CELL = 64, 4.0


@pytest.mark.parametrize(
    "ratio, ratio_previous", [(1.0, 1.0), (2.0, 0.25), (0.25, 2.0), (1.6818, 0.5946)]
)
def test_lagrange_weights_reproduce_quadratics(ratio, ratio_previous):
    # times in units of dt_n: t_{n-2} = -1 - 1/ratio_previous, t_{n-1} = -1, t_n = 0
    times = np.array([0.0, -1.0, -1.0 - 1.0 / ratio_previous])
    weights = np.array(lagrange_weights(ratio, ratio_previous))
    for power in range(3):
        assert weights @ times**power == pytest.approx(ratio**power, rel=1e-13, abs=1e-13)


def test_quadratic_guess_puts_contact_on_the_wall():
    rng = np.random.default_rng(1)
    u, u1, u2, wall = (rng.standard_normal(N) for _ in range(4))
    contact = rng.random(N) < 0.3
    out = np.empty(N)
    quadratic_guess(u, u1, u2, 1.5, -0.75, 0.25, wall, contact, out)
    np.testing.assert_array_equal(out[contact], wall[contact])
    np.testing.assert_allclose(
        out[~contact], (1.5 * u - 0.75 * u1 + 0.25 * u2)[~contact], rtol=1e-15, atol=1e-15
    )


def _motion(t, x):
    """A zero-mean displacement quadratic in time (no contact: the wall stays far above)."""
    shape = np.cos(2.0 * np.pi * x / CELL)
    return (0.01 + 0.03 * t - 0.02 * t**2) * shape


def _start(predictor, u, wall, t, t_next, dt_before, exact):
    """One start from u at t toward t_next, with an energy that is the distance to exact."""
    ratio = 1.0 if dt_before is None else (t_next - t) / dt_before
    gap = wall - u
    energy = lambda v, k_v=None: float(np.sum((v - exact) ** 2))  # noqa: E731
    predictor.start(
        u, wall, gap, np.zeros(N, dtype=bool), 0.0, ratio, (np.nan, np.nan), None, energy, None
    )


def test_third_start_extrapolates_a_quadratic_motion_exactly():
    domain = Domain(MPI.COMM_SELF, N, CELL, [(0, N)])
    predictor = Predictor(domain, window=0.1)
    wall = np.full(N, 10.0)
    times = [0.0, 0.3, 0.45, 0.85, 1.05]  # unequal steps
    errors = []
    for i in range(1, len(times)):
        u = _motion(times[i - 1], domain.x)
        exact = _motion(times[i], domain.x)
        dt_before = None if i == 1 else times[i - 1] - times[i - 2]
        _start(predictor, u, wall, times[i - 1], times[i], dt_before, exact)
        errors.append(np.max(np.abs(u - exact)))
    # the first start knows u_0 only, the second extrapolates linearly, the later ones
    # quadratically: exact to round-off
    assert errors[1] > 1e-4
    assert max(errors[2:]) < 1e-14


def test_state_round_trip_keeps_the_quadratic():
    domain = Domain(MPI.COMM_SELF, N, CELL, [(0, N)])
    wall = np.full(N, 10.0)
    times = [0.0, 0.2, 0.5, 0.6]
    first = Predictor(domain, window=0.1)
    for i in range(1, 3):
        u = _motion(times[i - 1], domain.x)
        _start(
            first,
            u,
            wall,
            times[i - 1],
            times[i],
            None if i == 1 else times[i - 1] - times[i - 2],
            _motion(times[i], domain.x),
        )
    state = first.state()
    second = Predictor(domain, window=0.1)
    second.restore(State({k: v.copy() for k, v in state.arrays.items()}, dict(state.scalars)))
    u = _motion(times[2], domain.x)
    exact = _motion(times[3], domain.x)
    _start(second, u, wall, times[2], times[3], times[2] - times[1], exact)
    np.testing.assert_allclose(u, exact, rtol=0, atol=1e-14)
    # without u_{n-2} (after a segment's start, or the preload's first step) it starts linear
    older = State(
        {k: v.copy() for k, v in state.arrays.items()},
        dict(state.scalars, has_before_previous=False),
    )
    old = Predictor(domain, window=0.1)
    old.restore(older)
    assert old.u_before_previous is None
    u = _motion(times[2], domain.x)
    _start(old, u, wall, times[2], times[3], times[2] - times[1], exact)
    assert np.max(np.abs(u - exact)) > 1e-5


def test_a_retried_step_starts_from_its_first_attempts_predictor_state(monkeypatch):
    # a rejected attempt is undone: the retry's guess reads the same u_{n-1}, u_{n-2} and
    # step ratio as the first attempt did (the attempt's shift of them is reverted)
    sim = Retraction(
        parse_case(case_text("nx = 1024")), MPI.COMM_SELF, planner_effort="FFTW_ESTIMATE"
    )
    sim.preload()
    for _ in range(4):
        sim.step()
    entries, start = [], sim.predictor.start

    def recorded(*args, **kwargs):
        p = sim.predictor
        entries.append((p.u_previous.copy(), p.u_before_previous.copy(), p.ratio_previous))
        return start(*args, **kwargs)

    judge, verdicts = sim.steps.judge, []

    def reject_first(*args, **kwargs):
        verdicts.append(judge(*args, **kwargs))
        return dataclasses.replace(verdicts[-1], accepted=len(verdicts) > 1)

    monkeypatch.setattr(sim.predictor, "start", recorded)
    monkeypatch.setattr(sim.steps, "judge", reject_first)
    sim.step()
    assert len(entries) == 2 and sim.rejected_steps == 1
    (previous, before, ratio), (previous_retry, before_retry, ratio_retry) = entries
    np.testing.assert_array_equal(previous_retry, previous)
    np.testing.assert_array_equal(before_retry, before)
    assert ratio_retry == ratio


def test_projection_holds_the_contact_a_guess_carries():
    # a guess with its contact on the risen wall has a positive mean: the Euclidean
    # projection lowers every node by the same shift, the contact off the wall with it
    # (a patch of millions of nodes then costs the CG hundreds of iterations to land); held,
    # the contact stays on the wall and the free nodes alone take the shift
    domain = Domain(MPI.COMM_SELF, N, CELL, [(0, N)])
    x = domain.x
    wall = 0.05 + x**2 / 2.0
    u = np.minimum(0.02 * np.cos(2.0 * np.pi * x / CELL), wall)
    contact = np.abs(x) < 0.5
    u[contact] = wall[contact]
    assert u.mean() > 1e-3
    held, plain = np.empty(N), np.empty(N)
    shift = project_feasible(domain, u, wall, held, hold_contact=True)
    project_feasible(domain, u, wall, plain)
    for out in (held, plain):
        assert abs(out.mean()) < 1e-15 and np.all(out <= wall)
    np.testing.assert_array_equal(held[contact], wall[contact])
    np.testing.assert_allclose(held[~contact], np.minimum(u - shift, wall)[~contact], atol=1e-15)
    assert np.all(wall[contact] - plain[contact] > 1e-3)


def test_the_first_step_starts_with_the_preloads_contact_on_the_new_wall(monkeypatch):
    # right after the preload the predictor's guess carries the contact with the rising
    # wall; the solve starts from it with every contact node on the new wall (gap exactly 0)
    sim = Retraction(
        parse_case(case_text("nx = 1024")), MPI.COMM_SELF, planner_effort="FFTW_ESTIMATE"
    )
    sim.preload()
    starts, start = [], sim.predictor.start

    def recorded(u, wall, gap_before, contact, *args, **kwargs):
        result = start(u, wall, gap_before, contact, *args, **kwargs)
        starts.append((contact.copy(), (wall - u)[contact]))
        return result

    monkeypatch.setattr(sim.predictor, "start", recorded)
    sim.step()
    contact, gaps = starts[0]
    assert contact.sum() > 10
    np.testing.assert_array_equal(gaps, 0.0)


def test_a_spheres_gap_moves_radially_with_its_contact():
    # u_n's gap max(0, r - a_n)^2 around a contact of radius a_n = 0.22 that grew from 0.2:
    # the guess takes the gap of r - 0.02 within the radial window (0.05 + 0.02 of a_n),
    # max(0, r - 0.24)^2 to the bilinear error (dx^2 / 8) |g''| per axis, dx^2 / 2 here,
    # and the linear guess's gap beyond it.
    n, cell = 64, 1.0
    domain = Domain(MPI.COMM_SELF, (n, n), cell, [(0, n * n)])
    predictor = Predictor(domain, window=1.0, radial_window=0.05)
    r = np.hypot(domain.x, domain.y)
    gap_before = np.maximum(0.0, r - 0.22) ** 2
    wall = 1.0 + 0.0 * r
    linear = wall - 0.5  # the linear guess's gap: 0.5 everywhere
    guess = predictor._moving_radius(linear, wall, gap_before, 1.0, (-0.22, 0.22), (-0.2, 0.2))
    gap = wall - guess
    near = np.abs(r - 0.22) < 0.07
    dx = cell / n
    assert np.abs(gap[near] - np.maximum(0.0, r[near] - 0.24) ** 2).max() <= dx**2 / 2
    assert np.abs(gap[near] - gap_before[near]).max() > 8 * dx**2 / 2  # (it moved)
    np.testing.assert_array_equal(gap[~near], 0.5)
    # no motion, no guess
    assert predictor._moving_radius(linear, wall, gap_before, 1.0, (-0.2, 0.2), (-0.2, 0.2)) is None


@pytest.mark.mpi
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="mpirun not found")
@pytest.mark.parametrize("ranks", [1, 2, 3])
def test_rows_around_a_block_under_mpirun(ranks):
    # the rows a sphere's radial guess reads across blocks (tests/mpi/check_rows.py)
    result = mpi_check("check_rows.py", ranks)
    assert result.returncode == 0, result.stdout + result.stderr
    assert f"on {ranks} ranks" in result.stdout


def tried_radial_guesses(case, monkeypatch):
    """(steps, the radial guesses made, the steps started from one) of a run of ``case``."""
    made = []
    original = Predictor._moving_radius

    def counted(self, *args):
        made.append(1)
        return original(self, *args)

    monkeypatch.setattr(Predictor, "_moving_radius", counted)
    _, sim = whole_run(case.text)
    return sim.surface.step_index, len(made), sim.predictor.choices[1]


def test_a_spheres_radial_guess_rests_where_it_keeps_losing(monkeypatch):
    # Elastic, the contact's edge moves with its shape: the guess starts some steps
    # (measured on 192^2: 14 of 118, 30 guesses made). Viscoelastic (k = 0.1) the
    # extrapolation in time wins every step (96^2: 62 steps, 9 guesses made): after
    # RADIAL_TRIES losses in a row the guess is made once every RADIAL_REST + 1 steps.
    steps, made, won = tried_radial_guesses(sphere_case(192), monkeypatch)
    assert won >= 8
    steps, made, won = tried_radial_guesses(sphere_case(96, modulus_ratio=0.1), monkeypatch)
    assert won == 0
    assert made <= RADIAL_TRIES + steps / (RADIAL_REST + 1) + 2
