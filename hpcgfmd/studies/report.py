"""What every measurement of docs/results.md prints around its table.

Before the table, :func:`header`: the date, the machine (host name, CPU model, cores, load
average) and the code (``git describe --always --dirty`` of the checkout the package runs
from, or "no git checkout", and :func:`code_identity`, a hash of the package's sources that
an installed copy has too). After it, :func:`verdict` for each target the table can judge:
met or missed, and by how much. The targets are :data:`TARGETS`, in one place.

Nothing here imports MPI: ``scripts/bench_scaling.py`` prints a header before it starts
mpirun.
"""

from __future__ import annotations

import datetime
import hashlib
import os
import socket
import subprocess
from dataclasses import dataclass
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Target:
    """A number a measurement must stay within: ``measured <= limit`` (``ceiling``) or
    ``measured >= limit`` (a floor); ``unit`` is printed after the numbers."""

    text: str
    limit: float
    ceiling: bool = True
    unit: str = ""


# The targets of the issues (speed; parallel; the house in order), judged by the commands
# that measure them; docs/results.md states each with its latest verdict.
TARGETS = {
    "case_cpu": Target("CPU time of a paper case at accuracy 5e-3 (no nx)", 5.0, unit=" s"),
    "pull_off": Target("pull-off error against the converged 2^17 value", 5e-3),
    "creeping_steps": Target("steps of (7, 0.045) at accuracy 5e-3", 700),
    "iterations_per_step": Target("CG iterations per step of a paper case at 5e-3", 8.0),
    "default_wall": Target(
        "the default case on 2 ranks (scripts/main.sh), the run's wall time", 15.0, unit=" s"
    ),
    "iteration_pairs": Target("bare FFT-pair times per CG iteration at 2^17", 3.0),
    "two_ranks": Target(
        "2 ranks against 1 per CG iteration at 2^22 and 2^24", 1.6, ceiling=False, unit="x"
    ),
    "knob": Target("validation runs outside their accuracy (pull-off or curve)", 0),
    "relaxed_steps": Target(
        "steps of a nearly relaxed case against its elastic counterpart's", 2.0, unit="x"
    ),
    "farm_ratio": Target("farm of equal cases, time on 2 ranks over time on 1", 1.0 / 1.9),
    "sphere_iteration_pairs": Target(
        "bare 2-D FFT-pair times per CG iteration of the sphere at 512^2 to 2048^2", 3.0
    ),
    "sphere_two_ranks": Target(
        "2 ranks against 1 per CG iteration of the sphere at 2048^2", 1.7, ceiling=False, unit="x"
    ),
    "sphere_case_wall": Target(
        "the documented sphere case on 2 ranks to detachment, wall time", 60.0, unit=" s"
    ),
}


def code_identity() -> str:
    """Hash of the package's Python sources (16 hex digits): a study that caches its runs
    keys them by it too, so that a run made by other code is not reused."""
    digest = hashlib.sha256()
    for path in sorted(PACKAGE.rglob("*.py")):
        digest.update(str(path.relative_to(PACKAGE)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def commit() -> str:
    """``git describe --always --dirty`` of the checkout holding the package, or a note."""
    root = PACKAGE.parent
    if not ((root / ".git").exists() and (root / "pyproject.toml").exists()):
        return "no git checkout"
    try:
        done = subprocess.run(
            ["git", "-C", str(root), "describe", "--always", "--dirty"],
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
            env=child_environment(),
        )
    except (OSError, subprocess.SubprocessError):
        return "git not available"
    return done.stdout.strip() if done.returncode == 0 else "git describe failed"


def machine() -> str:
    """Host name, CPU model and cores of this machine."""
    model = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as fh:
            model = next(
                (line.split(":", 1)[1].strip() for line in fh if line.startswith("model name")),
                model,
            )
    except OSError:
        pass
    return f"{socket.gethostname()} ({model}, {os.cpu_count()} cores)"


def header(title: str) -> str:
    """The lines printed before a table: its title, the date, the machine, the code; an
    empty line after them."""
    now = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    load = " ".join(f"{value:.2f}" for value in os.getloadavg())
    return (
        f"{title}\n"
        f"date {now}; machine {machine()}, load average {load};"
        f" commit {commit()} (code {code_identity()})\n"
    )


def _number(value: float, unit: str) -> str:
    if float(value).is_integer() and abs(value) < 1e7:
        return f"{int(value)}{unit}"
    return f"{value:.3g}{unit}"


def _judged(target: Target, measured: float) -> str:
    """``measured`` against ``target``: met and what is to spare, or missed and by how much."""
    within = measured <= target.limit if target.ceiling else measured >= target.limit
    gap = abs(measured - target.limit)
    if within:
        return f"met, {_number(gap, target.unit)} to spare" if gap else "met"
    if target.limit > 0 and measured > 0:
        factor = measured / target.limit if target.ceiling else target.limit / measured
        return f"MISSED by {factor:.2f}x, {_number(gap, target.unit)} over"
    return f"MISSED, {_number(gap, target.unit)} over"


def verdict(key: str, measured: float | list, subject: str = "") -> str:
    """One line: target ``key`` of :data:`TARGETS` against ``measured`` (of ``subject``),
    or against each ``(subject, measured)`` of a list; met or missed, with the ratio and the
    difference to the limit."""
    target = TARGETS[key]
    bound = "at most" if target.ceiling else "at least"
    items = measured if isinstance(measured, list) else [(subject, measured)]
    judged = "; ".join(
        f"{what + ' ' if what else ''}{_number(value, target.unit)} {_judged(target, value)}"
        for what, value in items
    )
    return f"target {target.text}, {bound} {_number(target.limit, target.unit)}: {judged}"


def no_target(reason: str = "") -> str:
    """The line of a table that judges no target."""
    return "targets: none for this table" + (f" ({reason})" if reason else "")


def child_environment(**extra) -> dict:
    """The environment for a child process (mpirun, a Python run) of a measurement.

    Python's own copy of the environment, without what an MPI launcher set for this process
    (a child mpirun would take itself for a rank of this job), one BLAS thread, OpenMPI
    allowed to run as root; ``extra`` on top.
    """
    env = dict(os.environ)
    if "PMIX_RANK" in env or "OMPI_COMM_WORLD_SIZE" in env:  # this process is a rank
        env = {
            key: value
            for key, value in env.items()
            if not key.startswith(("PMIX_", "PRTE_", "OMPI_"))
            or key.startswith("OMPI_ALLOW_RUN_AS_ROOT")
        }
    env.update(
        OMPI_ALLOW_RUN_AS_ROOT="1",
        OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
        OPENBLAS_NUM_THREADS="1",
        OMP_NUM_THREADS="1",
    )
    env.update(extra)
    return env


def markdown_table(head, rows) -> str:
    """A Markdown table of ``rows`` (sequences of cells) under the column names ``head``."""
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]
    return "\n".join(lines)
