"""The standard linear solid as the one-branch half-space: its step against the convolution
integral, creep against J(t), one elastic mode."""

import math

import numpy as np
import pytest

from hpcgfmd.model.halfspace import MaxwellHalfSpace
from hpcgfmd.model.material import GeneralizedMaxwell

SLS = GeneralizedMaxwell.standard_linear(1.0, 10.0, 1.0)


def test_step_limits():
    # dt -> 0: the instantaneous modulus; dt = inf: the relaxed solid without history (M7)
    assert SLS.step_factors(1e-9).e_eff == pytest.approx(10.0, rel=1e-8)
    relaxed = SLS.step_factors(math.inf)
    assert (relaxed.e_eff, relaxed.decays, relaxed.e_history) == (1.0, (0.0,), 0.0)


def test_step_factors_follow_the_convolution_integral_of_a_piecewise_linear_strain():
    # The step (M7)-(M8) in the factors' own recursion, p_{n+1} = Eeff eps_{n+1} + a p_n +
    # e_history eps_n (one mode, G = eps), from a relaxed start over steps of unequal length,
    # against Boltzmann's integral sigma(t) = int_0^t E(t - s) eps'(s) ds of the relaxation
    # modulus (M5) by quadrature: exact for a strain linear within each step (M40), so equal
    # to the quadrature's and the recursion's round-off (measured 2e-16 of the largest stress).
    from scipy.integrate import quad

    times = np.concatenate(([0.0], np.cumsum([1e-3, 0.3, 7.0, 0.05, 2.0, 1e-3, 0.7, 3.0])))
    steps = np.diff(times)  # the steps the times hold (a step of 1e-3 at t = 9 is 2e-12 off)
    strain = np.concatenate(([0.0], np.random.default_rng(4).uniform(-1.0, 1.0, steps.size)))
    rates = np.diff(strain) / steps
    stress, stepped = [0.0], 0.0
    for n, dt in enumerate(steps):
        factors = SLS.step_factors(dt)
        stepped = (
            factors.e_eff * strain[n + 1]
            + factors.decays[0] * stepped
            + factors.e_history * strain[n]
        )
        stress.append(stepped)
    for n, t in enumerate(times):
        exact = sum(
            rate
            * quad(
                lambda s, t=t: float(SLS.relaxation_modulus(t - s)),
                start,
                end,
                epsabs=1e-15,
                epsrel=1e-13,
            )[0]
            for rate, start, end in zip(rates[:n], times[:n], times[1 : n + 1])
        )
        assert stress[n] == pytest.approx(exact, rel=1e-12, abs=1e-13), (n, t)


def creep_error(grid, dt, t_end, mode=3, amplitude=1e-3):
    """Max error of u(t) of one mode under a step traction, against (2p/|q|) J(t).

    Runs the real solver path: the half-space's history and a ConstrainedCG with an applied
    traction and the wall far away. The state starts just after the step (t = 0+): the
    instantaneous response u = p/(s Einf), history consistent with a relaxed past
    (G = s u, p the applied traction).
    """
    half_space = MaxwellHalfSpace(SLS, grid.half_q, grid.n, grid.n)
    solver = grid.solver(tolerance=1e-13, scale=amplitude)
    s = grid.half_q[mode]
    applied = amplitude * np.cos(2 * math.pi * mode * grid.x / grid.cell)
    u = applied / (s * SLS.e_instantaneous)
    half_space.traction[:] = applied
    half_space.relaxed[:] = s * u
    wall = np.full(grid.n, 1.0)
    history = np.empty(grid.n)
    err = 0.0
    for i in range(1, int(round(t_end / dt)) + 1):
        half_space.history(dt, history)
        res = solver.solve(u, wall, half_space.operators(dt), history, applied=applied)
        assert res.converged
        half_space.update(solver.elastic_traction(), history, dt)
        exact = applied / s * SLS.creep_compliance(i * dt)
        err = max(err, np.abs(u - exact).max() / (amplitude / s))
    return err


def test_creep_of_one_mode_second_order_in_dt(grid_factory):
    grid = grid_factory(64, 1.0)
    errors = [creep_error(grid, dt, 8.0) for dt in (0.4, 0.2, 0.1)]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    # u linear within a step is exact to O(dt^2) for the smooth creep curve.
    assert np.all(np.abs(orders - 2.0) < 0.15), (errors, orders)
    assert errors[-1] < 1e-3


def test_one_mode_elastic_amplitude_to_roundoff(grid_factory):
    grid = grid_factory(256, 2.0)
    elastic = GeneralizedMaxwell.standard_linear(2.5, 2.5, 1.0)
    half_space = MaxwellHalfSpace(elastic, grid.half_q, grid.n, grid.n)
    solver = grid.solver(tolerance=1e-14)
    for mode in (1, 17, 128):
        q = 2 * math.pi * mode / grid.cell
        p = 0.3 * np.cos(q * grid.x + 0.4 * (mode < 128))
        u = np.zeros(grid.n)
        res = solver.solve(
            u, np.full(grid.n, 10.0), half_space.operators(math.inf), np.zeros(grid.n), applied=p
        )
        assert res.converged
        np.testing.assert_allclose(u, 2 * p / (q * 2.5), rtol=0, atol=1e-13 * np.abs(u).max())
