"""Grid and time-step convergence: three modes of ``python -m hpcgfmd bench``, each serial.

``bench convergence``: the pull-off load of the paper's cases (lambda0:V_z at k = 0.1,
h0/R = 0.1, L/R = 10, alpha = 5e-5) on the grids ``--nx`` with fixed steps (the indenter
moves dmax/4 per step, the fixed default; solver tolerance 1e-7), and on the grid ``--dt-nx``
with those steps times each ``--dt-factors``; the change at the last refinement of each. A
grid too coarse for a case (less than a point across its zone) is skipped.

``bench grid``: the grid error of the pull-off. Each case LAMBDA0:K:VZ:H0 (L/R = 8
sqrt(2 h0/R), alpha = 5e-5, or a fifth field for L/R) runs with its steps at accuracy 1e-3 on
the smallest powers of two with at least 1, 2, 4, 8 and 16 points across the relaxed zone w
(up to 2^17); a grid's error is its pull-off's distance to the finest one's, relative (the
finest grid's own error is not in the figures: they are lower bounds where convergence is
slow). When a case with k < 1 comes with its elastic counterpart (the same fields, k = 1),
their steps are compared on the grids of at least 8 points across w (target: the nearly
relaxed case within 2x of the elastic one's steps).

``bench time-error``: the time steps' error alone. One case (``key=value`` of [case]) on one
fixed grid ``--nx``, several step settings (``--runs``, each its [numerics] keys joined by
commas) against a reference setting on the same grid (the grid's error cancels): steps, CPU
seconds, the pull-off, its relative error and the curve error.
"""

from __future__ import annotations

import argparse
import math
import sys

from ..case import case_file_text, parse_case
from ..errors import CaseError
from ..model.grid import grid_label
from . import benchmark, report
from .cases import key_values

PAPER = {"modulus_ratio": 0.1, "depth": 0.1, "cell": 10.0, "adhesion": 5e-5}
POINTS = (1, 2, 4, 8, 16)
LARGEST = 2**17
COMPARED_FROM = 8  # points across w from which the nearly relaxed case's steps are compared


def _parse(parser, argv):
    try:
        return parser.parse_args(argv), None
    except SystemExit as exit_:
        return None, int(exit_.code or 0)


def _error(mode, message):
    print(f"bench {mode}: {message}", file=sys.stderr)
    return 2


def _self():
    from mpi4py import MPI

    return MPI.COMM_SELF


def convergence(comm, argv=None):
    """``bench convergence`` (rank 0 runs it); the exit status."""
    parser = argparse.ArgumentParser(
        prog="python -m hpcgfmd bench convergence", description=__doc__.split("\n\n")[1]
    )
    parser.add_argument(
        "--cases", nargs="+", required=True, metavar="L:V", help="lambda0:V_z pairs, e.g. 7:0.45"
    )
    parser.add_argument(
        "--nx",
        type=int,
        nargs="*",
        default=[],
        help="grids run at the fixed default step (may be empty)",
    )
    parser.add_argument(
        "--dt-factors",
        type=float,
        nargs="+",
        default=[],
        help="multiples of the fixed default step run on --dt-nx",
    )
    parser.add_argument(
        "--dt-nx", type=int, help="grid of the --dt-factors runs (default: the largest --nx)"
    )
    args, status = _parse(parser, argv)
    if args is None:
        return status
    if comm.Get_rank() != 0:  # serial: the other ranks have nothing to do
        return 0
    if not args.nx and args.dt_nx is None:
        return _error("convergence", "give --nx or --dt-nx")
    dt_nx = args.dt_nx or max(args.nx)
    runs = [(nx, 1.0) for nx in sorted(args.nx)]
    runs += [(dt_nx, f) for f in args.dt_factors if f != 1.0]
    texts, skipped = _convergence_cases(args.cases, runs)
    if isinstance(texts, int):  # a bad --cases entry: its status
        return texts
    print(
        report.header("Grid and time-step convergence (python -m hpcgfmd bench convergence)"),
        flush=True,
    )
    print("\n".join(skipped), flush=True)
    loads = {}
    for (key, nx, factor), text in texts.items():
        result = benchmark.run(text, _self())
        loads[key, nx, factor] = float(result["lbar"].min())
        print(
            f"  {key} nx {grid_label(nx)} dt x {factor:g}: {result['steps']} steps,"
            f" {result['cpu_s']:.0f} CPU s, pull-off {loads[key, nx, factor]:.5f}",
            flush=True,
        )
    head = [
        "lambda0, V_z",
        *(grid_label(nx) for nx in sorted(args.nx)),
        *(f"dt x {f:g} ({grid_label(dt_nx)})" for f in args.dt_factors if f != 1.0),
        "change at the last refinement",
    ]
    rows = [_convergence_row(key, loads, args, dt_nx) for key in args.cases]
    print(report.markdown_table(head, rows) + "\n\n" + report.no_target(), flush=True)
    return 0


def _convergence_cases(cases, runs):
    """The case files of each lambda0:V_z of ``cases`` at each (nx, dt factor) of ``runs``,
    and the lines of those a grid too coarse for the case left out; (status, None) for a
    bad entry of ``cases``."""
    texts, skipped = {}, []
    for key in cases:
        try:
            lambda0, vz = (float(v) for v in key.split(":"))
        except ValueError:
            return _error("convergence", f"--cases {key}: expected lambda0:V_z, e.g. 7:0.45"), None
        for nx, factor in runs:
            numerics = {"nx": nx, "step_control": "fixed", "tolerance": 1e-7}
            try:
                text = benchmark.case_text(lambda0, vz, numerics, PAPER)
                if factor != 1.0:  # the fixed default step (dmax/4 of travel) times factor
                    case = parse_case(text)
                    numerics["dt"] = factor * case.numerics.dt * case.units.time
                    text = benchmark.case_text(lambda0, vz, numerics, PAPER)
                parse_case(text)
            except CaseError as err:  # a grid too coarse for the case: its cell stays empty
                skipped.append(f"  {key} nx {grid_label(nx)} dt x {factor:g}: skipped, {err}")
                continue
            texts[key, nx, factor] = text
    return texts, skipped


def _convergence_row(key, loads, args, dt_nx):
    """The table row of one lambda0:V_z: its pull-offs and the change at the last
    refinement of the grid and of the step."""

    def cell(nx, factor):
        value = loads.get((key, nx, factor))
        return "" if value is None else f"{value:.4f}"

    cells = [key.replace(":", ", ")]
    cells += [cell(nx, 1.0) for nx in sorted(args.nx)]
    cells += [cell(dt_nx, f) for f in args.dt_factors if f != 1.0]
    changes = []
    grids = [nx for nx in sorted(args.nx) if (key, nx, 1.0) in loads]
    if len(grids) > 1:
        fine, coarse = loads[key, grids[-1], 1.0], loads[key, grids[-2], 1.0]
        changes.append(f"nx {100 * abs(fine / coarse - 1):.2g} %")
    finest = min((f for f in args.dt_factors if f != 1.0), default=None)
    if finest is not None and {(key, dt_nx, 1.0), (key, dt_nx, finest)} <= set(loads):
        change = abs(loads[key, dt_nx, finest] / loads[key, dt_nx, 1.0] - 1)
        changes.append(f"dt {100 * change:.2g} %")
    return cells + [", ".join(changes)]


def _pull_off(groups, nx):
    """(pull-off Lbar, steps, CPU s, cohesive-zone width at the pull-off / w) on nx nodes."""
    import time

    from ..runs.protocol import Retraction

    case = parse_case(case_file_text(groups, {"accuracy": 1e-3, "nx": nx}))
    start = time.process_time()
    sim = Retraction(case, _self())
    records = [sim.preload()]
    while not sim.detached():
        records.append(sim.step())
    sim.close()
    low = min(records, key=lambda r: r.load)
    zone = (low.cohesive_half_width - low.contact_half_width) / case.zone_width
    return low.load / case.load_scale, sim.surface.step_index, time.process_time() - start, zone


def grid_error(comm, argv=None):
    """``bench grid`` (rank 0 runs it); the exit status."""
    parser = argparse.ArgumentParser(
        prog="python -m hpcgfmd bench grid", description=__doc__.split("\n\n")[2]
    )
    parser.add_argument(
        "cases", nargs="+", metavar="L:K:V:H[:CELL]", help="lambda0:k:V_z:h0/R, optionally :L/R"
    )
    args, status = _parse(parser, argv)
    if args is None:
        return status
    if comm.Get_rank() != 0:  # serial: the other ranks have nothing to do
        return 0
    specs = []
    for spec in args.cases:
        try:
            fields = [float(v) for v in spec.split(":")]
            if len(fields) not in (4, 5):
                raise ValueError
            lambda0, k, vz, depth = fields[:4]
            cell = fields[4] if len(fields) > 4 else round(8.0 * math.sqrt(2.0 * depth), 3)
            groups = {
                "maugis": lambda0,
                "modulus_ratio": k,
                "velocity": vz,
                "depth": depth,
                "cell": cell,
                "adhesion": 5e-5,
            }
            case = parse_case(case_file_text(groups, {}))
        except CaseError as err:
            return _error("grid", f"{spec}: {err}")
        except ValueError:
            return _error("grid", f"{spec}: expected lambda0:k:V_z:h0/R[:L/R]")
        specs.append((spec, groups, case))
    print(report.header("Grid error of the pull-off (python -m hpcgfmd bench grid)"), flush=True)
    rows, steps = [], {}
    for spec, groups, case in specs:
        width, cell = case.zone_width, groups["cell"]
        grids = sorted({2 ** max(6, math.ceil(math.log2(p * cell / width))) for p in POINTS})
        runs = [(nx, *_pull_off(groups, nx)) for nx in grids if nx <= LARGEST]
        finest = runs[-1][1]
        cells = [
            f"{width / (cell / nx):.2f}: {abs(load / finest - 1):.1e} ({count}, {cpu:.0f} s,"
            f" z{zone:.1f})"
            for nx, load, count, cpu, zone in runs
        ]
        rows.append(
            [
                spec,
                f"{case.chi_ve / groups['modulus_ratio']:.3g}",
                *cells,
                *[""] * (len(POINTS) - len(cells)),
            ]
        )
        steps[spec] = {round(width / (cell / nx), 2): count for nx, _, count, _, _ in runs}
        print(f"  {spec} done", flush=True)
    head = [
        "case",
        "chi_ve/k",
        *(f"grid {i + 1}: w/dx: error (steps, CPU s, zone/w)" for i in range(len(POINTS))),
    ]
    lines = _relaxed_verdicts(specs, steps)
    print(
        report.markdown_table(head, rows)
        + "\n\n"
        + "\n".join(lines or [report.no_target("no case with its elastic counterpart")]),
        flush=True,
    )
    return 0


def _relaxed_verdicts(specs, steps) -> list:
    """The verdicts of the viscous cases against their elastic counterparts (the same groups
    with k = 1): the largest ratio of their steps on the grids both ran."""
    lines = []
    for spec, groups, _ in specs:
        if groups["modulus_ratio"] >= 1.0:
            continue
        elastic = next(
            (
                s
                for s, g, _ in specs
                if g["modulus_ratio"] == 1.0
                and all(g[k] == groups[k] for k in g if k != "modulus_ratio")
            ),
            None,
        )
        if elastic is None:
            continue
        shared = [p for p in steps[spec] if p in steps[elastic] and p >= COMPARED_FROM]
        if shared:
            ratio = max(steps[spec][p] / steps[elastic][p] for p in shared)
            lines.append(
                report.verdict(
                    "relaxed_steps",
                    ratio,
                    f"{spec} against {elastic} (w/dx {', '.join(f'{p:g}' for p in shared)})",
                )
            )
    return lines


def time_error(comm, argv=None):
    """``bench time-error`` (rank 0 runs it); the exit status."""
    parser = argparse.ArgumentParser(
        prog="python -m hpcgfmd bench time-error", description=__doc__.split("\n\n")[3]
    )
    parser.add_argument("case", nargs="+", help="[case] keys, key=value")
    parser.add_argument("--nx", type=int, required=True)
    parser.add_argument("--reference", nargs="+", required=True, help="numerics key=value")
    parser.add_argument(
        "--runs", nargs="+", required=True, help="one run each: numerics key=value joined by commas"
    )
    args, status = _parse(parser, argv)
    if args is None:
        return status
    if comm.Get_rank() != 0:  # serial: the other ranks have nothing to do
        return 0
    try:
        groups = key_values(args.case)
        reference_keys = key_values(args.reference)
        runs = [(item, key_values(item.split(","))) for item in args.runs]
        texts = [
            case_file_text(groups, {"nx": args.nx, **numerics})
            for numerics in (reference_keys, *(n for _, n in runs))
        ]
        for text in texts:
            parse_case(text)
    except ValueError as err:  # CaseError included
        return _error("time-error", str(err))
    print(
        report.header("The time steps' error on one grid (python -m hpcgfmd bench time-error)"),
        flush=True,
    )
    reference = benchmark.run(texts[0], _self())
    converged = float(reference["lbar"].min())
    rows = [
        [
            f"reference {' '.join(args.reference)}",
            reference["steps"],
            f"{reference['cpu_s']:.1f}",
            f"{converged:.5f}",
            "",
            "",
        ]
    ]
    for (item, _), text in zip(runs, texts[1:]):
        result = benchmark.run(text, _self())
        pull_off = float(result["lbar"].min())
        rows.append(
            [
                item,
                result["steps"],
                f"{result['cpu_s']:.1f}",
                f"{pull_off:.5f}",
                f"{abs(pull_off / converged - 1):.1e}",
                f"{benchmark.curve_error(reference, result):.1e}",
            ]
        )
    print(
        f"{' '.join(args.case)}, nx {grid_label(args.nx)}\n\n"
        + report.markdown_table(
            ("run", "steps", "CPU s", "pull-off Lbar", "pull-off error", "curve error"), rows
        )
        + "\n\n"
        + report.no_target(),
        flush=True,
    )
    return 0
