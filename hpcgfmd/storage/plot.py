"""PNG of a case in the paper's scaling (Fig. 5a) and of load against indenter position; for a
sphere also maps of its contact, cohesive and free regions at the snapshots."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from ..atomic import save_figure
from .reader import read_result

MAPS = 4  # a sphere's snapshots drawn as maps (the first ones)
# The JKR line's intercept sqrt(c r) for work ratio r (M25), (M55), and the axes' labels
LINES = {
    False: (
        2.0 * np.pi,
        r"$\bar L_n/\sqrt{\bar a_c}$",
        r"$(\pi/4)\,\bar a_c^{3/2}$",
        "per unit length $L_n$",
    ),
    True: (6.0, r"$\bar P/\bar A^{3/2}$", r"$\bar A^{3/2}$", "(force) $P$"),
}


def plot_case(path, output):
    """Write ``output`` (PNG): (a) the load-area curve in the coordinates where JKR is a line of
    slope 1, with the relaxed (dgamma0) and instantaneous (dgamma0/k) lines (the cylinder's
    paper Eq. 10, (M25); the sphere's (M55), (M57)) and for a sphere the Maugis-Dugdale
    curves of its lambda0 in its cell ((M56), (M59)); (b) load against u_z; for a sphere a row
    of maps of the contact (g <= 0), cohesive (g <= dmax) and free regions at its first
    snapshots."""
    result = read_result(path)
    s = result.series
    k = s.attrs["k"]
    intercept, xlabel, ylabel, load_label = LINES[s.sphere]
    maps = result.snapshots.time.size if s.sphere else 0
    rows = 2 if maps else 1
    fig = plt.figure(figsize=(11, 4.5 * rows))
    ax1, ax2 = fig.add_subplot(rows, 2, 1), fig.add_subplot(rows, 2, 2)
    x, y = s.scaled_curve()
    if x.size == 0:
        raise ValueError(f"{path}: no step with contact to plot")
    ax1.plot(x, y, "C0.-", ms=2, lw=1, label=f"hpcgfmd, V_z = {s.attrs['Vz']:g}")
    lowest = x.min()
    if s.sphere:  # Pbar / Abar^(3/2) runs off to -inf as the contact vanishes
        lowest = max(lowest, -4 * np.sqrt(intercept / k))
    xs = np.linspace(min(lowest, -2 * np.sqrt(intercept / k)), max(x.max(), 1.0), 50)
    ax1.plot(xs, xs + np.sqrt(intercept), "k:", label="JKR relaxed (dgamma0)")
    ax1.plot(xs, xs + np.sqrt(intercept / k), "r:", label="JKR instantaneous (dgamma0/k)")
    if s.sphere:  # at finite lambda0 the limits are Maugis-Dugdale's, not JKR's lines
        top = max(3.0, 1.2 * s.abar.max())
        for ratio, style, name in ((1.0, "k-", "relaxed"), (1.0 / k, "r-", "instantaneous")):
            ax1.plot(
                *_maugis_dugdale_form(s.attrs, ratio, top),
                style,
                lw=0.8,
                label=f"Maugis-Dugdale {name}",
            )
    ax1.set_xlabel(xlabel)
    ax1.set_ylabel(ylabel)
    ax1.set_ylim(0, 1.1 * y.max() if y.size else 1)
    ax1.set_xlim(xs[0], x.max() * 1.05 + 1 if x.size else 1)
    ax1.legend(fontsize=8)
    ax1.set_title(
        rf"$\lambda_0$ = {s.attrs['lambda0']:g}, k = {k:g}, "
        rf"$\chi_{{ve}}$ = {s.attrs['chi_ve']:.3g}"
    )
    ax2.plot(s.indenter, s.load, "C0-")
    i = s.pull_off()
    ax2.plot(s.indenter[i], s.load[i], "rv", label=f"pull-off {s.load[i]:.4g}")
    ax2.axhline(0, color="0.6", lw=0.5)
    ax2.set_xlabel("indenter position $u_z$")
    ax2.set_ylabel(f"load {load_label} (compressive > 0)")
    ax2.legend(fontsize=8)
    if maps:
        _maps(fig, result.snapshots, s.attrs["dmax"], min(maps, MAPS))
    fig.tight_layout()
    try:  # atomically: a reader (or a plot interrupted mid-write) never sees half a PNG
        save_figure(fig, output, dpi=120, format="png")
    finally:
        plt.close(fig)


def _maugis_dugdale_form(attrs, work_ratio, top):
    """The sphere's Maugis-Dugdale curve of work ``work_ratio`` dgamma0 at its sigma_a in its
    periodic cell ((M56), (M59); 1/k: the instantaneous limit (M57)) as (M55)'s line form
    (Pbar / Abar^(3/2), Abar^(3/2)), contact radii up to ``top`` a_s."""
    from ..model import sphere_theory

    cell = attrs["cell"] * (0.75 * np.pi * attrs["alpha"]) ** (-1.0 / 3.0)  # L / a_s (M52)
    radii = np.geomspace(0.05 * work_ratio ** (1.0 / 3.0), top, 120)
    pbar, _ = sphere_theory.periodic_cell(radii, cell, attrs["lambda0"], work_ratio)
    return pbar / radii**1.5, radii**1.5


def _maps(fig, snapshots, dmax, count):
    """The second row: the regions of the first ``count`` snapshots (2 contact, 1 cohesive,
    0 free) on the cell, x and y in the file's length unit."""
    x, y = snapshots.x, snapshots.y
    extent = (x[0], x[-1], y[0], y[-1])
    for i in range(count):
        ax = fig.add_subplot(2, count, count + i + 1)
        gap = snapshots.gap[i]
        regions = np.where(gap <= 0.0, 2, np.where(gap <= dmax, 1, 0))
        ax.imshow(regions, origin="lower", extent=extent, cmap="Greys", vmin=0, vmax=2)
        ax.set_title(f"t = {snapshots.time[i]:.4g}", fontsize=9)
        ax.set_xlabel("x")
        if i == 0:
            ax.set_ylabel("y (black: contact, grey: cohesive zone)")
