"""Analytic references: closed forms against independent evaluations."""

import numpy as np
import pytest

from hpcgfmd.model import theory


@pytest.mark.parametrize("k", [0.1, 0.5])
@pytest.mark.parametrize("vbar", [0.01, 0.3, 1.0, 5.0, 100.0])
def test_persson_brener_closed_form_equals_quadrature_of_eq6(vbar, k):
    # Eq. 8 is the exact SLS evaluation of Eq. 6 with the retardation-time convention;
    # the quadrature is accurate to ~1e-10, so 1e-8 relative leaves margin.
    closed = theory.persson_brener(vbar, k)
    direct = theory.persson_brener_quadrature(vbar, k)
    assert closed == pytest.approx(direct, rel=1e-8)


def test_persson_brener_limits_and_monotonicity():
    k = 0.1
    v = np.logspace(-4, 5, 40)
    c = theory.persson_brener(v, k)
    assert c[0] == pytest.approx(1.0, abs=1e-3)
    assert c[-1] == pytest.approx(1.0 / k, rel=1e-3)
    assert np.all(np.diff(c) > 0)


def test_maugis_dugdale_closure_and_jkr_limit():
    abar = np.array([1.0, 3.0, 6.0])
    lbar, m = theory.maugis_dugdale(abar, 3.5)
    assert np.all(np.abs(theory._md_closure(m, abar, 3.5)) < 1e-10)
    assert np.all(m > 1)
    # lambda -> infinity recovers JKR; the difference is O(m - 1) = O(w/a) = O(1/lambda^2).
    err = [
        np.max(np.abs(theory.maugis_dugdale(abar, lam)[0] - theory.jkr_load(abar)))
        for lam in (50.0, 100.0, 200.0)
    ]
    assert err[0] > err[1] > err[2]
    assert err[1] / err[2] == pytest.approx(4.0, rel=0.05)


def baney_hui_limit(abar, lam=100.0):
    """The lambda -> infinity limits of Baney-Hui's load (M26) and of its zone width
    a_c (m - 1) (in beta) times lambda^2, by Richardson extrapolation from lambda and
    2 lambda: both approach their limits as 1/lambda^2 (docs/model.md, after (M27)); what is
    left is O(1/lambda^4), measured up to 2.4e-9 relative at lambda = 100."""
    loads, widths = [], []
    for factor in (1.0, 2.0):
        load, m = theory.maugis_dugdale(abar, factor * lam)
        loads.append(load)
        widths.append((factor * lam) ** 2 * abar * (m - 1.0))
    return (4 * loads[1] - loads[0]) / 3, (4 * widths[1] - widths[0]) / 3


@pytest.mark.parametrize("work", [1.0, 3.0, 10.0])
def test_jkr_line_is_baney_hui_s_limit_and_carries_its_work(work):
    # Eq. 10 (M25) against an independent derivation, the Dugdale zone of (M26)-(M27) shrunk
    # to zero width. A work of adhesion w dgamma0 is a change of units: Baney-Hui in its own
    # scaling (beta_w = w^(1/3) beta, load scale w^(2/3) that of dgamma0) drawn in dgamma0's.
    abar = np.array([0.5, 1.0, 2.0, 3.0, 6.0, 10.0])
    limit, _ = baney_hui_limit(abar / work ** (1 / 3))
    reference = work ** (2 / 3) * limit
    np.testing.assert_allclose(theory.jkr_load(abar, work_ratio=work), reference, rtol=1e-7)
    # the effective work read off such a point (the slope-1 line through it, Figs. 4, 5a)
    x, y = theory.scaled_curve(abar, reference)
    np.testing.assert_allclose(theory.effective_work_ratio(x, y), work, rtol=1e-6)


def test_cohesive_zone_width_is_baney_hui_s_zone_in_the_jkr_limit():
    # (M23) w / beta = pi / (4 lambda^2) against Baney-Hui's a_c (m - 1) as lambda grows
    # (docs/model.md, after (M27)), the same at every contact width
    abar = np.array([0.5, 1.0, 3.0, 6.0, 10.0])
    _, width = baney_hui_limit(abar)
    for lam in (1.0, 3.5, 7.0, 14.0):
        np.testing.assert_allclose(theory.cohesive_width(lam) * lam**2, width, rtol=1e-7)


def test_groups_of_a_physical_case_are_their_definitions_in_si_units():
    # lambda0 (M20), V_z (M19), chi_ve in the first form of the paper's Eq. 22 (v_z tau
    # lambda0 / dmax) and the dimensional w = pi E0 dmax / (4 sigma_a) of (M23), from the SI
    # values of a [physical] case, against the groups the case forms (through chi_ve =
    # V_z lambda0^2 and w = beta pi / (4 lambda0^2))
    from cases import PHYSICAL, PHYSICAL_VALUES
    from hpcgfmd.case import parse_case

    si = {key: float(value) for key, value in PHYSICAL_VALUES.items()}
    radius, e0, tau = si["radius"], si["modulus_relaxed"], si["relaxation_time"]
    work, dmax, speed = si["work_of_adhesion"], si["interaction_range"], si["velocity"]
    beta = (radius**2 * work / e0) ** (1 / 3)
    maugis = (work**2 * radius / (e0**2 * dmax**3)) ** (1 / 3)
    case = parse_case(PHYSICAL)
    assert case.units.length == radius and case.units.time == tau
    assert case.maugis == pytest.approx(maugis, rel=1e-12)
    assert case.velocity == pytest.approx(speed * tau * radius / beta**2, rel=1e-12)
    assert case.chi_ve == pytest.approx(speed * tau * maugis / dmax, rel=1e-12)
    sigma_a = work / dmax
    assert case.zone_width * radius == pytest.approx(np.pi * e0 * dmax / (4 * sigma_a), rel=1e-12)


@pytest.mark.parametrize("rhodot", [1e-5, 3e-4, 1e-2])
def test_peel_velocity_convention_against_eq6_in_physical_units(rhodot):
    # Eq. 6 with Eq. 7 evaluated in the case's own units (relaxation time tau = 1, E0 = 1,
    # beta = alpha^(1/3), sigma_a = lambda0 beta), independently of the retardation-time
    # bookkeeping of persson_brener_quadrature.
    from scipy import integrate

    k, lam, alpha, tau = 0.1, 7.0, 5e-5, 1.0
    beta = alpha ** (1 / 3)
    sigma_a = lam * beta
    c0 = alpha / (np.pi * sigma_a**2)  # dgamma0 E0 / (pi sigma_a^2)

    def im_inverse_modulus(omega):  # E(w) = E0 + (Einf - E0) i w tau / (1 + i w tau)
        return (1.0 / (1.0 + (1.0 / k - 1.0) * 1j * omega * tau / (1.0 + 1j * omega * tau))).imag

    cbar = 1.0
    for _ in range(300):
        omega_c = 2 * np.pi * rhodot / (cbar * c0)
        val = integrate.quad(
            lambda w, omega_c=omega_c: np.sqrt(1 - w * w) / w * im_inverse_modulus(omega_c * w),
            0.0,
            1.0,
            limit=200,
            epsabs=1e-13,
        )[0]
        cbar = 1.0 / (1.0 + 2.0 / np.pi * val)
    vbar = theory.peel_velocity(rhodot, tau, k, lam, beta)
    assert theory.persson_brener(float(vbar), k) == pytest.approx(cbar, rel=1e-7)
