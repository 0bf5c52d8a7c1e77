"""Dugdale-Maugis law integrated over the linear interpolant (its energy against quadrature, its
traction against the energy's finite differences); contact-edge measures."""

import numpy as np
import pytest
from mpi4py import MPI

from hpcgfmd.model.interface import DugdaleMaugis, edge_positions
from hpcgfmd.parallel.domain import Domain


def periodic(gap):
    """The whole periodic grid as one block: its ghost nodes are its own ends."""
    return np.concatenate([gap[-1:], gap, gap[:1]])


def one_rank(n, cell):
    return Domain(MPI.COMM_SELF, n, cell, [(0, n)])


def test_traction_is_minus_energy_gradient():
    # Central differences of the element-integrated energy; the law is piecewise quadratic
    # in the gaps, so with h = 1e-7 dmax the difference is exact to round-off (~1e-8 sigma_a).
    rng = np.random.default_rng(1)
    law = DugdaleMaugis(sigma_a=2.0, dmax=0.1)
    n, dx = 64, 0.01
    gap = np.abs(np.cumsum(rng.normal(0, 0.03, n)))
    gap[10:14] = 0.0
    traction = law.traction(periodic(gap))
    h = 1e-7 * law.dmax
    for i in range(n):
        up, down = gap.copy(), gap.copy()
        up[i] += h
        down[i] -= h
        # u up = gap down: traction (upward) = dE/dg / dx
        fd = (law.energy(periodic(up), dx) - law.energy(periodic(down), dx)) / (2 * h) / dx
        assert traction[i] == pytest.approx(fd, abs=1e-6 * law.sigma_a)


def test_energy_is_the_law_integrated_over_the_linear_interpolant():
    # docs/model.md, "Discretisation": the element energy is -sigma_a times the integral of
    # max(dmax - g, 0) over the linear interpolant of its end gaps; here by quadrature (the
    # kink at g = dmax a break point), element by element around the periodic grid
    from scipy.integrate import quad

    law = DugdaleMaugis(sigma_a=2.0, dmax=0.1)
    n, dx = 64, 0.01
    gap = np.abs(np.random.default_rng(2).normal(law.dmax, 0.06, n))  # about dmax
    gap[10:14] = 0.0  # and a contact
    straddling = (gap - law.dmax) * (np.roll(gap, -1) - law.dmax) < 0
    assert np.count_nonzero(straddling) > 20  # elements with one end in the zone
    reference = 0.0
    for a, b in zip(gap, np.roll(gap, -1)):
        crossing = (law.dmax - a) / (b - a) if (a - law.dmax) * (b - law.dmax) < 0 else None
        reference -= (
            law.sigma_a
            * dx
            * quad(
                lambda s, a=a, b=b: max(law.dmax - (a + s * (b - a)), 0.0),
                0.0,
                1.0,
                points=None if crossing is None else [crossing],
                epsabs=1e-15,
                epsrel=1e-13,
            )[0]
        )
    assert law.energy(periodic(gap), dx) == pytest.approx(reference, rel=1e-12)


def test_traction_values_inside_outside_and_continuity():
    law = DugdaleMaugis(sigma_a=1.0, dmax=1.0)
    gap = np.linspace(0, 3, 301)
    t = law.traction(periodic(gap))
    assert np.allclose(t[1:99], 1.0)  # all elements inside the zone
    assert np.allclose(t[102:-1], 0.0)  # all elements outside
    assert np.all(np.abs(np.diff(t[:-1])) <= 0.6)  # no jump larger than the element's share
    # continuity in the gaps: moving the edge node across dmax changes t smoothly
    g = np.array([0.5, 0.999, 1.5, 2.0])
    g2 = g.copy()
    g2[1] = 1.001
    assert np.abs(law.traction(periodic(g)) - law.traction(periodic(g2))).max() < 0.01


def test_edge_interpolation_of_a_three_halves_gap():
    # gap = c (|x| - a)^(3/2) outside |x| < a is recovered exactly by the 3/2 model.
    x = (np.arange(200) - 100) * 0.01
    a = 0.4137
    gap = np.where(np.abs(x) > a, 0.2 * np.clip(np.abs(x) - a, 0, None) ** 1.5, 0.0)
    left, right = edge_positions(one_rank(200, 2.0), gap, 0.0, 1.5)
    assert right == pytest.approx(a, abs=1e-12)
    assert left == pytest.approx(-a, abs=1e-12)
    # no contact at all
    assert np.all(np.isnan(edge_positions(one_rank(200, 2.0), gap + 1.0, 0.0, 1.5)))


def test_edge_interpolation_of_a_linear_crossing():
    x = (np.arange(200) - 100) * 0.01
    gap = 0.5 + 3.0 * np.abs(x)  # crosses 1.2 at |x| = 0.2333...
    left, right = edge_positions(one_rank(200, 2.0), gap, 1.2, 1.0)
    assert right == pytest.approx(0.7 / 3.0, abs=1e-12)
    assert left == pytest.approx(-0.7 / 3.0, abs=1e-12)
