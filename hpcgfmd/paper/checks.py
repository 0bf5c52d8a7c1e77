"""Each of the paper's claims checked in numbers on our runs.

A check is a :class:`Check`: the figure, the paper's claim in our words, what we measured,
the numbers, and whether they support the claim under a stated criterion. A claim our
numbers do not support is reported as such, with the numbers. The criteria scale with the
runs' ``accuracy`` (the relative error of the pull-off and of the load-area curve each run
was asked for, docs/numerics.md "The accuracy knob"): a distance below ``RESOLVED`` times it
is not resolved from zero, one above it is. Distances between curves are the accuracy's
curve error (:func:`hpcgfmd.paper.curves.point_distances`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..model import theory
from ..studies.distance import polyline_distances
from . import curves

#: Distances up to this many times the accuracy count as agreement (two runs' errors add,
#: and the curve distance is a maximum over many points).
RESOLVED = 3.0
#: Eq. 8 "aligns quite well" with the per-point effective work when the median over the runs
#: of each run's median |ln(dgamma_eff / Eq. 8)| is below this (15 %).
EQ8_MEDIAN_LOG = 0.15
CONVENTIONS = ("retardation", "relaxation")


@dataclass
class Check:
    """One claim and its measurement."""

    figure: str
    claim: str
    measured: str
    values: dict = field(default_factory=dict)
    supported: bool | None = None  # None: nothing to decide (data missing)

    def line(self) -> str:
        verdict = {True: "supported", False: "NOT supported", None: "not decided"}
        numbers = ", ".join(f"{key} = {_fmt(value)}" for key, value in self.values.items())
        return (
            f"Fig. {self.figure}: {self.claim} -- {verdict[self.supported]}:"
            f" {self.measured}: {numbers}"
        )


def _fmt(value):
    if isinstance(value, float):
        return f"{value:.3g}"
    return str(value)


def _short(curve):
    g = curve.groups
    return f"lambda0={g['lambda0']:g},Vz={g['Vz']:g},h0={g['depth']:g}"


# --- Fig. 2 ----------------------------------------------------------------------------------
def check_fig2(k=0.1):
    """Eq. 8's limits, and its velocity convention: the closed form against the quadrature of
    Eq. 6 at the same vbar (retardation time), and against the quadrature at k vbar (what
    reading vbar with the relaxation time predicts instead)."""
    low, high = theory.persson_brener(1e-9, k), theory.persson_brener(1e9, k)
    vbar = np.logspace(-2, 3, 11)
    closed = np.array([theory.persson_brener(v, k) for v in vbar])
    quadrature = np.array([theory.persson_brener_quadrature(v, k) for v in vbar])
    other = np.array([theory.persson_brener_quadrature(k * v, k) for v in vbar])
    retardation = float(np.max(np.abs(np.log(closed / quadrature))))
    relaxation = float(np.max(np.abs(np.log(closed / other))))
    return [
        Check(
            "2",
            "dgamma_eff/dgamma0 -> 1 as vbar -> 0 and -> E_inf/E_0 = 1/k as vbar -> inf",
            "Eq. 8 at vbar = 1e-9 and 1e9",
            {"low": low, "high": high, "1/k": 1.0 / k},
            bool(abs(low - 1) < 1e-6 and abs(high * k - 1) < 1e-6),
        ),
        Check(
            "2",
            "Eq. 8 is the closed form of Eq. 6 for the SLS",
            "largest |ln(closed form / quadrature of Eq. 6)| for vbar in 1e-2..1e3, with"
            " tau_c the retardation time tau/k, and with tau_c = tau",
            {"retardation": retardation, "relaxation": relaxation},
            bool(retardation < 1e-6 < relaxation),
        ),
    ]


# --- Fig. 4 ----------------------------------------------------------------------------------
def baney_hui_distance(curve: curves.Retraction):
    """Our elastic retraction against Baney-Hui, and JKR against Baney-Hui.

    Returns
    -------
    ours : float
        Largest :func:`curves.point_distances` of our points up to the pull-off from the
        Baney-Hui curve of the same lambda (Eqs. 12-13) with the periodic cell's factor
        (docs/model.md (M29)), drawn from 5 % beyond our widest contact down to a fifth of
        our pull-off's width.
    jkr : float
        The same distance of the JKR curve (Eq. 10) from Baney-Hui's, from Baney-Hui's load
        minimum (before the tail of the complete withdrawal, paper Sec. 4) up to our first
        point's width; NaN when that range is empty.
    """
    lam, cell = curve.groups["lambda0"], curve.groups["cell"]
    end = curve.pull_off + 1
    # Baney-Hui from beyond our widest contact: where the load rises steeply with the width
    # (the preload, 20 times the pull-off load), a curve cut at our first point's width
    # would measure that point's distance along the load alone
    grid = np.linspace(1.05 * curve.abar[:end].max(), 0.2 * curve.abar[curve.pull_off], 800)
    bh = np.array([theory.maugis_dugdale(a, lam)[0] for a in grid])
    periodic = bh * theory.periodic_load_factor(grid * curve.beta, cell)
    a_scale, l_scale = curve.abar[0], abs(periodic.min())
    ours = polyline_distances(
        np.stack([curve.abar[:end] / a_scale, curve.lbar[:end] / l_scale], 1),
        np.stack([grid / a_scale, periodic / l_scale], 1),
    )
    upper = (grid >= grid[np.argmin(bh)]) & (grid <= curve.abar[0])
    jkr = polyline_distances(
        np.stack([grid[upper] / a_scale, theory.jkr_load(grid[upper]) / l_scale], 1),
        np.stack([grid / a_scale, bh / l_scale], 1),
    )
    return float(np.max(ours)), float(np.max(jkr)) if len(jkr) else np.nan


def check_fig4(runs, accuracy):
    """Our elastic retractions against Baney-Hui; Baney-Hui against JKR (paper Sec. 4)."""
    if not runs:
        return [Check("4", "elastic retractions follow Baney-Hui", "no runs", {}, None)]
    resolved = RESOLVED * accuracy
    distances, jkr = {}, {}
    for curve in runs:
        key = f"lambda={curve.groups['lambda0']:g}"
        distances[key], jkr[key] = baney_hui_distance(curve)
    large = [v for key, v in jkr.items() if float(key.split("=")[1]) >= 3.5]
    small = [v for key, v in jkr.items() if float(key.split("=")[1]) < 3.5]
    return [
        Check(
            "4",
            "our elastic (k = 1) retractions lie on the Baney-Hui curves (Eqs. 12-13)",
            "largest distance of our points up to the pull-off from the Baney-Hui curve, in"
            " units of abar_c(0) and |pull-off Lbar| (the accuracy knob's curve error);"
            f" agreement when <= {RESOLVED:g} x accuracy = {resolved:g}",
            distances,
            all(d <= resolved for d in distances.values()),
        ),
        Check(
            "4",
            "for lambda >= 3.5 Baney-Hui agrees excellently with JKR, poorer below",
            "largest distance of the JKR curve from Baney-Hui's, from Baney-Hui's load"
            f" minimum up, on the same scales; excellent when <= {resolved:g}, poorer when"
            " above it",
            jkr,
            bool(max(large) <= resolved and small and max(small) > resolved)
            if large and small
            else None,
        ),
    ]


# --- Figs. 5a and 8a -------------------------------------------------------------------------
def check_depths(figure, runs, key, accuracy):
    """The two depths' curves after the transient (paper Fig. 5a), for each value of ``key``
    (V_z in Fig. 5, lambda0 in Fig. 8) run at two depths: where they merge within the
    resolved distance (the verdict) and within the accuracy itself (finer, at the limit of
    what the runs resolve)."""
    pairs = curves.depth_pairs(runs, key)
    if not pairs:
        return [Check(figure, "the indentation depth matters only in a transient", "no runs")]
    values, merged = {}, []
    for value, (deep, shallow) in pairs.items():
        label = f"{key}={value:g}"
        for factor in (RESOLVED, 1.0):
            abar, distance, fraction = curves.merged_from(deep, shallow, factor * accuracy)
            values[f"{label}: of abar(0) within {factor * accuracy:g}"] = fraction
            if factor == RESOLVED:
                values[f"{label}: from abar"] = abar
                merged.append(np.isfinite(abar))
    return [
        Check(
            figure,
            "after a transient the curves from the two indentation depths superimpose",
            "the shallow curve's contact half-width, as a fraction of its initial one, from which"
            f" on (to its pull-off) it stays within {RESOLVED:g} x accuracy ="
            f" {RESOLVED * accuracy:g}"
            f" (and within the accuracy, {accuracy:g}) of the deep curve (distance in units of"
            " abar_c(0) and |pull-off Lbar|)",
            values,
            bool(all(merged)),
        )
    ]


# --- Figs. 5b and 8b -------------------------------------------------------------------------
def check_eq8(figure, runs, masks):
    """Per-point effective work in the steady parts (``masks``, :func:`curves.steady_masks`)
    against Eq. 8, in both conventions of vbar. Each run counts once (its median), whatever
    its number of steps."""
    if not runs:
        return [Check(figure, "the effective work follows Eq. 8", "no runs")]
    values, per_run = {}, {c: [] for c in CONVENTIONS}
    for curve, steady in zip(runs, masks):
        work = curve.effective_work()[steady]
        values[f"{_short(curve)}: steady points"] = int(steady.sum())
        for convention in CONVENTIONS:
            vbar = curve.vbar(convention)[steady]
            predicted = np.atleast_1d(
                theory.persson_brener(vbar, curve.groups["k"]) if vbar.size else vbar
            )
            median, largest, signed = curves.log_ratio_statistics(work, predicted)
            values[f"{_short(curve)} {convention}: median |ln|"] = median
            values[f"{_short(curve)} {convention}: max |ln|"] = largest
            values[f"{_short(curve)} {convention}: median ln"] = signed
            if np.isfinite(median):
                per_run[convention].append(median)
    summary = {c: float(np.median(per_run[c])) if per_run[c] else np.nan for c in CONVENTIONS}
    worst = {c: float(np.max(per_run[c])) if per_run[c] else np.nan for c in CONVENTIONS}
    best = min(CONVENTIONS, key=lambda c: summary[c] if np.isfinite(summary[c]) else np.inf)
    return [
        Check(
            figure,
            "the per-point effective work of the steady retraction follows Eq. 8",
            "per run, the median |ln(dgamma_eff / Eq. 8)| over its steady points (from where"
            " the two depths' curves merged to the pull-off); the median and the largest of"
            f" these over the runs, per convention of vbar; follows when the better"
            f" convention's median is below {EQ8_MEDIAN_LOG:g}",
            {
                **{f"{c}: median over runs": summary[c] for c in CONVENTIONS},
                **{f"{c}: worst run": worst[c] for c in CONVENTIONS},
                "data follow": best,
            },
            bool(summary[best] < EQ8_MEDIAN_LOG) if np.isfinite(summary[best]) else None,
        ),
        Check(
            figure,
            "per case",
            "steady points; median and largest |ln(dgamma_eff / Eq. 8)|"
            " and the median signed ln (> 0: Eq. 8 below the data)",
            values,
            None,
        ),
    ]


# --- Fig. 8: the instantaneous limit ---------------------------------------------------------
def check_instantaneous(runs, masks, accuracy):
    """Distance of each lambda0's steady effective work (``masks``) to the instantaneous
    limit dgamma_inf = dgamma0 / k (paper Sec. 5.2)."""
    resolved = RESOLVED * accuracy
    values, largest = {}, {}
    for curve, steady in zip(runs, masks):
        ratio = curve.effective_work()[steady] * curve.groups["k"]  # dgamma_eff / dgamma_inf
        if not ratio.size:
            continue
        values[f"{_short(curve)}: median"] = float(np.median(ratio))
        values[f"{_short(curve)}: largest"] = float(np.max(ratio))
        largest.setdefault(curve.groups["lambda0"], []).append(float(np.max(ratio)))
    if not largest:
        return [
            Check(
                "8",
                "lambda0 = 14 is not sufficient to reach the instantaneous limit",
                "no steady parts",
                {},
                None,
            )
        ]
    lams = sorted(largest)
    top = max(largest[lams[-1]])
    rising = all(max(largest[a]) < min(largest[b]) for a, b in zip(lams, lams[1:]))
    return [
        Check(
            "8",
            f"at V_z = 0.9, lambda0 = {lams[-1]:g} is not sufficient to reach the"
            " instantaneous limit",
            "steady dgamma_eff / dgamma_inf per run (its largest is at the pull-off); short"
            f" of the limit when 1 - largest > {RESOLVED:g} x accuracy = {resolved:g}",
            values,
            bool(1.0 - top > resolved),
        ),
        Check(
            "8",
            "a larger lambda0 brings the contact closer to the instantaneous limit",
            "the largest steady dgamma_eff / dgamma_inf of each lambda0's runs (both depths)"
            " rises with lambda0",
            {f"lambda0={lam:g}": max(largest[lam]) for lam in lams},
            bool(rising) if len(lams) > 1 else None,
        ),
    ]


# --- Fig. 9 ----------------------------------------------------------------------------------
#: Fig. 9's curves are compared past the start-up transient too: below this fraction of the
#: smaller initial contact half-width (the depths of Figs. 5a and 8a merge within three times
#: the accuracy by 0.97-0.99 of it, within the accuracy by 0.52-0.97).
PAST_TRANSIENT = 0.8


def check_collapse(runs):
    """Curves of equal chi_ve against curves of different chi_ve (paper Fig. 9): the largest
    distance within each pair of equal chi_ve, the smallest between neighbouring chi_ve
    groups, over the whole curves and past the start-up transient."""
    by_chi = {}
    for curve in runs:
        by_chi.setdefault(round(curve.groups["chi_ve"], 6), []).append(curve)
    chis = sorted(by_chi)
    results = []
    for scope, fraction in (("whole curves", np.inf), ("past the transient", PAST_TRANSIENT)):

        def distance(a, b, fraction=fraction):
            below = fraction * min(a.abar[0], b.abar[0])
            return max(curves.curve_distance(a, b, below), curves.curve_distance(b, a, below))

        within = {
            f"chi_ve={chi:.3g}": distance(*group)
            for chi, group in by_chi.items()
            if len(group) == 2
        }
        between = {
            f"chi_ve={a:.3g} vs {b:.3g}": float(
                np.nanmin([distance(x, y) for x in by_chi[a] for y in by_chi[b]])
            )
            for a, b in zip(chis, chis[1:])
        }
        numbers = list(within.values()) + list(between.values())
        if not within or not between or not np.all(np.isfinite(numbers)):
            results.append(
                Check(
                    "9",
                    "equal chi_ve gives the same curve",
                    f"{scope}: needs two pairs of equal chi_ve that overlap",
                    {**within, **between},
                    None,
                )
            )
            continue
        ratio = max(within.values()) / min(between.values())
        results.append(
            Check(
                "9",
                "cases of equal chi_ve = V_z lambda0^2 (different V_z and lambda0) respond"
                f" alike ({scope})",
                "largest distance of one curve's points up to the pull-off"
                + (f" and below {fraction:g} abar(0)" if np.isfinite(fraction) else "")
                + " from the other curve (units of abar_c(0) and |pull-off Lbar|) within each"
                " equal-chi_ve pair (either way round), the smallest between neighbouring chi_ve"
                " groups, and their ratio; a collapse when the ratio is below 1/2",
                {**within, **between, "ratio": ratio},
                bool(ratio < 0.5),
            )
        )
    return results


# --- Fig. B1 ---------------------------------------------------------------------------------
def check_convergence(series_by_label, accuracy):
    """Pull-off and curve at each resolution against the finest (paper Fig. B1).

    ``series_by_label``: {series label: [(setting label, retraction), ...] finest last}; a
    setting label names the grid ("2^17") or the step ("tau/50", "adaptive").
    """
    resolved = RESOLVED * accuracy
    checks = []
    for label, runs in series_by_label.items():
        if len(runs) < 2:
            continue
        finest_label, finest = runs[-1]
        values, paper = {}, []
        for setting, curve in runs[:-1]:
            pull = float(abs(curve.lbar[curve.pull_off] / finest.lbar[finest.pull_off] - 1))
            distance = curves.curve_distance(curve, finest)
            values[f"{setting}: pull-off"] = pull
            values[f"{setting}: curve"] = distance
            if setting in ("2^17", "tau/50"):
                paper += [pull, distance]
        values["finest"] = finest_label
        checks.append(
            Check(
                "B1",
                f"{label}: the paper's setting (n_x = 2^17, dt = tau/50) is converged",
                "relative pull-off difference and curve distance against"
                f" {finest_label}; converged when both are within {RESOLVED:g} x accuracy ="
                f" {resolved:g}",
                values,
                bool(max(paper) <= resolved) if paper else None,
            )
        )
    return checks


# --- Figs. 6 and 7: profiles -----------------------------------------------------------------
def check_separation(cases):
    """Fig. 6c: at zero load the surfaces that were in contact separate less the faster the
    retraction, and the gap profiles of different V_z do not cross. ``cases``: [(Vz,
    result)] by increasing V_z."""
    profiles = []
    for vz, result in cases:
        zero = [p for p in curves.snapshot_profiles(result) if p[0] == "L = 0"]
        if zero and np.isfinite(zero[0][5]):
            _, x, _, _, gap, edge = zero[0]
            profiles.append((vz, x, gap, edge))
    if len(profiles) < 2:
        return [
            Check(
                "6",
                "at zero load a faster retraction leaves a smaller separation",
                "needs two L = 0 snapshots with contact",
                {},
                None,
            )
        ]
    # compare on the first run's nodes from the outermost contact edge to 2 a_c(0)
    start = max(p[3] for p in profiles)
    x0 = profiles[0][1]
    nodes = x0[(x0 >= start) & (x0 <= 2.0)]
    gaps = [np.interp(nodes, x, gap) for _, x, gap, _ in profiles]
    values = {
        f"gap/R at x = a_c(0), V_z={vz:g}": float(np.interp(1.0, x, gap))
        for vz, x, gap, _ in profiles
    }
    ordered = all(bool(np.all(fast <= slow + 1e-12)) for slow, fast in zip(gaps, gaps[1:]))
    return [
        Check(
            "6",
            "at zero load a faster retraction leaves a smaller separation where"
            " the surfaces were in contact, and the profiles do not cross",
            "gap at the initial contact edge, and whether the gaps are ordered by V_z"
            " at every node from the outermost contact edge to 2 a_c(0)",
            values,
            ordered,
        )
    ]


def check_annulus(runs, levels=(5.0, 3.0)):
    """Fig. 7: the adhesive annulus widens with the retraction velocity, at (4/pi) abar_c
    = 5 and 3 (interpolated in the series). ``runs``: [(retraction, series)] by V_z."""
    values, rising = {}, True
    for level in levels:
        widths = []
        for curve, series in runs:
            target = level * np.pi / 4.0
            a = series.abar
            zone = (series.cohesive_half_width - series.contact_half_width) / series.attrs["beta"]
            below = np.flatnonzero(a[1:] < target)
            if not below.size:
                continue
            i = below[0] + 1
            t = (target - a[i - 1]) / (a[i] - a[i - 1])
            widths.append(float(zone[i - 1] + t * (zone[i] - zone[i - 1])))
            values[f"(4/pi)abar={level:g} Vz={curve.groups['Vz']:g}"] = widths[-1]
        rising &= len(widths) > 1 and all(a < b for a, b in zip(widths, widths[1:]))
    return [
        Check(
            "7",
            "the adhesive annulus widens with the retraction velocity",
            "cohesive-zone width (a_a - a_c) / beta at (4/pi) abar_c = 5 and 3, by V_z",
            values,
            bool(rising) if values else None,
        )
    ]
