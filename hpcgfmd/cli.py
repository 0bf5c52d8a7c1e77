"""Command line: ``python -m hpcgfmd [run|farm|info|plot|paper|bench] ...``, on one rank or under
mpirun/srun.

Exit statuses are those of :mod:`hpcgfmd.errors` (0 finished, 1 failure, 2 bad input with one
line on stderr and nothing written, 75 stopped by SIGTERM/SIGUSR1 after a checkpoint, 130
after SIGINT, with a checkpoint when a run had one to write). With no
command the embedded default case runs into a new time-stamped file.

Every command is called on all ranks of ``comm`` with the same arguments and takes the same
decisions on all of them (inputs and files are the same for all; solver decisions come from
reductions). Messages go through the ``hpcgfmd`` logger (:mod:`hpcgfmd.logs`): rank 0 prints
them, ``--quiet`` keeps only warnings and errors, ``--log FILE`` appends them to a file.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import math
import os
import signal
import sys
import time
from importlib import resources

from . import __version__, logs
from .case import load_case, parse_case
from .errors import (
    EXIT_FAILURE,
    EXIT_OK,
    EXIT_RESUMABLE,
    EXIT_USAGE,
    CaseError,
    CaseFailure,
    Interrupted,
    ResultFileError,
    SweepError,
    UsageError,
)
from .signals import STOP_SIGNALS

logger = logging.getLogger(__name__)


def _run(comm, case, output, overwrite, dry_run, restart=False, stop=None):
    from .runs.resume import prepare_output
    from .runs.single_case import describe, run_case

    logger.info(describe(case))
    if dry_run:
        from .runs.cost import resources_line

        logger.info(resources_line(case, comm.Get_size()))
        return EXIT_OK
    # one writer per output, decided before anything is read or computed (storage/lock.py)
    lock, resume = prepare_output(comm, case, output, overwrite, restart)
    try:
        logger.info(f"{'resuming' if resume else 'writing'} {output} on {comm.Get_size()} rank(s)")
        summary = run_case(case, output, comm, overwrite=overwrite, resume=resume, stop=stop)
    except CaseError as err:  # found by the preload, before the file was created
        raise UsageError(str(err)) from None
    except Interrupted as err:
        logger.info(f"hpcgfmd: {err}; run the same command again to continue")
        return err.status
    finally:
        if lock is not None:
            lock.release()
    logger.info(
        f"finished: {summary['steps']} steps, {summary['iterations']} iterations,"
        f" {summary['wall_time']:.1f} s wall time; results in {output}"
    )
    return EXIT_OK


def cmd_run(comm, args):
    try:
        case = load_case(args.case)
    except CaseError as err:
        raise UsageError(f"{args.case}: {err}") from None
    return _run(comm, case, args.output, args.overwrite, args.dry_run, args.restart, args.stop)


def cmd_default(comm, args):
    """Collective: run the default case (rank 0 names the output for all ranks)."""
    text = resources.files("hpcgfmd").joinpath("default_case.toml").read_text()
    case = parse_case(text)
    # one name for all ranks: rank 0's clock
    output = comm.bcast(time.strftime("hpcgfmd-default-%Y%m%d-%H%M%S.h5"), root=0)
    logger.info(
        "running the embedded default case (paper Fig. 5, V_z = 0.45); case file:\n" + text.strip()
    )
    return _run(comm, case, output, False, False, stop=args.stop)


def _farm_directory(args, sweep):
    if args.output is not None:
        return args.output
    if sweep.output is not None:  # relative to the sweep file, like its base case file
        return os.path.join(os.path.dirname(os.path.abspath(args.sweep)), sweep.output)
    return os.path.splitext(args.sweep)[0]


def cmd_farm(comm, args):
    from .runs.farm import check_farm_directory, plan_table, run_farm
    from .runs.sweep import load_sweep

    try:
        sweep = load_sweep(args.sweep)
    except SweepError as err:
        raise UsageError(f"{args.sweep}: {err}") from None
    out_dir = _farm_directory(args, sweep)
    if args.ranks_per_case is not None:
        ranks, source = args.ranks_per_case, "--ranks-per-case"
    else:
        ranks, source = sweep.ranks_per_case, f"{args.sweep}: [farm] ranks_per_case ="
    size = comm.Get_size()
    if args.case is None and (ranks < 1 or size % ranks):  # --case runs on all ranks
        divisors = [d for d in range(1, size + 1) if size % d == 0]
        raise UsageError(
            f"{source} {ranks}: expected a divisor of the {size} ranks"
            f" ({', '.join(map(str, divisors))})"
        )
    if args.case is not None and not 0 <= args.case < len(sweep.cases):
        raise UsageError(
            f"--case {args.case}: expected 0 to {len(sweep.cases) - 1} (see --dry-run)"
        )
    if os.path.exists(out_dir) and not os.path.isdir(out_dir):
        raise UsageError(f"-o {out_dir}: exists and is not a directory")
    if args.dry_run:
        logger.info(plan_table(sweep, out_dir, size // ranks, ranks))
        return EXIT_OK
    check_farm_directory(comm, out_dir)
    logger.info(f"farm: {len(sweep.cases)} cases in {out_dir}, {size} ranks, {ranks} per case")
    return run_farm(sweep, comm, out_dir, ranks_per_case=ranks, only=args.case, stop=args.stop)


def cmd_info(comm, args):
    from .storage.reader import read_result

    try:
        result = read_result(args.file)  # ResultFileError: one line naming the file
    except ResultFileError as err:
        raise UsageError(str(err)) from None
    s, a = result.series, result.attrs
    print(
        f"file: {args.file} (hpcgfmd {a.get('hpcgfmd_version')}), "
        f"{'finished' if result.finished else 'NOT finished'}"
    )
    print("case:\n  " + str(a.get("config", "")).strip().replace("\n", "\n  "))
    print(
        f"groups: lambda0 = {a['lambda0']:.6g}, lambda_inf = {a['lambda_inf']:.6g},"
        f" k = {a['k']:.6g}, V_z = {a['Vz']:.6g}, chi_ve = {a['chi_ve']:.6g},"
        f" alpha = {a['alpha']:.6g}, w/dx = {a['zone_points']:.3g}"
    )
    if "relaxation_moduli" in a:
        print(
            f"Prony series: E_i/E0 = {a['relaxation_moduli']}, tau_i/tau_r ="
            f" {a['relaxation_times']}"
        )
    if "drive_stiffness" in a:
        print(
            f"compliant drive: k_s / E0 = {a['drive_stiffness']:.6g}"
            + (" (load control)" if a["drive_stiffness"] == 0 else "")
        )
    sphere = s.sphere
    grid = " x ".join(str(n) for n in a["shape"]) if sphere else a["nx"]
    print(
        f"numerics: {'n' if sphere else 'nx'} = {grid}, dt = {a['dt']:.6g},"
        f" tolerance = {a['tolerance']:g}"
    )
    print(f"scales: beta = {a['beta']:.6g}, load scale = {a['load_scale']:.6g}")
    if s.load.size and not s.load.min() < 0.0:
        print("pull-off: none, no tensile load recorded")
    elif s.load.size:
        p = result.pull_off()
        so_far = "" if result.finished else " (the most tensile load so far)"
        names = (
            ("Pbar", "contact radius", "Abar") if sphere else ("Lbar", "contact half-width", "abar")
        )
        print(
            f"pull-off{so_far}: load = {p.load:.6g} ({names[0]} = {p.lbar:.6g}) at {names[1]}"
            f" {p.contact_half_width:.6g} ({names[2]} = {p.abar:.6g}), indenter"
            f" {p.indenter:.6g}, time {p.time:.6g}"
        )
        work = s.work_of_separation()
        if not math.isnan(work):
            # the sphere's scale pi dgamma0 R delta_s = load scale x beta^2 / R (M47)
            scaled = work * a["length_unit"] / (a["load_scale"] * a["beta"] ** 2)
            print(
                f"work of separation{so_far and ' so far'}: {work:.6g}"
                + (f" (in pi dgamma0 R delta_s: {scaled:.6g})" if sphere else "")
            )
    if "protocol_kinds" in a and s.load.size:
        _print_cycles(s, a)
    if result.finished:
        print(
            f"detachment: indenter {a['detachment_indenter']:.6g}, time {a['detachment_time']:.6g}"
        )
        print(
            f"steps: {a['steps']}, iterations: {a['iterations']}"
            f" ({a['iterations'] / max(a['steps'], 1):.1f} per step), FFT pairs:"
            f" {a['fft_pairs']}, wall time: {a['wall_time']:.1f} s"
        )
    elif s.time.size:
        print(f"steps so far: {s.time.size - 1}, iterations: {int(s.iterations.sum())}")
    else:
        print("no step written yet")
    return EXIT_OK


def _print_cycles(series, attrs):
    """info: the protocol's segments, and per cycle its pull-off and the drive's work."""
    print(f"protocol: {', '.join(attrs['protocol_kinds'])}")
    for cycle in series.cycles():
        print(
            f"cycle {cycle.index} (steps {cycle.first}-{cycle.last}): pull-off load"
            f" {cycle.pull_off:.6g} (Lbar = {cycle.lbar:.6g}) at indenter"
            f" {cycle.indenter:.6g}, time {cycle.time:.6g}; work of the drive"
            f" {cycle.work:.6g} (load x length, per unit length: the energy dissipated"
            " when the cycle starts and ends detached)"
        )


def cmd_plot(comm, args):
    from .storage.lock import check_output_path
    from .storage.reader import read_result

    try:
        read_result(args.file)  # the same files as info; a bad one writes no PNG
    except ResultFileError as err:
        raise UsageError(str(err)) from None
    try:
        from .storage.plot import plot_case
    except ImportError as err:
        raise UsageError(f"plot needs matplotlib ({err}); pip install 'hpcgfmd[plot]'") from None
    output = args.output or os.path.splitext(args.file)[0] + ".png"
    check_output_path(output, args.overwrite)
    try:
        plot_case(args.file, output)
    except (OSError, KeyError, ValueError) as err:
        raise UsageError(f"cannot plot {args.file}: {err}") from None
    print(f"wrote {output}")
    return EXIT_OK


def _common_options():
    """--quiet and --log, accepted before or after the command."""
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument(
        "--quiet",
        action="store_true",
        default=argparse.SUPPRESS,
        help="print warnings and errors only",
    )
    common.add_argument(
        "--log",
        metavar="FILE",
        default=argparse.SUPPRESS,
        help="also append the messages with time stamps to FILE",
    )
    return common


def build_parser():
    common = _common_options()
    parser = argparse.ArgumentParser(
        prog="python -m hpcgfmd",
        parents=[common],
        description=(
            "GFMD retraction of an adhesive cylinder from a viscoelastic half-space."
            " Without a command: run the embedded default case."
        ),
    )
    parser.add_argument("--version", action="version", version=f"hpcgfmd {__version__}")
    sub = parser.add_subparsers(dest="command")
    run = sub.add_parser("run", parents=[common], help="run one case file into an HDF5 file")
    run.add_argument("case", help="case file (TOML)")
    run.add_argument(
        "-o",
        "--output",
        default=None,
        help="output HDF5 file (default: the case file's name with .h5)",
    )
    run.add_argument("--overwrite", action="store_true", help="replace an existing output file")
    run.add_argument("--dry-run", action="store_true", help="validate; print cost and memory")
    run.add_argument(
        "--restart",
        action="store_true",
        help=(
            "continue from the checkpoint next to the output file (also automatic when both"
            " exist); any number of ranks"
        ),
    )
    run.set_defaults(func=cmd_run)
    farm = sub.add_parser(
        "farm", parents=[common], help="run every case of a sweep file (task farm)"
    )
    farm.add_argument("sweep", help="sweep file (TOML): base case plus [grid] / [[cases]]")
    farm.add_argument(
        "-o",
        "--output",
        default=None,
        help="directory of the result files and summary (default: [farm] output,"
        " else the sweep file's name)",
    )
    farm.add_argument(
        "--ranks-per-case",
        type=int,
        default=None,
        help="ranks sharing one case (default: [farm] ranks_per_case, else 1)",
    )
    farm.add_argument(
        "--case",
        type=int,
        default=None,
        help="run only this case index (as --dry-run lists them; job arrays)",
    )
    farm.add_argument(
        "--dry-run",
        action="store_true",
        help="list the cases, their groups and estimated cost; run nothing",
    )
    farm.set_defaults(func=cmd_farm)
    info = sub.add_parser("info", parents=[common], help="summarise a result file")
    info.add_argument("file")
    info.set_defaults(func=cmd_info)
    plot = sub.add_parser(
        "plot", parents=[common], help="PNG of the scaled load-area curve (paper Fig. 5a)"
    )
    plot.add_argument("file")
    plot.add_argument("-o", "--output", default=None, help="PNG path (default: file name .png)")
    plot.add_argument("--overwrite", action="store_true", help="replace an existing PNG")
    plot.set_defaults(func=cmd_plot)
    from .paper.command import add_parser as add_paper_parser

    add_paper_parser(sub, common)
    sub.add_parser(
        "bench",
        add_help=False,
        help="the measurements of docs/results.md, one mode per table"
        " (python -m hpcgfmd bench --help)",
    )
    return parser


def _parse(comm, argv):
    """The arguments, parsed on every rank; usage errors and --help print on rank 0 only."""
    if comm.Get_rank() == 0:
        return build_parser().parse_args(argv)
    with (
        open(os.devnull, "w") as quiet,
        contextlib.redirect_stdout(quiet),
        contextlib.redirect_stderr(quiet),
    ):
        return build_parser().parse_args(argv)


def _bench(comm, argv, stop, common):
    """Collective: ``python -m hpcgfmd bench [MODE]`` (its own options; ``common``: --quiet,
    --log)."""
    from .studies.bench import main as bench_main

    # no checkpoints to write: SIGTERM/SIGUSR1 end the benchmark as usual (it keeps the
    # tables of the cases done and the reference runs)
    if stop is not None and stop.received is not None:
        return EXIT_RESUMABLE
    for signum in STOP_SIGNALS:
        signal.signal(signum, signal.SIG_DFL)
    if not _configure_logs(comm, common):
        return EXIT_USAGE
    return bench_main(comm, argv)


def _configure_logs(comm, options):
    """The logger as --quiet and --log ask (``options``: parsed arguments that may hold
    them); False, with a one-line error on rank 0, when the log file cannot be opened."""
    try:
        logs.configure(
            comm.Get_rank(),
            quiet=getattr(options, "quiet", False),
            log_file=getattr(options, "log", None),
        )
    except OSError as err:
        if comm.Get_rank() == 0:
            print(f"hpcgfmd: error: --log {options.log}: {err.strerror}", file=sys.stderr)
        return False
    return True


def main(comm, argv=None, stop=None):
    """Collective entry point on all ranks of ``comm``; returns the exit status.

    ``stop`` is the process's :class:`~hpcgfmd.signals.StopSignals`, if the caller has one.

    Failures that every rank detects alike (bad input, non-convergence) return 2 or 1 on all
    ranks; anything else propagates, and with more than one rank the caller aborts the job.
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    common, rest = _common_options().parse_known_args(argv)
    if rest[:1] == ["bench"]:  # its own modes and options (hpcgfmd.studies.bench)
        return _bench(comm, rest[1:], stop, common)
    args = _parse(comm, argv)
    if not _configure_logs(comm, args):
        return EXIT_USAGE
    if getattr(args, "command", None) == "run" and args.output is None:
        args.output = os.path.splitext(args.case)[0] + ".h5"
    func = getattr(args, "func", cmd_default)
    args.stop = stop
    alike = (CaseFailure, FloatingPointError)
    if comm.Get_size() == 1:  # one process: any runtime failure is reported the same way
        alike += (RuntimeError, MemoryError)
    try:
        if func in (cmd_info, cmd_plot) and comm.Get_size() > 1:
            # serial tools: rank 0 works, the others wait for its status
            status = _serial(func, args) if comm.Get_rank() == 0 else None
            return comm.bcast(status, root=0)
        return func(comm, args)
    except UsageError as err:
        if comm.Get_rank() == 0:
            logger.error(f"error: {err}")
        return EXIT_USAGE
    except alike as err:
        # the output file keeps every step done so far, marked unfinished
        if comm.Get_rank() == 0:
            logger.error(f"failed: {type(err).__name__}: {err}")
        return EXIT_FAILURE


def _serial(func, args):
    from mpi4py import MPI

    try:
        return func(MPI.COMM_SELF, args)
    except UsageError as err:
        logger.error(f"error: {err}")
        return EXIT_USAGE
