"""Validation of the accuracy knob: achieved errors against converged runs, one table.

For each case (lambda0, k, V_z, h0/R; L/R and alpha shared) the knob is run at each
requested accuracy with everything else left to it (the grid included), and once at a much
finer accuracy that stands for the converged answer, on the grid of the relaxed zone
(:func:`reference_text`). The error of a run is the relative distance of its pull-off load
to the converged one, and the largest distance of its load-area points to the converged
curve (:func:`hpcgfmd.studies.benchmark.curve_error`); both must be at most the requested
accuracy. An elastic case (k = 1) has an exact reference instead: the Baney-Hui load-area
curve of its lambda0 with the periodic cell's factor (docs/model.md (M26), (M29);
:func:`theory_reference`), drawn densely, so its runs are judged against the continuum's
answer and no reference is run. ``--reference-widened`` runs the references on the knob's
own grid at their accuracy (the fast widening included): a tighter-accuracy reference where
the unwidened grid does not fit (lambda0 = 100, k = 0.2: 5x the nodes). The runs are shared
out over the ranks (one run per rank at a time, each on its own communicator); a run is
saved by its case text and the code's identity as the study starts (sources edited meanwhile
do not make it run again), and reused by a later call of the same code.

    mpirun -n 2 python -m hpcgfmd bench accuracy --out docs/figures/accuracy \\
        --cases 1:0.1:1:0.02 3.5:0.2:0.01:0.1 --accuracies 1e-2 5e-3 1e-3

writes PREFIX.csv and PREFIX.md: the table between the header of
:func:`hpcgfmd.studies.report.header` and the verdict on the runs outside their accuracy, as
it prints them.
"""

from __future__ import annotations

import argparse
import csv
import functools
import hashlib
import math
import os
import sys

import numpy as np

from .. import atomic
from ..case import parse_case
from ..case.groups import MIN_CELL_PER_CONTACT
from ..case.numerics import automatic_nx
from ..errors import CaseError
from ..model.grid import grid_label
from . import benchmark, report
from .distance import load_depth_distances

ACCURACIES = (1e-2, 5e-3, 1e-3)
REFERENCE_ACCURACY = 2e-4
CELL_PER_CONTACT = 8.0  # L = 8 sqrt(2 R h0): the periodic images change the load by < 3 %
ALPHA = {"cylinder": 5e-5, "sphere": 1e-3}  # the default adhesion alpha of each geometry
ZONE_PER_CELL = 0.23  # a sphere's preload zone within 0.23 L (a run refuses more than 0.25)
COLUMNS = (
    "lambda0",
    "k",
    "Vz",
    "depth",
    "accuracy",
    "nx",
    "steps",
    "iterations",
    "iterations_per_step",
    "cpu_s",
    "pulloff_Lbar",
    "pulloff_error",
    "curve_error",
    "within",
    "work_per_persson_brener",
    "reference",
)


def case_text(spec, accuracy, cell, alpha, sphere=False):
    """The case file of ``spec`` = (lambda0, k, V_z, h0/R) run at ``accuracy``, a cylinder's
    or (``sphere``) a sphere's; ``cell`` None: :func:`default_cell`."""
    return _text(spec, {"accuracy": accuracy}, cell, alpha, sphere)


def default_cell(spec, alpha, sphere=False):
    """L/R of a study's case ``spec`` = (lambda0, k, V_z, h0/R): the cylinder's
    CELL_PER_CONTACT sqrt(2 h0/R); the sphere's the least cell a case accepts,
    :data:`~hpcgfmd.case.groups.MIN_CELL_PER_CONTACT` sqrt(2 h0/R), or, where that is
    larger, the cell whose relaxed preload's cohesive zone (its outer radius, the elastic
    Maugis-Dugdale sphere's in its cell: :func:`~hpcgfmd.model.sphere_theory.preload_in_cell`)
    reaches ZONE_PER_CELL L, rounded up to 1e-3 R.

    The sphere's grid, set by its zone or its contact, grows as L, its nodes as L^2: its
    cells are the least a run accepts (:data:`~hpcgfmd.runs.single_case.MAX_ZONE_PER_CELL`,
    with a margin). At H0 = h0 / delta_s = 0.565: 4.4-5.6 starting contact radii from
    lambda0 = 7 to 1 (the zone reaches 1.53-1.71 a_s). Runs and references share the cell;
    the exact elastic curve carries its images to the traction's spread (docs/model.md,
    (M59)).
    """
    lambda0, _, _, depth = spec
    if not sphere:
        return round(CELL_PER_CONTACT * math.sqrt(2.0 * depth), 3)
    return _sphere_cell(lambda0, depth, alpha)


@functools.lru_cache(maxsize=256)
def _sphere_cell(lambda0, depth, alpha):
    from ..model import sphere_theory

    scales = sphere_theory.SphereGroups(lambda0, 1.0, 1.0, depth, 1.0, alpha)
    least = MIN_CELL_PER_CONTACT * math.sqrt(2.0 * depth)
    cell = least
    for _ in range(4):  # the zone widens as the cell's images lift it: a fixed point
        _, zone = sphere_theory.preload_in_cell(
            depth / scales.depth_scale, cell / scales.beta, lambda0
        )
        cell = max(least, zone * scales.beta / ZONE_PER_CELL)
    return math.ceil(1e3 * cell) / 1e3


def _text(spec, numerics, cell, alpha, sphere):
    lambda0, k, vz, depth = spec
    if cell is None:
        cell = default_cell(spec, alpha, sphere)
    geometry = {"modulus_ratio": k, "depth": depth, "cell": cell, "adhesion": alpha}
    if sphere:
        geometry = {"geometry": "sphere", **geometry}
    return benchmark.case_text(lambda0, vz, numerics, geometry)


def reference_text(spec, accuracy, cell, alpha, widened=False, sphere=False):
    """:func:`case_text` of the converged reference: the grid of ``accuracy`` without the
    fast retraction's widening (:func:`~hpcgfmd.model.accuracy.fast_widening`), so that a
    reference never shares that rule, which it validates (``widened``: it does); it has the
    contact points (:func:`~hpcgfmd.model.accuracy.contact_points`, a sphere's
    :func:`~hpcgfmd.model.accuracy.sphere_contact_points`) of its own, finer accuracy."""
    text = case_text(spec, accuracy, cell, alpha, sphere)
    if widened:
        return text
    nx = automatic_nx(parse_case(text), accuracy, widen=False)
    return _text(spec, {"accuracy": accuracy, "n" if sphere else "nx": nx}, cell, alpha, sphere)


def theory_reference(spec, cell, alpha, widest):
    """The exact load-area curve of an elastic ``spec`` (k = 1): Baney-Hui's Lbar(abar) of its
    lambda0 times the periodic factor of the cell (docs/model.md (M26), (M29)), drawn at
    4001 widths from ``widest`` (abar) down to a tenth of the load minimum's width. Its
    polyline lies within 1e-6 of the curve; its minimum within 1e-7 of the curve's."""
    from ..model import theory

    lambda0 = spec[0]
    beta = alpha ** (1.0 / 3.0)  # beta / R (R = 1)
    abar = np.linspace(widest, 0.086, 4001)
    lbar = np.array([theory.maugis_dugdale(a, lambda0)[0] for a in abar])
    lbar *= theory.periodic_load_factor(abar * beta, cell)
    return {"abar": abar, "lbar": lbar}


def sphere_reference(result):
    """The exact load-depth curve of an elastic sphere's run ``result`` (k = 1): the
    Maugis-Dugdale sphere of its lambda0 in its cell (docs/model.md (M56), (M59);
    :func:`~hpcgfmd.studies.sphere_check.maugis_dugdale_curve`) from 1.05 times its widest
    contact radius down, at 1201 radii: its chords within 3e-6 of the curve in the curve
    error's scales, its least force within 1e-6 of the curve's."""
    from .sphere_check import maugis_dugdale_curve

    case = result["case"]
    widest = 1.05 * float(result["abar"].max())
    return maugis_dugdale_curve(widest, case.cell / case.beta, case.maugis, points=1201)


def _elastic(spec):
    return spec[1] == 1.0


def _cached(text, comm, folder, identity):
    """The run of ``text``, reused from ``folder`` when the code of ``identity``
    (:func:`~hpcgfmd.studies.benchmark.code_identity`) made it before."""
    key = hashlib.sha256((identity + text).encode()).hexdigest()[:16]
    return benchmark.cached_run(text, comm, os.path.join(folder, key + ".npz"))


def persson_brener_ratio(result):
    """An SLS run's effective work of adhesion at its pull-off over Persson and Brener's at
    its edge speed there (paper Eqs. 8-9; NaN for an elastic solid or a Prony series, and
    where the pull-off comes within the retardation time tau / k of the retraction's start:
    Persson and Brener's crack runs into a relaxed far field, which a solid retracted
    faster than it creeps does not have).

    Ours inverts the JKR relation at the pull-off's (abar, Lbar) (:func:`~hpcgfmd.model.
    theory.effective_work_ratio`); the edge speed is the contact half-width's rate between
    the steps beside the pull-off (:func:`~hpcgfmd.model.theory.peel_velocity`, tau = 1).
    """
    from ..model import sphere_theory, theory

    case = result["case"]
    k = case.modulus_ratio
    lbar, abar, time = result["lbar"], result["abar"], result["time"]
    i = int(np.argmin(lbar))
    if k >= 1.0 or case.relaxation_moduli or not 0 < i < lbar.size - 1:
        return math.nan
    if time[i] - time[0] < 1.0 / k:
        return math.nan
    beta = case.beta if case.sphere else case.adhesion ** (1.0 / 3.0)  # the sphere's a_s
    rate = -(abar[i + 1] - abar[i - 1]) * beta / (time[i + 1] - time[i - 1])
    if case.sphere:  # (M55)'s inversion and (M58)'s edge speed
        speed = sphere_theory.peel_velocity(rate, 1.0, k, case.maugis, beta)
        ours = sphere_theory.effective_work_ratio(*sphere_theory.scaled_curve(abar[i], lbar[i]))
    else:
        speed = theory.peel_velocity(rate, 1.0, k, case.maugis, beta)
        ours = theory.effective_work_ratio(lbar[i] / np.sqrt(abar[i]), np.pi / 4 * abar[i] ** 1.5)
    return float(ours / theory.persson_brener(speed, k))


def curve_error(reference, result):
    """The run's curve error against ``reference``: a cylinder's load-area distance
    (:func:`~hpcgfmd.studies.benchmark.curve_error`), a sphere's load-depth distance
    (:func:`~hpcgfmd.studies.distance.load_depth_distances`), of its points up to its
    pull-off, the largest."""
    if not result["case"].sphere:
        return benchmark.curve_error(reference, result)
    end = int(np.argmin(result["lbar"])) + 1
    distances = load_depth_distances(
        result["dbar"][:end],
        result["lbar"][:end],
        reference["dbar"],
        reference["lbar"],
        reference["abar"],
    )
    return float(distances.max()) if len(distances) else math.nan


def _row(spec, accuracy, result, reference):
    lambda0, k, vz, depth = spec
    pull_off = float(result["lbar"].min())
    converged = float(reference["lbar"].min())
    error = abs(pull_off - converged) / abs(converged)
    curve = curve_error(reference, result)
    return {
        "lambda0": lambda0,
        "k": k,
        "Vz": vz,
        "depth": depth,
        "accuracy": accuracy,
        "nx": result["case"].numerics.nx,
        "steps": int(result["steps"]),
        "iterations": int(result["iterations"]),
        "iterations_per_step": result["iterations"] / max(result["steps"], 1),
        "cpu_s": result["cpu_s"],
        "pulloff_Lbar": pull_off,
        "pulloff_error": error,
        "curve_error": curve,
        "within": bool(error <= accuracy and curve <= accuracy),
        "work_per_persson_brener": persson_brener_ratio(result),
    }


def markdown(rows, sphere=False):
    """The table of docs/results.md ("The accuracy knob"; a sphere's: its grid n, its
    pull-off Pbar)."""
    grid, load = ("n", "Pbar") if sphere else ("nx", "Lbar")
    lines = [
        (
            f"| lambda0 | k | V_z | h0/R | accuracy | {grid} | steps | it/step | CPU s |"
            f" pull-off {load} | pull-off error | curve error | within | work / PB | reference |"
        ),
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['lambda0']:g} | {r['k']:g} | {r['Vz']:g} | {r['depth']:g} |"
            f" {r['accuracy']:g} | {grid_label(int(r['nx']))} | {r['steps']} |"
            f" {r['iterations_per_step']:.1f} | {r['cpu_s']:.1f} |"
            f" {r['pulloff_Lbar']:.5f} | {r['pulloff_error']:.1e} |"
            f" {r['curve_error']:.1e} | {'yes' if r['within'] else 'NO'} |"
            f" {_ratio(r.get('work_per_persson_brener', math.nan))} | {r.get('reference', '')} |"
        )
    return "\n".join(lines) + "\n"


def _ratio(value) -> str:
    return "" if math.isnan(value) else f"{value:.3f}"


def _parser():
    parser = argparse.ArgumentParser(
        prog="python -m hpcgfmd bench accuracy", description=__doc__.split("\n")[0]
    )
    parser.add_argument(
        "--cases",
        nargs="+",
        required=True,
        metavar="L:K:V:H",
        help="lambda0:k:V_z:h0/R, e.g. 3.5:0.2:0.01:0.1",
    )
    parser.add_argument("--accuracies", nargs="+", type=float, default=list(ACCURACIES))
    parser.add_argument(
        "--reference-accuracy",
        type=float,
        default=REFERENCE_ACCURACY,
        help=f"the accuracy of the converged runs (default {REFERENCE_ACCURACY:g})",
    )
    parser.add_argument(
        "--cell",
        type=float,
        help=(
            f"L/R (default {CELL_PER_CONTACT:g} sqrt(2 h0/R), the contact's width 8 times; a"
            f" sphere's the least a run accepts: {MIN_CELL_PER_CONTACT:g} sqrt(2 h0/R), or"
            f" its preload's cohesive zone within {ZONE_PER_CELL:g} L)"
        ),
    )
    parser.add_argument(
        "--alpha",
        type=float,
        help=f"alpha (default {ALPHA['cylinder']:g}; a sphere's {ALPHA['sphere']:g})",
    )
    parser.add_argument(
        "--geometry",
        choices=("cylinder", "sphere"),
        default="cylinder",
        help="the indenter (default cylinder): a sphere's elastic cases are judged against"
        " the Maugis-Dugdale sphere in its cell, its curves in load against depth",
    )
    parser.add_argument(
        "--reference-widened",
        action="store_true",
        help="run the references on the knob's grid, fast widening included",
    )
    parser.add_argument(
        "--out",
        default="accuracy",
        help="prefix of PREFIX.csv, PREFIX.md and the saved runs PREFIX-runs/",
    )
    return parser


def _specs(args):
    """The cases as (lambda0, k, V_z, h0/R) tuples, or a one-line error."""
    specs = []
    for key in args.cases:
        try:
            spec = tuple(float(v) for v in key.split(":"))
        except ValueError:
            spec = ()
        if len(spec) != 4:
            return None, f"--cases {key}: expected lambda0:k:V_z:h0/R, e.g. 3.5:0.2:0.01:0.1"
        for accuracy in (*args.accuracies, args.reference_accuracy):
            try:
                parse_case(_run_text(spec, accuracy, args))
            except CaseError as err:
                return None, f"--cases {key} (accuracy {accuracy:g}): {err}"
        specs.append(spec)
    if not all(args.reference_accuracy < a for a in args.accuracies):
        return None, (
            f"--reference-accuracy {args.reference_accuracy:g}: must be finer than"
            " every --accuracies value"
        )
    return specs, None


def main(comm, argv=None):
    """Collective over ``comm``: the study; 0, or 2 for bad arguments."""
    from mpi4py import MPI

    try:
        args = _parser().parse_args(argv)
    except SystemExit as exit_:
        return int(exit_.code or 0)
    if args.alpha is None:
        args.alpha = ALPHA[args.geometry]
    specs, error = _specs(args)
    if error:
        if comm.Get_rank() == 0:
            print(f"accuracy_study: error: {error}", file=sys.stderr)
        return 2
    folder = f"{args.out}-runs"
    head = (
        report.header("The accuracy knob's validation (python -m hpcgfmd bench accuracy)")
        if comm.Get_rank() == 0
        else ""
    )
    if comm.Get_rank() == 0:
        print(head, flush=True)
        os.makedirs(folder, exist_ok=True)
    # the code's identity once, on one rank: the runs of this study are keyed by the code it
    # started with, even if the sources change while it runs
    identity = comm.bcast(benchmark.code_identity() if comm.Get_rank() == 0 else None, root=0)
    texts = [_reference(spec, args)[0] for spec in specs if not _elastic(spec)]
    texts += [_run_text(s, a, args) for s in specs for a in args.accuracies]
    # references first, so that the ranks share them out too; each run on one rank. A run
    # refused by one rank (a cell too small for its contact) is raised on every rank alike.
    refused = None
    for text in texts[comm.Get_rank() :: comm.Get_size()]:
        try:
            _cached(text, MPI.COMM_SELF, folder, identity)
        except CaseError as err:
            refused = str(err)
            break
    refusals = [r for r in comm.allgather(refused) if r]
    if refusals:
        raise CaseError(refusals[0])
    rows = []
    if comm.Get_rank() == 0:
        for spec in specs:
            for accuracy in args.accuracies:
                rows.append(_judged(spec, accuracy, args, folder, identity))
        benchmark.write_csv(rows, f"{args.out}.csv", COLUMNS)
        table = markdown(rows, args.geometry == "sphere") + "\n".join(verdicts(rows)) + "\n"
        atomic.write_text(f"{args.out}.md", f"{head}\n{table}")
        print(table, end="")
    return 0


def _run_text(spec, accuracy, args):
    return case_text(spec, accuracy, args.cell, args.alpha, args.geometry == "sphere")


def _judged(spec, accuracy, args, folder, identity):
    """The row of ``spec``'s run at ``accuracy`` against its reference (saved runs): an
    elastic case's exact curve (Baney-Hui's, a sphere's Maugis-Dugdale in its cell), else
    the reference run."""
    from mpi4py import MPI

    result = _cached(_run_text(spec, accuracy, args), MPI.COMM_SELF, folder, identity)
    if _elastic(spec) and args.geometry == "sphere":
        reference, source = sphere_reference(result), "Maugis-Dugdale in the cell"
    elif _elastic(spec):
        cell = result["case"].cell
        widest = 1.05 * float(result["abar"].max())
        reference = theory_reference(spec, cell, args.alpha, widest)
        source = "Baney-Hui"
    else:
        text, source = _reference(spec, args)
        reference = _cached(text, MPI.COMM_SELF, folder, identity)
    return dict(_row(spec, accuracy, result, reference), reference=source)


def _reference(spec, args):
    """The reference run's case text and its name in the table."""
    text = reference_text(
        spec,
        args.reference_accuracy,
        args.cell,
        args.alpha,
        args.reference_widened,
        args.geometry == "sphere",
    )
    grid = "knob's grid" if args.reference_widened else "relaxed zone's grid"
    return text, f"run at {args.reference_accuracy:g}, {grid}"


def verdicts(rows):
    """The knob's target on the rows: how many runs are outside their accuracy, and the
    largest share of its accuracy a run's pull-off and curve errors reach."""
    bad = [r for r in rows if not r["within"]]
    share = max(
        (
            error / r["accuracy"]
            for r in rows
            for error in (r["pulloff_error"], r["curve_error"])
            if not math.isnan(error)
        ),
        default=math.nan,
    )
    return [
        (
            f"{len(rows) - len(bad)} of {len(rows)} runs within their accuracy; the largest"
            f" error {share:.2f} of its accuracy"
        ),
        report.verdict("knob", len(bad)),
    ]


def read_rows(path):
    """The rows of PREFIX.csv as numbers (for tests and plots)."""
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    for row in rows:
        for key in COLUMNS:
            if key == "reference":
                continue
            value = row.get(key) or ""  # (a column later tables added is empty in older ones)
            row[key] = value == "True" if key == "within" else float(value) if value else math.nan
    return rows
