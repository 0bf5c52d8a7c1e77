"""The adhesive sphere's scales, groups and closed-form references (pure functions, no state).

docs/model.md, "The sphere", (M47)-(M59): a rigid paraboloid h = r^2 / (2 R) on a periodic
square cell of a viscoelastic half-space (relaxed plane-strain modulus E0, k = E0/Einf) with the
Dugdale-Maugis law (sigma_a, dmax = dgamma0 / sigma_a). The references use the scaling of
Maugis (J. Colloid Interface Sci. 150, 243 (1992)) in the form of Johnson and Greenwood
(J. Colloid Interface Sci. 192, 326 (1997)), with K = 4 E0 / 3 (M47):

- Abar = a / a_s, a_s = (pi dgamma0 R^2 / K)^(1/3) (contact radius);
- Pbar = P / (pi dgamma0 R) (force, compressive positive);
- Dbar = delta / delta_s, delta_s = a_s^2 / R (indentation depth, pressed in positive);
- lambda = 2 sigma_a (R / (pi dgamma0 K^2))^(1/3), Maugis's parameter (M48).

A work of adhesion r dgamma0 (``work_ratio`` r: 1 relaxed, 1/k the instantaneous limit (M57))
is drawn in dgamma0's scaling throughout. Internal units are R = E0 = tau = 1, as for the
cylinder (:mod:`hpcgfmd.case.groups`); forces are then in E0 R^2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

#: The zeta-regularised sum' 1/|n| over the unit square lattice, 4 zeta(1/2) beta(1/2): the
#: zero-mean periodic Green's function's constant (M59) (Ewald summation gives the same).
MADELUNG_SQUARE = -3.900264920001956
#: sum' 1/|n|^3 over the unit square lattice, 4 zeta(3/2) beta(3/2) (M59).
LATTICE_SUM_3 = 9.033621683100948
#: The images' extra curvature per unit load, 2 LATTICE_SUM_3 / (3 pi) (M59).
IMAGE_CURVATURE = 2.0 * LATTICE_SUM_3 / (3.0 * math.pi)
#: The images' depth offset per unit load, 4 MADELUNG_SQUARE / (3 pi) (M59).
IMAGE_OFFSET = 4.0 * MADELUNG_SQUARE / (3.0 * math.pi)
#: ... and per unit second moment of the traction (its spread), LATTICE_SUM_3 / (3 pi) (M59).
IMAGE_SPREAD = LATTICE_SUM_3 / (3.0 * math.pi)

# scipy's optimize is imported where a theory needs it (as in theory.py): a run needs none.


def _optimize():
    from scipy import optimize

    return optimize


# --- scales and groups ---------------------------------------------------------------------


def scales(radius, modulus, work):
    """The sphere's contact-radius, force and depth scales (M47).

    Parameters
    ----------
    radius : float
        R (length).
    modulus : float
        Plane-strain modulus E* (stress); K = 4 E* / 3.
    work : float
        Work of adhesion dgamma (energy per area).

    Returns
    -------
    length, force, depth : float
        a_s = (pi dgamma R^2 / K)^(1/3) (length), pi dgamma R (force),
        delta_s = a_s^2 / R = (pi^2 dgamma^2 R / K^2)^(1/3) (length).
    """
    k_mod = 4.0 * modulus / 3.0
    length = (np.pi * work * radius**2 / k_mod) ** (1.0 / 3.0)
    return length, np.pi * work * radius, length**2 / radius


def maugis_parameter(radius, modulus, work, sigma_a):
    """Maugis's lambda = 2 sigma_a (R / (pi dgamma K^2))^(1/3), K = 4 E* / 3 (M48).

    Inputs in any consistent units (R length, E* and sigma_a stress, dgamma energy per area).
    """
    k_mod = 4.0 * modulus / 3.0
    return 2.0 * sigma_a * (radius / (np.pi * work * k_mod**2)) ** (1.0 / 3.0)


def physical_groups(radius, e0, einf, tau, work, dmax, velocity, depth, cell):
    """The sphere's ``[case]`` groups of a dimensional case (M48), (M49), (M24).

    Parameters
    ----------
    radius, e0, einf, tau, work, dmax, velocity, depth, cell : float
        R, E0, Einf (plane-strain moduli), tau, dgamma0, dmax, v_z, h0, L in consistent units.

    Returns
    -------
    dict
        maugis = lambda0 (Maugis's, with E0 and sigma_a = dgamma0 / dmax), modulus_ratio = k,
        velocity = V_z = v_z tau / delta_s, depth = h0 / R, cell = L / R and
        adhesion = alpha = dgamma0 / (E0 R): the names of :class:`hpcgfmd.case.groups.Groups`.
    """
    _, _, depth_scale = scales(radius, e0, work)
    return {
        "maugis": maugis_parameter(radius, e0, work, work / dmax),
        "modulus_ratio": e0 / einf,
        "velocity": velocity * tau / depth_scale,
        "depth": depth / radius,
        "cell": cell / radius,
        "adhesion": work / (e0 * radius),
    }


def scaled_problem(radius, e0, einf, tau, work, dmax, velocity, depth, cell):
    """The coefficients of the sphere's scaled problem (M51), formed from dimensional values.

    With X = r / a_s, U = u / delta_s, T = t / tau, P = p / sigma_a and Q = q a_s, the
    problem is P + dP/dT = stiffness |Q| (U + (Einf/E0) dU/dT) per mode, the gap
    G = X^2/2 - H0 + V_z T - U, the Dugdale law with range dmax / delta_s, the cell L / a_s,
    and the force Pbar = -force_factor (integral of P dX dY). Two cases with the same
    values here have the same scaled response. Arguments as :func:`physical_groups`.

    Returns
    -------
    dict
        stiffness = E0 delta_s / (2 a_s sigma_a), modulus_ratio = E0 / Einf,
        range = dmax / delta_s, velocity = v_z tau / delta_s, depth = h0 / delta_s,
        cell = L / a_s, force_factor = sigma_a a_s^2 / (pi dgamma0 R) (all dimensionless).
    """
    length, force, depth_scale = scales(radius, e0, work)
    sigma_a = work / dmax
    return {
        "stiffness": e0 * depth_scale / (2.0 * length * sigma_a),
        "modulus_ratio": e0 / einf,
        "range": dmax / depth_scale,
        "velocity": velocity * tau / depth_scale,
        "depth": depth / depth_scale,
        "cell": cell / length,
        "force_factor": sigma_a * length**2 / force,
    }


def chi_ve(Vz, lambda0):
    """The sphere's viscoelastic parameter chi_ve = (pi/3) V_z lambda0^2 (M53).

    The paper's edge stress rate (its Eqs. 19-22) with the cylinder's factor: chi_ve =
    (pi/4) V_z / W0, W0 = 3 / (4 lambda0^2) the sphere's scaled zone width (M53); for the
    cylinder (pi/4) V_z / W0 is V_z lambda0^2 (M22).
    """
    return np.pi / 3.0 * Vz * lambda0**2


def cohesive_width(lam):
    """The sphere's cohesive-zone width w / a_s = 3 / (4 lam^2) (M53), its JKR-limit zone
    (w = pi E* dmax / (4 sigma_a), (M23), in a_s)."""
    return 3.0 / (4.0 * lam**2)


@dataclass(frozen=True)
class SphereGroups:
    """The sphere's groups and the scales derived from them, in internal units R = E0 = tau = 1
    (M52); the names mirror :class:`hpcgfmd.case.groups.Groups`.

    Attributes
    ----------
    maugis : float
        lambda0, Maugis's parameter with E0 (M48) (not the cylinder's (M20)).
    modulus_ratio : float
        k = E0 / Einf in (0, 1].
    velocity : float
        V_z = v_z tau / delta_s (M49).
    depth, cell, adhesion : float
        h0 / R, L / R and alpha = dgamma0 / (E0 R) (M24).
    """

    maugis: float
    modulus_ratio: float
    velocity: float
    depth: float
    cell: float
    adhesion: float

    @property
    def beta(self) -> float:
        """The contact-radius scale a_s = (3 pi alpha / 4)^(1/3) (M52): beta's role."""
        return (0.75 * np.pi * self.adhesion) ** (1.0 / 3.0)

    @property
    def depth_scale(self) -> float:
        """The depth scale delta_s = a_s^2 (M52)."""
        return self.beta**2

    @property
    def load_scale(self) -> float:
        """The force scale pi dgamma0 R = pi alpha (E0 R^2) (M47)."""
        return np.pi * self.adhesion

    @property
    def sigma_a(self) -> float:
        """sigma_a = (lambda0 / 2) (16 pi alpha / 9)^(1/3) (M52)."""
        return 0.5 * self.maugis * (16.0 * np.pi * self.adhesion / 9.0) ** (1.0 / 3.0)

    @property
    def dmax(self) -> float:
        """dmax = alpha / sigma_a = 2 delta_s / (pi lambda0) (M50)."""
        return self.adhesion / self.sigma_a

    @property
    def indenter_speed(self) -> float:
        """v_z = V_z delta_s (M52)."""
        return self.velocity * self.depth_scale

    @property
    def lambda_inf(self) -> float:
        """The instantaneous Maugis parameter lambda0 k^(2/3) ((M48) with Einf; (M57))."""
        return self.maugis * self.modulus_ratio ** (2.0 / 3.0)

    @property
    def chi_ve(self) -> float:
        """chi_ve = (pi/3) V_z lambda0^2 (M53)."""
        return chi_ve(self.velocity, self.maugis)

    @property
    def zone_width(self) -> float:
        """The relaxed cohesive-zone width w0 = a_s 3 / (4 lambda0^2) = pi dmax / (4 sigma_a)
        (M53)."""
        return self.beta * cohesive_width(self.maugis)

    @property
    def scaled_depth(self) -> float:
        """H0 = h0 / delta_s (M52)."""
        return self.depth / self.depth_scale

    @property
    def scaled_cell(self) -> float:
        """L / a_s (M52)."""
        return self.cell / self.beta


class InternalValues(NamedTuple):
    """The dimensional inputs of a sphere case in internal units R = E0 = tau = 1."""

    sigma_a: float
    dmax: float
    v_z: float
    h0: float
    L: float


def internal_values(maugis, modulus_ratio, velocity, depth, cell, adhesion) -> InternalValues:
    """sigma_a, dmax, v_z, h0 and L of the sphere's groups in internal units (M52).

    Parameters
    ----------
    maugis, modulus_ratio, velocity, depth, cell, adhesion : float
        lambda0 (Maugis's, (M48)), k, V_z (M49), h0 / R, L / R, alpha (M24).

    Returns
    -------
    InternalValues
        sigma_a (E0), dmax (R), v_z (R / tau), h0 (R), L (R).
    """
    g = SphereGroups(maugis, modulus_ratio, velocity, depth, cell, adhesion)
    return InternalValues(g.sigma_a, g.dmax, g.indenter_speed, g.depth, g.cell)


# --- Hertz and JKR -------------------------------------------------------------------------


def hertz(abar):
    """Hertz's force and depth against the contact radius, Pbar = Abar^3, Dbar = Abar^2 (M54)
    (P = K a^3 / R, delta = a^2 / R)."""
    abar = np.asarray(abar, dtype=float)
    return abar**3, abar**2


def jkr(abar, work_ratio=1.0):
    """JKR sphere's force and depth against the contact radius (M55).

    Parameters
    ----------
    abar : float or array
        a / a_s (dimensionless, dgamma0's scale).
    work_ratio : float
        r = dgamma / dgamma0 (1 relaxed, 1/k instantaneous; 0 is Hertz).

    Returns
    -------
    pbar, dbar : ndarray
        Abar^3 - sqrt(6 r Abar^3) and Abar^2 - sqrt(8 r Abar / 3).
    """
    abar = np.asarray(abar, dtype=float)
    return abar**3 - np.sqrt(6.0 * work_ratio * abar**3), abar**2 - np.sqrt(
        8.0 * work_ratio * abar / 3.0
    )


def jkr_pull_off(work_ratio=1.0, control="load"):
    """Where a JKR sphere lets go (M55).

    Parameters
    ----------
    work_ratio : float
        r = dgamma / dgamma0.
    control : {"load", "displacement"}
        Load control lets go at the load minimum, Abar^3 = 3 r / 2, Pbar = -3 r / 2 (which
        displacement control passes through); displacement control jumps where the depth is
        least, Abar^3 = r / 6, Pbar = -5 r / 6, Dbar = -3 (r / 6)^(2/3).

    Returns
    -------
    abar, pbar, dbar : float
    """
    if control == "load":
        abar = (1.5 * work_ratio) ** (1.0 / 3.0)
    elif control == "displacement":
        abar = (work_ratio / 6.0) ** (1.0 / 3.0)
    else:
        raise ValueError(f"control = {control!r}: expected 'load' or 'displacement'")
    pbar, dbar = jkr(abar, work_ratio)
    return abar, float(pbar), float(dbar)


def scaled_curve(abar, pbar):
    """The sphere's load-area coordinates x = Pbar / Abar^(3/2), y = Abar^(3/2) (M55): the JKR
    curve of work ratio r is the line y = x + sqrt(6 r)."""
    abar = np.asarray(abar, dtype=float)
    return np.asarray(pbar, dtype=float) / abar**1.5, abar**1.5


def effective_work_ratio(x, y):
    """dgamma_eff / dgamma0 of a point (x, y) of :func:`scaled_curve`: the slope-1 line through
    it has intercept y - x = sqrt(6 dgamma_eff / dgamma0) (M55); sign(y - x) (y - x)^2 / 6."""
    d = np.asarray(y, dtype=float) - np.asarray(x, dtype=float)
    return np.sign(d) * d**2 / 6.0


# --- Maugis-Dugdale ------------------------------------------------------------------------


def _s_minus_arctan(s):
    """s - arctan(s) without cancellation at small s (series below 0.1: 8 terms, 1e-17)."""
    if s >= 0.1:
        return s - math.atan(s)
    s2, term, total = s * s, s, 0.0
    for n in range(1, 9):
        term *= -s2
        total -= term / (2 * n + 1)
    return total


def _md_closure(s, abar, lam):
    """Maugis's closure (M56) in s = sqrt(m^2 - 1), left side minus 1; increasing in s.

    (lam A^2 / 2)(s + (m^2 - 2) arctan s) + (4 lam^2 A / 3)(s arctan s - m + 1) - 1, written
    as (s - arctan s) + s^2 arctan s and s arctan s - s^2 / (1 + m) to keep the digits of
    m - 1 as m -> 1.
    """
    m = math.sqrt(1.0 + s * s)
    at = math.atan(s)
    first = _s_minus_arctan(s) + s * s * at
    second = s * at - s * s / (1.0 + m)
    return 0.5 * lam * abar * abar * first + 4.0 / 3.0 * lam * lam * abar * second - 1.0


def _md_point(abar, lam):
    """(Pbar, Dbar, m) of one contact radius on Maugis's curve (work ratio 1)."""
    if not abar > 0.0:
        raise ValueError(f"abar must be positive, got {abar}")
    high = 1.0
    while _md_closure(high, abar, lam) < 0.0:
        high *= 2.0
    s = _optimize().brentq(_md_closure, 0.0, high, args=(abar, lam), xtol=1e-300, rtol=1e-15)
    m = math.sqrt(1.0 + s * s)
    pbar = abar**3 - lam * abar * abar * (s + m * m * math.atan(s))
    dbar = abar * abar - 4.0 / 3.0 * abar * lam * s
    return pbar, dbar, m


def maugis_dugdale(abar, lam, work_ratio=1.0):
    """Maugis-Dugdale sphere: force, depth and zone ratio against the contact radius (M56).

    Solves the closure for m = c / a (c the cohesive zone's outer radius), then
    Pbar = A^3 - lam A^2 (s + m^2 arctan s), Dbar = A^2 - (4/3) A lam s, s = sqrt(m^2 - 1).
    A work of adhesion r dgamma0 at the same sigma_a is the same curve in its own scaling
    (lam r^(-1/3), Abar r^(-1/3)) drawn in dgamma0's (forces times r, depths times r^(2/3)).

    Parameters
    ----------
    abar : float or array
        a / a_s (dgamma0's scale), positive.
    lam : float
        Maugis's parameter with dgamma0 (M48); inf gives JKR (m = 1).
    work_ratio : float
        r = dgamma / dgamma0 > 0 (1/k with lam = lambda0: the instantaneous limit's curve,
        (M57)).

    Returns
    -------
    pbar, dbar, m : float or ndarray
    """
    if lam == np.inf:
        pbar, dbar = jkr(abar, work_ratio)
        if np.ndim(abar) == 0:
            return float(pbar), float(dbar), 1.0
        return pbar, dbar, np.ones_like(pbar)
    if not work_ratio > 0.0:
        raise ValueError(f"work_ratio must be positive with a finite lam, got {work_ratio}")
    scale = work_ratio ** (1.0 / 3.0)
    points = np.array(
        [_md_point(a / scale, lam / scale) for a in np.atleast_1d(np.asarray(abar, dtype=float))]
    ).reshape(-1, 3)
    pbar, dbar, m = work_ratio * points[:, 0], scale**2 * points[:, 1], points[:, 2]
    if np.ndim(abar) == 0:
        return float(pbar[0]), float(dbar[0]), float(m[0])
    return pbar, dbar, m


def maugis_dugdale_zero_contact(lam):
    """The end Abar -> 0 of Maugis's curve (M56): the zone radius C = c / a_s, Pbar, Dbar.

    As a -> 0 with c finite, the closure becomes (pi lam / 4) C^2 + (4 lam^2 / 3)(pi/2 - 1) C
    = 1, and Pbar -> -(pi/2) lam C^2, Dbar -> -(4/3) lam C; Pbar -> -2 (Bradley) as lam -> 0.
    """
    b = 4.0 / 3.0 * lam * lam * (np.pi / 2.0 - 1.0)
    a = np.pi * lam / 4.0
    c = 2.0 / (b + math.sqrt(b * b + 4.0 * a))  # the positive root, without cancellation
    return c, -np.pi / 2.0 * lam * c * c, -4.0 / 3.0 * lam * c


def maugis_dugdale_pull_off(lam, control="load", work_ratio=1.0):
    """Where a Maugis-Dugdale sphere lets go (M56).

    Load control: the least force of the curve (a minimum over Abar > 0, or its end
    Abar -> 0). Displacement control: the least depth (dDbar/dAbar = 0), where the contact
    jumps off; where Dbar falls all the way to Abar -> 0 (small lam) there is no jump and the
    end :func:`maugis_dugdale_zero_contact` is returned (Abar = 0). Displacement control
    passes through the load minimum before it jumps.

    Parameters
    ----------
    lam : float
        Maugis's parameter with dgamma0 (M48), finite and > 0.
    control : {"load", "displacement"}
    work_ratio : float
        r = dgamma / dgamma0 (as in :func:`maugis_dugdale`).

    Returns
    -------
    abar, pbar, dbar : float
    """
    if control not in ("load", "displacement"):
        raise ValueError(f"control = {control!r}: expected 'load' or 'displacement'")
    scale = work_ratio ** (1.0 / 3.0)
    lam_r = lam / scale
    column = 0 if control == "load" else 1

    def value(a):
        return _md_point(a, lam_r)[column]

    # the extremum lies near JKR's (Abar^3 = 3/2 or 1/6) for large lam and moves to Abar ~ lam
    # as lam -> 0: a log grid spans both, a bounded search between its neighbours refines it
    grid = np.geomspace(1e-3 * min(1.0, lam_r), 3.0, 161)
    values = np.array([value(a) for a in grid])
    i = int(np.argmin(values))
    if i == 0:
        _, pbar, dbar = maugis_dugdale_zero_contact(lam_r)
        return 0.0, float(work_ratio * pbar), float(scale**2 * dbar)
    if i == len(grid) - 1:
        raise ArithmeticError(f"no extremum below Abar = {grid[-1]} at lam = {lam}")
    found = _optimize().minimize_scalar(
        value, bounds=(grid[i - 1], grid[i + 1]), method="bounded", options={"xatol": 1e-12}
    )
    pbar, dbar, _ = _md_point(float(found.x), lam_r)
    return float(found.x * scale), float(work_ratio * pbar), float(scale**2 * dbar)


# --- viscoelastic limits and the crack-tip speed -------------------------------------------


class InstantaneousLimit(NamedTuple):
    """The sphere's instantaneous limit (M57)."""

    work_ratio: float  # dgamma_inf / dgamma0 = 1 / k
    lambda_inf: float  # the paper's: lambda0 k^(2/3), Maugis's lambda with Einf and dgamma0
    lambda_curve: float  # Maugis's lambda of the limit's curve: E0, dgamma_inf, sigma_a


def instantaneous_limit(lambda0, k) -> InstantaneousLimit:
    """The instantaneous limit of the sphere (M57): the bulk at E0 with dgamma_inf = dgamma0/k.

    Its curve is JKR with work ratio 1/k (:func:`jkr`), or Maugis-Dugdale with E0, dgamma_inf
    and the same sigma_a: ``maugis_dugdale(abar, lambda0, 1/k)``, whose own lambda is
    lambda0 k^(1/3) (and its zone w0 / k, the glassy tip's). The paper's lambda_inf =
    lambda0 k^(2/3) is (M48) with Einf and dgamma0.
    """
    return InstantaneousLimit(1.0 / k, lambda0 * k ** (2.0 / 3.0), lambda0 * k ** (1.0 / 3.0))


def tip_radius(lambda0, length_scale=1.0):
    """Persson-Brener's relaxed tip radius c0 = dgamma0 E0 / (pi sigma_a^2) = 3 a_s /
    (pi^2 lambda0^2) (M58) (in the unit of ``length_scale`` = a_s)."""
    return 3.0 * length_scale / (np.pi**2 * lambda0**2)


def peel_velocity(rhodot, tau, k, lambda0, length_scale):
    """The sphere's vbar = 2 pi rhodot tau / (k c0) (M58), retardation convention (M31).

    c0 from :func:`tip_radius`; :func:`hpcgfmd.model.theory.persson_brener` of the result is
    dgamma_eff / dgamma0. In scaled units (tau = a_s = 1, rhodot = -dAbar/dT) it is
    (2 pi^3 lambda0^2 / (3 k)) (-dAbar/dT).

    Parameters
    ----------
    rhodot : float or array
        Edge speed -da/dt (length / time), >= 0.
    tau : float
        Relaxation time (time).
    k : float
        E0 / Einf.
    lambda0 : float
        Maugis's parameter with E0 (M48).
    length_scale : float
        a_s (length, the unit of rhodot's length).
    """
    c0 = tip_radius(lambda0, length_scale)
    return 2.0 * np.pi * np.asarray(rhodot, dtype=float) * tau / (k * c0)


# --- the periodic cell ---------------------------------------------------------------------


def periodic_load_factor(a, cell):
    """Factor by which the square cell's images raise a Hertz or JKR sphere's force at contact
    radius a: 1 / (1 - (2 S3 / (3 pi)) (a / L)^3), S3 = sum' 1/|n|^3 (M59).

    Parameters
    ----------
    a : float or array
        Contact radius (same length unit as ``cell``).
    cell : float
        Period L.
    """
    a = np.asarray(a, dtype=float)
    return 1.0 / (1.0 - IMAGE_CURVATURE * (a / cell) ** 3)


def periodic_cell(abar, cell, lam=np.inf, work_ratio=1.0):
    """A sphere's force and depth in the periodic square cell, to the images' leading order
    (M59).

    The images add a uniform lift and a curvature: the isolated curve with the radius R' of
    R / R' = 1 + IMAGE_CURVATURE Pbar / Lbar^3 and the depth offset IMAGE_OFFSET Pbar / Lbar
    + IMAGE_SPREAD Mbar / Lbar^3 (Lbar = L / a_s; Mbar the traction's second moment,
    :func:`traction_moment`: the images' lift of a spread load rather than a point force).
    For Hertz and JKR (lam = inf) that is closed; for Maugis-Dugdale the isolated curve at
    R' (Abar R^(2/3) / R'^(2/3), lam R'^(1/3) / R^(1/3)) is iterated to the fixed point in
    Pbar. The next terms are smaller by O((a / L)^2) than the last ones kept.

    Parameters
    ----------
    abar : float or array
        a / a_s.
    cell : float
        L / a_s.
    lam : float
        Maugis's parameter with dgamma0; inf for Hertz (work_ratio 0) and JKR.
    work_ratio : float
        r = dgamma / dgamma0.

    Returns
    -------
    pbar, dbar : float or ndarray
        Force and depth (below the cell's mean surface level) in the scales of (M47).
    """
    curvature = IMAGE_CURVATURE / cell**3
    if lam == np.inf:
        abar = np.asarray(abar, dtype=float)
        adhesion = np.sqrt(6.0 * work_ratio * abar**3)
        pbar = (abar**3 - adhesion) / (1.0 - curvature * abar**3)
        dbar = abar**2 * (1.0 + curvature * pbar) - np.sqrt(8.0 * work_ratio * abar / 3.0)
        # Hertz's share pbar + adhesion at (2/5) a^2, JKR's singular one at (2/3) a^2
        moment = abar**2 * (0.4 * (pbar + adhesion) - 2.0 / 3.0 * adhesion)
        dbar = dbar + IMAGE_OFFSET * pbar / cell + IMAGE_SPREAD * moment / cell**3
        if np.ndim(abar) == 0:
            return float(pbar), float(dbar)
        return pbar, dbar
    points = [_md_in_cell(a, cell, lam, work_ratio)[:2] for a in np.atleast_1d(abar)]
    pbar, dbar = np.array(points, dtype=float).reshape(-1, 2).T
    if np.ndim(abar) == 0:
        return float(pbar[0]), float(dbar[0])
    return pbar, dbar


def preload_in_cell(depth, cell, lam):
    """The elastic Maugis-Dugdale sphere pressed to ``depth`` (Dbar) in its cell (M56), (M59):
    its contact radius Abar and its cohesive zone's outer radius c / a_s, on the branch of
    the curve above its least depth (the largest root of Dbar_cell(Abar) = depth).

    Parameters
    ----------
    depth : float
        h0 / delta_s, above the curve's least depth.
    cell : float
        L / a_s.
    lam : float
        Maugis's parameter with dgamma0 (M48), finite.
    """
    radii = np.linspace(0.05, math.sqrt(abs(depth)) + 2.0, 60)
    depths = np.array([_md_in_cell(a, cell, lam, 1.0)[1] for a in radii])
    below = np.nonzero(depths <= depth)[0]  # the root's bracket: the last of them and the next
    if not below.size or below[-1] == radii.size - 1:
        raise ValueError(f"no contact at depth {depth} in the cell {cell} (lam = {lam})")
    abar = _optimize().brentq(
        lambda a: _md_in_cell(a, cell, lam, 1.0)[1] - depth,
        radii[below[-1]],
        radii[below[-1] + 1],
        xtol=1e-12,
    )
    return abar, abar * _md_in_cell(abar, cell, lam, 1.0)[2]


def _md_in_cell(abar, cell, lam, work_ratio):
    """(Pbar, Dbar, m) of one contact radius of Maugis's curve in the cell (M59): the fixed point
    of Pbar = rho Pbar_MD(Abar rho^(-2/3), lam rho^(1/3)), rho = R'/R; it contracts by about
    IMAGE_CURVATURE (a / L)^3."""
    curvature = IMAGE_CURVATURE / cell**3
    pbar, dbar, m = maugis_dugdale(abar, lam, work_ratio)
    rho = 1.0
    for _ in range(100):
        rho = 1.0 / (1.0 + curvature * pbar)
        new, dbar, m = maugis_dugdale(
            abar * rho ** (-2.0 / 3.0), lam * rho ** (1.0 / 3.0), work_ratio
        )
        new *= rho
        # 1e-14: the inner closure's round-off can leave a 2-cycle a few ulp wide
        if abs(new - pbar) <= 1e-14 * (1.0 + abs(new)):
            pbar = new
            break
        pbar = new
    else:
        raise ArithmeticError(f"no fixed point at abar = {abar}, cell = {cell}")
    lift = IMAGE_OFFSET * pbar / cell + IMAGE_SPREAD * traction_moment(abar, pbar, lam, m) / cell**3
    return pbar, rho ** (1.0 / 3.0) * dbar + lift, m


def traction_moment(abar, pbar, lam, m):
    """The second moment of a Maugis-Dugdale sphere's traction, the integral of p r^2 over the
    surface, in pi dgamma0 R a_s^2 (the images' spread term of (M59)).

    Maugis's traction is Hertz's of the contact radius a, whose force Pbar - Pbar_D is
    spread as (2/5) a^2, plus Dugdale's adhesive one, -sigma_a on a < r < c and
    -(2 sigma_a / pi) arctan(sqrt((c^2 - a^2) / (a^2 - r^2))) inside (Maugis 1992; its force
    is (M56)'s Pbar_D = -lam A^2 (s + m^2 arctan s)); its moment, in closed form,
    -(lam / 2) A^4 ((pi / 2)(m^4 - 1) + 4 I(s)), I(s) the integral over t in (0, 1) of
    (1 - t^2) t arctan(s / t) (:func:`_dugdale_moment`). As m -> 1 (JKR) the adhesive share
    tends to (2/3) a^2 Pbar_D.

    Parameters
    ----------
    abar : float
        a / a_s.
    pbar : float
        The force (M47).
    lam : float
        Maugis's parameter with dgamma0 (M48) (the sigma_a of the adhesive traction).
    m : float
        c / a, >= 1.
    """
    s = math.sqrt(max(m * m - 1.0, 0.0))
    adhesive = -lam * abar * abar * (s + m * m * math.atan(s))
    dugdale = -0.5 * lam * abar**4 * (0.5 * math.pi * (m**4 - 1.0) + 4.0 * _dugdale_moment(s))
    return 0.4 * abar * abar * (pbar - adhesive) + dugdale


def _dugdale_moment(s):
    """I(s), the integral over t in (0, 1) of (1 - t^2) t arctan(s / t) (:func:`traction_moment`):
    arctan(s) / 4 + s B, B = 5/12 + s^2 / 4 - (2 + s^2) g / 4 with g = s arctan(1/s); for
    s > 10, where B's terms cancel, its series in u = 1/s, B = sum over n >= 1 of
    (-1)^(n+1) (2 / (2n + 1) - 1 / (2n + 3)) u^(2n) / 4 (to 1e-17 with 8 terms)."""
    if s > 10.0:
        u2 = 1.0 / (s * s)
        b = sum(
            (-1) ** (n + 1) * (2.0 / (2 * n + 1) - 1.0 / (2 * n + 3)) * u2**n / 4.0
            for n in range(1, 9)
        )
    else:
        g = s * (0.5 * math.pi - math.atan(s)) if s > 0.0 else 0.0
        b = 5.0 / 12.0 + 0.25 * s * s - 0.25 * (2.0 + s * s) * g
    return 0.25 * math.atan(s) + s * b
