"""The CG kernels' extremes against numpy: every length (the four lanes and their tail),
every span, NaN passed over as by one running max/min, and the entry bound of
``dot_and_entry`` against its definition node by node; the projection's compiled pass
against numpy's minimum to the bit."""
import numpy as np
import pytest

from hpcgfmd.solvers import step_kernels
from hpcgfmd.solvers.cg import kernels


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
    assert kernels._extremes(r, 9, 12) == (np.nanmax(_outside(r, 9, 12)),
                                           np.nanmin(_outside(r, 9, 12)))


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


@pytest.mark.parametrize("m, lo, hi, margin", [(41, 15, 22, 3), (41, 0, 5, 2), (41, 35, 41, 4),
                                               (9, 3, 3, 16), (6, 0, 6, 1), (0, 0, 0, 16)])
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
        free = step_kernels.below_wall(u, shift, wall, out)
        expected = np.minimum(u - shift, wall)
        assert out.tobytes() == expected.tobytes()
        assert free == np.count_nonzero(u - shift < wall)
