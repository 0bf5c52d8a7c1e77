"""The quadratic SLS and Prony step (docs/model.md, (M46)) against the exact convolution of a
prescribed displacement history.

One Fourier mode u(x, t) = g(t) cos(2 pi x / L) on a relaxed start (g(0) = g'(0) = 0), whose
exact substrate traction is p = (|q|/2) [E0 g + sum_i E_i int_0^t exp(-(t - s)/tau_i) g'(s) ds]
cos(2 pi x / L). The step is the protocol's: the history H' of the step given the step
before, then p_{n+1} = K' u_{n+1} + H' with K' the step's stiffness. A quadratic g is
followed to round-off (the step's polynomial is exact); a smooth one converges at third order
(the interpolation error of a quadratic, dt^3 g''', kept over the memory: global third order).
"""

import math

import numpy as np
import pytest
from mpi4py import MPI
from scipy.integrate import quad

from hpcgfmd.model.halfspace import MaxwellHalfSpace
from hpcgfmd.model.material import GeneralizedMaxwell
from hpcgfmd.parallel.domain import Domain
from hpcgfmd.parallel.fft import aligned_empty, plan_real_fft

N, CELL, E0 = 32, 1.0, 1.0
SLS = GeneralizedMaxwell.standard_linear(E0, 10.0, 1.0)
TWO_BRANCHES = GeneralizedMaxwell(E0, (6.0, 3.0), (0.3, 2.0))


class Mode:
    """The stepped and the exact traction of u = g(t) cos(2 pi x / L) on ``material``."""

    def __init__(self, material, g, dg):
        self.material, self.g, self.dg = material, g, dg
        self.fft = plan_real_fft(MPI.COMM_SELF, N, planner_effort="FFTW_ESTIMATE")
        self.domain = Domain(MPI.COMM_SELF, N, CELL, self.fft.x_blocks)
        self.shape = np.cos(2 * np.pi * self.domain.x / CELL)
        half_q = np.pi * np.abs(self.fft.wavenumber) / CELL
        self.half_q_mode = np.pi / CELL
        self.substrate = MaxwellHalfSpace(material, half_q, N, N)

    def u(self, t):
        out = aligned_empty(N)
        out[:] = self.g(t) * self.shape
        return out

    def branch_memory(self, t, tau):
        return (
            quad(
                lambda s: math.exp(-(t - s) / tau) * self.dg(s), 0.0, t, epsabs=1e-15, epsrel=1e-13
            )[0]
            if t > 0
            else 0.0
        )

    def exact(self, t):
        """Exact traction amplitude of the mode (stress)."""
        m = self.material
        return self.half_q_mode * (
            E0 * self.g(t)
            + sum(e * self.branch_memory(t, tau) for e, tau in zip(m.branch_moduli, m.branch_times))
        )

    def start(self, h):
        """The exact state at t = h (the linear first step from the relaxed t = 0 replaced
        by the exact one): p, G_h, G_0 and the stored branches' tractions (all but the
        first, whose stress p implies)."""
        sub, m = self.substrate, self.material
        sub.traction[:] = self.exact(h) * self.shape
        sub.relaxed[:] = self.half_q_mode * self.g(h) * self.shape
        sub.relaxed_before[:] = self.half_q_mode * self.g(0.0) * self.shape
        for branch, e, tau in zip(sub.branches, m.branch_moduli[1:], m.branch_times[1:]):
            branch[:] = self.half_q_mode * e * self.branch_memory(h, tau) * self.shape
        return sub.traction

    def run(self, h, steps):
        """Quadratic steps of length h from the exact state at t = h: the largest error of
        the traction amplitude over the largest exact amplitude."""
        p = self.start(h)
        history, elastic = aligned_empty(N), aligned_empty(N)
        worst = scale = 0.0
        for j in range(1, 1 + steps):
            self.substrate.history(h, history, h)
            ops = self.substrate.operators(h, h)
            self.fft.apply_diagonal(self.u((j + 1) * h), ops.stiffness, elastic)
            self.substrate.update(elastic, history, h, h)
            assert self.substrate.last_step_quadratic
            exact = self.exact((j + 1) * h)
            worst = max(worst, abs(2.0 * np.mean(p * self.shape) - exact))
            scale = max(scale, abs(exact))
        return worst / scale


@pytest.mark.parametrize("material", [SLS, TWO_BRANCHES], ids=["sls", "two-branches"])
def test_a_quadratic_history_is_followed_to_roundoff(material):
    mode = Mode(material, lambda t: 0.3 * t * t, lambda t: 0.6 * t)
    assert mode.run(0.4, 12) < 1e-12


@pytest.mark.parametrize("material", [SLS, TWO_BRANCHES], ids=["sls", "two-branches"])
def test_a_smooth_history_converges_at_third_order(material):
    # g(0) = g'(0) = 0; g''' does not vanish
    g, dg = (lambda t: 1.0 - math.cos(t) + 0.2 * t**3), (lambda t: math.sin(t) + 0.6 * t * t)
    span = 2.0
    errors = [Mode(material, g, dg).run(span / steps, steps - 1) for steps in (8, 16, 32)]
    orders = [math.log2(a / b) for a, b in zip(errors, errors[1:])]
    # the interpolation error of a quadratic is dt^3 g''' / 6 per unit time: order 3
    assert all(2.7 < order < 3.3 for order in orders), (errors, orders)


def test_branches_of_one_time_step_as_one_branch():
    """The stored branches (two of one time) and the implied one (one of their summed
    modulus) are two evaluations of one solid: their quadratic steps agree to round-off."""
    one, two = (
        GeneralizedMaxwell(E0, (9.0,), (1.0,)),
        GeneralizedMaxwell(E0, (4.5, 4.5), (1.0, 1.0)),
    )
    g, dg = (lambda t: math.sin(t) ** 2), (lambda t: math.sin(2 * t))
    modes = (Mode(one, g, dg), Mode(two, g, dg))
    tractions = [mode.start(0.3) for mode in modes]
    history, elastic = aligned_empty(N), aligned_empty(N)
    for j, (dt, before) in enumerate([(0.2, 0.3), (0.5, 0.2), (0.5, 0.5), (0.1, 0.5)]):
        t = 0.3 + sum((0.2, 0.5, 0.5, 0.1)[: j + 1])
        for mode in modes:
            mode.substrate.history(dt, history, before)
            mode.fft.apply_diagonal(
                mode.u(t), mode.substrate.operators(dt, before).stiffness, elastic
            )
            mode.substrate.update(elastic, history, dt, before)
        np.testing.assert_allclose(
            tractions[1], tractions[0], rtol=0, atol=1e-13 * np.abs(tractions[0]).max()
        )


def test_a_step_solved_again_updates_from_its_start():
    """The compliant drive solves a step several times: each update of the step starts from
    the state of the step's start, so the last one is the step's (two branches, quadratic)."""
    g, dg = (lambda t: math.sin(t) ** 2), (lambda t: math.sin(2 * t))
    again, once = Mode(TWO_BRANCHES, g, dg), Mode(TWO_BRANCHES, g, dg)
    history, elastic = aligned_empty(N), aligned_empty(N)
    for mode in (again, once):
        mode.start(0.3)
        mode.substrate.history(0.2, history, 0.3)
        if mode is again:  # a first attempt at another displacement
            mode.fft.apply_diagonal(
                mode.u(0.9), mode.substrate.operators(0.2, 0.3).stiffness, elastic
            )
            mode.substrate.update(elastic, history, 0.2, 0.3)
        mode.fft.apply_diagonal(mode.u(0.5), mode.substrate.operators(0.2, 0.3).stiffness, elastic)
        mode.substrate.update(elastic, history, 0.2, 0.3)
    for name, array in once.substrate.state().arrays.items():
        np.testing.assert_array_equal(again.substrate.state().arrays[name], array, name)
