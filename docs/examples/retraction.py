"""A small viscoelastic retraction from Python, in a few seconds, plotted in the paper's scaling.

    python docs/examples/retraction.py [OUTPUT.png]

The case: lambda0 = 3.5, k = 0.1, V_z = 1 (chi_ve = 12), h0/R = 0.03 in a cell of L/R = 2,
alpha = 1e-4, on 2048 nodes. The run is kept in memory (no file is left behind); the figure
shows (pi/4) abar^(3/2) against Lbar/sqrt(abar) (paper Fig. 5a) with the relaxed and the
instantaneous JKR lines, and the load against the indenter position.
"""

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import hpcgfmd  # noqa: E402

case = hpcgfmd.Case(
    maugis=3.5,
    modulus_ratio=0.1,
    velocity=1.0,
    depth=0.03,
    cell=2.0,
    adhesion=1e-4,
    numerics={"nx": 2048},
)
result = hpcgfmd.run(case, planner_effort="FFTW_ESTIMATE")  # small grid: no planning
pull_off = result.pull_off()
print(
    f"chi_ve = {case.chi_ve:.3g}; pull-off Lbar = {pull_off.lbar:.4f} at abar ="
    f" {pull_off.abar:.3f}; {result.attrs['steps']} steps"
)

series = result.series
x, y = series.scaled_curve()
k = case.modulus_ratio
line = np.linspace(x.min(), x.max(), 2)
fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
left.plot(x, y, ".-", ms=2, label=f"hpcgfmd, V_z = {case.velocity:g}")
left.plot(line, line + np.sqrt(2 * np.pi), "k:", label="JKR, relaxed (dgamma0)")
left.plot(line, line + np.sqrt(2 * np.pi / k), "r:", label="JKR, instantaneous (dgamma0/k)")
left.set_ylim(0.0, 1.1 * y.max())
left.set_xlabel("Lbar / sqrt(abar)")
left.set_ylabel("(pi/4) abar^(3/2)")
left.legend(fontsize=8)
right.plot(series.indenter, series.lbar)
right.set_xlabel("indenter position u_z / R")
right.set_ylabel("Lbar (compressive > 0)")
fig.tight_layout()
output = sys.argv[1] if len(sys.argv) > 1 else "retraction.png"
fig.savefig(output, dpi=100)
print(f"wrote {output}")
