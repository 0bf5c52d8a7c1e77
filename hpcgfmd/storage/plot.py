"""PNG of a case in the paper's scaling (Fig. 5a) and of load against indenter position."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from ..atomic import save_figure
from .reader import read_series


def plot_case(path, output):
    """Write ``output`` (PNG): (a) (pi/4) abar^(3/2) against Lbar/sqrt(abar) with the relaxed
    (dgamma0) and instantaneous (dgamma0/k) JKR lines of paper Eq. 10; (b) load against u_z."""
    s = read_series(path)
    k = s.attrs["k"]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.5))
    x, y = s.scaled_curve()
    if x.size == 0:
        raise ValueError(f"{path}: no step with contact to plot")
    ax1.plot(x, y, "C0.-", ms=2, lw=1, label=f"hpcgfmd, V_z = {s.attrs['Vz']:g}")
    xs = np.linspace(min(x.min(), -2 * np.sqrt(2 * np.pi / k)), max(x.max(), 1.0), 50)
    ax1.plot(xs, xs + np.sqrt(2 * np.pi), "k:", label="JKR relaxed (dgamma0)")
    ax1.plot(xs, xs + np.sqrt(2 * np.pi / k), "r:", label="JKR instantaneous (dgamma0/k)")
    ax1.set_xlabel(r"$\bar L_n/\sqrt{\bar a_c}$")
    ax1.set_ylabel(r"$(\pi/4)\,\bar a_c^{3/2}$")
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
    ax2.set_ylabel("load per unit length $L_n$ (compressive > 0)")
    ax2.legend(fontsize=8)
    fig.tight_layout()
    try:  # atomically: a reader (or a plot interrupted mid-write) never sees half a PNG
        save_figure(fig, output, dpi=120, format="png")
    finally:
        plt.close(fig)
