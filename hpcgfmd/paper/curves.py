"""What the paper's checks measure on a retraction (pure functions of a result file's series).

All in the paper's dgamma0 scaling (docs/model.md, "Scales and dimensionless groups"):
abar = a_c / beta, Lbar = L_n / (R dgamma0^2 E0)^(1/3), the scaled curve
(x, y) = (Lbar / sqrt(abar), (pi/4) abar^(3/2)) of Figs. 4, 5a, 8a and 9, and the effective
work of adhesion of a point, dgamma_eff / dgamma0 = (y - x)^2 / (2 pi) (the intercept of the
slope-1 line through it; paper Sec. 5.1, :func:`hpcgfmd.model.theory.effective_work_ratio`).
A sphere's retraction is in its own scaling (docs/model.md, "The sphere"): abar = Abar = a / a_s,
lbar = Pbar (M47), (x, y) = (Pbar / Abar^(3/2), Abar^(3/2)) and (y - x)^2 / 6 (M55), and its
peeling velocity (M58) (:mod:`hpcgfmd.model.sphere_theory`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import sphere_theory, theory
from ..studies.distance import load_area_distances


@dataclass
class Retraction:
    """The attached part of one retraction, up to its last step with contact.

    Attributes
    ----------
    time : ndarray
        Time of each step with contact, t = 0 first (tau).
    abar, lbar : ndarray
        Scaled contact half-width a_c / beta and load L_n / (R dgamma0^2 E0)^(1/3).
    x, y : ndarray
        The scaled curve (:func:`hpcgfmd.model.theory.scaled_curve`).
    rhodot : ndarray
        Peeling velocity -d a_c / dt (R / tau), by central differences in time.
    pull_off : int
        Index of the most tensile load.
    groups : dict
        lambda0, k, Vz, chi_ve, depth and cell (the file's attributes; lengths in R).
    beta : float
        (R^2 dgamma0 / E0)^(1/3) (R); a sphere's a_s (M47).
    sphere : bool
        A sphere's retraction: abar, lbar, x, y in its scaling (M47), (M55).
    """

    time: np.ndarray
    abar: np.ndarray
    lbar: np.ndarray
    x: np.ndarray
    y: np.ndarray
    rhodot: np.ndarray
    pull_off: int
    groups: dict
    beta: float
    sphere: bool = False

    @property
    def theory(self):
        """The closed forms of the retraction's geometry: :mod:`~hpcgfmd.model.theory` (the
        cylinder) or :mod:`~hpcgfmd.model.sphere_theory`."""
        return sphere_theory if self.sphere else theory

    @classmethod
    def from_series(cls, series) -> Retraction:
        """From :class:`hpcgfmd.storage.reader.Series` (any units: converted to R, tau)."""
        a = series.attrs
        keep = series.contact_half_width > 0
        last = int(np.flatnonzero(keep)[-1]) + 1 if keep.any() else 0
        keep = keep[:last]
        time = series.time[:last][keep] / a["time_unit"]
        half_width = series.contact_half_width[:last][keep] / a["length_unit"]
        beta = a["beta"] / a["length_unit"]
        abar = half_width / beta
        lbar = series.lbar[:last][keep]
        rhodot = -np.gradient(half_width, time) if time.size > 1 else np.zeros_like(time)
        groups = {key: float(a[key]) for key in ("lambda0", "k", "Vz", "chi_ve", "depth", "cell")}
        sphere = bool(series.sphere)
        x, y = (sphere_theory if sphere else theory).scaled_curve(abar, lbar)
        return cls(
            time=time,
            abar=abar,
            lbar=lbar,
            x=x,
            y=y,
            rhodot=rhodot,
            pull_off=int(np.argmin(lbar)) if lbar.size else 0,
            groups=groups,
            beta=beta,
            sphere=sphere,
        )

    def label(self) -> str:
        """lambda0, V_z and h0/R, for legends and check values."""
        g = self.groups
        return f"lambda0 = {g['lambda0']:g}, V_z = {g['Vz']:g}, h0/R = {g['depth']:g}"

    def effective_work(self) -> np.ndarray:
        """dgamma_eff / dgamma0 of every point (paper Sec. 5.1; a sphere's (M55))."""
        return self.theory.effective_work_ratio(self.x, self.y)

    def vbar(self, convention: str) -> np.ndarray:
        """The peeling velocity in Eq. 8's scaling vbar = 2 pi rhodot tau_c / c0.

        ``convention`` "retardation": tau_c = tau / k (the one with which the closed form of
        Eq. 8 equals the quadrature of Eq. 6; docs/model.md (M31)); "relaxation": tau_c = tau
        (the paper's wording), k times smaller.
        """
        k = self.groups["k"]
        lambda0 = self.groups["lambda0"]
        retardation = self.theory.peel_velocity(self.rhodot, 1.0, k, lambda0, self.beta)
        if convention == "retardation":
            return retardation
        if convention == "relaxation":
            return k * retardation
        raise ValueError(f"convention {convention!r}: expected retardation or relaxation")

    def steady(self, from_abar: float) -> np.ndarray:
        """Mask of the steady part: the points from ``from_abar`` down (where the curves of
        two indentation depths have merged, :func:`merged_from`: the initial conditions no
        longer matter, paper Sec. 5.1) to the pull-off (past it the two edges interact or
        the contact jumps off). Empty for a NaN ``from_abar``."""
        mask = np.zeros(self.abar.size, dtype=bool)
        mask[: self.pull_off + 1] = self.abar[: self.pull_off + 1] <= from_abar
        return mask


def point_distances(curve: Retraction, reference: Retraction, upto: int | None = None):
    """Distance of each point of ``curve`` to ``reference``'s attached curve.

    Measured in the (abar, Lbar) plane scaled by the reference's abar(0) and |pull-off
    Lbar| (dimensionless): the curve error of the accuracy knob
    (:func:`hpcgfmd.studies.benchmark.curve_error`).

    Parameters
    ----------
    curve, reference : Retraction
    upto : int, optional
        Last index of ``curve`` taken (default its pull-off).

    Returns
    -------
    ndarray, shape (upto + 1,)
        NaN when the reference has fewer than two points up to its pull-off.
    """
    end = (curve.pull_off if upto is None else upto) + 1
    return load_area_distances(curve.abar[:end], curve.lbar[:end], reference.abar, reference.lbar)


def curve_distance(a: Retraction, b: Retraction, below: float = np.inf) -> float:
    """Largest :func:`point_distances` of ``a``'s points up to its pull-off with abar <=
    ``below`` from ``b``'s curve; NaN without such points."""
    distances = point_distances(a, b)
    keep = a.abar[: a.pull_off + 1] <= below
    return float(np.max(distances[keep])) if keep.any() else np.nan


def merged_from(deep: Retraction, shallow: Retraction, tolerance: float):
    """Where two depths' curves have merged (paper Fig. 5a): the largest abar of the shallow
    curve from which on (down to its pull-off) its points stay within ``tolerance`` of the
    deep curve (:func:`point_distances`).

    Returns (abar from which on, largest distance there, that abar as a fraction of the
    shallow curve's abar(0)); NaN when the last point before the pull-off is not within.
    """
    gap = point_distances(shallow, deep)
    inside = np.isfinite(gap) & (gap <= tolerance)
    if not inside.size or not inside[-1]:
        return np.nan, np.nan, np.nan
    outside = np.flatnonzero(~inside)
    first = outside[-1] + 1 if outside.size else 0
    return (
        float(shallow.abar[first]),
        float(np.max(gap[first:])),
        float(shallow.abar[first] / shallow.abar[0]),
    )


def depth_pairs(retractions, key):
    """{value of ``key``: (deep, shallow)} of the retractions that share ``key``'s value (e.g.
    V_z) at two indentation depths, deep first."""
    by_value = {}
    for curve in retractions:
        by_value.setdefault(curve.groups[key], {})[curve.groups["depth"]] = curve
    return {
        value: tuple(depths[d] for d in sorted(depths, reverse=True))
        for value, depths in sorted(by_value.items())
        if len(depths) == 2
    }


def steady_masks(retractions, key, tolerance):
    """The steady part of each retraction (same order): from where its pair of depths
    merged within ``tolerance`` (:func:`merged_from`) to its pull-off; empty without a
    pair or when the pair never merges."""
    start = {}
    for deep, shallow in depth_pairs(retractions, key).values():
        abar = merged_from(deep, shallow, tolerance)[0]
        start[id(deep)] = start[id(shallow)] = abar
    return [curve.steady(start.get(id(curve), np.nan)) for curve in retractions]


def log_ratio_statistics(measured, predicted):
    """Median and largest |ln(measured / predicted)|, and the median signed ln, over the
    finite positive pairs (NaN for none)."""
    measured, predicted = np.asarray(measured), np.asarray(predicted)
    ok = (measured > 0) & (predicted > 0) & np.isfinite(measured) & np.isfinite(predicted)
    if not ok.any():
        return np.nan, np.nan, np.nan
    signed = np.log(measured[ok] / predicted[ok])
    return float(np.median(np.abs(signed))), float(np.max(np.abs(signed))), float(np.median(signed))


def snapshot_profiles(result, contact_levels=(5.0, 3.0)):
    """The snapshots at (4/pi) abar_c = 5 and 3 and at zero load of one result file (the
    paper's Figs. 6 and 7), each picked among the file's snapshots by its own step: the one
    whose contact half-width is nearest the level (within 2 %: the run took it when the
    contact first dropped below a width given in the case file), and the first with a
    tensile load.

    Returns
    -------
    list of (title, x / a_c(0), (u - u_z) / R, p / E0, gap / R, contact edge / a_c(0))
        For the snapshots found; x and the profiles over the whole cell.
    """
    s, snaps = result.series, result.snapshots
    if not snaps.time.size or not s.time.size:
        return []
    steps = [int(np.argmin(np.abs(s.time - t))) for t in snaps.time]
    widths = s.contact_half_width[steps]
    a0 = s.contact_half_width[0]
    chosen = []
    for level in contact_levels:
        target = level * np.pi / 4.0 * s.attrs["beta"]
        j = int(np.argmin(np.abs(widths - target)))
        if abs(widths[j] - target) <= 0.02 * target:
            chosen.append((f"(4/pi) abar_c = {level:g}", j))
    tensile = [j for j, i in enumerate(steps) if s.load[i] < 0.0 and i > 0 and s.load[i - 1] >= 0.0]
    if tensile:
        chosen.append(("L = 0", tensile[0]))
    length, stress = s.attrs["length_unit"], s.attrs["stress_unit"]
    found = []
    for title, j in chosen:
        i = steps[j]
        inside = snaps.x[(snaps.gap[j] <= 0.0) & (snaps.x >= 0.0)]
        edge = float(inside.max() / a0) if inside.size else np.nan
        found.append(
            (
                title,
                snaps.x / a0,
                (snaps.surface[j] - s.indenter[i]) / length,
                snaps.pressure[j] / stress,
                snaps.gap[j] / length,
                edge,
            )
        )
    return found
