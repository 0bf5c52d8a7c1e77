"""Task farm: every case of a sweep, as many at a time as there are rank groups.

Scheduling. The ranks of ``comm`` are split (``comm.Split``) into groups of ``ranks_per_case``
consecutive ranks; each group runs one case at a time on its own communicator (the engine is
the distributed one, so a group of K ranks shares one large grid). Cases are handed out
dynamically, the most expensive first (estimated cost, :mod:`hpcgfmd.runs.cost`): the next
index comes from an atomic counter in an MPI window on rank 0 (``MPI.Win.Fetch_and_op``),
fetched by each group's leader when the group is free and broadcast inside the group. There
is no master rank: every rank computes, and a long case never waits behind short ones.

Progress. After each case that ends (finished, failed or skipped) its group's leader prints
"k of N cases done, ... ETA ..." (:func:`progress_line`): k counts the cases done by all
groups (tallies beside the counter in the same window, ``MPI.Win.Fetch_and_op``), the ETA
is the estimated cost of the cases not done over the groups, times the wall time per
estimated second measured on the cases done so far.

Outputs. ``OUTDIR/<name>.h5`` per case (named from the swept values, see
:mod:`hpcgfmd.runs.sweep`), and ``OUTDIR/summary.csv`` and ``OUTDIR/summary.h5`` with one row per
case, written atomically by rank 0 at the end from the result files themselves (so the table is
complete after a resumed farm, or after the last element of a job array, too).

Faults. A case that fails (invalid parameters, a cell too small, non-convergence, NaN) is
recorded with its error and the farm goes on. Re-running the same command resumes: a case
whose file is marked finished (and belongs to the same case) is skipped, an interrupted one
continues from its checkpoint, any other is started again. SIGTERM or SIGUSR1 makes every
running case checkpoint and stop, and no new case starts; so does SIGINT (Ctrl-C).

Exit status: 0 all cases finished; 75 interrupted by a signal (130 after SIGINT), or cases
left to another process writing them (the same command continues); 100 + N when N cases
failed (capped at 199); 2 for a bad sweep file or command line.
"""

from __future__ import annotations

import contextlib
import fcntl
import logging
import os
import tempfile
import time

import h5py
import numpy as np
from mpi4py import MPI

from ..atomic import replacing, write_csv
from ..errors import (
    EXIT_FAILED_BASE,
    EXIT_INTERRUPTED,
    EXIT_RESUMABLE,
    CaseError,
    CaseFailure,
    Interrupted,
    UsageError,
)
from ..signals import StopSignals
from ..storage.checkpoint import checkpoint_path, usable_checkpoint
from ..storage.lock import acquire_output_lock
from ..storage.reader import read_series
from ..storage.result_file import UNIT_NAMES
from .cost import estimated_memory, model_line
from .progress import duration_text
from .single_case import run_case

logger = logging.getLogger(__name__)
# text whatever the rows hold (an error column with no failure is empty strings, not NaN)
TEXT_COLUMNS = ("name", "status", "error", "file")
SUMMARY_COLUMNS = (
    "index",
    "name",
    "status",
    "error",
    "lambda0",
    "lambda_inf",
    "k",
    "Vz",
    "chi_ve",
    "alpha",
    "depth",
    "cell",
    "nx",
    "pull_off_load",
    "pull_off_lbar",
    "pull_off_contact_half_width",
    "pull_off_abar",
    "detachment_indenter",
    "max_effective_work",
    "steps",
    "wall_time",
    "ranks",
    "file",
)
# the dimension of each numeric summary column (storage.result_file.UNIT_NAMES; None: a number
# of its own, the groups are dimensionless); swept columns keep the sweep file's values
SUMMARY_DIMENSIONS = {
    "pull_off_load": "load",
    "pull_off_contact_half_width": "length",
    "detachment_indenter": "length",
}


def case_file(out_dir, item) -> str:
    """The output file of a case: ``<out_dir>/<name>.h5``, always inside ``out_dir`` (names
    are built from keys and swept values with every character but [A-Za-z0-9.+-_] removed;
    checked again here, so that no value can name a file elsewhere)."""
    name = item.name + ".h5"
    if os.path.basename(name) != name or name.startswith("."):
        raise ValueError(f"case name {item.name!r} would leave the output directory")
    return os.path.join(out_dir, name)


def file_status(path, item) -> str:
    """'new', 'finished', 'resumable', 'unfinished', 'damaged' (checkpoints, none usable) or
    'other case' for a case's output file."""
    if not os.path.exists(path):
        return "new"
    try:
        with h5py.File(path, "r") as f:
            finished = bool(f.attrs.get("finished", False))
            identity = str(f.attrs.get("case_identity", ""))
    except OSError:
        return "unfinished"  # unreadable (killed while being created): written again
    if item.case is None or identity != item.case.identity():
        return "other case"
    if finished:
        return "finished"
    # a checkpoint generation that passes its digest; damaged ones only: refused, as by run
    chosen, problems = usable_checkpoint(checkpoint_path(path))
    return "resumable" if chosen else "damaged" if problems else "unfinished"


def check_farm_directory(comm, out_dir):
    """Collective: the farm's directory exists (made if need be) and takes a file, else one
    UsageError line on every rank, before any case runs."""
    error = None
    if comm.Get_rank() == 0:
        try:
            os.makedirs(out_dir, exist_ok=True)
            fd, probe = tempfile.mkstemp(dir=out_dir, prefix=".write-test-")
            os.close(fd)
            os.remove(probe)
        except OSError as err:
            error = f"-o {out_dir}: cannot write there ({err.strerror})"
    error = comm.bcast(error, root=0)
    if error:
        raise UsageError(error)


def plan_table(sweep, out_dir, groups, ranks_per_case=1):
    """The dry run's listing: each case, its groups, its file's state, its estimated cost
    (single-core seconds) and its memory per rank on ``ranks_per_case`` ranks."""
    width = max([32] + [len(item.name) for item in sweep.cases])
    lines = [
        f"{len(sweep.cases)} cases; outputs in {out_dir}",
        (
            f"{'#':>3}  {'name':<{width}} {'lambda0':>8} {'k':>6} {'V_z':>8} {'chi_ve':>9}"
            f" {'h0/R':>6} {'nx':>8} {'cost/s':>8} {'GB/rank':>7}  file"
        ),
    ]
    costs = [item.cost() for item in sweep.cases]
    loads = [0.0] * max(groups, 1)
    for cost in sorted(costs, reverse=True):
        loads[loads.index(min(loads))] += cost  # longest first onto the freest group
    for item, cost in zip(sweep.cases, costs):
        if item.case is None:
            lines.append(f"{item.index:>3}  {item.name:<{width}} invalid: {item.error}")
            continue
        g = item.case.groups()
        lines.append(
            f"{item.index:>3}  {item.name:<{width}} {g['lambda0']:>8.4g} {g['k']:>6.3g}"
            f" {g['Vz']:>8.4g} {g['chi_ve']:>9.4g} {g['depth']:>6.3g}"
            f" {item.case.numerics.nx:>8} {cost:>8.3g}"
            f" {estimated_memory(item.case, ranks_per_case) / 1e9:>7.3g}"
            f"  {file_status(case_file(out_dir, item), item)}"
        )
    memory = max(
        (estimated_memory(item.case, ranks_per_case) for item in sweep.cases if item.case),
        default=0.0,
    )
    lines.append(
        f"estimated cost: {sum(costs):.3g} core-seconds = {sum(costs) / 3600:.3g} core-hours"
        f" (model: {model_line()}); about {max(loads):.3g} s on {groups} group(s) of"
        f" {ranks_per_case} rank(s), longest first; memory at most {memory / 1e9:.3g} GB per"
        " rank"
    )
    return "\n".join(lines)


# the counter window's slots: the next position of the order, then the tallies of the cases
# done (count, their estimated cost, and of those timed from their start: estimated cost and
# wall seconds; costs and seconds in milliseconds)
NEXT, DONE, DONE_COST, TIMED_COST, TIMED_WALL = range(5)
TALLIES = 4


class _Counter:
    """Dynamic hand-out of ``order``: an atomic next-position counter in a window on rank 0,
    beside the farm's tallies of the cases done (:meth:`report`).

    Built by :meth:`create` (collective); :meth:`next` and :meth:`report` are called by group
    leaders only, each one atomic operation on rank 0's window.
    """

    def __init__(self, comm, order):
        itemsize = MPI.INT64_T.Get_size()
        self.order = order
        self.window = MPI.Win.Allocate(
            (1 + TALLIES) * itemsize if comm.Get_rank() == 0 else 0, itemsize, comm=comm
        )
        if comm.Get_rank() == 0:
            self.window.Lock(0)
            self.window.Put(np.zeros(1 + TALLIES, dtype=np.int64), 0)
            self.window.Unlock(0)
        comm.Barrier()
        self._one = np.ones(1, dtype=np.int64)
        self._value = np.zeros(1, dtype=np.int64)
        self._tallies = np.zeros(TALLIES, dtype=np.int64)
        self.total = len(order)
        self.shared = True

    @classmethod
    def create(cls, comm, order, group_index, n_groups, say):
        """Collective: the window, or a static longest-first split where windows fail."""
        try:
            made = cls(comm, order)
            ok = True
        except MPI.Exception:  # e.g. Open MPI's osc/pt2pt under MPI_THREAD_MULTIPLE
            made, ok = None, False
        if comm.allreduce(ok, op=MPI.LAND):
            return made
        if made is not None:
            made.free()
        say("farm: no MPI window here; cases are split statically (longest first)")
        return _StaticQueue(order, group_index, n_groups)

    def next(self):
        """The next case index, or None when all are handed out; one atomic operation."""
        self.window.Lock(0)
        self.window.Fetch_and_op(self._one, self._value, 0, NEXT, op=MPI.SUM)
        self.window.Unlock(0)
        position = int(self._value[0])
        return self.order[position] if position < len(self.order) else None

    def report(self, cost, wall=None):
        """Add one case done (its estimated ``cost``; ``wall``: its wall seconds when it ran
        from its start, else None) to the farm's tallies; returns them with it:
        (cases done, their estimated cost, estimated cost and wall seconds of the timed)."""
        add = np.array(
            [
                1,
                round(1e3 * cost),
                round(1e3 * cost) if wall is not None else 0,
                round(1e3 * wall) if wall is not None else 0,
            ],
            dtype=np.int64,
        )
        self.window.Lock(0)  # exclusive: the four additions are one atomic update
        for slot in range(TALLIES):
            self.window.Fetch_and_op(
                add[slot : slot + 1], self._tallies[slot : slot + 1], 0, DONE + slot, op=MPI.SUM
            )
        self.window.Unlock(0)
        done, cost_done, timed_cost, timed_wall = (self._tallies + add).tolist()
        return done, 1e-3 * cost_done, 1e-3 * timed_cost, 1e-3 * timed_wall

    def free(self):
        self.window.Free()


class _StaticQueue:
    """Fallback: the longest-first order dealt round-robin to the groups (no messages); the
    tallies are this group's own."""

    def __init__(self, order, group_index, n_groups):
        self.mine = [i for k, i in enumerate(order) if k % n_groups == group_index]
        self.total = len(self.mine)
        self.shared = False
        self.tallies = [0, 0.0, 0.0, 0.0]

    def next(self):
        return self.mine.pop(0) if self.mine else None

    def report(self, cost, wall=None):
        timed = wall is not None
        self.tallies = [
            self.tallies[0] + 1,
            self.tallies[1] + cost,
            self.tallies[2] + (cost if timed else 0.0),
            self.tallies[3] + (wall if timed else 0.0),
        ]
        return tuple(self.tallies)

    def free(self):
        pass


def progress_line(label, noun, done, total, elapsed, cost_left, timed_cost, timed_wall, groups):
    """The farm's line after a case ends: k of N done, the time elapsed and the time left.

    The time left is the estimated cost of the cases not done, ``cost_left`` core-seconds
    (:mod:`hpcgfmd.runs.cost`), shared by the ``groups``, times the ratio of wall seconds to
    estimated cost measured on the cases timed so far (``timed_wall`` / ``timed_cost``: the
    ones run from their start; 1, the model alone, before the first), so it corrects itself.
    """
    measured = timed_cost > 0.0 and timed_wall > 0.0
    ratio = timed_wall / timed_cost if measured else 1.0
    cost_left = max(cost_left, 0.0) if done < total else 0.0
    left = cost_left * ratio / max(groups, 1)
    basis = f"x {ratio:.2f} measured/estimated" if measured else "the estimate alone"
    return (
        f"{label}: {done} of {total} {noun} done, {duration_text(elapsed)} elapsed, ETA"
        f" {duration_text(left)} ({cost_left:.3g} estimated core-s left over {groups}"
        f" group(s), {basis})"
    )


def _run_one(item, out_dir, group, say, stop):
    """Collective on ``group``: run (or resume, or skip) one case; returns its record."""
    path = case_file(out_dir, item)
    record = {
        "index": item.index,
        "name": item.name,
        "file": os.path.basename(path),
        "ranks": group.Get_size(),
        "error": "",
    }
    if item.case is None:
        return _failed(item, record, say, item.error)
    try:  # one writer per result file (storage/lock.py): another farm may be running it
        lock = acquire_output_lock(group, path)
    except UsageError as err:
        # left to its writer: pending here (the summary takes it from the file once finished)
        say(f"[{item.index}] {item.name}: skipped: {err}", logging.WARNING)
        return dict(record, status="pending", error=str(err))
    try:
        return _run_locked(item, path, record, group, say, stop)
    finally:
        if lock is not None:
            lock.release()


def _failed(item, record, say, error):
    """The record of a failed case, its error reported (an error: shown under --quiet too)."""
    say(f"[{item.index}] {item.name}: failed: {error}", logging.ERROR)
    return dict(record, status="failed", error=error)


def _run_locked(item, path, record, group, say, stop):
    """Collective over ``group``: :func:`_run_one` once the result file's lock is held."""
    # one reading of the file system for the whole group (caches may differ between nodes)
    status = group.bcast(file_status(path, item) if group.Get_rank() == 0 else None, root=0)
    if status == "finished":
        say(f"[{item.index}] {item.name}: finished before, skipped")
        return dict(record, status="finished")
    if status == "damaged":
        newest = checkpoint_path(path)
        return _failed(
            item,
            record,
            say,
            f"cannot resume: {newest} and its previous"
            " generation are damaged; remove them to start the case again",
        )
    if status == "other case":
        return _failed(
            item, record, say, f"{path} holds another case; move it away to run this one"
        )
    say(
        f"[{item.index}] {item.name}: {'resuming' if status == 'resumable' else 'starting'}"
        f" on {group.Get_size()} rank(s)"
    )
    alike = (CaseError, CaseFailure, FloatingPointError)
    if group.Get_size() == 1:  # nothing collective to leave hanging: record any error
        alike += (Exception,)
    started = time.monotonic()
    try:
        with _quiet_case():
            summary = run_case(
                item.case,
                path,
                group,
                overwrite=status == "unfinished",
                resume=status == "resumable",
                stop=stop,
            )
    except Interrupted:
        say(f"[{item.index}] {item.name}: interrupted, checkpointed")
        return dict(record, status="interrupted")
    except alike as err:
        return _failed(item, record, say, f"{type(err).__name__}: {err}")
    say(
        f"[{item.index}] {item.name}: finished, {summary['steps']} steps,"
        f" {time.monotonic() - started:.1f} s"
    )
    # a case run from its start measures the cost model (a resumed one ran only its rest)
    return dict(record, status="finished", timed=status != "resumable")


@contextlib.contextmanager
def _quiet_case():
    """The farm reports each case in one line: the case's own progress lines are held back."""
    loggers = [
        logging.getLogger(f"hpcgfmd.runs.{name}") for name in ("single_case", "progress", "watch")
    ]
    levels = [one.level for one in loggers]
    for one in loggers:
        one.setLevel(logging.WARNING)
    try:
        yield
    finally:
        for one, level in zip(loggers, levels):
            one.setLevel(level)


def run_farm(
    sweep, comm, out_dir, ranks_per_case=1, only=None, stop=None, label="farm", noun="cases"
) -> int:
    """Collective: run the cases of ``sweep`` on ``comm``; returns the exit status.

    ``only`` runs just that case index on all of ``comm`` (one element of a job array).
    ``stop``: the process's :class:`StopSignals` (else the farm installs its own).
    ``label`` and ``noun`` name the farm and its cases in the progress lines
    (:func:`progress_line`: "farm: 3 of 12 cases done, ...").
    """
    if stop is None:
        with StopSignals() as own:
            return run_farm(sweep, comm, out_dir, ranks_per_case, only, own, label, noun)
    with stop.listening():  # SIGINT, too, stops the cases cleanly (hpcgfmd.signals)
        status = _farm(sweep, comm, out_dir, ranks_per_case, only, stop, label, noun)
    if status == EXIT_RESUMABLE and comm.allreduce(stop.interrupted, op=MPI.LOR):
        return EXIT_INTERRUPTED
    return status


def _farm(sweep, comm, out_dir, ranks_per_case, only, stop, label, noun) -> int:
    """Collective: the body of :func:`run_farm`, while it listens to the stop signals."""
    started = time.monotonic()
    rank = comm.Get_rank()
    if rank == 0:
        os.makedirs(out_dir, exist_ok=True)
    comm.Barrier()
    costs = [item.cost() for item in sweep.cases]
    if only is not None:
        group, order = comm, [only]
    else:
        group = comm.Split(color=rank // ranks_per_case, key=rank)
        order = sorted(range(len(sweep.cases)), key=lambda i: -costs[i])
    leader = group.Get_rank() == 0

    def say(line, level=logging.INFO):  # each group's leader reports its own cases
        if leader:
            logger.log(level, line, extra={"every_rank": True})

    n_groups = comm.Get_size() // group.Get_size() if only is None else 1
    queue = _Counter.create(comm, order, rank // group.Get_size(), n_groups, say)
    total_cost = sum(costs[i] for i in (order if queue.shared else queue.mine))
    records = []
    while True:
        # a signal between cases: the group agrees, then takes no new case
        if group.allreduce(stop.received is not None, op=MPI.LOR):
            break
        index = queue.next() if leader else None
        index = group.bcast(index, root=0)
        if index is None:
            break
        case_started = time.monotonic()
        record = _run_one(sweep.cases[index], out_dir, group, say, stop)
        if record["status"] == "interrupted":
            if leader:
                records.append(record)
            break
        if leader:
            records.append(record)
            wall = time.monotonic() - case_started if record.get("timed") else None
            done, cost_done, timed_cost, timed_wall = queue.report(costs[index], wall)
            say(
                progress_line(
                    label,
                    noun,
                    done,
                    queue.total,
                    time.monotonic() - started,
                    total_cost - cost_done,
                    timed_cost,
                    timed_wall,
                    n_groups,
                )
                + ("" if queue.shared else "; this group's cases only")
            )
    queue.free()
    status = _summarise(sweep, comm, out_dir, records, order)
    if group is not comm:
        group.Free()
    return status


def _summarise(sweep, comm, out_dir, records, order) -> int:
    """Collective: the summary tables (rank 0 writes them from the result files and the
    groups' records) and the farm's exit status, on every rank."""
    gathered = comm.gather(records, root=0)
    status = 0
    if comm.Get_rank() == 0:
        done = {r["index"]: r for part in gathered for r in part}
        rows = write_summary(sweep, out_dir, done)
        counts = {
            s: sum(r["status"] == s for r in rows)
            for s in ("finished", "failed", "interrupted", "pending")
        }
        logger.info(
            f"farm: {counts['finished']} finished, {counts['failed']} failed,"
            f" {counts['interrupted']} interrupted, {counts['pending']} pending;"
            f" summary in {os.path.join(out_dir, 'summary.csv')}"
        )
        mine = [r for r in rows if r["index"] in set(order)]  # --case: just that one
        failed = sum(r["status"] == "failed" for r in mine)
        if any(r["status"] in ("interrupted", "pending") for r in mine):
            status = EXIT_RESUMABLE  # a signal, or cases another process is writing
        elif failed:
            status = EXIT_FAILED_BASE + min(failed, 99)
    return comm.bcast(status, root=0)


def _case_results(path):
    """Pull-off, detachment and effective work of a finished result file."""
    s = read_series(path)
    i = s.pull_off()
    # Delta gamma_eff from the point (Lbar/sqrt(abar), (pi/4) abar^(3/2)) holds while the
    # contact is JKR-like, up to pull-off; past it abar -> 0 at detachment and x diverges.
    work = s.effective_work()[: np.count_nonzero(s.contact_half_width[: i + 1] > 0)]
    return {
        "pull_off_load": float(s.load[i]),
        "pull_off_lbar": float(s.lbar[i]),
        "pull_off_contact_half_width": float(s.contact_half_width[i]),
        "pull_off_abar": float(s.abar[i]),
        "detachment_indenter": float(s.attrs.get("detachment_indenter", np.nan)),
        "max_effective_work": float(np.max(work)) if work.size else np.nan,
        "steps": int(s.attrs.get("steps", s.time.size - 1)),
        "wall_time": float(s.attrs.get("wall_time", np.nan)),
    }


def summary_rows(sweep, out_dir, records):
    """One row per case: this run's records, completed from the result files on disk."""
    rows = []
    for item in sweep.cases:
        path = case_file(out_dir, item)
        record = records.get(item.index)
        status = record["status"] if record else "pending"
        if status == "pending" and item.case is None:
            status = "failed"
        if status == "pending" and file_status(path, item) == "finished":
            status = "finished"
        row = {
            "index": item.index,
            "name": item.name,
            "status": status,
            "error": (record or {}).get("error", "") or (item.error or ""),
            # empty when the case wrote none (it failed before its first step)
            "file": os.path.basename(path) if os.path.exists(path) else "",
            "ranks": (record or {}).get("ranks", ""),
        }
        row.update({k: v for k, v in item.values.items()})
        if item.case is not None:
            row.update(item.case.groups())
            row["nx"] = item.case.numerics.nx
        if status == "finished":
            row.update(_case_results(path))
        rows.append(row)
    return rows


def write_summary(sweep, out_dir, records):
    """summary.csv and summary.h5 (one row per case of the sweep); returns the rows.

    Elements of a job array (``farm --case``) finish independently and each refreshes the
    whole table from the files on disk, under a lock and each file replaced atomically, so
    the last one to finish leaves the complete summary.
    """
    with open(os.path.join(out_dir, ".summary.lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        rows = summary_rows(sweep, out_dir, records)
        forms = [item.case.form for item in sweep.cases if item.case is not None]
        _write_tables(out_dir, rows, sweep.swept, forms[0] if forms else "case")
    return rows


def _write_tables(out_dir, rows, swept, form):
    """summary.csv and summary.h5, each replaced atomically (:mod:`hpcgfmd.atomic`);
    ``form``: the cases' input form (the units of summary.h5's ``units`` attributes)."""
    names = UNIT_NAMES[form]
    columns = list(SUMMARY_COLUMNS[:4]) + [k for k in swept] + list(SUMMARY_COLUMNS[4:])
    write_csv(os.path.join(out_dir, "summary.csv"), columns, rows)
    with (
        replacing(os.path.join(out_dir, "summary.h5")) as temporary,
        h5py.File(temporary, "w") as f,
    ):
        for column in columns:
            values = [row.get(column, "") for row in rows]
            numbers = [v for v in values if v != ""]
            if column == "index":
                f.create_dataset(column, data=np.asarray(values, dtype=np.int64))
            elif column not in TEXT_COLUMNS and all(
                isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)
                for v in numbers
            ):
                # missing values (a failed case has no pull-off) are NaN: plottable columns
                f.create_dataset(
                    column, data=np.asarray([np.nan if v == "" else v for v in values], dtype=float)
                )
            else:
                f.create_dataset(
                    column,
                    data=np.asarray([str(v) for v in values], dtype=object),
                    dtype=h5py.string_dtype(),
                )
                continue
            f[column].attrs["units"] = (
                "as in the sweep file"
                if column in swept
                else "s"
                if column == "wall_time"
                else names[SUMMARY_DIMENSIONS.get(column)]
            )
        f.attrs["columns"] = columns
