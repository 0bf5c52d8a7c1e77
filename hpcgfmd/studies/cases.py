"""``python -m hpcgfmd bench cases``: the paper's four cases at the default accuracy.

Each case (lambda0, V_z) at h0/R = 0.1, L/R = 10, alpha = 5e-5, k = 0.1 runs as a user runs
it, ``accuracy`` alone (the grid the knob's), in a process of its own started by this one
(``python -m hpcgfmd bench cases --child ...``: the retraction in memory, no output file), so
that its CPU time is the whole process's, interpreter and imports included, as ``/usr/bin/time``
counts it (user + system, from ``getrusage`` of the finished child). The iterations are split
as the targets count them: all of them over the accepted steps, and of those the preload's,
the rejected and abandoned attempts' and the last step's (the snap-off's solve). The pull-off
error is against the converged 2^17 runs of ``bench speed`` (:data:`REFERENCES`).

Then the embedded default case as ``scripts/main.sh`` runs it, ``mpirun -n 2 python -m
hpcgfmd`` (``--default-ranks``; 0 leaves it out), in a temporary folder, on all the cores:
the run's own wall time as its file records it, and the whole command's CPU time.

The table is followed by the verdicts on the speed targets (:data:`report.TARGETS`). Pin it
to a core to keep other work off it: ``taskset -c 0 python -m hpcgfmd bench cases`` (the
paper's cases inherit the core). Runs on one rank.
"""

from __future__ import annotations

import argparse
import glob
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time

from .. import atomic
from ..case import parse_case
from ..errors import CaseError
from ..model.grid import grid_label
from . import report
from .benchmark import GEOMETRY, case_text

CASES = ("7:4.5", "7:9", "14:0.9", "7:0.045")
# The converged pull-off Lbar on 2^17 nodes (the reference runs of ``bench speed``, their
# settings benchmark.REFERENCE)
REFERENCES = {"7:4.5": -7.88014, "7:9": -8.03998, "14:0.9": -7.83019, "7:0.045": -4.39865}
CREEPING = "7:0.045"


def _value(text):
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def key_values(items):
    """{key: value} of ``key=value`` items (numbers where they parse)."""
    pairs = {}
    for item in items:
        key, equals, value = item.partition("=")
        if not equals or not key:
            raise ValueError(f"{item}: expected key=value")
        pairs[key] = _value(value)
    return pairs


def _parser():
    parser = argparse.ArgumentParser(
        prog="python -m hpcgfmd bench cases",
        description=__doc__.split("\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=__doc__.split("\n\n", 1)[1],
    )
    parser.add_argument(
        "--cases",
        nargs="*",
        default=list(CASES),
        metavar="L:V",
        help="lambda0:V_z pairs, none for the default case alone (default:"
        " the paper's four, " + " ".join(CASES) + ")",
    )
    parser.add_argument(
        "--numerics",
        nargs="+",
        default=[],
        metavar="KEY=VALUE",
        help="[numerics] keys of every case (default: none, accuracy 5e-3)",
    )
    parser.add_argument(
        "--geometry",
        nargs=3,
        type=float,
        metavar=("DEPTH", "CELL", "ALPHA"),
        help="h0/R, L/R, alpha instead of 0.1 10 5e-5 (quick checks only)",
    )
    parser.add_argument(
        "--default-ranks",
        type=int,
        default=2,
        metavar="P",
        help="ranks of the default case's run (default 2, as scripts/main.sh; 0: not run)",
    )
    parser.add_argument("--out", help="also write the printed text to OUT.md")
    parser.add_argument("--child", metavar="L:V", help=argparse.SUPPRESS)
    return parser


def _run_child(comm, key, numerics, geometry):
    """In the child: one retraction in memory; rank 0 prints its counts as one JSON line."""
    from ..runs.protocol import Retraction

    lambda0, vz = (float(v) for v in key.split(":"))
    case = parse_case(case_text(lambda0, vz, numerics, geometry))
    start = time.perf_counter()
    sim = Retraction(case, comm)
    loads = [sim.preload().load]
    accepted = last = 0  # iterations of the accepted solves, and of the last one
    while not sim.detached():
        record = sim.step()
        loads.append(record.load)
        accepted, last = accepted + record.iterations, record.iterations
    result = {
        "nx": case.numerics.nx,
        "steps": sim.surface.step_index,
        "rejected": sim.rejected_steps,
        "iterations": sim.equilibrium.iterations,
        "preload": sim.preload_iterations,
        "attempts": sim.equilibrium.iterations - sim.preload_iterations - accepted,
        "last": last,
        "fft_pairs": sim.fft.pairs,
        "pull_off": min(loads) / case.load_scale,
        "run_s": time.perf_counter() - start,
    }
    sim.close()
    if comm.Get_rank() == 0:
        print("RESULT " + json.dumps(result), flush=True)
    return 0


def _every_core():
    """In a child before it starts: all the machine's cores (mpirun binds its ranks)."""
    os.sched_setaffinity(0, range(os.cpu_count()))


def _measure(command, cwd=None, pinned=True):
    """Run ``command`` (on this process's cores, or on all if not ``pinned``); its finished
    process, its CPU seconds, its wall seconds."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(
        command,
        capture_output=True,
        text=True,
        cwd=cwd,
        check=False,
        env=report.child_environment(),
        preexec_fn=None if pinned else _every_core,
    )
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return done, cpu, wall


def _paper_case(key, args):
    """The row of one case, run in a child process; None and a message on failure."""
    command = [sys.executable, "-m", "hpcgfmd", "bench", "cases", "--child", key]
    if args.numerics:
        command += ["--numerics", *args.numerics]
    if args.geometry:
        command += ["--geometry", *map(str, args.geometry)]
    done, cpu, wall = _measure(command)
    lines = [line for line in done.stdout.splitlines() if line.startswith("RESULT ")]
    if done.returncode != 0 or not lines:
        return None, f"case {key} failed (status {done.returncode}): {done.stderr[-500:]}"
    result = json.loads(lines[-1].removeprefix("RESULT "))
    result.update(cpu_s=cpu, wall_s=wall)
    return result, None


def _default_case(ranks):
    """The embedded default case as scripts/main.sh runs it; (result, None) or (None, error)."""
    from ..storage.reader import read_series

    with tempfile.TemporaryDirectory(prefix="hpcgfmd-bench-") as folder:
        command = [sys.executable, "-m", "hpcgfmd", "--quiet"]
        if ranks > 1:
            command = ["mpirun", "-n", str(ranks), *command]
        done, cpu, wall = _measure(command, cwd=folder, pinned=False)
        files = glob.glob(os.path.join(folder, "*.h5"))
        if done.returncode != 0 or len(files) != 1:
            return None, f"the default case failed (status {done.returncode}): {done.stderr[-500:]}"
        series = read_series(files[0])
        attrs = series.attrs
        return {
            "nx": int(attrs["nx"]) if "nx" in attrs else None,
            "steps": int(attrs["steps"]),
            "iterations": int(attrs["iterations"]),
            "fft_pairs": int(attrs["fft_pairs"]),
            "pull_off": float(series.lbar.min()),
            "run_s": float(attrs["wall_time"]),
            "cpu_s": cpu,
            "wall_s": wall,
        }, None


def _cells(label, r, reference):
    error = abs(r["pull_off"] / reference - 1) if reference else math.nan
    steps = max(r["steps"], 1)
    split = f"{r['preload']}, {r['attempts']}, {r['last']}" if "preload" in r else ""
    return [
        label,
        grid_label(r["nx"]) if r.get("nx") else "",
        r["steps"],
        r.get("rejected", ""),
        f"{r['iterations']} ({r['iterations'] / steps:.2f})",
        split,
        r["fft_pairs"],
        f"{r['cpu_s']:.2f}",
        f"{r['run_s']:.2f}",
        f"{r['pull_off']:.5f}",
        f"{error:.1e}" if reference else "",
    ]


HEAD = (
    "case (lambda0, V_z)",
    "nodes",
    "steps",
    "rejected",
    "iterations (per step)",
    "preload, rejected attempts, last step",
    "FFT pairs",
    "CPU s",
    "run s",
    "pull-off Lbar",
    "error",
)


def main(comm, argv=None):
    """Collective (one rank): the mode's command line; the exit status."""
    parser = _parser()
    try:
        args = parser.parse_args(argv)
        numerics = key_values(args.numerics)
    except SystemExit as exit_:
        return int(exit_.code or 0)
    except ValueError as err:
        print(f"bench cases: --numerics {err}", file=sys.stderr)
        return 2
    geometry = dict(GEOMETRY)
    if args.geometry:
        geometry.update(depth=args.geometry[0], cell=args.geometry[1], adhesion=args.geometry[2])
    for key in [args.child] if args.child else args.cases:
        try:
            lambda0, vz = (float(v) for v in key.split(":"))
            parse_case(case_text(lambda0, vz, numerics, geometry))
        except ValueError as err:  # CaseError included
            detail = err if isinstance(err, CaseError) else "expected lambda0:V_z, e.g. 7:4.5"
            if comm.Get_rank() == 0:
                print(f"bench cases: --cases {key}: {detail}", file=sys.stderr)
            return 2
    if args.child:
        return _run_child(comm, args.child, numerics, geometry)
    if comm.Get_size() > 1:
        if comm.Get_rank() == 0:
            print(
                "bench cases: runs each case in a process of its own; start it on one rank",
                file=sys.stderr,
            )
        return 2
    head = report.header(
        "The paper's four cases at the default accuracy (python -m hpcgfmd bench cases)"
    )
    print(head, flush=True)
    rows, judged, status = [], {}, 0
    paper = not args.geometry
    for key in args.cases:
        result, error = _paper_case(key, args)
        if error:
            print(f"bench cases: {error}", file=sys.stderr)
            status = 1
            continue
        lam, vz = key.split(":")
        subject = f"({lam}, {vz})"
        reference = REFERENCES.get(key) if paper and not numerics else None
        rows.append(_cells(subject, result, reference))
        judged.setdefault("case_cpu", []).append((subject, result["cpu_s"]))
        if reference:
            judged.setdefault("pull_off", []).append(
                (subject, abs(result["pull_off"] / reference - 1))
            )
        judged.setdefault("iterations_per_step", []).append(
            (subject, result["iterations"] / max(result["steps"], 1))
        )
        if key == CREEPING:
            judged.setdefault("creeping_steps", []).append((subject, result["steps"]))
    if args.default_ranks > 0:
        result, error = _default_case(args.default_ranks)
        if error:
            print(f"bench cases: {error}", file=sys.stderr)
            status = 1
        else:
            label = f"default (7, 0.45), {args.default_ranks} rank(s)"
            rows.append(_cells(label, result, None))
            judged["default_wall"] = [(label, result["run_s"])]
    lines = [report.verdict(key, items) for key, items in judged.items()]
    text = (
        report.markdown_table(HEAD, rows) + "\n\n"
        "CPU s: the whole command, all its processes; run s: the run's own wall time (set-up,"
        " preload, retraction)."
        "\n" + "\n".join(lines)
    )
    print(text, flush=True)
    if args.out:
        atomic.write_text(args.out + ".md", f"{head}\n{text}\n")
    return status
