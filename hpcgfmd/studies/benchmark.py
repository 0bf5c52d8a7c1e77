"""Speed against error: the fast solver and the paper's method on the paper's hard cases.

``python -m hpcgfmd bench speed`` (``bench`` without a mode) runs, for each case
(lambda0, V_z) at h0/R = 0.1, L/R = 10, alpha = 5e-5, k = 0.1 (docs/model.md, "Scales and
dimensionless groups"):

1. A reference run: the fast solver with fine settings (:data:`REFERENCE`: edge motion
   <= w/4 per step, load deviation <= 5e-4 load scales, history error <= 2e-4 load scales,
   residual 1e-7) at the largest grid of the sweep.
2. The fast solver (active-set CG, adaptive steps) over the accuracy knobs: n_x, the CG
   tolerance, the step control (edge fraction; fixed steps for comparison).
   a. On the reference's grid: ``accuracy`` then sets the steps and the solver tolerance
      (the grid's share of the error is measured by the rows of the smaller grids).
   b. As a user runs it (rows ``cg-auto``): ``accuracy`` alone, the grid chosen from it
      (docs/numerics.md, "The accuracy knob"); a grid finer than the reference's is skipped,
      as the reference could not measure its error.
3. The paper's method (damped Verlet GFMD, fixed dt = tau/50, tau/100 for V_z >= 9, a fixed
   number E of pseudo steps per step): far too slow to finish (its authors' E = 1024 sqrt(n_x)
   is 370,000 pseudo steps per step at 2^17), so it runs a SHORTENED retraction of a few
   steps for several E; its error is the largest load deviation over those steps from the
   converged equilibria of the same steps (CG, tolerance 1e-10, same dt), relative to the
   reference pull-off load, and its full-run time is the measured cost per pseudo step times
   E times the number of steps of the whole retraction (the reference's duration / dt).
   This is its equilibration lag alone, a lower bound of its error: its fixed steps add a
   time error, which the next item measures.
4. The paper method's time error: the whole retraction with its fixed steps, dt = tau/50 and
   tau/100, solved by CG to a residual of 1e-8 (the equilibria its pseudo steps tend to),
   against the reference; skipped when longer than ``--paper-time-steps`` steps.

Errors of a run against the reference: pull-off load (most tensile sample) relative error;
curve error: the largest distance of the run's points (abar_c, Lbar) up to its pull-off to
the (much denser) reference's polyline, both coordinates divided by the reference's (abar_c at
t = 0, |Lbar| at pull-off).
Wall times include set-up (FFTW planning) and preload. Everything is collective over
``comm``; rank 0 writes the CSV, the table and the PNG, and prints the table between the
header of :func:`hpcgfmd.studies.report.header` and the verdicts of the runs as a user makes
them (accuracy alone) on the speed targets.
"""

from __future__ import annotations

import argparse
import csv
import logging
import math
import os
import sys
import time

import numpy as np

from .. import atomic
from ..case import case_file_text, parse_case
from ..errors import CaseError
from ..model.grid import grid_label
from ..runs.protocol import Retraction
from ..runs.single_case import check_zone_in_cell
from . import report
from .distance import load_area_distances
from .report import code_identity  # the studies' saved runs are keyed by it

logger = logging.getLogger(__name__)

CASES = ("7:4.5", "7:9", "14:0.9", "7:0.045")
GEOMETRY = {"modulus_ratio": 0.1, "depth": 0.1, "cell": 10.0, "adhesion": 5e-5}
# The reference must be sampled more densely than the finest run: the curve error is the
# distance to its polyline (at load_tolerance 3e-3 and time_tolerance 1e-3 the chords of
# the reference, not the run, made a curve error of 2.7e-3 for accuracy 1e-3 on the tests'
# small case; 4.4e-4 at these settings).
REFERENCE = {
    "edge_fraction": 0.25,
    "load_tolerance": 5e-4,
    "time_tolerance": 2e-4,
    "tolerance": 1e-7,
}
# Fast-solver sweep at the largest grid (nx given, so the accuracy sets the steps and the
# solver tolerance; the grid's share is the nx rows): (label, numerics overrides).
SWEEP = (
    ("accuracy=1e-2", {"accuracy": 1e-2}),
    ("accuracy=5e-3 (default)", {}),
    ("accuracy=1e-3", {"accuracy": 1e-3}),
    ("fixed dt=dmax/(4 v_z)", {"step_control": "fixed"}),
)
# ... and with the grid chosen by the accuracy (no nx), as a user runs it: (label, accuracy)
AUTO_GRID = (("1e-2", 1e-2), ("5e-3", 5e-3), ("1e-3", 1e-3))
# pseudo steps per step of the paper's method: the slowest modes contract by about
# exp(-E / (512 ln-units)) at 2^17 with Eeff = 10 E0 (hpcgfmd/solvers/verlet.py)
PAPER_EQUILIBRATION = (2000, 8000)
PAPER_STEPS = 4
PAPER_TIME_STEPS = 20000  # longest fixed-step run for the paper method's time error
PAPER_TIME_DIVISIONS = (50, 100)  # its steps, tau / these
COLUMNS = (
    "case",
    "lambda0",
    "Vz",
    "solver",
    "label",
    "accuracy",
    "nx",
    "tolerance",
    "step_control",
    "edge_fraction",
    "equilibration_steps",
    "dt",
    "steps",
    "iterations",
    "iterations_per_step",
    "fft_pairs",
    "wall_s",
    "cpu_s",
    "setup_s",
    "ms_per_iteration",
    "pulloff_Lbar",
    "pulloff_error",
    "curve_error",
    "extrapolated",
    "ranks",
    "machine",
    "commit",
)


def case_text(lambda0, vz, numerics, geometry=GEOMETRY):
    """The case file of (lambda0, V_z) with the given ``[numerics]`` keys and geometry."""
    return case_file_text({"maugis": lambda0, "velocity": vz, **geometry}, numerics)


def run(text, comm, max_steps=None, progress=None):
    """Collective: one retraction in memory; its cost and its (time, load, a_c) series."""
    case = parse_case(text)
    comm.Barrier()
    start = time.perf_counter()
    cpu_start = time.process_time()
    sim = Retraction(case, comm)
    setup = time.perf_counter() - start
    records = [sim.preload()]
    try:
        check_zone_in_cell(case, records[0])  # the cells `hpcgfmd run` accepts
    except CaseError:
        sim.close()  # the transform's shared window, before the error ends the study
        raise
    preloaded = last = time.perf_counter()
    preloaded_cpu = time.process_time()
    while not sim.finished() and (max_steps is None or sim.surface.step_index < max_steps):
        records.append(sim.step())
        if progress and time.perf_counter() - last > progress and comm.Get_rank() == 0:
            last = time.perf_counter()
            peeled = records[-1].contact_half_width / records[0].contact_half_width
            logger.info(
                f"    ... step {sim.surface.step_index}, t = {records[-1].time:.4g},"
                f" a_c/a_c(0) = {peeled:.3f}, {last - start:.0f} s"
            )
    wall = comm.allreduce(time.perf_counter() - start, op=_max())
    # CPU seconds of the slowest rank: on a shared machine the wall time counts the other
    # processes too, the CPU time only this run's work (equal to the wall time when idle)
    cpu = comm.allreduce(time.process_time() - cpu_start, op=_max())
    retraction = comm.allreduce(time.perf_counter() - preloaded, op=_max())
    retraction_cpu = comm.allreduce(time.process_time() - preloaded_cpu, op=_max())
    result = {
        "case": case,
        "wall_s": wall,
        "cpu_s": cpu,
        "setup_s": setup,
        "retraction_s": retraction,
        "retraction_cpu_s": retraction_cpu,
        "retraction_iterations": sim.equilibrium.iterations - sim.preload_iterations,
        "steps": sim.surface.step_index,
        "iterations": sim.equilibrium.iterations,
        "fft_pairs": sim.fft.pairs,
        "time": np.array([r.time for r in records]),
        "lbar": np.array([r.load for r in records]) / case.load_scale,
        "abar": np.array([r.contact_half_width for r in records]) / case.beta,
        # the indenter's depth below the surface's level (the sphere's curve error, Dbar)
        "dbar": -np.array([r.indenter for r in records]) / case.depth_scale,
        "dt": np.array([r.dt for r in records]),
    }
    sim.close()
    return result


def _max():
    from mpi4py import MPI

    return MPI.MAX


def curve_error(reference, result):
    """Largest distance of the run's points (abar, Lbar) up to its pull-off to the
    reference's load-area curve up to the reference's pull-off
    (:func:`~hpcgfmd.studies.distance.load_area_distances`, scaled by the reference's
    abar_c at t = 0 and |Lbar| at pull-off).

    After the run's pull-off the contact jumps; the pull-off error measures where it came.
    The reference is sampled much more densely, so its polyline stands for the exact curve
    and the distance is the error of the computed points, not of interpolating between them.
    """
    end = int(np.argmin(result["lbar"])) + 1
    distances = load_area_distances(
        result["abar"][:end], result["lbar"][:end], reference["abar"], reference["lbar"]
    )
    return float(distances.max()) if len(distances) else math.nan


def paper_dt(vz):
    """The paper's fixed step (Appendix B): tau/50, tau/100 for its fastest case (V_z = 9)."""
    return 1.0 / 100.0 if vz >= 9.0 else 1.0 / 50.0


def measure_paper(lambda0, vz, nx, reference, comm, geometry, equilibrations, steps):
    """Shortened retractions of the paper's method (module docstring, item 3): rows."""
    dt = paper_dt(vz)
    numerics = {"nx": nx, "step_control": "fixed", "dt": dt, "tolerance": 1e-10}
    exact = run(
        case_text(lambda0, vz, {**numerics, "solver": "cg"}, geometry), comm, max_steps=steps
    )
    total_steps = math.ceil(reference["time"][-1] / dt)
    l_scale = abs(reference["lbar"].min())
    rows = []
    for equilibration in equilibrations:
        # its CG preload as converged as the exact run's, so that the error is the lag alone
        # (at the knob's tolerance the preload's own error, 9e-5 at 2.5e-3, stands in for it)
        paper = {**numerics, "solver": "paper", "equilibration_steps": equilibration}
        result = run(case_text(lambda0, vz, paper, geometry), comm, max_steps=steps)
        error = float(np.abs(result["lbar"][1:] - exact["lbar"][1:]).max()) / l_scale
        rows.append(_paper_row(result, error, nx, dt, equilibration, steps, total_steps))
    # The paper authors' own setting, E = 1024 sqrt(n_x) (the default of
    # [numerics] equilibration_steps): far too long to run even shortened; its error is at
    # most that of the largest E measured (the lag only shrinks with E).
    authors = parse_case(
        case_text(lambda0, vz, {"nx": nx, "solver": "paper"}, geometry)
    ).numerics.setting("equilibration_steps")
    if rows and authors > max(equilibrations):
        last = rows[-1]
        per_pseudo = last["ms_per_iteration"] * 1e-3
        per_pseudo_cpu = (last["cpu_s"] - last["setup_s"]) / last["iterations"]
        rows.append(
            dict(
                last,
                label=f"E={authors} = 1024 sqrt(nx), the authors' (error <= the"
                f" E={last['equilibration_steps']} row's, extrapolated)",
                equilibration_steps=authors,
                iterations=total_steps * authors,
                iterations_per_step=float(authors),
                fft_pairs=total_steps * authors,
                wall_s=last["setup_s"] + per_pseudo * total_steps * authors,
                cpu_s=last["setup_s"] + per_pseudo_cpu * total_steps * authors,
            )
        )
    return rows


def _paper_row(result, error, nx, dt, equilibration, steps, total_steps):
    """The row of the paper's method with ``equilibration`` pseudo steps per step: its
    shortened run's cost extrapolated to the whole retraction's ``total_steps``."""
    # cost of one pseudo step: the retraction's time (the preload is CG's) per pseudo step
    per_pseudo = result["retraction_s"] / max(result["retraction_iterations"], 1)
    per_pseudo_cpu = result["retraction_cpu_s"] / max(result["retraction_iterations"], 1)
    pseudo_steps = total_steps * equilibration
    return {
        "solver": "paper",
        "label": f"E={equilibration} (shortened: {steps} of"
        f" {total_steps} steps, extrapolated; error: its equilibration lag alone)",
        "nx": nx,
        "tolerance": math.nan,
        "step_control": "fixed",
        "edge_fraction": math.nan,
        "equilibration_steps": equilibration,
        "dt": dt,
        "steps": total_steps,
        "iterations": pseudo_steps,
        "iterations_per_step": float(equilibration),
        "fft_pairs": pseudo_steps,
        "wall_s": result["wall_s"] - result["retraction_s"] + per_pseudo * pseudo_steps,
        "cpu_s": result["cpu_s"] - result["retraction_cpu_s"] + per_pseudo_cpu * pseudo_steps,
        "setup_s": result["setup_s"],
        "ms_per_iteration": 1e3 * per_pseudo,
        "pulloff_Lbar": math.nan,
        "pulloff_error": error,
        "curve_error": error,
        "extrapolated": True,
    }


def measure_paper_time_error(lambda0, vz, nx, reference, comm, geometry, budget, say):
    """The paper method's time error (module docstring, item 4): rows, one per step length."""
    rows = []
    for division in PAPER_TIME_DIVISIONS:
        dt = 1.0 / division
        total_steps = math.ceil(reference["time"][-1] / dt)
        label = f"time error at dt=tau/{division} (CG, fixed steps)"
        if total_steps > budget:
            say(f"  paper  {label}: skipped, {total_steps} steps > --paper-time-steps {budget}")
            continue
        text = case_text(
            lambda0, vz, {"nx": nx, "step_control": "fixed", "dt": dt, "tolerance": 1e-8}, geometry
        )
        rows.append(_row(label, run(text, comm), reference, "paper-time"))
        say(_line(rows[-1]))
    return rows


def _row(label, result, reference, solver="cg"):
    case = result["case"]
    num = case.numerics
    ref_po = reference["lbar"].min()
    po = result["lbar"].min()
    return {
        "solver": solver,
        "label": label,
        "accuracy": num.accuracy,
        "nx": num.nx,
        "tolerance": num.tolerance,
        "step_control": num.step_control,
        "edge_fraction": num.edge_fraction if num.step_control == "adaptive" else math.nan,
        "equilibration_steps": math.nan,
        "dt": float(np.median(result["dt"][1:])),
        "steps": result["steps"],
        "iterations": result["iterations"],
        "iterations_per_step": result["iterations"] / max(result["steps"], 1),
        "fft_pairs": result["fft_pairs"],
        "wall_s": result["wall_s"],
        "cpu_s": result["cpu_s"],
        "setup_s": result["setup_s"],
        "ms_per_iteration": 1e3 * result["retraction_s"] / max(result["retraction_iterations"], 1),
        "pulloff_Lbar": po,
        "pulloff_error": abs(po - ref_po) / abs(ref_po),
        "curve_error": curve_error(reference, result),
        "extrapolated": False,
    }


def cached_run(text, comm, path):
    """:func:`run`, or its result saved in ``path`` (.npz) by an earlier run of the same text.

    The reference runs are the long ones; a re-run of the benchmark reuses them.
    """
    if path and os.path.exists(path):
        with np.load(path, allow_pickle=False) as saved:
            if str(saved["text"]) == text:
                result = {key: saved[key] for key in SERIES if key in saved}
                result.update(
                    {key: float(saved[key]) if key in saved else math.nan for key in SCALARS}
                )
                result["case"] = parse_case(text)
                result["cached"] = True
                return result
    result = run(text, comm, progress=60.0)
    if path and comm.Get_rank() == 0:
        with atomic.replacing(path) as temporary:  # its name ends in .npz, as savez wants
            np.savez(
                temporary,
                text=text,
                **{key: result[key] for key in SERIES if key in result},
                **{key: result[key] for key in SCALARS},
            )
    return result


SERIES = ("time", "lbar", "abar", "dbar", "dt")  # a run's saved series
SCALARS = (
    "wall_s",
    "cpu_s",
    "setup_s",
    "retraction_s",
    "retraction_cpu_s",
    "retraction_iterations",
    "steps",
    "iterations",
    "fft_pairs",
)


def auto_grid_cases(lambda0, vz, geometry, auto_grid=AUTO_GRID):
    """(label, case text without nx, the grid the accuracy knob chooses) per accuracy."""
    cases = []
    for label, accuracy in auto_grid:
        text = case_text(lambda0, vz, {"accuracy": accuracy}, geometry)
        cases.append((label, text, parse_case(text).numerics.nx))
    return cases


def bench_case(
    key,
    comm,
    nxs,
    sweep,
    equilibrations,
    paper_steps,
    geometry,
    say,
    cache_prefix=None,
    paper_time_steps=PAPER_TIME_STEPS,
    auto_grid=AUTO_GRID,
):
    lambda0, vz = (float(v) for v in key.split(":"))
    top = max(nxs)
    say(f"case lambda0 = {lambda0:g}, V_z = {vz:g}: reference at nx = {top}")
    cache = f"{cache_prefix}-reference-{lambda0:g}-{vz:g}-{top}.npz" if cache_prefix else None
    settings = {"nx": top, **REFERENCE}
    reference = cached_run(case_text(lambda0, vz, settings, geometry), comm, cache)
    say(
        f"  reference: pull-off Lbar {reference['lbar'].min():.6f}, {int(reference['steps'])}"
        f" steps, {reference['wall_s']:.0f} s{' (saved earlier)' if 'cached' in reference else ''}"
    )
    rows = [
        _row(
            "reference " + " ".join(f"{k}={v:g}" for k, v in settings.items() if k != "nx"),
            reference,
            reference,
            "reference",
        )
    ]
    for label, overrides in sweep:
        rows.append(
            _row(
                label,
                run(case_text(lambda0, vz, {"nx": top, **overrides}, geometry), comm),
                reference,
            )
        )
        say(_line(rows[-1]))
    for nx in sorted(set(nxs) - {top}):
        try:
            text = case_text(lambda0, vz, {"nx": nx}, geometry)
            parse_case(text)
        except CaseError as err:  # e.g. fewer than one point across the cohesive zone
            say(f"  nx={nx} skipped: {err}")
            continue
        rows.append(_row(f"nx={nx} (default)", run(text, comm), reference))
        say(_line(rows[-1]))
    for label, text, nx in auto_grid_cases(lambda0, vz, geometry, auto_grid):
        if nx > top:
            say(
                f"  cg-auto accuracy={label}: skipped, its grid nx={nx} is finer than the"
                f" reference's {top}"
            )
            continue
        rows.append(
            _row(f"accuracy={label}, nx from the accuracy", run(text, comm), reference, "cg-auto")
        )
        say(_line(rows[-1]))
    if equilibrations:
        for row in measure_paper(
            lambda0, vz, top, reference, comm, geometry, equilibrations, paper_steps
        ):
            rows.append(row)
            say(_line(row))
        rows += measure_paper_time_error(
            lambda0, vz, top, reference, comm, geometry, paper_time_steps, say
        )
    for row in rows:
        row.update(case=key, lambda0=lambda0, Vz=vz, ranks=comm.Get_size())
    return rows


def _line(row):
    return (
        f"  {row['solver']:6s} {row['label']:45s} nx={row['nx']:7d} wall {row['wall_s']:9.1f} s"
        f" cpu {row['cpu_s']:9.1f} s"
        f"  pairs {row['fft_pairs']:>11}  pull-off error {row['pulloff_error']:.2e}"
        f"  curve error {row['curve_error']:.2e}"
    )


def markdown(rows):
    """The table of docs/results.md ("Speed against error"): one line per row, in order."""
    lines = [
        (
            "| case (lambda0, V_z) | solver, setting | accuracy | n_x | steps | it/step |"
            " ms/it | FFT pairs | CPU s | pull-off Lbar | pull-off error | curve error |"
        ),
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]

    def number(value, form):
        return "" if value is None or math.isnan(value) else format(value, form)

    for r in rows:
        kind = {
            "cg": "fast: ",
            "cg-auto": "fast, nx chosen: ",
            "paper": "paper: ",
            "paper-time": "paper's steps: ",
        }.get(r["solver"], "")
        lam, vz = r["case"].split(":")
        lines.append(
            f"| {lam}, {vz} | {kind}{r['label']} |"
            f" {number(r['accuracy'], 'g') if r['solver'] in ('cg', 'cg-auto') else ''} |"
            f" {grid_label(int(r['nx']))} | {int(r['steps'])} |"
            f" {number(r['iterations_per_step'], '.1f')} |"
            f" {number(r['ms_per_iteration'], '.2f')} |"
            f" {int(r['fft_pairs'])} | {number(r['cpu_s'], '.1f')} |"
            f" {number(r['pulloff_Lbar'], '.5f')} |"
            f" {number(r['pulloff_error'], '.1e')} | {number(r['curve_error'], '.1e')} |"
        )
    return "\n".join(lines) + "\n"


def verdicts(rows):
    """The speed targets judged on the rows of the runs as a user makes them (accuracy
    5e-3 alone, the grid the knob's: rows ``cg-auto``), one line each."""
    judged = {}
    for r in rows:
        if r["solver"] != "cg-auto" or r["accuracy"] != 5e-3:
            continue
        lam, vz = r["case"].split(":")
        subject = f"({lam}, {vz})"
        judged.setdefault("case_cpu", []).append((subject + " in its process", r["cpu_s"]))
        judged.setdefault("pull_off", []).append((subject, r["pulloff_error"]))
        judged.setdefault("iterations_per_step", []).append((subject, r["iterations_per_step"]))
        if (float(lam), float(vz)) == (7.0, 0.045):
            judged.setdefault("creeping_steps", []).append((subject, r["steps"]))
    return [report.verdict(key, items) for key, items in judged.items()] or [
        "targets: none judged (no run at accuracy 5e-3 with the knob's grid)"
    ]


def write_markdown(rows, path, head=""):
    """Atomic: ``head``, :func:`markdown` of the rows and their :func:`verdicts` to ``path``;
    the whole text, as printed."""
    text = (head + "\n" if head else "") + markdown(rows) + "\n" + "\n".join(verdicts(rows))
    atomic.write_text(path, text + "\n")
    return text


def write_csv(rows, path, columns=COLUMNS):
    """Atomic: the rows' ``columns`` (missing ones empty) to the CSV file ``path``."""
    atomic.write_csv(path, columns, rows)


def plot(rows, path, clock="wall"):
    """PNG: pull-off error against wall (or CPU) time, one panel per case and solver line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = list(dict.fromkeys(r["case"] for r in rows))
    fig, axes = plt.subplots(1, len(cases), figsize=(4.2 * len(cases), 4), squeeze=False)
    for ax, key in zip(axes[0], cases):
        top = max(x["nx"] for x in rows if x["case"] == key)
        for solver, style, label in (
            ("cg", "C0o-", "fast (active-set CG, adaptive dt), reference's grid"),
            ("cg-auto", "C2^-", "fast, grid from the accuracy (no nx)"),
            ("paper", "C3s--", "paper (damped Verlet, extrapolated)"),
        ):
            pts = sorted(
                (r[f"{clock}_s"], max(r["pulloff_error"], 1e-7))
                for r in rows
                if r["case"] == key
                and r["solver"] == solver
                and (solver == "cg-auto" or r["nx"] == top)
            )
            if pts:
                ax.loglog(*zip(*pts), style, label=label)
        # the speed targets: within 0.5 % in at most 5 s of one core
        ax.axhline(report.TARGETS["pull_off"].limit, color="k", lw=0.5, ls=":")
        ax.axvline(report.TARGETS["case_cpu"].limit, color="k", lw=0.5, ls=":")
        lam, vz = key.split(":")
        ax.set_title(f"lambda0 = {lam}, V_z = {vz}")
        ax.set_xlabel("wall time (s)" if clock == "wall" else "CPU time of the slowest rank (s)")
        ax.set_ylabel("pull-off load error (relative)")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    fig.tight_layout()
    atomic.save_figure(fig, path, dpi=110)
    plt.close(fig)


def _parser(modes=""):
    parser = argparse.ArgumentParser(
        prog="python -m hpcgfmd bench [speed]",
        description=__doc__.split("\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="--quiet and --log FILE as for every command (before or after bench)\n\n" + modes,
    )
    parser.add_argument(
        "--cases",
        nargs="+",
        default=list(CASES),
        help="lambda0:V_z pairs (default: the paper's hard and slow cases)",
    )
    parser.add_argument(
        "--nx",
        nargs="+",
        type=int,
        default=[16, 17],
        help="log2 of the grids; the largest is the reference's (default 16 17)",
    )
    parser.add_argument(
        "--paper-equilibration",
        nargs="*",
        type=int,
        default=list(PAPER_EQUILIBRATION),
        help=(
            "pseudo steps per step of the paper's method (shortened runs;"
            f" default {' '.join(map(str, PAPER_EQUILIBRATION))})"
        ),
    )
    parser.add_argument(
        "--paper-steps",
        type=int,
        default=PAPER_STEPS,
        help=(
            "steps of the paper method's shortened runs, whose cost is extrapolated to the whole"
            f" retraction (default {PAPER_STEPS})"
        ),
    )
    parser.add_argument(
        "--paper-time-steps",
        type=int,
        default=PAPER_TIME_STEPS,
        help=(
            "longest whole retraction run at the paper's fixed steps for its time error"
            f" (default {PAPER_TIME_STEPS}; 0 skips them)"
        ),
    )
    parser.add_argument("--no-fixed", action="store_true", help="skip the fixed-step run")
    _output_options(parser)
    return parser


def _output_options(parser):
    """The second half of :func:`_parser`'s options: which rows run, where they are written."""
    parser.add_argument(
        "--no-auto",
        action="store_true",
        help=("skip the runs with the grid chosen by the accuracy (rows cg-auto)"),
    )
    parser.add_argument(
        "--only",
        nargs="+",
        metavar="SETTING",
        help=(
            "run only these fast-solver settings ("
            + ", ".join(s[0].split(" ")[0] for s in SWEEP)
            + ")"
        ),
    )
    parser.add_argument(
        "--geometry",
        nargs=3,
        type=float,
        metavar=("DEPTH", "CELL", "ALPHA"),
        help="h0/R, L/R, alpha instead of 0.1 10 5e-5 (quick checks only)",
    )
    parser.add_argument(
        "--out",
        default="speed_vs_error",
        help=(
            "output prefix: PREFIX.csv, PREFIX.md (the table), PREFIX.png and the reference runs"
            " PREFIX-reference-*.npz (reused when present; default speed_vs_error)"
        ),
    )
    parser.add_argument(
        "--clock",
        choices=("wall", "cpu"),
        default="wall",
        help=(
            "time axis of the PNG: wall time, or the CPU time of the slowest rank (equal to the"
            " wall time on an idle machine; use it on a shared one; default wall)"
        ),
    )
    parser.add_argument(
        "--collect",
        action="store_true",
        help=(
            "run nothing: combine the per-case tables PREFIX-<lambda0>-<V_z>.csv of earlier runs"
            " (e.g. one job per case) into PREFIX.csv, PREFIX.md and PREFIX.png"
        ),
    )
    parser.add_argument(
        "--reference-only", action="store_true", help="compute (or check) the reference runs only"
    )


def _settings(args, geometry):
    """(the fast-solver sweep to run, None), or (None, the one-line error) for bad arguments."""
    sweep = [s for s in SWEEP if not (args.no_fixed and s[1].get("step_control") == "fixed")]
    if args.only:
        unknown = [o for o in args.only if not any(s[0].split(" ")[0] == o for s in SWEEP)]
        if unknown:
            return None, (
                f"--only {' '.join(unknown)}: expected among"
                f" {', '.join(s[0].split(' ')[0] for s in SWEEP)}"
            )
        sweep = [s for s in sweep if s[0].split(" ")[0] in args.only]
    if args.reference_only:  # the references alone: no sweep, no other grid, no paper rows
        sweep, args.nx, args.paper_equilibration = [], [max(args.nx)], []
        args.no_auto = True
    if args.paper_time_steps < 0:
        return None, f"--paper-time-steps {args.paper_time_steps}: expected an integer >= 0"
    if args.paper_steps < 1:
        return None, f"--paper-steps {args.paper_steps}: expected an integer >= 1"
    if any(e < 1 for e in args.paper_equilibration):
        return None, f"--paper-equilibration {args.paper_equilibration}: expected integers >= 1"
    if any(not 6 <= e <= 26 for e in args.nx):
        return None, f"--nx {args.nx}: expected log2 of the grid sizes, between 6 and 26"
    for key in args.cases:
        try:
            lambda0, vz = (float(v) for v in key.split(":"))
        except ValueError:
            return None, f"--cases {key}: expected lambda0:V_z, e.g. 7:4.5"
        try:  # the reference's case file: bad groups or geometry are refused before any run
            parse_case(case_text(lambda0, vz, {"nx": 2 ** max(args.nx), **REFERENCE}, geometry))
        except CaseError as err:
            return None, f"--cases {key} (--nx {max(args.nx)}, --geometry): {err}"
    return sweep, None


def main(comm, argv=None, modes=""):
    """Collective: ``python -m hpcgfmd bench [speed]``; the exit status. ``modes``: the list
    of the bench modes its ``--help`` ends with (:func:`hpcgfmd.studies.bench.modes_help`)."""
    try:
        args = _parser(modes).parse_args(argv)
    except SystemExit as exit_:
        return int(exit_.code or 0)
    geometry = dict(GEOMETRY)
    if args.geometry:
        geometry.update(depth=args.geometry[0], cell=args.geometry[1], adhesion=args.geometry[2])
    rank0 = comm.Get_rank() == 0
    sweep, error = _settings(args, geometry)
    if error:
        if rank0:
            print(f"bench: {error}", file=sys.stderr)
        return 2
    title = "Speed against error (python -m hpcgfmd bench speed)"
    head = report.header(title) if rank0 else ""
    if args.collect:
        status = 0
        if rank0:
            rows = collect(args.out)
            if not rows:
                print(
                    f"bench: --collect --out {args.out}: no per-case table"
                    f" {args.out}-<lambda0>-<V_z>.csv to collect (run the cases first)",
                    file=sys.stderr,
                )
                status = 2
            else:
                made = sorted(
                    {
                        f"{r.get('machine') or 'an unrecorded machine'}, commit"
                        f" {r.get('commit') or 'unrecorded'}"
                        for r in rows
                    }
                )
                head = (
                    head.rstrip("\n")
                    + "\ncollected from rows measured on "
                    + "; ".join(made)
                    + "\n"
                )
                write_csv(rows, args.out + ".csv")
                print(write_markdown(rows, args.out + ".md", head), flush=True)
                plot(rows, args.out + ".png", args.clock)
                logger.info(f"collected {len(rows)} rows into {args.out}.csv, .md and .png")
        return comm.bcast(status, root=0)  # the same status on every rank
    if rank0:
        print(head, flush=True)
    made = comm.bcast(
        (report.machine(), f"{report.commit()} (code {code_identity()})") if rank0 else None, root=0
    )
    rows, text = [], ""
    for key in args.cases:
        case_rows = bench_case(
            key,
            comm,
            [2**e for e in args.nx],
            sweep,
            args.paper_equilibration,
            args.paper_steps,
            geometry,
            logger.info,
            args.out,
            args.paper_time_steps,
            () if args.no_auto else AUTO_GRID,
        )
        for row in case_rows:
            row.update(machine=made[0], commit=made[1])
        rows += case_rows
        if rank0:  # after every case: a long benchmark keeps what it measured
            write_csv(case_rows, f"{args.out}-{key.replace(':', '-')}.csv")
            write_csv(rows, args.out + ".csv")
            text = write_markdown(rows, args.out + ".md", head)
            plot(rows, args.out + ".png", args.clock)
    if rank0:
        print(text.removeprefix(head).lstrip("\n"), flush=True)
    logger.info(f"wrote {args.out}.csv, {args.out}.md and {args.out}.png")
    return 0


def collect(prefix):
    """The rows of every per-case CSV PREFIX-<lambda0>-<V_z>.csv (cases run as separate jobs)."""
    import glob

    rows = []
    for path in sorted(glob.glob(f"{glob.escape(prefix)}-*.csv")):
        with open(path, newline="") as fh:
            for row in csv.DictReader(fh):
                for key in COLUMNS:
                    if key in (
                        "case",
                        "solver",
                        "label",
                        "step_control",
                        "extrapolated",
                        "machine",
                        "commit",
                    ):
                        continue
                    value = row.get(key)  # (older tables lack newer columns)
                    row[key] = float(value) if value not in ("", None) else math.nan
                row["extrapolated"] = row["extrapolated"] == "True"
                rows.append(row)
    return rows
