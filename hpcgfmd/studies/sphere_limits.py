"""The viscoelastic sphere's retraction against its limits: the instantaneous limit (M57) and
Persson-Brener's effective work of adhesion at the measured edge speed (M58), in the periodic
cell (M59). What tests/test_sphere_limits.py asserts and scripts/sphere_limits.py tabulates
(docs/results.md, "The sphere").

A run's attached points (Abar, Pbar, Dbar) are read in the sphere's scales (M47). The effective
work of a point is the work ratio r = dgamma_eff / dgamma0 of the reference curve through it:
JKR's line (M55), (y - x)^2 / 6, or the Maugis-Dugdale curve (M56) with E0, the same sigma_a
and the work r dgamma0, found by inverting that curve at the point's contact radius; both in
the cell (M59). At lambda0 <= 3 JKR's line reads the points of Maugis-Dugdale curves 0.6 to
1.4 times their r (the curves are no lines there); the instantaneous limit is the
Maugis-Dugdale one (M57). The edge speed -dAbar/dT is the local
least-squares slope of the contact radius against time (the node count's radius steps by a
fraction of dx, too noisy for differences between neighbouring steps).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..model import sphere_theory, theory
from .distance import load_area_distances, polyline_distances

#: Eq. 8's velocity read with the retardation time tau / k (M58) or the relaxation time tau
#: (k times smaller), as docs/paper.md does for the cylinder.
CONVENTIONS = ("retardation", "relaxation")


class SphereCurve(NamedTuple):
    """The attached steps of a sphere's retraction in the scales of (M47)."""

    time: np.ndarray  # T = t / tau
    abar: np.ndarray  # contact radius a / a_s (the node count's equivalent radius)
    pbar: np.ndarray  # force P / (pi dgamma0 R), compressive positive
    dbar: np.ndarray  # depth of the apex below the mean surface level, delta / delta_s
    cell: float  # L / a_s
    maugis: float  # lambda0 (M48)
    k: float  # E0 / Einf
    dx: float  # grid spacing / a_s


def sphere_curve(case, series) -> SphereCurve:
    """The attached steps of ``series`` (a run of the sphere ``case``) as a SphereCurve."""
    keep = series.contact_half_width > 0
    return SphereCurve(
        series.time[keep],
        series.contact_half_width[keep] / case.beta,
        series.load[keep] / case.load_scale,
        -series.indenter[keep] / case.depth_scale,
        case.cell / case.beta,
        case.maugis,
        case.modulus_ratio,
        case.dx / case.beta,
    )


def jkr_work(abar, pbar, cell):
    """dgamma_eff / dgamma0 of points (Abar, Pbar) from JKR's line (M55), the cell's images
    taken out first (M59): Pbar_isolated = Pbar (1 - IMAGE_CURVATURE (Abar / Lbar)^3)."""
    abar = np.asarray(abar, dtype=float)
    isolated = np.asarray(pbar) * (1.0 - sphere_theory.IMAGE_CURVATURE * (abar / cell) ** 3)
    return sphere_theory.effective_work_ratio(*sphere_theory.scaled_curve(abar, isolated))


def maugis_work(abar, pbar, maugis, cell, upper):
    """dgamma_eff / dgamma0 of points (Abar, Pbar): the work ratio r of the Maugis-Dugdale
    curve with E0, the same sigma_a and work r dgamma0 (M56), in the cell (M59), through
    each point (its force at a given radius falls monotonically with r).

    Parameters
    ----------
    abar, pbar : array
        Contact radii a / a_s and forces P / (pi dgamma0 R) (M47).
    maugis : float
        lambda0 (M48).
    cell : float
        L / a_s.
    upper : float
        The largest r sought (1/k and a margin); NaN where r is not within (1/8, upper).
    """
    from scipy import optimize

    out = np.full(np.size(abar), np.nan)
    for i, (a, p) in enumerate(zip(np.atleast_1d(abar), np.atleast_1d(pbar))):

        def excess(r, a=a, p=p):
            return sphere_theory.periodic_cell(a, cell, maugis, r)[0] - p

        if excess(0.125) > 0.0 > excess(upper):
            out[i] = optimize.brentq(excess, 0.125, upper, xtol=1e-8, rtol=1e-10)
    return out


def edge_speed(time, abar, reach):
    """-dAbar/dT at each point (a_s / tau, rhodot tau / a_s of (M58)): the least-squares slope
    of Abar against T (``time``, tau) over the points whose Abar is within ``reach`` (a_s) of
    the point's, and at least its neighbours (the node count's radius steps by a fraction of
    dx, so ``reach`` of a few dx smooths it)."""
    out = np.empty(abar.size)
    for i in range(abar.size):
        near = np.abs(abar - abar[i]) <= reach
        near[max(i - 1, 0) : i + 2] = True
        out[i] = -np.polyfit(time[near], abar[near], 1)[0]
    return out


def glassy_limit(radii, maugis, k, cell, depth0):
    """The retraction at V_z -> infinity from the relaxed preload at depth ``depth0`` (Dbar),
    on its contact radii (M57): the instantaneous curve's force, and the depth
    k Dbar_inst + (1 - k) Dbar0 (both in the cell (M59))."""
    pbar, dbar = sphere_theory.periodic_cell(radii, cell, maugis, 1.0 / k)
    return pbar, k * dbar + (1.0 - k) * depth0


def least_load(cell, maugis, work_ratio):
    """The least force of the Maugis-Dugdale curve (M56) of work ``work_ratio`` dgamma0 (same
    sigma_a) in the cell (M59): where load control lets go and displacement control passes
    (on a grid of radii, then a bounded search between the grid's neighbours)."""
    radii = np.linspace(0.1, 2.5, 97) * work_ratio ** (1.0 / 3.0)

    def load(a):
        return sphere_theory.periodic_cell(a, cell, maugis, work_ratio)[0]

    from scipy import optimize

    i = int(np.argmin([load(a) for a in radii]))
    found = optimize.minimize_scalar(
        load, bounds=(radii[max(i - 1, 0)], radii[min(i + 1, radii.size - 1)]), method="bounded"
    )
    return float(found.fun)


def pull_off_fraction(curve):
    """Where the run's pull-off (its most tensile force) lies between the relaxed limit's
    least force (M56 with E0, dgamma0) and the instantaneous limit's (M57: E0, dgamma0 / k,
    the same sigma_a), both in the cell (M59): 0 relaxed, 1 instantaneous.

    Returns
    -------
    pull_off, relaxed, instantaneous, fraction : float
    """
    relaxed = least_load(curve.cell, curve.maugis, 1.0)
    instantaneous = least_load(curve.cell, curve.maugis, 1.0 / curve.k)
    pull_off = float(curve.pbar.min())
    return pull_off, relaxed, instantaneous, (pull_off - relaxed) / (instantaneous - relaxed)


class GlassyCheck(NamedTuple):
    """A run at V_z -> infinity against the glassy limit (M57) (forces in pi dgamma0 R)."""

    pull_off: float  # the run's most tensile force
    reference: float  # the instantaneous limit's least force in the cell
    curve: float  # largest distance of the run's (Dbar, Pbar) points to the limit's curve
    points: int  # the points compared: their cohesive zone inside the preload's contact
    work: tuple  # least and largest k dgamma_eff / dgamma0 of those points (Maugis-Dugdale)


def zone_inside(curve):
    """The points up to the pull-off whose contact radius and instantaneous cohesive zone
    (c = m a, (M56) with work dgamma0 / k) lie at least dx inside the preload's contact
    radius: where the glassy retraction is the instantaneous problem exactly (M57)."""
    _, _, m = sphere_theory.maugis_dugdale(curve.abar, curve.maugis, 1.0 / curve.k)
    upto = np.arange(curve.abar.size) <= int(np.argmin(curve.pbar))
    return upto & (m * curve.abar <= curve.abar[0] - curve.dx)


def glassy_check(curve) -> GlassyCheck:
    """A run with V_z -> infinity (its bulk glassy from the relaxed preload) against the glassy
    limit (M57): its force and depth, both exact observables, on the points of
    :func:`zone_inside`, against the curve (Dbar, Pbar) of :func:`glassy_limit`, distances
    in the preload's depth and the limit's |least force|."""
    inside = zone_inside(curve)
    reference = least_load(curve.cell, curve.maugis, 1.0 / curve.k)
    radii = np.linspace(0.5 * curve.abar[inside].min(), curve.abar[0], 400)
    pbar, dbar = glassy_limit(radii, curve.maugis, curve.k, curve.cell, curve.dbar[0])
    scale = np.array([curve.dbar[0], abs(reference)])
    points = np.c_[curve.dbar[inside], curve.pbar[inside]] / scale
    distance = polyline_distances(points, np.c_[dbar, pbar] / scale).max()
    work = curve.k * maugis_work(
        curve.abar[inside], curve.pbar[inside], curve.maugis, curve.cell, 2.0 / curve.k
    )
    return GlassyCheck(
        float(curve.pbar.min()),
        reference,
        float(distance),
        int(inside.sum()),
        (float(work.min()), float(work.max())),
    )


def steady_masks(deep, shallow, tolerance):
    """The steady parts of two depths' runs of one case (the cylinder's paper Fig. 5a,
    :func:`hpcgfmd.paper.curves.merged_from`): from the contact radius at which the shallow
    run's (Abar, Pbar) points come within ``tolerance`` of the deep run's curve (for good,
    to its pull-off; :func:`~hpcgfmd.studies.distance.load_area_distances`) down to each
    run's pull-off. Empty masks when they never merge.

    Returns
    -------
    deep_mask, shallow_mask : ndarray of bool
    from_abar : float
        The contact radius from which on they are merged (NaN: never).
    """
    end = int(np.argmin(shallow.pbar)) + 1
    gap = load_area_distances(shallow.abar[:end], shallow.pbar[:end], deep.abar, deep.pbar)
    inside = np.isfinite(gap) & (gap <= tolerance)
    from_abar = np.nan
    if inside.size and inside[-1]:
        outside = np.flatnonzero(~inside)
        from_abar = float(shallow.abar[outside[-1] + 1 if outside.size else 0])
    masks = []
    for curve in (deep, shallow):
        mask = np.zeros(curve.abar.size, dtype=bool)
        upto = int(np.argmin(curve.pbar)) + 1
        mask[:upto] = curve.abar[:upto] <= from_abar  # all False for a NaN from_abar
        masks.append(mask)
    return masks[0], masks[1], from_abar


class PerssonBrenerCheck(NamedTuple):
    """One run's steady points against Persson-Brener's Eq. 8 (M30) at their edge speed (M58).

    ``maugis`` and ``jkr`` map each convention of :data:`CONVENTIONS` to the median over the
    points of ln(dgamma_eff / Eq. 8) (> 0: Eq. 8 below the data), the effective work read
    from (M56) and from (M55).
    """

    points: int
    vbar: tuple  # least and largest vbar of the points, retardation convention
    work: tuple  # least and largest k dgamma_eff / dgamma0 (Maugis-Dugdale reading)
    maugis: dict
    jkr: dict


def persson_brener_check(curve, mask, reach) -> PerssonBrenerCheck:
    """The effective work of ``curve``'s points ``mask`` (a SphereCurve and a boolean mask,
    e.g. :func:`steady_masks`') against Eq. 8 at the edge speed of :func:`edge_speed`
    (``reach`` in a_s), vbar (M58) in both conventions (:data:`CONVENTIONS`)."""
    speed = edge_speed(curve.time, curve.abar, reach)[mask]
    vbar = sphere_theory.peel_velocity(speed, 1.0, curve.k, curve.maugis, 1.0)
    abar, pbar = curve.abar[mask], curve.pbar[mask]
    readings = {
        "maugis": maugis_work(abar, pbar, curve.maugis, curve.cell, 2.0 / curve.k),
        "jkr": jkr_work(abar, pbar, curve.cell),
    }
    logs = {name: {} for name in readings}
    for convention in CONVENTIONS:
        scaled = vbar if convention == "retardation" else curve.k * vbar
        eq8 = np.atleast_1d(theory.persson_brener(scaled, curve.k))
        for name, work in readings.items():
            logs[name][convention] = np.log(work / eq8)
    return PerssonBrenerCheck(
        int(mask.sum()),
        (float(vbar.min()), float(vbar.max())),
        (float(curve.k * readings["maugis"].min()), float(curve.k * readings["maugis"].max())),
        {c: float(np.median(v)) for c, v in logs["maugis"].items()},
        {c: float(np.median(v)) for c, v in logs["jkr"].items()},
    )
