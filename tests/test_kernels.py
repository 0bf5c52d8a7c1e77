"""The CG kernels' extremes against numpy: every length (the four lanes and their tail),
every span, NaN passed over as by one running max/min, and the entry bound of
``dot_and_entry`` against its definition node by node; the projection's compiled pass
against numpy's minimum to the bit."""

import numpy as np
import pytest

from hpcgfmd.solvers import kernels, step_kernels


def _outside(a, lo, hi):
    return np.concatenate([a[:lo], a[hi:]])


@pytest.mark.parametrize("m", range(0, 14))
def test_extremes_outside_every_span(m):
    rng = np.random.default_rng(m)
    r = rng.standard_normal(m)
    for lo in range(m + 1):
        for hi in range(lo, m + 1):
            rest = _outside(r, lo, hi)
            high, low = kernels._extremes(r, lo, hi)
            if rest.size:
                assert (high, low) == (rest.max(), rest.min())
            else:
                assert (high, low) == (-np.inf, np.inf)


def test_extremes_pass_over_nan():
    """A NaN node leaves the extremes of the others (the residual's NaN shows in its sum)."""
    r = np.random.default_rng(1).standard_normal(23)
    r[[0, 5, 22]] = np.nan
    assert kernels._extremes(r, 9, 12) == (
        np.nanmax(_outside(r, 9, 12)),
        np.nanmin(_outside(r, 9, 12)),
    )


def test_residual_extremes_and_sum():
    rng = np.random.default_rng(2)
    m, p, q, lo, hi = 37, 12, 20, 10, 22
    load, traction = rng.standard_normal(m), rng.standard_normal(m)
    r = np.empty(m)
    total, high, low = kernels.residual(load, traction, p, q, lo, hi, r)
    expected = -load.copy()
    expected[p:q] += traction[p:q]
    np.testing.assert_array_equal(r, expected)
    assert total == pytest.approx(expected.sum(), rel=1e-13)
    assert (high, low) == (_outside(expected, lo, hi).max(), _outside(expected, lo, hi).min())


@pytest.mark.parametrize(
    "m, lo, hi, margin",
    [(41, 15, 22, 3), (41, 0, 5, 2), (41, 35, 41, 4), (9, 3, 3, 16), (6, 0, 6, 1), (0, 0, 0, 16)],
)
def test_entry_bound_below_every_node_outside(m, lo, hi, margin):
    """No node outside [lo, hi) reaches ``level`` along d before the returned length, and
    the nodes within the margin give their exact entry lengths."""
    rng = np.random.default_rng(m + lo)
    d, kd = rng.standard_normal(m), rng.standard_normal(m)
    level = 0.1
    gap = level + rng.uniform(0.01, 1.0, m)
    total, entry = kernels.dot_and_entry(d, kd, gap, lo, hi, level, margin)
    assert total == pytest.approx(float(d @ kd), rel=1e-12, abs=1e-12)
    outside = np.r_[0:lo, hi:m]
    rising = outside[d[outside] > 0.0]
    exact = (gap[rising] - level) / d[rising]
    assert entry <= (exact.min() if rising.size else np.inf)
    near = rising[(rising >= lo - margin) & (rising < hi + margin)]
    far = outside[(outside < lo - margin) | (outside >= hi + margin)]
    # the farther nodes' bound: their smallest room over their largest rise
    rise = d[far].max() if far.size else 0.0
    bound = (gap[far].min() - level) / rise if rise > 0.0 else np.inf
    near_exact = ((gap[near] - level) / d[near]).min() if near.size else np.inf
    assert entry == min(bound, near_exact)


def test_below_wall_is_numpys_minimum_to_the_bit():
    """min(u - shift, wall) with NaN on either side and zeros of both signs, and the free
    count u - shift < wall (NaN never free)."""
    u = np.array([1.0, -0.0, 0.0, np.nan, 2.0, 3.0, 0.5, -1.0, np.inf])
    wall = np.array([2.0, 0.0, -0.0, 1.0, np.nan, 3.0, 0.25, -1.0, 1.0])
    for shift in (0.0, 0.25):
        out = np.empty_like(u)
        free = step_kernels.below_wall(u, shift, wall, out, False)
        expected = np.minimum(u - shift, wall)
        assert out.tobytes() == expected.tobytes()
        assert free == np.count_nonzero(u - shift < wall)


def _gaps(rng, m, dmax):
    """Gaps of m nodes and two ghosts: beyond the range, a zone with straddling elements,
    and nodes on the wall (gap 0)."""
    gap_ext = rng.uniform(1.05 * dmax, 3.0 * dmax, m + 2)
    if m:
        a = int(rng.integers(0, m + 2))
        b = int(rng.integers(a, m + 3))
        gap_ext[a:b] = rng.uniform(0.0, dmax, b - a)
        gap_ext[a + (b - a) // 3 : a + (b - a) // 2] = 0.0
    return gap_ext


@pytest.mark.parametrize("m", [0, 1, 2, 3, 7, 40])
def test_cohesive_energy_is_the_laws(m):
    """The compiled sum of the elements' ramp means against the numpy law (the law's energy
    with sigma_a = dx = 1 is minus the sum), zone anywhere, ghosts included, or no zone."""
    from hpcgfmd.model.interface import DugdaleMaugis

    rng = np.random.default_rng(40 + m)
    dmax = 0.3
    law = DugdaleMaugis(1.0, dmax)
    for _ in range(60):
        gap_ext = _gaps(rng, m, dmax)
        assert kernels.cohesive_energy(gap_ext, dmax) == pytest.approx(
            -law.energy(gap_ext, 1.0), rel=1e-13, abs=1e-15
        )
    assert kernels.cohesive_energy(np.full(m + 2, 2.0 * dmax), dmax) == 0.0
    everywhere = np.full(m + 2, 0.25 * dmax)
    assert kernels.cohesive_energy(everywhere, dmax) == pytest.approx(0.75 * dmax * m)


@pytest.mark.parametrize("sigma_a", [0.0, 0.8])
def test_interface_traction_is_the_law_and_the_reaction(grid_factory, sigma_a):
    """The solver's interface traction against its definition on every node: the numpy
    law's cohesive traction, and on the wall (gap <= 0) K u + H + mu - applied."""
    from hpcgfmd.model.interface import DugdaleMaugis

    grid = grid_factory(64, 4.0)
    dmax = 0.3
    solver = grid.solver(sigma_a=sigma_a, dmax=dmax)
    rng = np.random.default_rng(7)
    for applied in (None, rng.standard_normal(grid.n)):
        gap_ext = _gaps(rng, grid.n, dmax)
        gap_ext[21:25] = 0.0  # a contact within its zone, whatever the random zone
        gap_ext[18:21] = gap_ext[25:28] = 0.5 * dmax
        gap_ext[0], gap_ext[-1] = gap_ext[-2], gap_ext[1]  # periodic ghosts
        u = rng.standard_normal(grid.n)
        wall = u + gap_ext[1:-1]
        wall[gap_ext[1:-1] == 0.0] = u[gap_ext[1:-1] == 0.0]  # on the wall exactly
        history = rng.standard_normal(grid.n)
        k_u = rng.standard_normal(grid.n)
        out = np.full(grid.n, np.nan)
        solver.problem.interface_traction(u, k_u, wall, history, 0.37, out, applied)
        expected = DugdaleMaugis(sigma_a, dmax).traction(
            np.r_[(wall - u)[-1], wall - u, (wall - u)[0]]
        )
        balance = k_u + history + 0.37
        if applied is not None:
            balance -= applied
        on_wall = wall - u <= 0.0
        expected[on_wall] = balance[on_wall]
        assert on_wall.any()
        np.testing.assert_allclose(out, expected, rtol=1e-14, atol=1e-15)
