"""Closed-form references for the adhesive cylinder (pure functions, no state).

All quantities are in the paper's dgamma0 scaling (docs/model.md, "Scales and dimensionless
groups"): abar = a / beta, Lbar = L_n / (R dgamma0^2 E0)^(1/3), beta = (R^2 dgamma0 / E0)^(1/3),
with E0 the relaxed plane-strain modulus. Equation numbers refer to the paper (Van Dokkum,
Pérez-Ràfols, Dorogin, Nicola: retraction of an adhesive cylindrical indenter from a
viscoelastic substrate) as corrected in docs/model.md.
"""

from __future__ import annotations

import numpy as np

# scipy's optimize and integrate are imported where a theory needs them: a run needs neither,
# and they add about 0.1 s of CPU to every process's start.


def _optimize():
    from scipy import optimize

    return optimize


def _integrate():
    from scipy import integrate

    return integrate


def jkr_load(abar, work_ratio=1.0):
    """2D JKR load per unit length of a cylinder (paper Eq. 10, corrected).

    Parameters
    ----------
    abar : float or array
        Contact half-width a_c / beta (dimensionless).
    work_ratio : float
        dgamma / dgamma0; 1 for the relaxed limit, 1/k for the instantaneous limit.

    Returns
    -------
    Lbar : float or array
        Lbar = (pi/4) abar^2 - sqrt(2 pi abar work_ratio), compressive positive.
    """
    abar = np.asarray(abar, dtype=float)
    return np.pi / 4.0 * abar**2 - np.sqrt(2.0 * np.pi * abar * work_ratio)


def _md_closure(m, abar, lam):
    """Left side minus right side of the Baney-Hui closure (paper Eq. 13; docs/model.md (M27))."""
    s = np.sqrt(m * m - 1.0)
    ach = np.arccosh(m)
    return (
        lam * abar**2 / 2.0 * (m * s - ach)
        + 4.0 * lam**2 * abar / np.pi * (s * ach - m * np.log(m))
        - 1.0
    )


def maugis_dugdale(abar, lam):
    """2D Maugis-Dugdale (Baney and Hui) load and zone ratio (paper Eqs. 12-13, corrected).

    Parameters
    ----------
    abar : float or array
        Contact half-width a_c / beta (dimensionless), positive.
    lam : float
        Maugis parameter (dimensionless).

    Returns
    -------
    Lbar : ndarray
        (pi/4) abar^2 - 2 lam abar sqrt(m^2 - 1).
    m : ndarray
        a_a / a_c, the cohesive-zone to contact half-width ratio (> 1).
    """
    abar_arr = np.atleast_1d(np.asarray(abar, dtype=float))
    m = np.empty_like(abar_arr)
    for i, ab in enumerate(abar_arr):
        if not ab > 0:
            raise ValueError(f"abar must be positive, got {ab}")
        hi = 2.0
        while _md_closure(hi, ab, lam) < 0.0:  # the closure grows monotonically in m
            hi = 1.0 + 2.0 * (hi - 1.0)
        m[i] = _optimize().brentq(_md_closure, 1.0, hi, args=(ab, lam), xtol=1e-15, rtol=1e-14)
    lbar = np.pi / 4.0 * abar_arr**2 - 2.0 * lam * abar_arr * np.sqrt(m * m - 1.0)
    if np.ndim(abar) == 0:
        return float(lbar[0]), float(m[0])
    return lbar, m


def periodic_load_factor(a, cell):
    """Factor by which the periodic cell raises the load at contact half-width a.

    docs/model.md (M29): with zero mean displacement and period L the images add a
    curvature 2 pi L_n / (3 E* L^2), so L_n(a) = L_isolated(a) / (1 - pi^2 a^2 / (6 L^2)) to
    O((a/L)^4), for Hertz, JKR and Maugis-Dugdale alike.

    Parameters
    ----------
    a : float or array
        Contact half-width (same length unit as ``cell``).
    cell : float
        Period L.
    """
    a = np.asarray(a, dtype=float)
    return 1.0 / (1.0 - np.pi**2 * a**2 / (6.0 * cell**2))


def chi_ve(Vz, lambda0):
    """Viscoelastic parameter chi_ve = v_z tau lambda0 / dmax = V_z lambda0^2 (paper Eq. 22)."""
    return Vz * lambda0**2


def cohesive_width(lam):
    """Cohesive-zone width w / beta = pi / (4 lam^2) (paper Eq. D.6 with Eq. 20 scaled)."""
    return np.pi / (4.0 * lam**2)


def persson_brener(vbar, k):
    """Effective work of adhesion dgamma_eff / dgamma0 for the SLS (paper Eqs. 8-9).

    Solves cbar = [1 - (1 - k) (sqrt(1 + (cbar/vbar)^2) - cbar/vbar)]^(-1) for cbar in [1, 1/k].

    Convention (docs/model.md, (M31)): this closed form equals the quadrature of Eq. 6 when
    vbar = 2 pi rhodot tau_r / c0 with the RETARDATION time tau_r = tau / k of the SLS whose
    relaxation time is tau; see :func:`peel_velocity` and :func:`persson_brener_quadrature`.

    Parameters
    ----------
    vbar : float or array
        Dimensionless peeling-edge velocity (retardation-time convention), >= 0.
    k : float
        E0 / Einf in (0, 1].
    """
    vb = np.atleast_1d(np.asarray(vbar, dtype=float))
    out = np.empty_like(vb)
    for i, v in enumerate(vb):
        if v <= 0.0:
            out[i] = 1.0
            continue

        def f(c, v=v):
            s = c / v
            return c * (1.0 - (1.0 - k) * (np.sqrt(1.0 + s * s) - s)) - 1.0

        # f(1) <= 0 and f(1/k) >= 0 (the bracket bounds of Eq. 8); f is monotone between them.
        out[i] = 1.0 if k == 1.0 else _optimize().brentq(f, 1.0, 1.0 / k, xtol=1e-14, rtol=1e-13)
    return float(out[0]) if np.ndim(vbar) == 0 else out


def persson_brener_quadrature(vbar, k):
    """dgamma_eff / dgamma0 from a direct quadrature of the paper's Eq. 6 with Eq. 7 (SLS).

    Independent of the closed form: :func:`persson_brener_modulus` with the SLS's complex
    modulus E(w) / E0 = 1 + (1/k - 1) i w tau / (1 + i w tau), time in units of the
    retardation time tau_r = tau / k (so tau = k), and 2 pi rhodot / c0 = vbar (see
    :func:`persson_brener`).
    """

    def modulus(omega):
        return 1.0 + (1.0 / k - 1.0) * 1j * omega * k / (1.0 + 1j * omega * k)

    return persson_brener_modulus(vbar, 2.0 * np.pi, modulus)


def persson_brener_modulus(rhodot, c0, modulus):
    """dgamma_eff / dgamma0 by quadrature of the paper's Eq. 6 with Eq. 7, for any linear
    viscoelastic solid (docs/model.md (M31) and (M42)).

    Eq. 6: dgamma_eff / dgamma0 = cbar, cbar = [1 + (2/pi) integral_0^1 sqrt(1 - w^2) / w
    Im(E0 / E(omega_c w)) dw]^(-1) (integrated in ln w) with omega_c = 2 pi rhodot /
    (cbar c0), solved for cbar as a fixed point (Eq. 7: the tip radius c = cbar c0 grows
    with the dissipation). For the SLS
    it equals :func:`persson_brener_quadrature` (and the closed form :func:`persson_brener`
    with the retardation-time convention of vbar).

    Parameters
    ----------
    rhodot : float
        Peeling-edge velocity (length / time), >= 0.
    c0 : float
        Relaxed tip radius dgamma0 E0 / (pi sigma_a^2) = beta / (pi lambda0^2) (length).
    modulus : callable
        omega (1 / time, array) -> E(omega) / E0 (complex): for a Prony series
        ``material.complex_modulus(omega) / material.e_relaxed``
        (:meth:`~hpcgfmd.model.material.GeneralizedMaxwell.complex_modulus`).

    Returns
    -------
    float
        dgamma_eff / dgamma0, between 1 (rhodot -> 0) and Einf / E0 (rhodot -> infinity).
    """
    if rhodot <= 0.0:
        return 1.0

    def enhancement(cbar):
        omega_c = 2.0 * np.pi * rhodot / (cbar * c0)

        # in s = ln w: each branch's loss peak is a bump of a few units of s wherever
        # omega_c lies; below w = exp(s_low) the integrand (~ omega) adds nothing
        def integrand(s):
            w = np.exp(s)
            return np.sqrt(-np.expm1(2.0 * s)) * (1.0 / modulus(omega_c * w)).imag

        s_low = -40.0 - max(0.0, np.log(omega_c))
        val, _ = _integrate().quad(integrand, s_low, 0.0, limit=400, epsabs=1e-13, epsrel=1e-12)
        return 1.0 / (1.0 + 2.0 / np.pi * val)

    # the fixed point cbar = enhancement(cbar) lies in [1, Einf/E0] (between the relaxed and
    # the glassy work of adhesion); found by bracketed root finding (a fixed-point iteration
    # converges slowly where cbar is large)
    def excess(c):
        return enhancement(c) - c

    if excess(1.0) <= 0.0:
        return 1.0
    high = float(np.real(modulus(1e300)))  # Einf / E0
    while excess(high) > 0.0:  # (only by the quadrature's error)
        high *= 1.0 + 1e-9
    return float(_optimize().brentq(excess, 1.0, high, xtol=1e-13, rtol=1e-12))


def peel_velocity(rhodot, tau, k, lambda0, beta):
    """Dimensionless peeling velocity vbar = 2 pi rhodot tau / (k c0) (retardation convention).

    c0 = dgamma0 E0 / (pi sigma_a^2) = beta / (pi lambda0^2) (paper Eq. 7 with sigma_a from
    lambda0). Inputs in any consistent units (rhodot in length/time, beta in length).
    """
    c0 = beta / (np.pi * lambda0**2)
    return 2.0 * np.pi * np.asarray(rhodot, dtype=float) * tau / (k * c0)


def scaled_curve(abar, lbar):
    """The paper's scaled load-area coordinates (Figs. 4, 5a, 8a, 9; docs/model.md,
    "Observables"): x = Lbar / sqrt(abar), y = (pi/4) abar^(3/2). The JKR curve of work
    ratio w is the line y = x + sqrt(2 pi w) (Eq. 10)."""
    abar = np.asarray(abar, dtype=float)
    return np.asarray(lbar, dtype=float) / np.sqrt(abar), np.pi / 4.0 * abar**1.5


def effective_work_ratio(x, y):
    """dgamma_eff / dgamma0 of a point (x, y) = (Lbar/sqrt(abar), (pi/4) abar^(3/2)).

    docs/model.md, "Observables": the slope-1 line through the point has intercept y - x =
    sqrt(2 pi dgamma_eff / dgamma0).
    """
    d = np.asarray(y, dtype=float) - np.asarray(x, dtype=float)
    return np.sign(d) * d**2 / (2.0 * np.pi)
