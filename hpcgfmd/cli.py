"""Command line: ``python -m hpcgfmd [run|info|plot] ...``.

Exit status: 0 finished, 2 bad input (one line on stderr, nothing written), 1 failure.
With no arguments the embedded default case runs into a new time-stamped file.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from importlib import resources

from . import __version__
from .config import CaseError, load_case, parse_case
from .driver import NonConvergenceError

EXIT_OK, EXIT_FAILURE, EXIT_USAGE = 0, 1, 2


class UsageError(Exception):
    """Bad input detected by the command line: one line, exit status 2."""


def _check_output_path(path, overwrite):
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise UsageError(f"-o {path}: directory {directory} does not exist")
    if os.path.isdir(path):
        raise UsageError(f"-o {path}: is a directory; give a file name")
    if os.path.exists(path) and not overwrite:
        raise UsageError(f"-o {path}: file exists; choose another name or pass --overwrite")


def _run(case, output, overwrite, dry_run):
    from .runner import describe, run_case

    print(describe(case), flush=True)
    if dry_run:
        return EXIT_OK
    _check_output_path(output, overwrite)
    print(f"writing {output}", flush=True)
    try:
        summary = run_case(case, output, printer=lambda line: print(line, flush=True),
                           overwrite=overwrite)
    except CaseError as err:  # found by the preload, before the file was created
        raise UsageError(str(err)) from None
    print(f"finished: {summary['steps']} steps, {summary['iterations']} iterations,"
          f" {summary['wall_time']:.1f} s wall time; results in {output}", flush=True)
    return EXIT_OK


def cmd_run(args):
    try:
        case = load_case(args.case)
    except CaseError as err:
        raise UsageError(f"{args.case}: {err}") from None
    return _run(case, args.output, args.overwrite, args.dry_run)


def cmd_default(args):
    text = resources.files("hpcgfmd").joinpath("default_case.toml").read_text()
    case = parse_case(text)
    output = time.strftime("hpcgfmd-default-%Y%m%d-%H%M%S.h5")
    print("running the embedded default case (paper Fig. 5, V_z = 0.45); case file:")
    print(text.strip())
    return _run(case, output, False, False)


def cmd_info(args):
    from .analysis import read_series

    path = args.file
    if not os.path.isfile(path):
        raise UsageError(f"{path}: no such file")
    try:
        s = read_series(path)
    except (OSError, KeyError) as err:
        raise UsageError(f"{path}: not an hpcgfmd case file ({err})") from None
    a = s.attrs
    print(f"file: {path} (hpcgfmd {a.get('hpcgfmd_version')}), "
          f"{'finished' if a.get('finished') else 'NOT finished'}")
    print("case:\n  " + str(a.get("config", "")).strip().replace("\n", "\n  "))
    print(f"groups: lambda0 = {a['lambda0']:.6g}, lambda_inf = {a['lambda_inf']:.6g},"
          f" k = {a['k']:.6g}, V_z = {a['Vz']:.6g}, chi_ve = {a['chi_ve']:.6g},"
          f" alpha = {a['alpha']:.6g}, w/dx = {a['zone_points']:.3g}")
    print(f"numerics: nx = {a['nx']}, dt = {a['dt']:.6g}, tolerance = {a['tolerance']:g}")
    print(f"scales: beta = {a['beta']:.6g}, load scale = {a['load_scale']:.6g}")
    if s.load.size:
        i = s.pull_off()
        print(f"pull-off: load = {s.load[i]:.6g} (Lbar = {s.lbar[i]:.6g}) at contact half-width"
              f" {s.contact_half_width[i]:.6g} (abar = {s.abar[i]:.6g}), indenter"
              f" {s.indenter[i]:.6g}, time {s.time[i]:.6g}")
    if a.get("finished"):
        print(f"detachment: indenter {a['detachment_indenter']:.6g},"
              f" time {a['detachment_time']:.6g}")
        print(f"steps: {a['steps']}, iterations: {a['iterations']}"
              f" ({a['iterations'] / max(a['steps'], 1):.1f} per step), FFT pairs:"
              f" {a['fft_pairs']}, wall time: {a['wall_time']:.1f} s")
    elif s.time.size:
        print(f"steps so far: {s.time.size - 1}, iterations: {int(s.iterations.sum())}")
    else:
        print("no step written yet")
    return EXIT_OK


def cmd_plot(args):
    if not os.path.isfile(args.file):
        raise UsageError(f"{args.file}: no such file")
    try:
        from .plot import plot_case
    except ImportError as err:
        raise UsageError(f"plot needs matplotlib ({err}); pip install 'hpcgfmd[plot]'") from None
    output = args.output or os.path.splitext(args.file)[0] + ".png"
    try:
        plot_case(args.file, output)
    except (OSError, KeyError, ValueError) as err:
        raise UsageError(f"cannot plot {args.file}: {err}") from None
    print(f"wrote {output}")
    return EXIT_OK


def build_parser():
    parser = argparse.ArgumentParser(prog="python -m hpcgfmd", description=(
        "GFMD retraction of an adhesive cylinder from a viscoelastic half-space."
        " Without a command: run the embedded default case."))
    parser.add_argument("--version", action="version", version=f"hpcgfmd {__version__}")
    sub = parser.add_subparsers(dest="command")
    run = sub.add_parser("run", help="run one case file into an HDF5 file")
    run.add_argument("case", help="case file (TOML)")
    run.add_argument("-o", "--output", default=None, help="output HDF5 file (default: case name .h5)")
    run.add_argument("--overwrite", action="store_true", help="replace an existing output file")
    run.add_argument("--dry-run", action="store_true", help="validate and print the groups only")
    run.set_defaults(func=cmd_run)
    info = sub.add_parser("info", help="summarise a case file's results")
    info.add_argument("file")
    info.set_defaults(func=cmd_info)
    plot = sub.add_parser("plot", help="PNG of the scaled load-area curve (paper Fig. 5a)")
    plot.add_argument("file")
    plot.add_argument("-o", "--output", default=None, help="PNG path (default: file name .png)")
    plot.set_defaults(func=cmd_plot)
    return parser


def main(argv=None):
    """Entry point; returns the exit status."""
    args = build_parser().parse_args(argv)
    if getattr(args, "command", None) == "run" and args.output is None:
        args.output = os.path.splitext(args.case)[0] + ".h5"
    func = getattr(args, "func", cmd_default)
    try:
        return func(args)
    except UsageError as err:
        print(f"hpcgfmd: error: {err}", file=sys.stderr)
        return EXIT_USAGE
    except (NonConvergenceError, FloatingPointError, RuntimeError, MemoryError) as err:
        # the output file keeps every step done so far, marked unfinished
        print(f"hpcgfmd: failed: {type(err).__name__}: {err}", file=sys.stderr)
        return EXIT_FAILURE
