"""The paper's figures drawn from our runs: one PNG per figure, its plotted data as CSV.

Axes and scalings as in the paper (docs/paper.md): the scaled curve (pi/4) abar^(3/2) against
Lbar / sqrt(abar), the per-point effective work against the peeling velocity vbar of Eq. 8
(retardation-time convention, tau_c = tau / k, with Eq. 8 also drawn as the relaxation-time
reading), profiles against x / a_c(t = 0). Limits: relaxed = Baney-Hui with lambda0 and
dgamma0, instantaneous = JKR with dgamma0 / k (paper Sec. 4).
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from .. import atomic
from ..model import theory
from .curves import snapshot_profiles

X_LABEL = r"$\bar L_n/\sqrt{\bar a_c}$"
Y_LABEL = r"$(\pi/4)\,\bar a_c^{3/2}$"


def write_csv(path, columns, rows):
    """``rows`` (iterables in the order of ``columns``) to ``path``, atomically; floats in
    10 significant digits."""
    atomic.write_csv(
        path, columns, ([f"{v:.10g}" if isinstance(v, float) else v for v in row] for row in rows)
    )


def _save(fig, path):
    """The figure to ``path`` (PNG, atomically), then closed."""
    try:
        fig.tight_layout()
        atomic.save_figure(fig, path, dpi=110)
    finally:
        plt.close(fig)


def _limits(ax, lambda0, k, top):
    """Relaxed (Baney-Hui, lambda0) and instantaneous (JKR, dgamma0/k) limits; the y range
    up to ``top`` (the x range is the curves', set before)."""
    abar = np.linspace(0.3, 14.0, 300)
    ax.plot(
        *theory.scaled_curve(abar, theory.maugis_dugdale(abar, lambda0)[0]),
        "k:",
        lw=1.2,
        label=rf"relaxed limit ($\lambda_0$ = {lambda0:g})",
    )
    ax.plot(
        *theory.scaled_curve(abar, theory.jkr_load(abar, 1.0 / k)),
        "r:",
        lw=1.2,
        label=r"instantaneous limit (JKR, $\Delta\gamma_0/k$)",
    )
    ax.set_ylim(0, top)


def _curve_rows(label, curve, steady):
    vbar = curve.vbar("retardation")
    work = curve.effective_work()
    return [
        (
            label,
            curve.groups["lambda0"],
            curve.groups["Vz"],
            curve.groups["depth"],
            float(curve.abar[i]),
            float(curve.lbar[i]),
            float(curve.x[i]),
            float(curve.y[i]),
            float(vbar[i]),
            float(work[i]),
            int(steady[i]),
        )
        for i in range(curve.abar.size)
    ]


CURVE_COLUMNS = (
    "case",
    "lambda0",
    "Vz",
    "h0",
    "abar",
    "Lbar",
    "x",
    "y",
    "vbar_retardation",
    "work_ratio",
    "steady",
)


def _scaled_axes(ax, runs, styles):
    """The scaled curves of ``runs``; the x range ends on the left where the tails of the
    last contact (abar -> 0, x -> -inf) leave the paper's frame, 1.5 x the instantaneous
    JKR intercept left of zero."""
    for (label, curve), style in zip(runs, styles):
        ax.plot(curve.x, curve.y, **style, label=label)
    k = min((c.groups["k"] for _, c in runs), default=0.1)
    xs = np.concatenate([c.x for _, c in runs]) if runs else np.array([-10.0, 0.0])
    lo = max(float(np.min(xs)), -1.5 * np.sqrt(2 * np.pi / k))
    hi = max(float(np.max(xs)), 1.0)
    ax.set_xlim(lo, hi + 0.05 * (hi - lo))
    ax.set_xlabel(X_LABEL)
    ax.set_ylabel(Y_LABEL)


def _top(runs):
    """The y range's top: 15 % above the highest point of the runs."""
    return 1.15 * max((float(np.max(c.y)) for _, c in runs), default=10.0)


def _reference(runs):
    """lambda0, k and h0/R of the limits and titles: the runs' middle lambda0 (the paper's
    7), their k, and their depths."""
    lams = sorted(c.groups["lambda0"] for _, c in runs) or [7.0]
    k = runs[0][1].groups["k"] if runs else 0.1
    depths = sorted({c.groups["depth"] for _, c in runs}, reverse=True)
    return lams[len(lams) // 2], k, depths


def draw_fig2(path, k=0.1):
    """Eq. 8 against vbar = 2 pi rhodot tau / (k c0) (retardation time): read with that
    convention it is Eq. 6; read with the relaxation time tau it predicts Eq. 8 at k vbar
    (the dashed line, the convention of Figs. 5b and 8b's dashed lines)."""
    vbar = np.logspace(-3, 4, 300)
    retardation = theory.persson_brener(vbar, k)
    relaxation = theory.persson_brener(k * vbar, k)
    fig, ax = plt.subplots(figsize=(5.5, 4))
    ax.semilogx(vbar, retardation, "k-", label=r"Eq. 8, $\tau_c = \tau/k$ (= Eq. 6)")
    ax.semilogx(vbar, relaxation, "k--", label=r"Eq. 8, $\tau_c = \tau$")
    ax.set_xlabel(r"$\bar v(\dot\rho) = 2\pi\dot\rho\,\tau/(k c_0)$")
    ax.set_ylabel(r"$\Delta\gamma_{eff}/\Delta\gamma_0$")
    ax.set_title(f"Eq. 8, k = {k:g}")
    ax.legend(fontsize=8)
    _save(fig, path + ".png")
    write_csv(
        path + ".csv",
        ("vbar", "work_retardation_convention", "work_relaxation_convention"),
        zip(vbar, retardation, relaxation),
    )


def draw_fig4(path, runs, lambdas=(0.75, 1.5, 3.5, 7.0)):
    """Fig. 4: the Baney-Hui curves of ``lambdas`` (Eqs. 12-13), the JKR line (Eq. 10) and
    our elastic retractions as points.

    Parameters
    ----------
    path : str
        Output prefix: ``path.png`` and ``path.csv`` (source, lambda, abar, Lbar, x, y).
    runs : list of Retraction
        The elastic (k = 1) runs; each drawn in the colour of its lambda0.
    lambdas : tuple of float
        Maugis parameters of the Baney-Hui curves.
    """
    fig, ax = plt.subplots(figsize=(6, 4.5))
    rows = []
    abar = np.linspace(0.05, 14.0, 400)
    for i, lam in enumerate(lambdas):
        lbar = theory.maugis_dugdale(abar, lam)[0]
        x, y = theory.scaled_curve(abar, lbar)
        ax.plot(x, y, color=f"C{i}", lw=1, label=rf"Baney-Hui $\lambda$ = {lam:g}")
        rows += [("Baney-Hui", lam, a, b, u, v) for a, b, u, v in zip(abar, lbar, x, y)]
    for i, lam in enumerate(lambdas):
        for curve in (c for c in runs if abs(c.groups["lambda0"] - lam) < 1e-9):
            ax.plot(
                curve.x,
                curve.y,
                "o",
                color=f"C{i}",
                ms=2.5,
                mfc="none",
                label=rf"hpcgfmd $\lambda$ = {lam:g}, k = 1",
            )
            rows += [
                ("hpcgfmd", lam, a, b, u, v)
                for a, b, u, v in zip(curve.abar, curve.lbar, curve.x, curve.y)
            ]
    ax.plot(*theory.scaled_curve(abar, theory.jkr_load(abar)), "k--", lw=1, label="JKR (Eq. 10)")
    ax.set_xlim(-12, 25)
    ax.set_ylim(0, 12)
    ax.set_xlabel(X_LABEL)
    ax.set_ylabel(Y_LABEL)
    ax.legend(fontsize=7, ncol=2)
    _save(fig, path + ".png")
    write_csv(path + ".csv", ("source", "lambda", "abar", "Lbar", "x", "y"), rows)


def draw_curves_and_work(path, runs, masks, color_key):
    """Figs. 5 and 8: (a) scaled curves of both depths with the limits, (b) per-point
    effective work against vbar (retardation convention) with Eq. 8 in both readings.

    Parameters
    ----------
    path : str
        Output prefix: ``path.png`` and ``path.csv`` (:data:`CURVE_COLUMNS`).
    runs : list of (str, Retraction)
        Legend label and retraction.
    masks : list of ndarray of bool
        The steady points of each run (:func:`hpcgfmd.paper.curves.steady_masks`), drawn
        large in (b).
    color_key : str
        The group that sets the colour ("Vz" in Fig. 5, "lambda0" in Fig. 8); the deeper
        indentation is dashed.
    """
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.5))
    lambda0, k, depths = _reference(runs)
    keys = sorted({c.groups[color_key] for _, c in runs})
    styles = [
        {
            "color": f"C{keys.index(c.groups[color_key])}",
            "lw": 1,
            "ls": "--" if c.groups["depth"] == depths[0] and len(depths) > 1 else "-",
        }
        for _, c in runs
    ]
    _scaled_axes(ax1, runs, styles)
    _limits(ax1, lambda0, k, _top(runs))
    shallow = f", solid {depths[-1]:g}" if len(depths) > 1 else ""
    ax1.set_title(f"(a) dashed h0/R = {depths[0]:g}{shallow}" if depths else "(a)")
    ax1.legend(fontsize=6)
    rows = []
    for (label, curve), style, steady in zip(runs, styles, masks):
        vbar, work = curve.vbar("retardation"), curve.effective_work()
        ax2.loglog(vbar[~steady], work[~steady], ".", color=style["color"], ms=1, alpha=0.3)
        ax2.loglog(vbar[steady], work[steady], ".", color=style["color"], ms=3)
        rows += _curve_rows(label, curve, steady)
    grid = np.logspace(-2, 5, 200)
    ax2.loglog(grid, theory.persson_brener(grid, k), "k-", label=r"Eq. 8, $\tau_c = \tau/k$")
    ax2.loglog(grid, theory.persson_brener(k * grid, k), "k--", label=r"Eq. 8, $\tau_c = \tau$")
    ax2.set_xlabel(r"$\bar v(\dot\rho) = 2\pi\dot\rho\,\tau/(k c_0)$")
    ax2.set_ylabel(r"$\Delta\gamma_{eff}/\Delta\gamma_0$")
    ax2.set_ylim(0.5, 1.5 / k)
    ax2.set_title("(b) large dots: steady part (depths merged, to the pull-off)")
    ax2.legend(fontsize=7)
    _save(fig, path + ".png")
    write_csv(path + ".csv", CURVE_COLUMNS, rows)


def draw_fig9(path, runs):
    """Fig. 9: scaled curves coloured by chi_ve, solid and dashed within a pair of equal
    chi_ve, with the limits. ``runs``: list of (legend label, Retraction); writes
    ``path.png`` and ``path.csv``."""
    fig, ax = plt.subplots(figsize=(6.5, 4.8))
    lambda0, k, depths = _reference(runs)
    chis = sorted({round(c.groups["chi_ve"], 6) for _, c in runs}, reverse=True)
    seen, styles = {}, []
    for _, curve in runs:
        chi = round(curve.groups["chi_ve"], 6)
        seen[chi] = seen.get(chi, 0) + 1
        styles.append(
            {"color": f"C{chis.index(chi)}", "lw": 1, "ls": "-" if seen[chi] == 1 else "--"}
        )
    _scaled_axes(ax, runs, styles)
    _limits(ax, lambda0, k, _top(runs))
    ax.legend(fontsize=6)
    ax.set_title(
        f"h0/R = {', '.join(f'{d:g}' for d in depths)}, colour:"
        r" $\chi_{ve} = V_z\lambda_0^2$"
    )
    _save(fig, path + ".png")
    write_csv(
        path + ".csv",
        CURVE_COLUMNS,
        [
            row
            for label, curve in runs
            for row in _curve_rows(label, curve, np.zeros(curve.abar.size, dtype=bool))
        ],
    )


def draw_profiles(path, cases, field, zoom):
    """Figs. 6 and 7: one panel per snapshot level, the velocities overlaid, and a zoom
    around the contact edge of the first level.

    Parameters
    ----------
    path : str
        Output prefix: ``path.png`` and ``path.csv`` (snapshot, Vz, x / a_c(0), value).
    cases : list of (float, Result)
        V_z and the case file's results, by increasing V_z.
    field : {"surface", "pressure"}
        (u - u_z) / R (Fig. 6) or the traction p / E0, attractive positive (Fig. 7).
    zoom : float
        Half-width of the zoom window, in x / a_c(0).

    Returns
    -------
    bool
        False when no case has the snapshots (nothing written).
    """
    per_level = {}
    rows = []
    for vz, result in cases:
        for title, x, surface, pressure, _, edge in snapshot_profiles(result):
            values = surface if field == "surface" else pressure
            per_level.setdefault(title, []).append((vz, x, values, edge))
            keep = (x >= 0.0) & (x <= 2.0)
            rows += [(title, vz, float(a), float(b)) for a, b in zip(x[keep], values[keep])]
    if not per_level:
        return False
    fig, axes = plt.subplots(1, len(per_level) + 1, figsize=(4 * (len(per_level) + 1), 3.8))
    for ax, (title, lines) in zip(axes, per_level.items()):
        for i, (vz, x, values, _) in enumerate(lines):
            ax.plot(x, values, color=f"C{i}", lw=1, label=f"V_z = {vz:g}")
        ax.set_xlim(0, 1.5)
        ax.set_title(title)
        ax.set_xlabel(r"$x / a_c^{t=0}$")
        ax.set_ylabel("(u - u_z)/R" if field == "surface" else "p / E0 (attractive > 0)")
        ax.legend(fontsize=7)
    title, lines = next(iter(per_level.items()))
    edge = float(np.nanmedian([line[3] for line in lines]))
    window = (edge - zoom, edge + zoom)
    near = []
    for i, (vz, x, values, _) in enumerate(lines):
        axes[-1].plot(x, values, color=f"C{i}", lw=1, label=f"V_z = {vz:g}")
        near.append(values[(x >= window[0]) & (x <= window[1])])
    axes[-1].set_xlim(*window)
    near = np.concatenate(near)
    if near.size:
        pad = 0.05 * (near.max() - near.min()) + 1e-12
        axes[-1].set_ylim(near.min() - pad, near.max() + pad)
    axes[-1].set_title(f"near the contact edge, {title}")
    axes[-1].set_xlabel(r"$x / a_c^{t=0}$")
    _save(fig, path + ".png")
    write_csv(path + ".csv", ("snapshot", "Vz", "x_over_a0", field), rows)
    return True


def draw_convergence(path, panels):
    """Fig. B1: per case, the scaled curves of every resolution, pull-off in the legend.

    ``panels``: {case label: [(setting label, curve)]}."""
    fig, axes = plt.subplots(1, max(len(panels), 1), figsize=(6 * max(len(panels), 1), 4.5))
    axes = np.atleast_1d(axes)
    rows = []
    for ax, (label, runs) in zip(axes, panels.items()):
        for i, (setting, curve) in enumerate(runs):
            ax.plot(
                curve.x,
                curve.y,
                color=f"C{i}",
                lw=1,
                label=f"{setting}: pull-off {curve.lbar[curve.pull_off]:.4f}",
            )
            rows += [
                (label, setting, float(a), float(b), float(u), float(v))
                for a, b, u, v in zip(curve.abar, curve.lbar, curve.x, curve.y)
            ]
        ax.set_xlabel(X_LABEL)
        ax.set_ylabel(Y_LABEL)
        ax.set_title(label)
        ax.legend(fontsize=7)
    _save(fig, path + ".png")
    write_csv(path + ".csv", ("case", "setting", "abar", "Lbar", "x", "y"), rows)
