"""Command line: ``python -m hpcgfmd [run|farm|info|plot] ...``, on one rank or under mpirun/srun.

Exit status: 0 finished, 2 bad input (one line on stderr, nothing written), 1 failure,
75 stopped by SIGTERM/SIGUSR1 after a checkpoint (resumable: run the same command again).
With no arguments the embedded default case runs into a new time-stamped file.

Every command is called on all ranks of ``comm`` with the same arguments and takes the same
decisions on all of them (inputs and files are the same for all; solver decisions come from
reductions); only rank 0 prints.
"""
from __future__ import annotations

import argparse
import contextlib
import os
import signal
import sys
import time
from importlib import resources

from . import __version__
from .config import CaseError, load_case, parse_case
from .driver import CaseFailure
from .signals import STOP_SIGNALS

EXIT_OK, EXIT_FAILURE, EXIT_USAGE, EXIT_RESUMABLE = 0, 1, 2, 75


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


def _printer(comm):
    """print() on rank 0, nothing elsewhere."""
    if comm.Get_rank() == 0:
        return lambda *line: print(*line, flush=True)
    return lambda *line: None


def _resume_wanted(comm, case, output, restart, overwrite):
    """Collective: whether to continue from the checkpoint next to ``output``.

    Rank 0 reads the files and broadcasts its verdict, so every rank decides alike even on a
    file system whose caches differ between nodes.
    """
    verdict = None
    if comm.Get_rank() == 0:
        try:
            verdict = (_check_resume(case, output, restart, overwrite), None)
        except UsageError as err:
            verdict = (False, str(err))
    resume, error = comm.bcast(verdict, root=0)
    if error:
        raise UsageError(error)
    return resume


def _check_resume(case, output, restart, overwrite):
    import h5py

    from .checkpoint import checkpoint_path, read_checkpoint_attrs

    checkpoint = checkpoint_path(output)
    have_output, have_checkpoint = os.path.exists(output), os.path.exists(checkpoint)
    if not restart and (overwrite or not (have_output and have_checkpoint)):
        return False
    if not have_checkpoint:
        raise UsageError(f"--restart: no checkpoint {checkpoint} for -o {output}")
    if not have_output:
        raise UsageError(f"--restart: checkpoint {checkpoint} exists but its output {output}"
                         " does not")
    try:
        saved = read_checkpoint_attrs(checkpoint)
        identity = str(saved["case_identity"])
    except (OSError, KeyError, ValueError) as err:
        raise UsageError(f"{checkpoint}: not an hpcgfmd checkpoint ({err})") from None
    if identity != case.identity():
        raise UsageError(f"{checkpoint}: checkpoint of a different case (identity {identity},"
                         f" this case {case.identity()}); choose another -o or remove it")
    try:
        with h5py.File(output, "r") as f:
            written = (str(f.attrs["case_identity"]), int(f.attrs["steps_complete"]),
                       int(f["snapshots"].attrs["complete"]))
    except (OSError, KeyError) as err:
        raise UsageError(f"-o {output}: not the output of this checkpoint ({err})") from None
    needed = (identity, int(saved["step_index"]) + 1, int(saved["snapshots_written"]))
    if written[0] != needed[0] or written[1] < needed[1] or written[2] < needed[2]:
        raise UsageError(f"-o {output}: does not match checkpoint {checkpoint} (case"
                         f" {written[0]}, {written[1]} steps, {written[2]} snapshots written;"
                         f" the checkpoint needs case {needed[0]}, {needed[1]} steps,"
                         f" {needed[2]} snapshots)")
    return True


def _run(comm, case, output, overwrite, dry_run, restart=False, stop=None):
    from .runner import Interrupted, describe, run_case

    say = _printer(comm)
    say(describe(case))
    if dry_run:
        return EXIT_OK
    resume = _resume_wanted(comm, case, output, restart, overwrite)
    if not resume:
        _check_output_path(output, overwrite)
    say(f"{'resuming' if resume else 'writing'} {output} on {comm.Get_size()} rank(s)")
    try:
        summary = run_case(case, output, comm, printer=say, overwrite=overwrite, resume=resume,
                           stop=stop)
    except CaseError as err:  # found by the preload, before the file was created
        raise UsageError(str(err)) from None
    except Interrupted as err:
        say(f"hpcgfmd: {err}; run the same command again to continue")
        return EXIT_RESUMABLE
    say(f"finished: {summary['steps']} steps, {summary['iterations']} iterations,"
        f" {summary['wall_time']:.1f} s wall time; results in {output}")
    return EXIT_OK


def cmd_run(comm, args):
    try:
        case = load_case(args.case)
    except CaseError as err:
        raise UsageError(f"{args.case}: {err}") from None
    return _run(comm, case, args.output, args.overwrite, args.dry_run, args.restart, args.stop)


def cmd_default(comm, args):
    text = resources.files("hpcgfmd").joinpath("default_case.toml").read_text()
    case = parse_case(text)
    # one name for all ranks: rank 0's clock
    output = comm.bcast(time.strftime("hpcgfmd-default-%Y%m%d-%H%M%S.h5"), root=0)
    say = _printer(comm)
    say("running the embedded default case (paper Fig. 5, V_z = 0.45); case file:")
    say(text.strip())
    return _run(comm, case, output, False, False, stop=args.stop)


def cmd_farm(comm, args):
    from .farm import case_file, file_status, run_farm
    from .sweep import SweepError, load_sweep

    try:
        sweep = load_sweep(args.sweep)
    except SweepError as err:
        raise UsageError(f"{args.sweep}: {err}") from None
    if args.output is not None:
        out_dir = args.output
    elif sweep.output is not None:  # relative to the sweep file, like its base case file
        out_dir = os.path.join(os.path.dirname(os.path.abspath(args.sweep)), sweep.output)
    else:
        out_dir = os.path.splitext(args.sweep)[0]
    if args.ranks_per_case is not None:
        ranks, source = args.ranks_per_case, "--ranks-per-case"
    else:
        ranks, source = sweep.ranks_per_case, f"{args.sweep}: [farm] ranks_per_case ="
    size = comm.Get_size()
    if args.case is None and (ranks < 1 or size % ranks):  # --case runs on all ranks
        divisors = [d for d in range(1, size + 1) if size % d == 0]
        raise UsageError(f"{source} {ranks}: expected a divisor of the {size} ranks"
                         f" ({', '.join(map(str, divisors))})")
    if args.case is not None and not 0 <= args.case < len(sweep.cases):
        raise UsageError(f"--case {args.case}: expected 0 to {len(sweep.cases) - 1}"
                         " (see --dry-run)")
    if os.path.exists(out_dir) and not os.path.isdir(out_dir):
        raise UsageError(f"-o {out_dir}: exists and is not a directory")
    say = _printer(comm)
    if args.dry_run:
        say(_farm_table(sweep, out_dir, comm.Get_size() // ranks, case_file, file_status))
        return EXIT_OK
    say(f"farm: {len(sweep.cases)} cases in {out_dir}, {comm.Get_size()} ranks,"
        f" {ranks} per case")
    # each group's leader prints its own cases' lines
    return run_farm(sweep, comm, out_dir, ranks_per_case=ranks,
                    printer=lambda line: print(line, flush=True), only=args.case,
                    stop=args.stop)


def _farm_table(sweep, out_dir, groups, case_file, file_status):
    """The dry run's listing: each case, its groups, its file's state and its estimated cost."""
    lines = [f"{len(sweep.cases)} cases; outputs in {out_dir}",
             f"{'#':>3}  {'name':<32} {'lambda0':>8} {'k':>6} {'V_z':>8} {'chi_ve':>9}"
             f" {'h0/R':>6} {'nx':>8} {'cost/s':>8}  file"]
    loads = [0.0] * max(groups, 1)
    for item in sorted(sweep.cases, key=lambda c: -c.cost()):
        loads[loads.index(min(loads))] += item.cost()  # longest first onto the freest group
    for item in sweep.cases:
        if item.case is None:
            lines.append(f"{item.index:>3}  {item.name:<32} invalid: {item.error}")
            continue
        g = item.case.groups()
        lines.append(f"{item.index:>3}  {item.name:<32} {g['lambda0']:>8.4g} {g['k']:>6.3g}"
                     f" {g['Vz']:>8.4g} {g['chi_ve']:>9.4g} {g['depth']:>6.3g}"
                     f" {item.case.numerics.nx:>8} {item.cost():>8.3g}"
                     f"  {file_status(case_file(out_dir, item), item)}")
    from .sweep import ITERATIONS_PER_STEP, SECONDS_PER_NODE_ITERATION
    total = sum(c.cost() for c in sweep.cases)
    lines.append(f"estimated cost: {total:.0f} core-seconds (model:"
                 f" {SECONDS_PER_NODE_ITERATION * 2**17 * 1e3:.2g} ms per CG iteration at"
                 f" 2^17 nodes, {ITERATIONS_PER_STEP:g} iterations per step); about {max(loads):.0f} s on"
                 f" {groups} group(s) of ranks, longest first")
    return "\n".join(lines)


def cmd_info(comm, args):
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


def cmd_plot(comm, args):
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


def _serial(func, args):
    from mpi4py import MPI

    try:
        return func(MPI.COMM_SELF, args)
    except UsageError as err:
        print(f"hpcgfmd: error: {err}", file=sys.stderr)
        return EXIT_USAGE


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
    run.add_argument("--restart", action="store_true", help=(
        "continue from the checkpoint next to the output file (also automatic when both"
        " exist); any number of ranks"))
    run.set_defaults(func=cmd_run)
    farm = sub.add_parser("farm", help="run every case of a sweep file (task farm)")
    farm.add_argument("sweep", help="sweep file (TOML): base case plus [grid] / [[cases]]")
    farm.add_argument("-o", "--output", default=None,
                      help="directory of the case files and summary (default: [farm] output,"
                           " else the sweep file's name)")
    farm.add_argument("--ranks-per-case", type=int, default=None,
                      help="ranks sharing one case (default: [farm] ranks_per_case, else 1)")
    farm.add_argument("--case", type=int, default=None,
                      help="run only this case index (as --dry-run lists them; job arrays)")
    farm.add_argument("--dry-run", action="store_true",
                      help="list the cases, their groups and estimated cost; run nothing")
    farm.set_defaults(func=cmd_farm)
    info = sub.add_parser("info", help="summarise a case file's results")
    info.add_argument("file")
    info.set_defaults(func=cmd_info)
    plot = sub.add_parser("plot", help="PNG of the scaled load-area curve (paper Fig. 5a)")
    plot.add_argument("file")
    plot.add_argument("-o", "--output", default=None, help="PNG path (default: file name .png)")
    plot.set_defaults(func=cmd_plot)
    sub.add_parser("bench", add_help=False,
                   help="speed against error of the fast solver and the paper's method"
                        " (python -m hpcgfmd bench --help)")
    return parser


def main(comm, argv=None, stop=None):
    """Entry point on all ranks of ``comm``; returns the exit status.

    ``stop`` is the process's :class:`~hpcgfmd.signals.StopSignals`, if the caller has one.

    Failures that every rank detects alike (bad input, non-convergence) return 2 or 1 on all
    ranks; anything else propagates, and with more than one rank the caller aborts the job.
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["bench"]:  # its own options (hpcgfmd.benchmark)
        from .benchmark import main as bench_main
        # no checkpoints to write: SIGTERM/SIGUSR1 end the benchmark as usual (it keeps the
        # tables of the cases done and the reference runs)
        if stop is not None and stop.received is not None:
            return EXIT_RESUMABLE
        for signum in STOP_SIGNALS:
            signal.signal(signum, signal.SIG_DFL)
        return bench_main(comm, argv[1:])
    if comm.Get_rank() == 0:
        args = build_parser().parse_args(argv)
    else:  # usage errors, --help and --version are printed once, by rank 0
        with open(os.devnull, "w") as quiet, contextlib.redirect_stdout(quiet), \
                contextlib.redirect_stderr(quiet):
            args = build_parser().parse_args(argv)
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
            print(f"hpcgfmd: error: {err}", file=sys.stderr)
        return EXIT_USAGE
    except alike as err:
        # the output file keeps every step done so far, marked unfinished
        if comm.Get_rank() == 0:
            print(f"hpcgfmd: failed: {type(err).__name__}: {err}", file=sys.stderr)
        return EXIT_FAILURE
