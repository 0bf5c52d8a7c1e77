"""``python -m hpcgfmd paper``: run the paper's studies through the farm, draw every figure,
check every claim.

    mpirun -n 2 python -m hpcgfmd paper [-o DIR] [--figures 2,4,5,...] [--accuracy A]
                                        [--dry-run] [--draw-only]

Layout of DIR (default ``paper``): ``runs/`` the farm's result files and summary (resumable:
run the command again after an interruption), ``figN.png`` and ``figN.csv`` per figure,
``checks.txt`` and ``checks.csv`` with every claim's numbers and verdict.
"""

from __future__ import annotations

import csv
import logging
import os
import time

from ..atomic import write_csv, write_text
from ..errors import EXIT_FAILURE, EXIT_OK, ResultFileError, SweepError, UsageError
from ..model.grid import grid_label
from . import checks as claims
from .curves import Retraction, steady_masks
from .study import DEFAULT_ACCURACY, FIGURES, SWEEP_FILES, paper_study

logger = logging.getLogger(__name__)


def add_parser(sub, common):
    """The ``paper`` subcommand of the command line (:mod:`hpcgfmd.cli`)."""
    paper = sub.add_parser(
        "paper", parents=[common], help="run, draw and check the paper's figures (docs/paper.md)"
    )
    paper.add_argument(
        "-o",
        "--output",
        default="paper",
        help="directory of the runs, figures and checks (default: paper)",
    )
    paper.add_argument(
        "--figures",
        default=",".join(FIGURES),
        help=f"comma-separated figures (default: all, {','.join(FIGURES)})",
    )
    paper.add_argument(
        "--accuracy",
        type=float,
        default=None,
        help=f"[numerics] accuracy of every run (default: the sweep files', {DEFAULT_ACCURACY:g})",
    )
    paper.add_argument(
        "--sweeps",
        default=None,
        metavar="DIR",
        help="sweep files fig4.toml, fig5.toml, fig8.toml, fig9.toml, figB1.toml"
        " in DIR replace the shipped ones (your own study, same figures)",
    )
    paper.add_argument(
        "--ranks-per-case", type=int, default=1, help="ranks sharing one case (default 1)"
    )
    paper.add_argument(
        "--dry-run",
        action="store_true",
        help="list the cases and their estimated cost; run nothing",
    )
    paper.add_argument(
        "--draw-only",
        action="store_true",
        help="draw and check from the runs already in DIR/runs; run nothing",
    )
    paper.set_defaults(func=cmd_paper)
    return paper


def parse_figures(text: str) -> list:
    """The figure labels of ``--figures`` (UsageError naming the value otherwise)."""
    wanted = [part.strip() for part in text.split(",") if part.strip()]
    unknown = [f for f in wanted if f not in FIGURES]
    if unknown or not wanted:
        raise UsageError(
            f"--figures {text}: expected a comma-separated list of {', '.join(FIGURES)}"
        )
    return [f for f in FIGURES if f in wanted]


def own_sweeps(directory):
    """{figure: sweep file text} of the files of ``--sweeps DIR`` (empty without it)."""
    if directory is None:
        return {}
    if not os.path.isdir(directory):
        raise UsageError(f"--sweeps {directory}: not a directory")
    texts = {}
    for figure, name in SWEEP_FILES.items():
        path = os.path.join(directory, name)
        if os.path.exists(path):
            try:
                with open(path, encoding="utf-8") as fh:
                    texts[figure] = fh.read()
            except (OSError, UnicodeDecodeError) as err:
                raise UsageError(f"--sweeps {directory}: cannot read {name} ({err})") from None
    if not texts:
        raise UsageError(f"--sweeps {directory}: none of {', '.join(SWEEP_FILES.values())} there")
    return texts


def cmd_paper(comm, args):
    """Collective: the ``paper`` command on all ranks."""
    from ..runs.farm import check_farm_directory, plan_table, run_farm

    figures = parse_figures(args.figures)
    accuracy = args.accuracy
    if accuracy is not None and not 0.0 < accuracy < 0.1:
        raise UsageError(f"--accuracy {accuracy:g}: expected a relative error in (0, 0.1)")
    size = comm.Get_size()
    if args.ranks_per_case < 1 or size % args.ranks_per_case:
        raise UsageError(
            f"--ranks-per-case {args.ranks_per_case}: expected a divisor of the {size} ranks"
        )
    try:
        sweep, members = paper_study(figures, accuracy, own_sweeps(args.sweeps))
    except SweepError as err:
        raise UsageError(str(err)) from None
    runs_dir = os.path.join(args.output, "runs")
    if args.dry_run:
        logger.info(plan_table(sweep, runs_dir, size // args.ranks_per_case))
        for figure in figures:
            logger.info(
                f"Fig. {figure}: {len(members[figure])} runs"
                + (f" ({', '.join(members[figure])})" if members[figure] else "")
            )
        return EXIT_OK
    if os.path.exists(args.output) and not os.path.isdir(args.output):
        raise UsageError(f"-o {args.output}: exists and is not a directory")
    status = EXIT_OK
    if not args.draw_only and sweep.cases:
        check_farm_directory(comm, runs_dir)
        logger.info(
            f"paper: {len(sweep.cases)} runs for Figs. {', '.join(figures)} in"
            f" {runs_dir}, {size} ranks"
        )
        # one farm of every figure's runs: its progress lines count k of N over all of them
        status = run_farm(
            sweep,
            comm,
            runs_dir,
            ranks_per_case=args.ranks_per_case,
            stop=args.stop,
            label="paper",
            noun="runs",
        )
    drawn = EXIT_OK
    if comm.Get_rank() == 0:
        # rank 0 alone draws; whatever fails there, the others must hear its status
        try:
            os.makedirs(args.output, exist_ok=True)
            draw_all(args.output, runs_dir, figures, members)
        except (OSError, ValueError, KeyError, IndexError, RuntimeError) as err:
            logger.error(f"failed: drawing the figures: {type(err).__name__}: {err}")
            drawn = EXIT_FAILURE
    drawn = comm.bcast(drawn, root=0)
    return comm.bcast(status, root=0) if drawn == EXIT_OK else drawn


def _load(runs_dir, name):
    """(Retraction, Result) of a finished run with contact, or None."""
    from ..storage.reader import read_result

    path = os.path.join(runs_dir, name + ".h5")
    if not os.path.exists(path):
        return None
    try:
        result = read_result(path)
    except ResultFileError:
        return None
    if not result.finished or not (result.series.contact_half_width > 0).any():
        return None
    return Retraction.from_series(result.series), result


def run_accuracy(result) -> float:
    """The ``[numerics] accuracy`` a run was made with (its stored case file)."""
    from ..case import parse_case

    return parse_case(result.attrs["config"]).numerics.accuracy


def _setting(result):
    """How a Fig. B1 run was resolved: its grid, and its fixed step or adaptive."""
    a = result.attrs
    nx = int(a["nx"])
    grid = grid_label(nx)
    if a["step_control"] == "fixed":
        return grid, f"tau/{round(a['time_unit'] / a['dt']):d}"
    return grid, "adaptive"


def _remove(path, suffixes):
    """A figure without data leaves no stale file of an earlier drawing."""
    for suffix in suffixes:
        if os.path.exists(path + suffix):
            os.remove(path + suffix)


def draw_all(out_dir, runs_dir, figures, members):
    """Rank 0: every figure's PNG and CSV, the checks (printed and written).

    The checks' resolution is the coarsest ``[numerics] accuracy`` of the runs found (the
    study's default when there are none)."""
    from . import figures as draw

    found = {name: _load(runs_dir, name) for f in figures for name in members[f]}
    accuracies = [run_accuracy(item[1]) for item in found.values() if item is not None]
    accuracy = max(accuracies, default=DEFAULT_ACCURACY)
    logger.info(
        f"paper: checks resolve distances down to {claims.RESOLVED:g} x accuracy"
        f" {accuracy:g} (the coarsest of the runs)"
    )
    all_checks, costs = [], {}
    for figure in figures:
        names = members[figure]
        loaded = [found[n] for n in names if found[n] is not None]
        missing = [n for n in names if found[n] is None]
        if missing:
            logger.warning(
                f"Fig. {figure}: {len(missing)} of {len(names)} runs missing or"
                f" unfinished ({', '.join(missing)}); drawn without them"
            )
        costs[figure] = sum(float(r.attrs.get("wall_time", 0.0)) for _, r in loaded)
        path = os.path.join(out_dir, f"fig{figure}")
        curves = [c for c, _ in loaded]
        started = time.perf_counter()
        if figure == "2":
            draw.draw_fig2(path)
            all_checks += claims.check_fig2()
        elif figure == "4":
            draw.draw_fig4(path, curves)
            all_checks += claims.check_fig4(curves, accuracy)
        elif figure in ("5", "8"):
            key = "Vz" if figure == "5" else "lambda0"
            masks = steady_masks(curves, key, claims.RESOLVED * accuracy)
            draw.draw_curves_and_work(path, [(c.label(), c) for c in curves], masks, key)
            all_checks += claims.check_depths(f"{figure}a", curves, key, accuracy)
            all_checks += claims.check_eq8(f"{figure}b", curves, masks)
            if figure == "8":
                all_checks += claims.check_instantaneous(curves, masks, accuracy)
        elif figure in ("6", "7"):  # the profiles of the deeper indentation (the paper's)
            depth = max((c.groups["depth"] for c in curves), default=0.0)
            deep = sorted(
                ((c, r) for c, r in loaded if c.groups["depth"] == depth),
                key=lambda item: item[0].groups["Vz"],
            )
            if not draw.draw_profiles(
                path,
                [(c.groups["Vz"], r) for c, r in deep],
                "surface" if figure == "6" else "pressure",
                0.08 if figure == "6" else 0.04,
            ):
                _remove(path, (".png", ".csv"))
            if figure == "6":
                all_checks += claims.check_separation([(c.groups["Vz"], r) for c, r in deep])
            if figure == "7":
                all_checks += claims.check_annulus([(c, r.series) for c, r in deep])
        elif figure == "9":
            draw.draw_fig9(path, [(c.label(), c) for c in curves])
            all_checks += claims.check_collapse(curves)
        elif figure == "B1":
            panels, series = _convergence(loaded)
            draw.draw_convergence(path, panels)
            all_checks += claims.check_convergence(series, accuracy)
        logger.info(
            f"Fig. {figure}: {path}.png, {path}.csv ({len(loaded)} runs,"
            f" {costs[figure]:.0f} s of runs; drawn in"
            f" {time.perf_counter() - started:.1f} s)"
        )
    for figure in figures:
        write_checks(
            os.path.join(out_dir, f"fig{figure}-checks"),
            [c for c in all_checks if c.figure.rstrip("ab") == figure],
        )
    collect_checks(out_dir)
    for check in all_checks:
        logger.info(check.line())
    return all_checks, costs


def _convergence(loaded):
    """Fig. B1's panels and its convergence series (grid: finest last; time: tau/100 last)."""
    panels, series = {}, {}
    for curve, result in loaded:
        g = curve.groups
        case = f"lambda0 = {g['lambda0']:g}, V_z = {g['Vz']:g}"
        grid, step = _setting(result)
        panels.setdefault(case, []).append((f"{grid}, {step}", curve))
        if step == "adaptive":
            series.setdefault(f"{case}, grid", []).append(
                (f"{grid}", curve, int(result.attrs["nx"]))
            )
        # steps per tau: the adaptive run first, the finest fixed step last (the reference)
        per_tau = 0 if step == "adaptive" else round(result.attrs["time_unit"] / result.attrs["dt"])
        series.setdefault(f"{case}, time on {grid}", []).append((step, curve, per_tau))
    ordered = {}
    for label, runs in series.items():
        runs.sort(key=lambda item: item[2])
        if "time on" in label and runs[-1][2] == 0:
            continue  # a grid without fixed-step runs
        ordered[label] = [(s, c) for s, c, _ in runs]
    for runs in panels.values():
        runs.sort(key=lambda item: item[0])
    return panels, ordered


CHECK_COLUMNS = ("figure", "claim", "supported", "measured", "quantity", "value")


def _write_lines(path, lines):
    write_text(path, "".join(line + "\n" for line in lines))


def _write_table(path, rows):
    write_csv(path, CHECK_COLUMNS, rows)


def write_checks(prefix, checks):
    """PREFIX.txt (one line per check) and PREFIX.csv (one row per number), atomically."""
    _write_lines(prefix + ".txt", [c.line() for c in checks])
    _write_table(
        prefix + ".csv",
        [
            (c.figure, c.claim, c.supported, c.measured, key, value)
            for c in checks
            for key, value in (c.values or {"-": ""}).items()
        ],
    )


def collect_checks(out_dir):
    """checks.txt and checks.csv: every figure's checks in ``out_dir``, in the paper's order
    (a figure drawn alone later replaces only its own)."""
    lines, rows = [], []
    for figure in FIGURES:
        prefix = os.path.join(out_dir, f"fig{figure}-checks")
        if not os.path.exists(prefix + ".txt"):
            continue
        with open(prefix + ".txt") as fh:
            lines += fh.read().splitlines()
        with open(prefix + ".csv", newline="") as fh:
            rows += list(csv.reader(fh))[1:]
    _write_lines(os.path.join(out_dir, "checks.txt"), lines)
    _write_table(os.path.join(out_dir, "checks.csv"), rows)
