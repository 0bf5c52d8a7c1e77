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
    err = [np.max(np.abs(theory.maugis_dugdale(abar, lam)[0] - theory.jkr_load(abar)))
           for lam in (50.0, 100.0, 200.0)]
    assert err[0] > err[1] > err[2]
    assert err[1] / err[2] == pytest.approx(4.0, rel=0.05)


def test_jkr_scaled_form_is_slope_one_line():
    abar = np.linspace(0.5, 8, 20)
    x = theory.jkr_load(abar) / np.sqrt(abar)
    y = np.pi / 4 * abar**1.5
    np.testing.assert_allclose(y - x, np.sqrt(2 * np.pi), rtol=1e-13)
    np.testing.assert_allclose(theory.effective_work_ratio(x, y), 1.0, rtol=1e-12)


def test_groups():
    assert theory.chi_ve(0.45, 7.0) == pytest.approx(22.05)
    assert theory.cohesive_width(7.0) == pytest.approx(np.pi / 196)


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
        val = integrate.quad(lambda w: np.sqrt(1 - w * w) / w * im_inverse_modulus(omega_c * w),
                             0.0, 1.0, limit=200, epsabs=1e-13)[0]
        cbar = 1.0 / (1.0 + 2.0 / np.pi * val)
    vbar = theory.peel_velocity(rhodot, tau, k, lam, beta)
    assert theory.persson_brener(float(vbar), k) == pytest.approx(cbar, rel=1e-7)
