"""Equilibrium solver: feasibility projection, Hertz, iteration growth with n_x."""

import math

import numpy as np
import pytest

from cases import FIXED_STEPS, case_text, pull_off_run
from hpcgfmd.model import theory
from hpcgfmd.model.halfspace import StepOperators
from hpcgfmd.model.interface import edge_positions
from hpcgfmd.solvers.projection import project_feasible


def test_project_feasible_zero_mean_and_wall():
    rng = np.random.default_rng(0)
    u = rng.normal(size=1000)
    wall = np.full(1000, 0.5) + 0.1 * rng.normal(size=1000)
    from mpi4py import MPI

    from hpcgfmd.parallel.domain import Domain

    out = np.empty(1000)
    shift = project_feasible(Domain(MPI.COMM_SELF, 1000, 1.0, [(0, 1000)]), u, wall, out)
    assert abs(out.mean()) < 1e-14
    assert np.all(out <= wall)
    free = out < wall
    np.testing.assert_allclose(out[free], u[free] - shift, atol=1e-12)
    np.testing.assert_array_equal(out[~free], wall[~free])


def hertz(grid, depth):
    solver = grid.solver(tolerance=1e-10, scale=math.sqrt(depth))
    ops = StepOperators.from_modulus(grid.half_q, 1.0, grid.n)
    u = np.zeros(grid.n)
    wall = grid.x**2 / 2 - depth
    res = solver.solve(u, wall, ops, np.zeros(grid.n))
    assert res.converged
    p = np.empty(grid.n)
    solver.problem.interface_traction(
        u, solver.elastic_traction(), wall, np.zeros(grid.n), res.mean_traction, p
    )
    left, right = edge_positions(grid.domain, wall - u, 0.0, 1.5)
    return -p.sum() * grid.dx, 0.5 * (right - left), res.iterations


def test_hertz_load_against_contact_half_width(grid_factory):
    # 2D Hertz with the periodic-image factor (docs/model.md (M29), O((a/L)^4) left);
    # a from the (x - a)^(3/2) edge model. Asked: within 1 %; measured 0.04 % at n = 4096,
    # so 0.3 % leaves room for the O(dx^2) discretisation and the O((a/L)^4) remainder.
    grid = grid_factory(4096, 4.0)
    for depth in (0.02, 0.04):
        load, a, _ = hertz(grid, depth)
        reference = math.pi * a**2 / 4 * theory.periodic_load_factor(a, grid.cell)
        assert load == pytest.approx(reference, rel=0.003)


def test_hertz_depth_matches_periodic_green_function(grid_factory):
    # Zero-mean periodic Green's function -(2/(pi E)) ln|2 sin(pi x / L)| integrated over the
    # Hertz pressure: h0 = (a^2 / 2R) (1/2 - ln(pi a / L)) to O((a/L)^2).
    grid = grid_factory(8192, 10.0)
    _, a, _ = hertz(grid, 0.1)
    assert pytest.approx(a**2 / 2 * (0.5 - math.log(math.pi * a / grid.cell)), rel=5e-3) == 0.1


def test_iterations_do_not_grow_like_sqrt_n(grid_factory):
    # Counts over a ladder of grids are not monotone (active-set restarts), so fit the
    # log-log slope: measured 0.20 (8 to 25 iterations from 512 to 32768 points); plain CG
    # or damped dynamics would give 0.5.
    sizes = [512, 1024, 2048, 4096, 8192, 16384, 32768]
    its = [hertz(grid_factory(n, 4.0), 0.04)[2] for n in sizes]
    slope = np.polyfit(np.log(sizes), np.log(its), 1)[0]
    assert slope < 0.3, (its, slope)


@pytest.mark.parametrize("k, velocity", [(1.0, 1.0), (0.1, 9.0)])
def test_every_iteration_lowers_the_energy(k, velocity):
    # Path following rests on monotone descent from the start of each step (module
    # docstring of hpcgfmd.solvers.cg.solver). The solve is deterministic, so the state after m
    # iterations is a prefix of the state after m + 1: compare energies along the sequence,
    # through the preload from flat (many wall contacts) and a retraction step.
    from mpi4py import MPI

    from hpcgfmd.case import parse_case
    from hpcgfmd.runs.protocol import Retraction

    case = parse_case(case_text("nx = 2048", modulus_ratio=k, velocity=velocity))
    sim = Retraction(case, MPI.COMM_SELF, planner_effort="FFTW_ESTIMATE")
    solver = sim.solver
    np.add(sim.profile, sim.surface.indenter, out=sim.equilibrium.wall)
    ops = sim.substrate.operators(math.inf)
    start = np.zeros(sim.n)
    for phase in ("preload", "retraction"):
        energies = []
        for m in range(0, 60):
            u = start.copy()
            solver.max_iterations, solver.tolerance = m, 0.0
            solver.solve(u, sim.equilibrium.wall, ops, sim.equilibrium.history)
            energies.append(
                solver.problem.energy(u, sim.equilibrium.wall, ops, sim.equilibrium.history)
            )
        rises = np.diff(energies)
        scale = np.abs(energies).max()
        assert np.all(rises <= 1e-12 * scale), (phase, rises.max() / scale)
        # and the sequence does descend (measured: 8 to 31 clear drops before round-off)
        assert np.count_nonzero(rises < -1e-12 * scale) >= 5, (phase, rises / scale)
        # next: a retraction step of the real protocol, 20 steps in
        solver.max_iterations, solver.tolerance = 5000, case.numerics.tolerance
        sim.preload()
        for _ in range(20):
            sim.step()
        start = sim.surface.u.copy()
        dt = case.numerics.dt
        sim.substrate.history(dt, sim.equilibrium.history)
        sim.surface.indenter += case.indenter_speed * dt
        np.add(sim.profile, sim.surface.indenter, out=sim.equilibrium.wall)
        ops = sim.substrate.operators(dt)


def _retraction(k, velocity):
    """Whole retraction of a small case at fixed steps and a tight solver tolerance, so that
    two solvers take the same steps and their solutions differ by the tolerance only (adaptive
    steps would follow their differences): (pull-off Lbar, the run)."""
    numerics = FIXED_STEPS + "nx = 2048\ntolerance = 1e-9"
    return pull_off_run(case_text(numerics, modulus_ratio=k, velocity=velocity))


@pytest.mark.slow
@pytest.mark.parametrize("k, velocity", [(1.0, 1.0), (0.1, 9.0)])
def test_line_search_extensions_same_branch_fewer_iterations(monkeypatch, k, velocity):
    # Going on along d while the energy provably falls (hpcgfmd.solvers.cg.line_search) changes
    # the way down, not where it ends: the same pull-off to the solver's tolerance 1e-9
    # (measured 1.3e-11 and 4e-12 relative) with fewer iterations (measured 0.45 and 0.61 of
    # the count without extensions, the step capped near 1.9 alpha as before).
    import hpcgfmd.solvers.cg.line_search as solver_module

    extended, run = _retraction(k, velocity)
    monkeypatch.setattr(solver_module, "MAX_EXTENSIONS", 0)
    capped, capped_run = _retraction(k, velocity)
    assert extended == pytest.approx(capped, rel=1e-8)
    assert run.surface.step_index == capped_run.surface.step_index
    assert run.solver.counters()["extensions"] > capped_run.solver.counters()["extensions"]
    assert run.equilibrium.iterations < 0.7 * capped_run.equilibrium.iterations
