"""The sphere's references (docs/model.md, "The sphere"): closed forms against independent
evaluations (axisymmetric elasticity by quadrature, lattice sums, Fourier series of the cell,
Eq. 6 by quadrature) and their known limits."""

import math

import numpy as np
import pytest
from scipy import integrate, special

from hpcgfmd.model import sphere_theory as st
from hpcgfmd.model import theory

# --- the scaled problem and its groups -----------------------------------------------------

BASE = {
    "radius": 2e-3,
    "e0": 1.5e6,
    "einf": 1.5e7,
    "tau": 0.3,
    "work": 0.04,
    "dmax": 4e-8,
    "velocity": 2e-6,
    "depth": 3e-5,
    "cell": 5e-4,
}


def rescaled(case, length=1.0, stress=1.0, time=1.0, alpha=1.0):
    """The case in other units (R, E0, tau scaled; every group kept), and with alpha times
    alpha but lambda0, k, V_z, h0 / delta_s and L / a_s kept: dgamma0 -> alpha dgamma0 moves
    a_s by alpha^(1/3), delta_s by alpha^(2/3); sigma_a by alpha^(1/3) keeps lambda0."""
    c = dict(case)
    c["radius"] *= length
    c["e0"] *= stress
    c["einf"] *= stress
    c["tau"] *= time
    c["work"] *= stress * length
    for key in ("dmax", "depth", "cell"):
        c[key] *= length
    c["velocity"] *= length / time
    c["work"] *= alpha
    c["dmax"] *= alpha ** (2 / 3)  # sigma_a = dgamma0 / dmax grows by alpha^(1/3)
    c["velocity"] *= alpha ** (2 / 3)
    c["depth"] *= alpha ** (2 / 3)
    c["cell"] *= alpha ** (1 / 3)
    return c


def test_scaled_problem_depends_on_the_groups_only():
    # (M51): the coefficients formed from dimensional values; equal groups (other units, and
    # another alpha with equal H0 and L / a_s) give equal coefficients to round-off
    reference = st.scaled_problem(**BASE)
    for other in (
        rescaled(BASE, length=7.0, stress=0.01, time=300.0),
        rescaled(BASE, alpha=20.0),
        rescaled(BASE, length=0.1, stress=5.0, time=1e-3, alpha=1e-3),
    ):
        got = st.scaled_problem(**other)
        for key, value in reference.items():
            assert got[key] == pytest.approx(value, rel=1e-12), key
    # another alpha alone moves h0/R and L/R but not the scaled problem
    assert st.physical_groups(**rescaled(BASE, alpha=20.0))["depth"] != pytest.approx(
        st.physical_groups(**BASE)["depth"], rel=1e-3
    )


def test_scaled_coefficients_are_the_documented_functions_of_the_groups():
    # (M50)-(M52): stiffness 3/(4 lambda0), range 2/(pi lambda0), force factor lambda0/2,
    # H0 = (h0/R)(3 pi alpha/4)^(-2/3), L/a_s = (L/R)(3 pi alpha/4)^(-1/3)
    g = st.physical_groups(**BASE)
    c = st.scaled_problem(**BASE)
    lam, alpha = g["maugis"], g["adhesion"]
    assert c["stiffness"] == pytest.approx(3 / (4 * lam), rel=1e-12)
    assert c["range"] == pytest.approx(2 / (np.pi * lam), rel=1e-12)
    assert c["force_factor"] == pytest.approx(lam / 2, rel=1e-12)
    assert c["depth"] == pytest.approx(g["depth"] * (0.75 * np.pi * alpha) ** (-2 / 3), rel=1e-12)
    assert c["cell"] == pytest.approx(g["cell"] * (0.75 * np.pi * alpha) ** (-1 / 3), rel=1e-12)
    assert c["velocity"] == g["velocity"] and c["modulus_ratio"] == g["modulus_ratio"]
    # Maugis's lambda against Tabor's-like cylinder group (M20) of the same values:
    # lambda_sphere = (9 / (2 pi))^(1/3) lambda_cylinder
    cylinder = (BASE["work"] ** 2 * BASE["radius"] / (BASE["e0"] ** 2 * BASE["dmax"] ** 3)) ** (
        1 / 3
    )
    assert lam == pytest.approx((9 / (2 * np.pi)) ** (1 / 3) * cylinder, rel=1e-12)


def test_internal_values_are_the_case_in_units_of_r_e0_tau():
    # (M52): the groups' internal sigma_a, dmax, v_z, h0, L are the dimensional values
    # divided by E0, R and R / tau; their groups come back through physical_groups
    g = st.physical_groups(**BASE)
    values = st.internal_values(**g)
    r, e0, tau = BASE["radius"], BASE["e0"], BASE["tau"]
    assert values.sigma_a == pytest.approx(BASE["work"] / BASE["dmax"] / e0, rel=1e-12)
    assert values.dmax == pytest.approx(BASE["dmax"] / r, rel=1e-12)
    assert values.v_z == pytest.approx(BASE["velocity"] * tau / r, rel=1e-12)
    assert values.h0 == pytest.approx(BASE["depth"] / r, rel=1e-12)
    assert values.L * r / BASE["cell"] == pytest.approx(1.0, rel=1e-12)
    groups = st.SphereGroups(**g)
    back = st.physical_groups(
        1.0, 1.0, 1.0 / g["modulus_ratio"], 1.0, g["adhesion"], values.dmax, values.v_z,
        values.h0, values.L,
    )  # fmt: skip
    for key, value in g.items():
        assert back[key] == pytest.approx(value, rel=1e-12), key
    # the scales in R units: a_s and pi dgamma0 R of (M47), w0 = pi E0 dmax / (4 sigma_a)
    length, force, depth = st.scales(r, e0, BASE["work"])
    assert groups.beta == pytest.approx(length / r, rel=1e-12)
    assert groups.depth_scale == pytest.approx(depth / r, rel=1e-12)
    assert groups.load_scale == pytest.approx(force / (e0 * r**2), rel=1e-12)
    assert groups.zone_width == pytest.approx(np.pi * values.dmax / (4 * values.sigma_a), rel=1e-12)
    assert groups.lambda_inf == pytest.approx(
        st.maugis_parameter(r, BASE["einf"], BASE["work"], BASE["work"] / BASE["dmax"]), rel=1e-12
    )
    # chi_ve = (pi/4) v_z tau R / (a_s w0) (M53), from the dimensional values
    w0 = np.pi * e0 * BASE["dmax"] ** 2 / (4 * BASE["work"])
    chi = np.pi / 4 * BASE["velocity"] * tau * r / (length * w0)
    assert groups.chi_ve == pytest.approx(chi, rel=1e-12)


# --- Maugis-Dugdale against axisymmetric elasticity ----------------------------------------


def ring_deflection(r, pressure, breaks, modulus):
    """Surface deflection (into the body) at radius r under the axisymmetric pressure, by
    quadrature of the ring kernel w = (4 / (pi E*)) int p(rho) rho / (r + rho) K(k^2) drho,
    k^2 = 4 r rho / (r + rho)^2 (K's log singularity at rho = r: 1 - k^2 = ((r - rho) /
    (r + rho))^2 through ellipkm1, the interval split there)."""

    def integrand(rho):
        p = ((r - rho) / (r + rho)) ** 2
        return pressure(rho) * rho / (r + rho) * special.ellipkm1(p)

    edges = sorted({0.0, *breaks, *([r] if 0.0 < r < max(breaks) else [])})
    total = 0.0
    for lo, hi in zip(edges[:-1], edges[1:]):
        total += integrate.quad(integrand, lo, hi, limit=200, epsabs=1e-15, epsrel=1e-12)[0]
    return 4.0 / (np.pi * modulus) * total


@pytest.mark.parametrize("lam, abar", [(0.5, 0.8), (1.0, 1.2), (3.0, 0.6)])
def test_maugis_dugdale_is_the_dugdale_solution_of_an_elastic_half_space(lam, abar):
    # Maugis's pressure (Hertz's of radius a, plus -sigma_a on a < r < c and its image
    # -(2 sigma_a / pi) arctan(sqrt((c^2 - a^2) / (a^2 - r^2))) inside) summed by quadrature,
    # its deflection by the ring kernel: the force is Pbar, the contact follows the sphere at
    # depth Dbar, and the gap at c is dmax (the closure). Measured to 2e-13 (force), 2e-14
    # delta_s (deflection) and 1e-14 (gap): the tolerances leave the quadrature's 1e-12 margin.
    radius, modulus, work = 1.0, 1.0, 1e-3
    length, force, depth = st.scales(radius, modulus, work)
    sigma = lam / 2 * (np.pi * work * (4 * modulus / 3) ** 2 / radius) ** (1 / 3)
    pbar, dbar, m = st.maugis_dugdale(abar, lam)
    a = abar * length
    c = m * a
    k = np.sqrt(c * c - a * a)

    def pressure(rho):
        if rho < a:
            inner = np.sqrt(a * a - rho * rho)
            hertz = 2 * modulus / (np.pi * radius) * inner
            return hertz - 2 * sigma / np.pi * np.arctan2(k, inner)
        return -sigma if rho < c else 0.0

    load = sum(
        integrate.quad(lambda rho: 2 * np.pi * rho * pressure(rho), lo, hi, epsrel=1e-12)[0]
        for lo, hi in ((0.0, a), (a, c))
    )
    assert load / force == pytest.approx(pbar, rel=1e-9)
    # its second moment, the images' spread term of (M59), is the closed form's (inside, in
    # rho = a sin t: the arctan's square-root edge at a is smooth in t; 1e-15 measured)
    inside = integrate.quad(
        lambda t: 2 * np.pi * (a * np.sin(t)) ** 3 * pressure(a * np.sin(t)) * a * np.cos(t),
        0.0,
        np.pi / 2,
        epsabs=0,
        epsrel=1e-12,
    )[0]
    outside = integrate.quad(lambda rho: 2 * np.pi * rho**3 * pressure(rho), a, c, epsrel=1e-12)
    moment = (inside + outside[0]) / (force * length**2)
    assert moment == pytest.approx(st.traction_moment(abar, pbar, lam, m), rel=1e-12)
    delta = dbar * depth
    for r in (0.0, 0.4 * a, 0.9 * a):
        w = ring_deflection(r, pressure, (a, c), modulus)
        assert w == pytest.approx(delta - r * r / (2 * radius), abs=1e-9 * depth)
    gap = c * c / (2 * radius) - delta + ring_deflection(c, pressure, (a, c), modulus)
    assert gap == pytest.approx(work / sigma, rel=1e-8)


# --- limits ---------------------------------------------------------------------------------


def test_maugis_dugdale_tends_to_jkr_as_one_over_lambda_squared():
    # (M56) -> (M55) as lambda -> infinity: the force and depth differences fall 4x per
    # doubling of lambda (measured 4.00 +- 0.01 from lambda = 50); at lambda = 100 they are
    # below 1.1e-3 (force) and 3e-4 (depth) on 0.3 <= Abar <= 3 (measured 1.0e-3, 2.7e-4)
    abar = np.array([0.3, 0.6, 1.0, 1.5, 3.0])
    jkr_p, jkr_d = st.jkr(abar)
    errors = []
    for lam in (50.0, 100.0, 200.0):
        p, d, _ = st.maugis_dugdale(abar, lam)
        errors.append((np.max(np.abs(p - jkr_p)), np.max(np.abs(d - jkr_d))))
        if lam == 100.0:
            assert errors[-1][0] < 1.1e-3 and errors[-1][1] < 3e-4
    for first, second in zip(errors, errors[1:]):
        assert first[0] / second[0] == pytest.approx(4.0, rel=0.02)
        assert first[1] / second[1] == pytest.approx(4.0, rel=0.02)
    # the pull-off approaches -3/2 the same way (1.6e-3 at lambda 10, 1.6e-5 at 100)
    pulls = [st.maugis_dugdale_pull_off(lam)[1] + 1.5 for lam in (10.0, 100.0)]
    assert 0 > pulls[1] > -2e-5 and pulls[0] / pulls[1] == pytest.approx(100, rel=0.05)


def richardson(abar, lam, work_ratio=1.0):
    """Maugis's force and zone width (A (m - 1) lam^2) extrapolated to lambda -> infinity
    from lam and 2 lam (both O(1/lambda^2)); left O(1/lambda^4), 1e-8 relative here."""
    loads, widths = [], []
    for factor in (1.0, 2.0):
        p, _, m = st.maugis_dugdale(abar, factor * lam, work_ratio)
        loads.append(p)
        widths.append((factor * lam) ** 2 * abar * (m - 1.0))
    return (4 * loads[1] - loads[0]) / 3, (4 * widths[1] - widths[0]) / 3


@pytest.mark.parametrize("work", [1.0, 10.0])
def test_jkr_line_is_maugis_s_limit_and_carries_its_work(work):
    # (M55) against Maugis's curve of work r dgamma0 (same sigma_a) with its zone shrunk to
    # zero; the slope-1 line through each point gives back r
    abar = np.array([0.4, 1.0, 2.0, 4.0])
    limit, width = richardson(abar, 400.0, work)
    pbar, _ = st.jkr(abar, work)
    np.testing.assert_allclose(pbar, limit, rtol=1e-7, atol=1e-9)
    x, y = st.scaled_curve(abar, limit)
    np.testing.assert_allclose(st.effective_work_ratio(x, y), work, rtol=1e-6)
    # the zone: pi E0 dmax_r / (4 sigma_a) with dmax_r = r dmax, i.e. r times (M53)'s
    # 3 / (4 lambda0^2) (the instantaneous limit's w0 / k, (M57))
    np.testing.assert_allclose(width, st.cohesive_width(1.0) * work, rtol=1e-6)


def test_jkr_pull_offs():
    # Johnson, Kendall and Roberts (1971); Maugis 1992: -3/2 pi dgamma R under load control,
    # -5/6 under fixed grips at a^3 = a0^3 / 36 (a0^3 = 6 pi dgamma R^2 / K, zero load)
    a, p, d = st.jkr_pull_off()
    assert p == pytest.approx(-1.5, rel=1e-14) and a**3 == pytest.approx(1.5, rel=1e-14)
    a0 = 6 ** (1 / 3)
    a, p, d = st.jkr_pull_off(control="displacement")
    assert p == pytest.approx(-5 / 6, rel=1e-14) and a == pytest.approx(a0 / 36 ** (1 / 3))
    assert st.jkr(a0)[0] == pytest.approx(0.0, abs=1e-14)
    # the depth there is the least: the curve's slope dD/dA vanishes
    step = 1e-5
    slope = (st.jkr(a + step)[1] - st.jkr(a - step)[1]) / (2 * step)
    assert abs(slope) < 1e-8
    assert d == pytest.approx(-3 * 6 ** (-2 / 3), rel=1e-14)
    # and the same points as lambda -> infinity of Maugis's (within 1e-4 at lambda = 100)
    for control in ("load", "displacement"):
        got, want = st.maugis_dugdale_pull_off(100.0, control), st.jkr_pull_off(1.0, control)
        np.testing.assert_allclose(got, want, atol=1e-3)


def test_bradley_limit_of_the_pull_off():
    # lambda -> 0: the rigid sphere's 2 pi dgamma R (Bradley 1932). The curve's end Abar -> 0
    # gives Pbar + 2 -> (8/3)(pi/2 - 1)(2 / sqrt(pi)) lambda^(3/2) (M56); the least force lies
    # just below it (0.3 % of the difference at lambda = 0.01)
    coefficient = 8 / 3 * (np.pi / 2 - 1) * 2 / np.sqrt(np.pi)
    for lam in (1e-3, 1e-2):
        _, pbar, _ = st.maugis_dugdale_pull_off(lam)
        assert (pbar + 2) / (coefficient * lam**1.5) == pytest.approx(1.0, rel=0.01)
        _, end, _ = st.maugis_dugdale_zero_contact(lam)
        assert pbar <= end
    # the end is the curve's limit: Maugis's closure at a tiny Abar
    c, end, dend = st.maugis_dugdale_zero_contact(0.5)
    p, d, m = st.maugis_dugdale(1e-7, 0.5)
    assert m * 1e-7 == pytest.approx(c, rel=1e-6)
    assert (p, d) == pytest.approx((end, dend), rel=1e-6)


def test_pull_off_between_bradley_and_jkr_and_monotone():
    # the least force rises monotonically from -2 (lambda -> 0) to -3/2 (lambda -> inf)
    # (Johnson and Greenwood 1997, Fig. 2); under fixed grips there is no jump below
    # lambda ~ 0.9 (the depth falls to the end Abar -> 0) and one above
    lams = [0.05, 0.3, 1.0, 3.0, 10.0]
    pulls = [st.maugis_dugdale_pull_off(lam)[1] for lam in lams]
    assert pulls[0] > -2 and pulls[-1] < -1.5 and np.all(np.diff(pulls) > 0)
    assert st.maugis_dugdale_pull_off(0.5, "displacement")[0] == 0.0
    a, p, d = st.maugis_dugdale_pull_off(1.0, "displacement")
    assert a > 0 and d < st.maugis_dugdale(a * 1.01, 1.0)[1]
    assert d < st.maugis_dugdale(a * 0.99, 1.0)[1]


def test_hertz_is_maugis_dugdale_without_adhesion():
    # dimensional Maugis-Dugdale at a fixed contact radius and range, dgamma -> 0 (so
    # sigma_a -> 0): force and depth tend to Hertz's K a^3 / R and a^2 / R (M54), the
    # difference falling in proportion to sigma_a (ratios within 20 % of 10 per decade)
    radius, modulus, a, dmax = 1.0, 1.0, 0.05, 1e-3
    errors = []
    for work in (1e-7, 1e-8, 1e-9):
        length, force, depth = st.scales(radius, modulus, work)
        lam = st.maugis_parameter(radius, modulus, work, work / dmax)
        p, d, _ = st.maugis_dugdale(a / length, lam)
        hp, hd = st.hertz(a / length)
        errors.append((abs(p / hp - 1), abs(d / hd - 1)))
        assert p * force == pytest.approx(4 * modulus * a**3 / (3 * radius), rel=2e-2)
        assert d * depth == pytest.approx(a * a / radius, rel=2e-2)
    for first, second in zip(errors, errors[1:]):
        assert 8 < first[0] / second[0] < 12 and 8 < first[1] / second[1] < 12


def test_instantaneous_limit_curve_is_maugis_s_with_the_instantaneous_work():
    # (M57): E0 bulk, dgamma_inf = dgamma0 / k, the same sigma_a, formed dimensionally
    lambda0, k = 3.0, 0.1
    limit = st.instantaneous_limit(lambda0, k)
    assert limit.work_ratio == 10.0
    radius, e0, work = 1.0, 1.0, 1e-3
    sigma = lambda0 / 2 * (np.pi * work * (4 * e0 / 3) ** 2 / radius) ** (1 / 3)
    assert limit.lambda_inf == pytest.approx(
        st.maugis_parameter(radius, e0 / k, work, sigma), rel=1e-12
    )
    assert limit.lambda_curve == pytest.approx(
        st.maugis_parameter(radius, e0, work / k, sigma), rel=1e-12
    )
    length0, force0, depth0 = st.scales(radius, e0, work)
    length, force, depth = st.scales(radius, e0, work / k)
    a = np.array([0.3, 0.7, 1.5]) * length0
    p, d, _ = st.maugis_dugdale(a / length0, lambda0, limit.work_ratio)
    own_p, own_d, _ = st.maugis_dugdale(a / length, limit.lambda_curve)
    np.testing.assert_allclose(p * force0, own_p * force, rtol=1e-12)
    np.testing.assert_allclose(d * depth0, own_d * depth, rtol=1e-12)


# --- Persson-Brener -----------------------------------------------------------------------


@pytest.mark.parametrize("rhodot", [1e-5, 3e-4, 1e-2])
def test_peel_velocity_of_the_sphere_against_eq6_in_internal_units(rhodot):
    # Eq. 6 with Eq. 7 in units R = E0 = tau = 1, c0 = dgamma0 E0 / (pi sigma_a^2) from the
    # sphere's sigma_a (M52), against the closed form at the sphere's vbar (M58)
    k, lam, alpha = 0.1, 3.0, 5e-5
    groups = st.SphereGroups(lam, k, 1.0, 0.05, 4.0, alpha)
    c0 = alpha / (np.pi * groups.sigma_a**2)

    def modulus(omega):
        return 1.0 + (1.0 / k - 1.0) * 1j * omega / (1.0 + 1j * omega)

    direct = theory.persson_brener_modulus(rhodot, c0, modulus)
    vbar = st.peel_velocity(rhodot, 1.0, k, lam, groups.beta)
    assert theory.persson_brener(float(vbar), k) == pytest.approx(direct, rel=1e-7)
    # c0 = (4 / pi^2) w0 (M58)
    assert st.tip_radius(lam, groups.beta) == pytest.approx(
        4 / np.pi**2 * groups.zone_width, rel=1e-12
    )


# --- the periodic cell ---------------------------------------------------------------------


def test_lattice_constants():
    # MADELUNG_SQUARE by Ewald summation (independent of the splitting eta); LATTICE_SUM_3
    # as 4 zeta(3/2) beta(3/2) (Hurwitz zeta)
    i, j = np.meshgrid(np.arange(-12, 13), np.arange(-12, 13))
    n = np.hypot(i, j).ravel()
    n = n[n > 0]
    for eta in (1.5, 2.5):
        real = np.sum(special.erfc(eta * n) / n)
        g = 2 * np.pi * n
        reciprocal = 2 * np.pi * np.sum(special.erfc(g / (2 * eta)) / g)
        total = real + reciprocal - 2 * eta / np.sqrt(np.pi) - 2 * np.sqrt(np.pi) / eta
        assert total == pytest.approx(st.MADELUNG_SQUARE, abs=1e-12)
    beta = 4**-1.5 * (special.zeta(1.5, 0.25) - special.zeta(1.5, 0.75))
    assert 4 * special.zeta(1.5) * beta == pytest.approx(st.LATTICE_SUM_3, rel=1e-13)


def cell_deflection(p0, a, cell, n, xs):
    """Deflection (into the body) of the zero-mean periodic surface under the pressure
    p0 sqrt(1 - r^2/a^2) (r < a) repeated on the square lattice of period ``cell``, E* = 1,
    at (x, 0): the Fourier series 2 p~(q) / |q| over |q_x|, |q_y| < pi n / cell, with the
    disc's exact transform p~ = 2 pi p0 a^2 (sin qa - qa cos qa) / (qa)^3. Truncation:
    below 1e-5 of the deflection here."""
    q1 = 2 * np.pi * np.fft.fftfreq(n, d=cell / n)
    qx, qy = np.meshgrid(q1, q1, indexing="ij")
    q = np.hypot(qx, qy)
    q[0, 0] = 1.0
    qa = q * a
    weight = 2 * np.pi * p0 * a * a * (np.sin(qa) - qa * np.cos(qa)) / qa**3 * 2 / q
    weight[0, 0] = 0.0  # zero mean
    return np.array([np.sum(weight * np.cos(qx * x)) / cell**2 for x in xs])


@pytest.mark.parametrize("ratio", [0.1, 0.2])
def test_hertz_in_the_cell_against_the_periodic_fourier_series(ratio):
    # (M59): the contact radius a in the cell of period L = a / ratio; the pressure Hertz's
    # for R' (force Pbar of periodic_cell) on every cell; the zero-mean deflection must be
    # the sphere's, Dbar delta_s - r^2 / (2 R), in the contact. The depth carries the lift
    # 1.66 (a/L) Abar^2 and the spread's 0.23 (a/L)^2 of it (3.8e-4 and 3.1e-3 Abar^2 at
    # a/L = 0.1 and 0.2); the terms left out are O((a/L)^5): measured 7.3e-7 and 2.3e-5
    # Abar^2 (tolerance 1e-4, against the spread's 3.8e-4 and 3.1e-3). The curvature's next
    # terms: 1.5e-5 and 5.1e-4 (tolerance 2e-3, against the images' 1.9e-3 and 1.5e-2)
    radius, work = 1.0, 1e-3
    length, force, depth = st.scales(radius, 1.0, work)
    abar = 2.0
    a = abar * length
    cell = a / ratio
    pbar, dbar = st.periodic_cell(abar, cell / length, work_ratio=0.0)
    p0 = 3 * pbar * force / (2 * np.pi * a * a)  # Hertz's peak for the force Pbar
    w0, w1 = cell_deflection(p0, a, cell, 2048, (0.0, 0.5 * a))
    assert w0 / depth == pytest.approx(dbar, abs=1e-4 * abar**2)
    isolated = st.hertz(abar)[1]
    assert abs(w0 / depth - isolated) > 0.1 * abar**2 * ratio  # the offset is seen
    curvature = (w0 - w1) / (0.25 * a * a) * 2 * radius  # 1 for the sphere
    assert curvature == pytest.approx(1.0, abs=2e-3)
    assert st.periodic_load_factor(a, cell) == pytest.approx(pbar / abar**3, rel=1e-12)


def test_periodic_cell_of_maugis_dugdale_tends_to_jkr_s():
    # the fixed point on Maugis's curve at large lambda against the closed JKR form in the
    # cell (the same images); both reduce to the isolated curves as L grows (offset ~ 1/L)
    abar = np.array([0.5, 1.0, 2.0])
    jkr = st.periodic_cell(abar, 8.0)
    md = st.periodic_cell(abar, 8.0, lam=4000.0)
    np.testing.assert_allclose(md[0], jkr[0], atol=2e-6)
    np.testing.assert_allclose(md[1], jkr[1], atol=2e-6)
    far = st.periodic_cell(abar, 1e6, lam=1.0)
    isolated = st.maugis_dugdale(abar, 1.0)
    np.testing.assert_allclose(far[0], isolated[0], rtol=1e-12)
    np.testing.assert_allclose(far[1], isolated[1], atol=1e-5)
    assert math.isfinite(st.periodic_cell(1.0, 8.0, lam=1.0)[0])
