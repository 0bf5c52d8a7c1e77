"""Figures of the model beyond the paper: a Prony series, the compliant drive, cycles.

    python scripts/beyond_paper.py --out docs/figures   # about 30 minutes on one core

<out>/prony.png: a two-branch Prony series against the standard linear solid of the same k
and reference time tau_r (docs/model.md (M41)): the paper's geometry (lambda0 = 7, h0/R =
0.1, L/R = 10, alpha = 5e-5) at two velocities, for the SLS (k = 0.1) and for E_i/E0 = (3,
6), tau_i/tau_r = (0.1, 1.45); (a) the relaxation moduli, (b) the scaled load-area curves,
(c) the per-point effective work of adhesion against each solid's Persson-Brener
prediction at the measured peeling velocity (Eq. 6 by quadrature, (M42)).

<out>/drive.png: jump-off of an elastic cylinder (lambda0 = 3.5, the tests' small cell)
hanging on springs of three stiffnesses against the displacement-controlled curve, with each
spring's line at its jump (tangent to the curve where dL/du_z = k_s; (M43)).

<out>/cycle.png: an approach-dwell-retract cycle (approach from out of contact to h0/R =
0.03, dwell 1 tau, retraction until detached) of the drive test's cylinder, elastic and SLS
(k = 0.1) at V_z = 1 and 10: (a) the hysteresis loops, load against indenter, (b) the load
against time (the dwell's relaxation), with each loop's area (the dissipated energy, (M45))
in cycle.txt, and the elastic loop's against the energy its two jumps release.

<out>/prony-accuracy.txt: the two-branch solid's pull-off at accuracies 1e-2 and 5e-3
against 1e-3 at V_z = 0.45 and 0.045 (about 20 of the 30 minutes).

<out>/prony.txt, drive.txt and cycle.txt get the figures' numbers. The runs are kept in
<out>/beyond-runs/ and reused when their case file is unchanged.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

import hpcgfmd
from hpcgfmd.case import case_file_text
from hpcgfmd.model import theory
from hpcgfmd.paper.curves import Retraction
from hpcgfmd.studies.benchmark import code_identity

GEOMETRY = {"maugis": 7.0, "depth": 0.1, "cell": 10.0, "adhesion": 5e-5}
MATERIALS = {
    "SLS": {"modulus_ratio": 0.1},
    "two branches": {"relaxation_moduli": [3.0, 6.0], "relaxation_times": [0.1, 1.45]},
}
VELOCITIES = (0.045, 0.45)
STEADY_FROM = 0.8  # effective work compared from abar <= 0.8 abar(0) to the pull-off


def case_text(material, velocity, accuracy):
    return case_file_text({**GEOMETRY, **material, "velocity": velocity}, {"accuracy": accuracy})


def run(text, runs: Path, name: str):
    """The result of ``text``, from runs/<name>.h5 when that file holds the same case made by
    this code (runs/<name>.code holds the code identity of the run that wrote it)."""
    path, stamp = runs / f"{name}.h5", runs / f"{name}.code"
    code = code_identity()
    if path.exists() and stamp.exists() and stamp.read_text() == code:
        result = hpcgfmd.open(path)
        if result.finished and str(result.attrs.get("config", "")) == text:
            return result
    result = hpcgfmd.run(text, path, overwrite=True)
    stamp.write_text(code)
    return result


def predicted_work(case, rhodot):
    """Persson-Brener dgamma_eff / dgamma0 of the case's solid at peel speeds rhodot (R/tau_r)."""
    material = case.material()
    c0 = case.beta / (np.pi * case.maugis**2)
    return np.array(
        [theory.persson_brener_modulus(max(r, 0.0), c0, material.complex_modulus) for r in rhodot]
    )


def prony_figure(out: Path, runs: Path, accuracy: float, plt):
    """<out>/prony.png and prony.txt (module docstring)."""
    fig, (ax_e, ax_c, ax_w) = plt.subplots(1, 3, figsize=(15, 4.6))
    lines = [
        f"# scripts/beyond_paper.py --accuracy {accuracy:g}: Prony series against the SLS",
        "# material, V_z, steps, iterations, pull-off Lbar, abar at"
        f" pull-off, median and largest |ln(dgamma_eff / Persson-Brener)| from abar <="
        f" {STEADY_FROM} abar(0) to the pull-off",
    ]
    t = np.logspace(-3, 2, 300)
    for (label, material), color in zip(MATERIALS.items(), ("C0", "C3")):
        case = hpcgfmd.Case.from_toml(case_text(material, VELOCITIES[0], accuracy))
        ax_e.semilogx(t, case.material().relaxation_modulus(t), color=color, label=label)
        for velocity, style in zip(VELOCITIES, ("-", "--")):
            text = case_text(material, velocity, accuracy)
            case = hpcgfmd.Case.from_toml(text)
            result = run(text, runs, f"{label.replace(' ', '_')}-Vz_{velocity:g}")
            curve = Retraction.from_series(result.series)
            stop = curve.pull_off + 1
            ax_c.plot(
                curve.x[:stop],
                curve.y[:stop],
                color=color,
                ls=style,
                label=f"{label}, V_z = {velocity:g}",
            )
            steady = np.zeros(curve.abar.size, dtype=bool)
            steady[:stop] = curve.abar[:stop] <= STEADY_FROM * curve.abar[0]
            work = curve.effective_work()[steady]
            predicted = predicted_work(case, curve.rhodot[steady])
            ax_w.loglog(
                curve.rhodot[steady],
                work,
                ".",
                color=color,
                ms=3,
                alpha=0.6 if style == "-" else 0.3,
            )
            ln = np.abs(np.log(work / predicted))
            lines.append(
                f"{label}, {velocity:g}, {result.attrs['steps']},"
                f" {result.attrs['iterations']}, {curve.lbar[curve.pull_off]:.5g},"
                f" {curve.abar[curve.pull_off]:.4g}, {np.median(ln):.3f},"
                f" {ln.max():.3f}"
            )
        speeds = np.logspace(-4, 1, 60)
        ax_w.loglog(
            speeds, predicted_work(case, speeds), color=color, label=f"Persson-Brener, {label}"
        )
    ax_e.set(xlabel="t / tau_r", ylabel="E*(t) / E0", title="(a) relaxation modulus")
    ax_e.legend()
    x = np.linspace(-6, 4, 10)
    for ratio, name in ((1.0, "JKR relaxed"), (10.0, "JKR instantaneous")):
        ax_c.plot(x, x + np.sqrt(2 * np.pi * ratio), "k:", lw=0.8)
        ax_c.annotate(name, (x[-1], x[-1] + np.sqrt(2 * np.pi * ratio)), fontsize=7)
    ax_c.set(
        xlabel="Lbar / sqrt(abar)",
        ylabel="(pi/4) abar^(3/2)",
        title="(b) retraction to pull-off, lambda0 = 7",
    )
    ax_c.legend(fontsize=7)
    ax_w.set(
        xlabel="peeling velocity -da_c/dt (R / tau_r)",
        ylabel="dgamma_eff / dgamma0",
        title="(c) effective work of adhesion (dots: runs)",
    )
    ax_w.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "prony.png", dpi=110)
    return lines


ACCURACY_CASES = (0.45, 0.045)  # V_z of the two-branch solid at lambda0 = 7
ACCURACIES = (1e-2, 5e-3)
REFERENCE_ACCURACY = 1e-3


def accuracy_table(runs: Path):
    """The two-branch solid's pull-off at accuracies 1e-2 and 5e-3 against 1e-3 (the
    accuracy knob on a Prony series, the paper's geometry): rows of <out>/prony-accuracy.txt."""
    material = MATERIALS["two branches"]
    lines = [
        "# scripts/beyond_paper.py --only accuracy: two-branch Prony series, lambda0 = 7,"
        f" pull-off against accuracy {REFERENCE_ACCURACY:g}",
        "# V_z, accuracy, nx, steps, iterations, pull-off Lbar, relative error",
    ]
    for velocity in ACCURACY_CASES:
        results = {}
        for accuracy in (REFERENCE_ACCURACY,) + ACCURACIES:
            results[accuracy] = run(
                case_text(material, velocity, accuracy),
                runs,
                f"two_branches-Vz_{velocity:g}-accuracy_{accuracy:g}",
            )
        reference = results[REFERENCE_ACCURACY].pull_off().lbar
        for accuracy, result in results.items():
            lbar = result.pull_off().lbar
            lines.append(
                f"{velocity:g}, {accuracy:g}, {result.attrs['nx']},"
                f" {result.attrs['steps']}, {result.attrs['iterations']},"
                f" {lbar:.6g}, {abs(lbar / reference - 1.0):.2e}"
            )
    return lines


DRIVE_CASE = {
    "maugis": 3.5,
    "modulus_ratio": 1.0,
    "velocity": 1.0,
    "depth": 0.03,
    "cell": 2.0,
    "adhesion": 1e-4,
}
STIFFNESSES = (1.0, 0.3, 0.1)


def drive_figure(out: Path, runs: Path, plt):
    """<out>/drive.png and drive.txt (module docstring)."""

    def text(stiffness=None, numerics=None):
        drive = {} if stiffness is None else {"drive_stiffness": stiffness}
        return case_file_text({**DRIVE_CASE, **drive}, numerics or {"nx": 4096, "accuracy": 1e-3})

    case = hpcgfmd.Case.from_toml(text())
    scale = case.load_scale
    fixed = run(text(), runs, "displacement").series
    attached = fixed.contact_half_width > 0
    z, load = fixed.indenter[attached], fixed.load[attached]
    fig, (ax_l, ax_z) = plt.subplots(1, 2, figsize=(11, 4.6))
    ax_l.plot(z / case.dmax, load / scale, "k", lw=1.5, label="displacement control")
    lines = [
        "# scripts/beyond_paper.py: jump-off of an elastic cylinder (lambda0 = 3.5, k = 1)"
        " on a spring, nx = 4096, accuracy 1e-3",
        f"# displacement control: pull-off Lbar {load.min() / scale:.5g}",
        "# k_s / E0, predicted jump: drive Z, indenter u_z (both in dmax), Lbar;"
        " run: drive, indenter, Lbar at the last attached step; pull-off Lbar; steps",
    ]
    for stiffness, color in zip(STIFFNESSES, ("C0", "C1", "C3")):
        balances = z - load / stiffness  # the drive position of each balance on the curve
        j = int(np.argmax(balances))
        series = run(text(stiffness), runs, f"spring_{stiffness:g}").series
        last = int(np.flatnonzero(series.contact_half_width > 0)[-1])
        line_z = np.linspace(z[j] - 0.6 * case.dmax, series.drive[last], 50)
        ax_l.plot(
            series.indenter[: last + 1] / case.dmax,
            series.load[: last + 1] / scale,
            color=color,
            lw=1,
            label=f"k_s = {stiffness:g} E0",
        )
        ax_l.plot(
            line_z / case.dmax,
            stiffness * (line_z - series.drive[last]) / scale,
            color=color,
            ls=":",
            lw=0.8,
        )
        ax_l.plot(
            series.indenter[last] / case.dmax, series.load[last] / scale, "o", color=color, ms=5
        )
        ax_z.plot(
            series.drive / case.dmax,
            series.indenter / case.dmax,
            color=color,
            label=f"k_s = {stiffness:g} E0",
        )
        lines.append(
            f"{stiffness:g}, {balances[j] / case.dmax:.5g}, {z[j] / case.dmax:.5g},"
            f" {load[j] / scale:.5g}; {series.drive[last] / case.dmax:.5g},"
            f" {series.indenter[last] / case.dmax:.5g},"
            f" {series.load[last] / scale:.5g}; {series.load.min() / scale:.5g};"
            f" {series.time.size - 1}"
        )
    ax_l.set(
        xlim=(z[np.argmin(load)] / case.dmax - 1.5, z[-1] / case.dmax + 0.5),
        ylim=(1.01 * load.min() / scale, 0.8 * load.min() / scale),
        xlabel="indenter u_z / dmax",
        ylabel="Lbar",
        title="(a) load against indenter: the spring lines at the jumps",
    )
    ax_l.legend(fontsize=8)
    ax_z.set(
        xlabel="drive Z / dmax",
        ylabel="indenter u_z / dmax",
        title="(b) the indenter follows the drive, then jumps",
    )
    ax_z.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "drive.png", dpi=110)
    return lines


CYCLE = ({"approach": 0.03}, {"dwell": 1.0}, {"retract": math.inf})
CYCLE_RUNS = (("elastic", 1.0, 1.0), ("SLS, V_z = 1", 0.1, 1.0), ("SLS, V_z = 10", 0.1, 10.0))


def cycle_figure(out: Path, runs: Path, plt):
    """<out>/cycle.png and cycle.txt (module docstring)."""
    fig, (ax_l, ax_t) = plt.subplots(1, 2, figsize=(11, 4.6))
    lines = [
        "# scripts/beyond_paper.py: approach 0.03 R, dwell 1 tau, retract until detached;"
        " lambda0 = 3.5, alpha = 1e-4, L/R = 2, nx = 4096, accuracy 1e-3",
        "# run: steps, pull-off Lbar (retraction), Lbar at the jump into contact,"
        " loop area (E0 R^2 per unit length) and in dgamma0 beta",
    ]
    for (label, k, velocity), color in zip(CYCLE_RUNS, ("k", "C0", "C3")):
        groups = {**DRIVE_CASE, "modulus_ratio": k, "velocity": velocity}
        text = case_file_text(groups, {"nx": 4096, "accuracy": 1e-3}, CYCLE)
        case = hpcgfmd.Case.from_toml(text)
        series = run(text, runs, f"cycle-{label.replace(' ', '').replace(',', '-')}").series
        scale = case.load_scale
        (cycle,) = series.cycles()
        ax_l.plot(
            series.indenter,
            series.load / scale,
            color=color,
            lw=1,
            label=f"{label}: loop {cycle.work / (case.adhesion * case.beta):.3g} dgamma0 beta",
        )
        ax_t.plot(series.time, series.load / scale, color=color, lw=1, label=label)
        contact = np.flatnonzero(series.contact_half_width > 0)
        lines.append(
            f"{label}: {series.time.size - 1}, {cycle.lbar:.5g},"
            f" {series.load[contact[0]] / scale:.5g}, {cycle.work:.5g},"
            f" {cycle.work / (case.adhesion * case.beta):.5g}"
        )
    ax_l.set(
        xlabel="indenter u_z / R",
        ylabel="Lbar",
        xlim=(-0.032, 0.008),
        title="(a) approach, dwell, retraction: hysteresis loops",
    )
    ax_l.legend(fontsize=8)
    ax_t.set(xlabel="t / tau", ylabel="Lbar", title="(b) load against time")
    ax_t.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "cycle.png", dpi=110)
    return lines


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="docs/figures", help="directory of the figures")
    parser.add_argument(
        "--accuracy",
        type=float,
        default=5e-3,
        help="[numerics] accuracy of the Prony figure's runs",
    )
    parser.add_argument(
        "--only",
        choices=("prony", "drive", "cycle", "accuracy"),
        help="one figure, or the Prony series' accuracy table only",
    )
    args = parser.parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(args.out)
    runs = out / "beyond-runs"
    runs.mkdir(parents=True, exist_ok=True)
    parts = {
        "prony": lambda: prony_figure(out, runs, args.accuracy, plt),
        "drive": lambda: drive_figure(out, runs, plt),
        "cycle": lambda: cycle_figure(out, runs, plt),
        "accuracy": lambda: accuracy_table(runs),
    }
    for name, part in parts.items():
        if args.only in (None, name):
            lines = part()
            stem = "prony-accuracy" if name == "accuracy" else name
            (out / f"{stem}.txt").write_text("\n".join(lines) + "\n")
            print("\n".join(lines))


if __name__ == "__main__":
    main()
