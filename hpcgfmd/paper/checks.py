"""Each of the paper's claims checked in numbers on our runs.

A check is a :class:`Check`: the figure, the paper's claim in our words, what we measured,
the numbers, and whether they support the claim under a stated criterion. A claim our
numbers do not support is reported as such, with the numbers. The criteria scale with the
study's ``accuracy`` (the relative error of the pull-off and of the load-area curve each run
was asked for, docs/numerics.md "The accuracy knob"): a distance below a few times it is not
resolved from zero, one well above it is.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..model import theory
from . import curves

#: Distances up to this many times the study's accuracy count as agreement (two runs' errors
#: add, and the curve distance is a maximum over many points).
RESOLVED = 3.0
#: Eq. 8 "aligns quite well" with the per-point effective work when the median |ln ratio|
#: over the steady parts is below this (15 %: the paper's Fig. 5b scatter).
EQ8_MEDIAN_LOG = 0.15
#: "Not sufficient to reach the instantaneous limit": the steady effective work stays below
#: this fraction of dgamma0 / k.
SHORT_OF_LIMIT = 0.9
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
        return (f"Fig. {self.figure}: {self.claim} -- {verdict[self.supported]}:"
                f" {self.measured}: {numbers}")


def _fmt(value):
    if isinstance(value, float):
        return f"{value:.3g}"
    return str(value)


def _label(curve):
    g = curve.groups
    return f"lambda0={g['lambda0']:g},Vz={g['Vz']:g},h0={g['depth']:g}"


# --- Fig. 2 ----------------------------------------------------------------------------------
def check_fig2(k=0.1):
    """Eq. 8's limits and its convention: the closed form against the quadrature of Eq. 6."""
    low, high = theory.persson_brener(1e-9, k), theory.persson_brener(1e9, k)
    vbar = np.logspace(-2, 3, 11)
    closed = np.array([theory.persson_brener(v, k) for v in vbar])
    quadrature = np.array([theory.persson_brener_quadrature(v, k) for v in vbar])
    # the same quadrature with the velocity scaled by the relaxation time (k times smaller)
    relaxed = np.array([theory.persson_brener_quadrature(k * v, k) for v in vbar])
    retardation = float(np.max(np.abs(np.log(closed / quadrature))))
    relaxation = float(np.max(np.abs(np.log(closed / relaxed))))
    return [
        Check("2", "dgamma_eff/dgamma0 -> 1 as vbar -> 0 and -> E_inf/E_0 = 1/k as vbar -> inf",
              "Eq. 8 at vbar = 1e-9 and 1e9", {"low": low, "high": high, "1/k": 1.0 / k},
              bool(abs(low - 1) < 1e-6 and abs(high * k - 1) < 1e-6)),
        Check("2", "Eq. 8 is the closed form of Eq. 6 for the SLS",
              "largest |ln(closed form / quadrature of Eq. 6)| for vbar in 1e-2..1e3, with"
              " tau_c the retardation time tau/k, and with tau_c = tau",
              {"retardation": retardation, "relaxation": relaxation},
              bool(retardation < 1e-6 < relaxation)),
    ]


# --- Fig. 4 ----------------------------------------------------------------------------------
def baney_hui_distance(curve: curves.Retraction):
    """Our elastic retraction against Baney-Hui (Eqs. 12-13 with the periodic cell's factor,
    docs/model.md (M29)): the largest :func:`curves.point_distances` of our points up to
    the pull-off from the Baney-Hui curve; and, on the same scales, the largest distance of
    JKR (Eq. 10) from Baney-Hui from Baney-Hui's load minimum up (before the tail of the
    complete withdrawal, paper Sec. 4)."""
    lam, cell = curve.groups["lambda0"], curve.groups["cell"]
    grid = np.linspace(curve.abar[0], 0.2 * curve.abar[curve.pull_off], 800)
    bh = np.array([theory.maugis_dugdale(a, lam)[0] for a in grid])
    reference = curves.Retraction(
        time=grid, abar=grid, lbar=bh * theory.periodic_load_factor(grid * curve.beta, cell),
        x=grid, y=grid, rhodot=grid, pull_off=int(np.argmin(bh)), groups=curve.groups,
        beta=curve.beta)
    ours = float(np.nanmax(curves.point_distances(curve, reference)))
    upper = grid >= grid[np.argmin(bh)]
    jkr = theory.jkr_load(grid[upper])
    jkr_curve = replace(reference, abar=grid[upper], lbar=jkr, pull_off=int(np.argmin(jkr)))
    jkr_distance = float(np.nanmax(curves.point_distances(
        jkr_curve, replace(reference, lbar=bh), upto=jkr.size - 1)))
    return ours, jkr_distance


def check_fig4(runs, accuracy):
    """Our elastic retractions against Baney-Hui; Baney-Hui against JKR (paper Sec. 4)."""
    checks = []
    if not runs:
        return [Check("4", "elastic retractions follow Baney-Hui", "no runs", {}, None)]
    distances, jkr = {}, {}
    for curve in runs:
        lam = curve.groups["lambda0"]
        distances[f"lambda={lam:g}"], jkr[f"lambda={lam:g}"] = baney_hui_distance(curve)
    checks.append(Check(
        "4", "our elastic (k = 1) retractions lie on the Baney-Hui curves (Eqs. 12-13)",
        "largest distance of our points up to the pull-off from the Baney-Hui curve, in"
        " units of abar_c(0) and |pull-off Lbar| (the accuracy knob's curve error); agreement"
        f" when <= {RESOLVED:g} x accuracy = {RESOLVED * accuracy:g}",
        distances, all(d <= RESOLVED * accuracy for d in distances.values())))
    large = {key: value for key, value in jkr.items() if float(key.split("=")[1]) >= 3.5}
    small = {key: value for key, value in jkr.items() if float(key.split("=")[1]) < 3.5}
    checks.append(Check(
        "4", "for lambda >= 3.5 Baney-Hui agrees excellently with JKR, poorer below",
        "largest distance of the JKR curve from Baney-Hui's, from Baney-Hui's load minimum"
        " up, on the same scales",
        jkr, bool(large and small and max(large.values()) < min(small.values()))
        if large and small else None))
    return checks


# --- Fig. 5a ---------------------------------------------------------------------------------
def check_depths(figure, runs, key, accuracy):
    """The two depths' curves after the transient (paper Fig. 5a), for each value of ``key``
    (V_z in Fig. 5, lambda0 in Fig. 8) run at two depths."""
    pairs = curves.depth_pairs(runs, key)
    if not pairs:
        return [Check(figure, "the indentation depth matters only in a transient", "no runs")]
    values, merged = {}, []
    for value, (deep, shallow) in pairs.items():
        label = f"{key}={value:g}"
        abar, distance, fraction = curves.merged_from(deep, shallow, RESOLVED * accuracy)
        values[f"{label}: from abar"] = abar
        values[f"{label}: of abar(0)"] = fraction
        values[f"{label}: largest distance after"] = distance
        merged.append(np.isfinite(abar))
    return [Check(
        figure, "after a transient the curves from the two indentation depths superimpose",
        "the shallow curve's largest abar from which on (to its pull-off) it stays within"
        f" {RESOLVED:g} x accuracy = {RESOLVED * accuracy:g} of the deep one (distance in"
        " units of abar_c(0) and |pull-off Lbar|), as abar and as a fraction of its abar(0)",
        values, bool(all(merged)))]


# --- Figs. 5b and 8b ---------------------------------------------------------------------------
def check_eq8(figure, runs, masks):
    """Per-point effective work in the steady parts (``masks``, :func:`curves.steady_masks`)
    against Eq. 8, in both conventions of vbar."""
    if not runs:
        return [Check(figure, "the effective work follows Eq. 8", "no runs")]
    values, pooled = {}, {c: [] for c in CONVENTIONS}
    for curve, steady in zip(runs, masks):
        work = curve.effective_work()[steady]
        values[f"{_label(curve)}: steady points"] = int(steady.sum())
        for convention in CONVENTIONS:
            vbar = curve.vbar(convention)[steady]
            predicted = np.atleast_1d(theory.persson_brener(vbar, curve.groups["k"])
                                      if vbar.size else vbar)
            median, largest = curves.log_ratio_statistics(work, predicted)
            values[f"{_label(curve)} {convention}: median"] = median
            values[f"{_label(curve)} {convention}: max"] = largest
            if vbar.size:
                pooled[convention].append(np.abs(np.log(np.clip(work, 1e-300, None)
                                                        / predicted)))
    summary = {c: float(np.median(np.concatenate(pooled[c]))) if pooled[c] else np.nan
               for c in CONVENTIONS}
    best = min(CONVENTIONS, key=lambda c: summary[c] if np.isfinite(summary[c]) else np.inf)
    return [
        Check(figure, "the per-point effective work of the steady retraction follows Eq. 8",
              "median |ln(dgamma_eff / Eq. 8)| over all steady points (from where the two"
              " depths' curves merged to the pull-off), per convention of vbar; follows when"
              f" the better one is below {EQ8_MEDIAN_LOG:g}",
              {**{f"all points {c}": summary[c] for c in CONVENTIONS}, "data follow": best},
              bool(summary[best] < EQ8_MEDIAN_LOG) if np.isfinite(summary[best]) else None),
        Check(figure, "per case", "steady points, median and largest |ln(dgamma_eff / Eq. 8)|",
              values, None),
    ]


# --- Fig. 8a ---------------------------------------------------------------------------------
def check_instantaneous(runs, masks):
    """Distance of each lambda0's steady effective work (``masks``) to the instantaneous
    limit dgamma0 / k."""
    if not runs:
        return [Check("8", "lambda0 = 14 does not reach the instantaneous limit", "no runs")]
    values, fractions = {}, {}
    for curve, steady in zip(runs, masks):
        ratio = curve.effective_work()[steady] * curve.groups["k"]  # dgamma_eff / dgamma_inf
        if not ratio.size:
            continue
        lam = curve.groups["lambda0"]
        values[f"{_label(curve)}: median"] = float(np.median(ratio))
        values[f"{_label(curve)}: max"] = float(np.max(ratio))
        fractions.setdefault(lam, []).append(float(np.max(ratio)))
    lams = sorted(fractions)
    highest = max(fractions[lams[-1]]) if lams else np.nan
    rising = all(np.median(fractions[a]) < np.median(fractions[b])
                 for a, b in zip(lams, lams[1:]))
    return [
        Check("8", f"at V_z = 0.9, lambda0 = {lams[-1]:g} is not sufficient to reach the"
              " instantaneous limit" if lams else "lambda0 = 14 is not sufficient",
              "steady dgamma_eff / dgamma_inf (dgamma_inf = dgamma0 / k); short of the limit"
              f" when its largest value is below {SHORT_OF_LIMIT:g}",
              values, bool(highest < SHORT_OF_LIMIT) if np.isfinite(highest) else None),
        Check("8", "a larger lambda0 brings the contact closer to the instantaneous limit",
              "the largest steady dgamma_eff / dgamma_inf rises with lambda0",
              {f"lambda0={lam:g}": float(np.median(fractions[lam])) for lam in lams},
              bool(rising) if len(lams) > 1 else None),
    ]


# --- Fig. 9 ----------------------------------------------------------------------------------
#: Fig. 9's curves are compared past the start-up transient too: below this fraction of the
#: smaller initial contact half-width (Fig. 5a's merge points lie at 0.6-0.9 of it).
PAST_TRANSIENT = 0.8


def check_collapse(runs, accuracy):
    """Curves of equal chi_ve against curves of different chi_ve (paper Fig. 9): the largest
    load distance within each pair of equal chi_ve, the smallest between neighbouring chi_ve
    groups, over the whole curves and past the start-up transient."""
    by_chi = {}
    for curve in runs:
        by_chi.setdefault(round(curve.groups["chi_ve"], 6), []).append(curve)
    chis = sorted(by_chi)
    results = []
    for scope, fraction in (("whole curves", np.inf), ("past the transient", PAST_TRANSIENT)):
        def distance(a, b):
            below = fraction * min(a.abar[0], b.abar[0])
            return max(curves.curve_distance(a, b, below), curves.curve_distance(b, a, below))

        within = {f"chi_ve={chi:.3g}": distance(*group)
                  for chi, group in by_chi.items() if len(group) == 2}
        between = {f"chi_ve={a:.3g} vs {b:.3g}": float(np.nanmin(
            [distance(x, y) for x in by_chi[a] for y in by_chi[b]]))
            for a, b in zip(chis, chis[1:])}
        if not within or not between:
            results.append(Check("9", "equal chi_ve gives the same curve",
                                 f"{scope}: needs two pairs of equal chi_ve", {}, None))
            continue
        ratio = max(within.values()) / min(between.values())
        results.append(Check(
            "9", "cases of equal chi_ve = V_z lambda0^2 (different V_z and lambda0) respond"
            f" alike ({scope})",
            "largest distance of one curve's points up to the pull-off"
            + (f" and below {fraction:g} abar(0)" if np.isfinite(fraction) else "")
            + " from the other curve (units of abar_c(0) and |pull-off Lbar|) within each"
            " equal-chi_ve pair (either way round), the smallest"
            " between neighbouring chi_ve groups, and their ratio; a collapse when the ratio"
            " is below 1/2", {**within, **between, "ratio": ratio}, bool(ratio < 0.5)))
    return results


# --- Fig. B1 ---------------------------------------------------------------------------------
def check_convergence(series_by_label, accuracy):
    """Pull-off and curve at each resolution against the finest (paper Fig. B1).

    ``series_by_label``: {case label: [(setting label, retraction), ...] finest last}.
    """
    checks = []
    for label, runs in series_by_label.items():
        if len(runs) < 2:
            continue
        finest_label, finest = runs[-1]
        values = {}
        for setting, curve in runs[:-1]:
            pull = abs(curve.lbar[curve.pull_off] / finest.lbar[finest.pull_off] - 1)
            values[f"{setting}: pull-off"] = float(pull)
            values[f"{setting}: curve"] = curves.curve_distance(curve, finest)
        values["finest"] = finest_label
        paper = [v for k, v in values.items() if isinstance(v, float) and "pull-off" in k
                 and ("2^17" in k or "tau/50" in k or "tau/100" in k)]
        checks.append(Check(
            "B1", f"{label}: the paper's n_x = 2^17 and dt = tau/50 (tau/100 at V_z = 9) are"
            " converged", f"relative pull-off difference and curve distance against"
            f" {finest_label}; converged when the paper's settings are within"
            f" {RESOLVED:g} x accuracy = {RESOLVED * accuracy:g}",
            values, bool(paper and max(paper) <= RESOLVED * accuracy) if paper else None))
    return checks


def check_annulus(runs, levels=(5.0, 3.0)):
    """Fig. 7: the adhesive annulus widens with the retraction velocity, at (4/pi) abar_c
    = 5 and 3 (interpolated in the series)."""
    values, rising = {}, True
    for level in levels:
        widths = []
        for curve, series in runs:
            target = level * np.pi / 4.0
            a = series.contact_half_width / series.attrs["beta"]
            zone = (series.cohesive_half_width - series.contact_half_width) / series.attrs["beta"]
            below = np.flatnonzero(a[1:] < target)
            if not below.size:
                widths.append(np.nan)
                continue
            i = below[0] + 1
            t = (target - a[i - 1]) / (a[i] - a[i - 1])
            widths.append(float(zone[i - 1] + t * (zone[i] - zone[i - 1])))
            values[f"(4/pi)abar={level:g} Vz={curve.groups['Vz']:g}"] = widths[-1]
        finite = [w for w in widths if np.isfinite(w)]
        rising &= len(finite) > 1 and all(a < b for a, b in zip(finite, finite[1:]))
    return [Check("7", "the adhesive annulus widens with the retraction velocity",
                  "cohesive-zone width (a_a - a_c) / beta at (4/pi) abar_c = 5 and 3, by V_z",
                  values, bool(rising) if values else None)]


def check_separation(cases):
    """Fig. 6c: at zero load the surfaces that were in contact separate less the faster the
    retraction, and the profiles of different V_z do not cross. ``cases``: [(Vz, result)]
    by increasing V_z."""
    profiles = []
    for vz, result in cases:
        zero = [p for p in curves.snapshot_profiles(result) if p[0] == "L = 0"]
        if zero:
            title, x, lifted, _, edge = zero[0]
            profiles.append((vz, x, lifted, edge))
    if len(profiles) < 2:
        return [Check("6", "at zero load a faster retraction leaves a smaller separation",
                      "needs two L = 0 snapshots", {}, None)]
    # the gap (h + u_z - u) / R = x^2 / 2R - (u - u_z) / R; x in units of a_c(0)
    start = max(p[3] for p in profiles)
    values, ordered = {}, True
    gaps = []
    for vz, x, lifted, _ in profiles:
        a0 = cases[0][1].series.contact_half_width[0] / cases[0][1].series.attrs["length_unit"]
        keep = (x >= start) & (x <= 2.0)
        gaps.append(((x[keep] * a0) ** 2 / 2.0 - lifted[keep]))
        at_a0 = np.interp(1.0, x[keep], gaps[-1])
        values[f"gap/R at x = a_c(0), V_z={vz:g}"] = float(at_a0)
    for slow, fast in zip(gaps, gaps[1:]):
        ordered &= bool(np.all(fast <= slow + 1e-12))
    return [Check("6", "at zero load a faster retraction leaves a smaller separation where"
                  " the surfaces were in contact, and the profiles do not cross",
                  "gap at the initial contact edge, and whether the gaps are ordered by V_z"
                  " at every node from the outermost contact edge to 2 a_c(0)",
                  values, ordered)]
