"""The CG kernels against numpy: the extremes (integer keys of the bits) on every span, NaN
passed over as by one running max/min; the entry bound against its definition node by node,
alone and fused with the direction's update and projection; the fused passes of the step,
the residual and the start of a solve across chunk ends; the projection's compiled pass
against numpy's minimum to the bit."""

import numpy as np
import pytest

from hpcgfmd.solvers import extremes, kernels, step_kernels


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


def _entry_reference(d, gap, lo, hi, level, margin):
    """The entry bound from its definition: the nodes within ``margin`` of [lo, hi) give their
    exact entry length, the farther ones min(gap - level) / max(d) (numpy)."""
    m = d.size
    outside = np.r_[0:lo, hi:m]
    rising = outside[d[outside] > 0.0]
    near = rising[(rising >= lo - margin) & (rising < hi + margin)]
    far = outside[(outside < lo - margin) | (outside >= hi + margin)]
    rise = d[far].max() if far.size else 0.0
    bound = (gap[far].min() - level) / rise if rise > 0.0 else np.inf
    near_exact = ((gap[near] - level) / d[near]).min() if near.size else np.inf
    exact = (gap[rising] - level) / d[rising]
    return min(bound, near_exact), (exact.min() if rising.size else np.inf)


# spans at the block's ends, inside, empty; blocks of a few nodes and of several chunks
ENTRY_CASES = [
    (41, 15, 22, 3),
    (41, 0, 5, 2),
    (41, 35, 41, 4),
    (9, 3, 3, 16),
    (6, 0, 6, 1),
    (0, 0, 0, 16),
    (2 * kernels.CHUNK + 37, kernels.CHUNK - 5, kernels.CHUNK + 9, 700),
]


# spans (p, q, lo, hi) in blocks of several chunks: across a chunk's end, at the block's ends
RESIDUAL_CASES = [
    (
        3 * kernels.CHUNK + 11,
        kernels.CHUNK - 3,
        2 * kernels.CHUNK + 5,
        kernels.CHUNK - 2,
        2 * kernels.CHUNK + 4,
    ),
    (kernels.CHUNK + 1, 0, kernels.CHUNK + 1, 0, kernels.CHUNK + 1),
    (37, 0, 3, 0, 2),
    (37, 12, 20, 13, 19),
    (5, 0, 0, 0, 0),
]


@pytest.mark.parametrize("m, p, q, lo, hi", RESIDUAL_CASES)
def test_step_and_residual_in_one_pass(m, p, q, lo, hi):
    """The accepted step (u, gap, load) and the next residual against numpy: the same bits
    node by node, the sum to round-off, the extremes outside [lo, hi) exactly."""
    rng = np.random.default_rng(m + p)
    u, d, load, kd, gap, traction = (rng.standard_normal(m) for _ in range(6))
    traction[:p] = traction[q:] = 0.0
    length = 0.37
    expected_u, expected_gap = u + length * d, gap - length * d
    expected_load = load + length * kd
    expected_r = -expected_load
    expected_r[p:q] += traction[p:q]
    r = np.empty(m)
    total, high, low = kernels.update_and_residual(
        u, d, load, kd, gap, length, traction, p, q, lo, hi, r
    )
    for got, want in ((u, expected_u), (gap, expected_gap), (load, expected_load), (r, expected_r)):
        np.testing.assert_array_equal(got, want)
    # reassociated: a few ulps of the sum of |r| per node
    assert total == pytest.approx(expected_r.sum(), abs=1e-14 * (np.abs(expected_r).sum() + 1))
    rest = _outside(expected_r, lo, hi)
    assert (high, low) == ((rest.max(), rest.min()) if rest.size else (-np.inf, np.inf))


@pytest.mark.parametrize("m, p, q, lo, hi", RESIDUAL_CASES)
def test_start_of_a_solve_is_the_residual(m, p, q, lo, hi):
    """start_point and residual_span give what the gaps, numpy's near scan and
    :func:`kernels.residual` give: load, gap and r to the bit, the same extremes."""
    rng = np.random.default_rng(2 * m + q)
    u, wall, k_u, linear, traction = (rng.standard_normal(m) for _ in range(5))
    traction[:p] = traction[q:] = 0.0
    load, gap, r = np.empty(m), np.empty(m), np.empty(m)
    level = -0.5
    total, scan = kernels.start_point(u, wall, k_u, linear, load, gap, r, level)
    np.testing.assert_array_equal(load, k_u + linear)
    np.testing.assert_array_equal(gap, wall - u)
    assert scan == kernels.near(wall - u, level)
    total, high, low = kernels.residual_span(r, traction, p, q, lo, hi, total)
    expected = np.empty(m)
    reference = kernels.residual(k_u + linear, traction, p, q, lo, hi, expected)
    np.testing.assert_array_equal(r, expected)
    assert (high, low) == reference[1:]
    assert total == pytest.approx(reference[0], abs=1e-14 * (np.abs(expected).sum() + 1))


@pytest.mark.parametrize("m, lo, hi, margin", ENTRY_CASES)
def test_entry_bound_below_every_node_outside(m, lo, hi, margin):
    """No node outside [lo, hi) reaches ``level`` along d before the returned length, and
    the nodes within the margin give their exact entry lengths: the bound alone, formed
    with the direction update and with the projection of a restarting direction."""
    rng = np.random.default_rng(m + lo)
    d, d_old = rng.standard_normal(m), rng.standard_normal(m)
    level = 0.1
    gap = level + rng.uniform(0.01, 1.0, m)
    expected, exact = _entry_reference(d, gap, lo, hi, level, margin)
    entry = kernels.entry_bound(d, gap, lo, hi, level, margin)
    assert entry <= exact
    assert entry == expected
    # d = z + 0.7 d_old, formed by the update (the same bits as numpy's)
    z = d - 0.7 * d_old
    y = z.copy()
    entry = kernels.axpy_entry(y, d_old, 0.7, gap, lo, hi, level, margin)
    np.testing.assert_array_equal(y, z + 0.7 * d_old)
    assert entry == _entry_reference(y, gap, lo, hi, level, margin)[0]
    # a restarting direction is z itself, projected: z - shift, 0 on the pressed nodes
    pressed = rng.uniform(size=hi - lo) < 0.5
    z = d.copy()
    r, r_old = rng.standard_normal(m), rng.standard_normal(m)
    sums = kernels.project_direction(
        z, 0.3, lo, hi, pressed, r, r_old, d_old, True, gap, level, margin
    )
    projected = d - 0.3
    projected[lo:hi][pressed] = 0.0
    np.testing.assert_array_equal(z, projected)
    assert sums[3] == _entry_reference(projected, gap, lo, hi, level, margin)[0]


@pytest.mark.parametrize("m, lo, hi, margin", ENTRY_CASES)
def test_projected_direction_and_its_dots(m, lo, hi, margin):
    """z - shift with the pressed nodes zeroed, and r.z, r_old.z, r.d_old against numpy
    (summed in another order: to round-off of the sums of |terms|)."""
    rng = np.random.default_rng(3 * m + hi)
    z, r, r_old, d_old = (rng.standard_normal(m) for _ in range(4))
    pressed = rng.uniform(size=hi - lo) < 0.3
    expected = z - 0.2
    expected[lo:hi][pressed] = 0.0
    gap = np.ones(m)
    sums = kernels.project_direction(
        z, 0.2, lo, hi, pressed, r, r_old, d_old, False, gap, 0.1, margin
    )
    np.testing.assert_array_equal(z, expected)
    # reassociated sums of m terms of size ~1: a few ulps of the sum of |terms| per node
    for value, a, b in zip(sums[:3], (r, r_old, r), (expected, expected, d_old), strict=True):
        assert value == pytest.approx(float(a @ b), abs=1e-14 * (np.abs(a * b).sum() + 1.0))
    assert sums[3] == np.inf


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


SPECIAL = [np.nan, -np.nan, np.inf, -np.inf, 0.0, -0.0, 5e-324, -5e-324, 1e308, -1e308]


@pytest.mark.parametrize("m", [0, 1, 5, 17, 300])
def test_integer_extremes_are_the_float_extremes(m):
    """max_min and low_scan against numpy's nanmax/nanmin (NaN passed over, infinities and
    subnormals ordered), every slice of short blocks."""
    rng = np.random.default_rng(m)
    a = rng.standard_normal(m) * 10.0 ** rng.integers(-300, 300, m)
    b = rng.standard_normal(m)
    if m:
        a[rng.integers(0, m, min(m, 4))] = rng.choice(SPECIAL, min(m, 4))
        b[rng.integers(0, m, min(m, 4))] = rng.choice(SPECIAL, min(m, 4))
    for first in range(0, m + 1, max(1, m // 7)):
        for last in range(first, m + 1, max(1, m // 5)):
            high, low = extremes.max_min(a, b, first, last, -np.inf, np.inf)
            x, y = a[first:last], b[first:last]
            x, y = x[~np.isnan(x)], y[~np.isnan(y)]
            assert high == (x.max() if x.size else -np.inf)
            assert low == (y.min() if y.size else np.inf)
    level = 0.5
    first, last, smallest = extremes.low_scan(b, level)
    below = np.flatnonzero(b < level)
    assert (first, last) == ((below[0], below[-1]) if below.size else (m, -1))
    finite = b[~np.isnan(b)]
    assert smallest == (finite.min() if finite.size else np.inf)


def test_signed_zeros_order():
    """-0.0 sorts below +0.0 (either is the extreme of the other as numbers)."""
    z = np.array([0.0, -0.0])
    high, low = extremes.max_min(z, z, 0, 2, -np.inf, np.inf)
    assert high == 0.0 and low == 0.0
    assert not np.signbit(high) and np.signbit(low)


def test_feasibility_and_equality():
    """The read-only test of a feasible start and the compiled equality against numpy."""
    rng = np.random.default_rng(5)
    m = 3000
    wall = rng.standard_normal(m)
    u = wall - np.abs(rng.standard_normal(m))
    u[::7] = wall[::7]  # on the wall: not free, not moved
    moved, free, high = step_kernels.feasibility(u, wall)
    assert (moved, free, high) == (0, np.count_nonzero(u < wall), np.abs(wall).max())
    u[[4, 2999]] = wall[[4, 2999]] + 1.0
    wall[10] = np.nan
    moved, free, high = step_kernels.feasibility(u, wall)
    assert moved == 3 and high == np.nanmax(np.abs(wall))
    v = u.copy()
    assert step_kernels.equal(u, v)
    for i in (0, 1023, 1024, m - 1):
        v = u.copy()
        v[i] += 1e-300 if v[i] == 0.0 else abs(v[i]) * 1e-15
        assert not step_kernels.equal(u, v)


def test_on_wall_and_pushed_nodes():
    """The on-wall mask with its first and last node, and the pushed ones, against numpy."""
    rng = np.random.default_rng(9)
    m, lo, hi = 200, 40, 170
    gap = rng.uniform(-1.0, 1.0, m)
    d = rng.standard_normal(m)
    on = np.zeros(m, dtype=bool)
    count, first, last = kernels.on_wall(gap, lo, hi, 0.1, on)
    expected = gap[lo:hi] <= 0.1
    np.testing.assert_array_equal(on[: hi - lo], expected)
    where = lo + np.flatnonzero(expected)
    assert (count, first, last) == (expected.sum(), where[0], where[-1])
    pushed = np.zeros(m, dtype=bool)
    count = kernels.pushed(d, lo, hi, on, pushed)
    np.testing.assert_array_equal(pushed[: hi - lo], expected & (d[lo:hi] > 0.0))
    assert count == np.count_nonzero(expected & (d[lo:hi] > 0.0))
    assert kernels.on_wall(np.ones(m), lo, hi, 0.1, on)[1:] == (hi, lo - 1)  # none on it
