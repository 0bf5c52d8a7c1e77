"""One case from a validated :class:`~hpcgfmd.case.Case` to a finished HDF5 file.

Collective over the case's communicator. A run survives the end of a job's allocation:
the full state is checkpointed (:mod:`hpcgfmd.storage.checkpoint`) every ``[output]
checkpoint_interval`` seconds of wall time and/or every ``checkpoint_steps`` steps, and when
the process receives SIGTERM or SIGUSR1 (what SLURM sends before the time limit) or SIGINT,
after which the run stops with :class:`~hpcgfmd.errors.Interrupted` (exit status 75, 130 after
SIGINT). ``resume=True``
continues from the checkpoint on any number of ranks, appending to the same output file.
Progress goes to the ``hpcgfmd`` logger (:mod:`hpcgfmd.logs`).
"""

from __future__ import annotations

import json
import logging
import math
import os
import time

import numpy as np
from mpi4py import MPI

from ..case import Case
from ..errors import (
    EXIT_INTERRUPTED,
    EXIT_RESUMABLE,
    CaseError,
    CaseFailure,
    Interrupted,
    NonConvergenceError,
)
from ..model import accuracy as knob
from ..signals import StopSignals
from ..solvers import solver_class
from ..storage.checkpoint import (
    checkpoint_path,
    read_checkpoint,
    remove_checkpoint,
    usable_checkpoint,
)
from ..storage.result_file import ResultFile
from ..storage.space import free_bytes, room_for_a_step
from .checkpoints import Checkpoints
from .cost import estimated_memory
from .progress import Progress
from .protocol import Retraction
from .watch import StopRequested, Watch

logger = logging.getLogger(__name__)

# The indenter must have left the surface long before it is one radius above it.
MAX_INDENTER_HEIGHT = 1.0
# After the preload the cohesive zone must stay within a quarter of the cell: beyond that the
# periodic images change the load by more than about 10 % (docs/model.md (M29)).
MAX_ZONE_PER_CELL = 0.25


class SnapshotSchedule:
    """Decides at which steps full profiles are written (``[output]`` of the case)."""

    def __init__(self, output):
        self.times = list(output.snapshot_times)
        self.widths = list(output.snapshot_contact_widths)  # descending
        self.zero_load = output.snapshot_zero_load

    def due(self, record) -> bool:
        """True (once per trigger) when a requested time, width or zero load is reached."""
        hit = False
        while self.times and record.time >= self.times[0]:
            self.times.pop(0)
            hit = True
        while self.widths and record.contact_half_width <= self.widths[0]:
            self.widths.pop(0)
            hit = True
        if self.zero_load and record.time > 0 and record.load <= 0.0:
            self.zero_load = False
            hit = True
        return hit

    def state(self) -> str:
        return json.dumps({"times": self.times, "widths": self.widths, "zero_load": self.zero_load})

    def restore(self, text):
        saved = json.loads(text)
        self.times, self.widths, self.zero_load = (
            saved["times"],
            saved["widths"],
            saved["zero_load"],
        )


def describe(case: Case) -> str:
    """The derived groups and numerics, printed at start."""
    g = case.groups()
    u = case.units
    num = case.numerics
    contact = (
        f"{knob.sphere_contact_points(num.accuracy):.3g} across sqrt(R h0)"
        if case.sphere
        else f"{knob.contact_points(num.accuracy):.3g} across sqrt(2 R h0)"
    )
    auto = (
        f" (from accuracy {num.accuracy:g}: the smallest f 2^a, f in {{1, 3, 9}}, with"
        f" {knob.zone_points(num.accuracy, case.chi_ve, case.modulus_ratio, case.maugis):.2g}"
        f" points across w and {contact})"
        if num.nx_automatic
        else ""
    )
    if num.step_control == "fixed":
        steps = "fixed steps dt"
    else:
        steps = (
            f"adaptive steps from dt in [{num.dt_min * u.time:.4g},"
            f" {num.dt_max * u.time:.4g}], edge motion <= {num.edge_fraction:.3g} w,"
            f" load deviation <= {num.load_tolerance:.3g}, history error <="
            f" {num.time_tolerance:.3g} load scales"
        )
    material = (
        [
            f"Prony series: E_i/E0 = {_numbers(g['relaxation_moduli'])}, tau_i/tau_r ="
            f" {_numbers(g['relaxation_times'])}; V_z and chi_ve with tau_r ="
            f" {u.time:.6g}"
        ]
        if case.relaxation_moduli
        else []
    )
    if case.compliant:
        material.append(
            f"compliant drive: the indenter on a spring of k_s ="
            f" {case.drive_stiffness * u.stress:.6g} per unit length"
            f" (k_s / E0 = {case.drive_stiffness:.6g})"
        )
    return "\n".join(
        [
            f"lambda0 = {g['lambda0']:.6g}   lambda_inf = {g['lambda_inf']:.6g}   k = {g['k']:.6g}"
            f"   V_z = {g['Vz']:.6g}   chi_ve = {g['chi_ve']:.6g}   alpha = {g['alpha']:.6g}",
            *material,
            f"h0/R = {g['depth']:.6g}   L/R = {g['cell']:.6g}   beta = {case.beta * u.length:.6g}"
            f"   load scale = {case.load_scale * case.load_unit:.6g}"
            f"   w/dx = {g['zone_points']:.3g}",
            f"{'n' if case.sphere else 'nx'} = {num.nx}{auto}   dt = {num.dt * u.time:.6g}"
            f"   tolerance = {num.tolerance:g}"
            f"   accuracy = {num.accuracy:g}",
            f"solver: {solver_class(num.solver).describe(num)}; {steps}",
        ]
    )


def _numbers(values) -> str:
    return "[" + ", ".join(f"{v:.6g}" for v in values) + "]"


def run_case(
    case: Case, path, comm, overwrite=False, resume=False, planner_effort="FFTW_MEASURE", stop=None
) -> dict:
    """Collective: run (or resume) the retraction of ``case`` into the HDF5 file ``path``.

    A new run solves the preload before the file is created: a contact too large for the
    cell is reported as a :class:`CaseError` with no file touched; ``overwrite`` replaces an
    existing file (only once the preload succeeded). ``resume`` continues from the
    checkpoint next to ``path`` (the caller checked that it belongs to this case).
    Returns the summary stored in the file; raises :class:`Interrupted` after a signal.
    ``stop`` is the caller's :class:`StopSignals` (the farm's, shared by its cases); without
    one, the run installs its own from the start, so a signal during the set-up counts too.
    The run looks at the signals in every phase (:mod:`.watch`): planning, the preload, a
    step's solve, the output; it stops within a fraction of a second of a solve's iteration,
    with the last accepted step's checkpoint when there is one.
    """
    if stop is None:
        with StopSignals() as own:
            return run_case(case, path, comm, overwrite, resume, planner_effort, own)
    with stop.listening():
        start = time.monotonic()
        check_memory(case, comm)
        watch = Watch(stop, case.output.progress_interval)
        sim = Retraction(case, comm, planner_effort=planner_effort, watch=watch)
        # Free the transform's shared-memory window (collective) when every rank stops
        # alike; on any other error the job aborts and a collective here would hang.
        try:
            watch.check(comm)  # a signal while the transforms were planned
            summary = _run(sim, case, path, comm, overwrite, resume, stop, start)
        except StopRequested as err:
            sim.close()
            raise Interrupted(
                f"stopped by a signal during the {err}; nothing was written", _status(stop, comm)
            ) from None
        except (CaseError, CaseFailure, FloatingPointError, Interrupted):
            sim.close()
            raise
        sim.close()
        return summary


def check_memory(case, comm):
    """Collective: CaseError, before anything is allocated, when the ranks of ``comm`` on
    this node would need more memory than it has (the estimate of
    :func:`~.cost.estimated_memory`)."""
    node = comm.Split_type(MPI.COMM_TYPE_SHARED)
    sharing = node.Get_size()
    node.Free()
    per_rank = estimated_memory(case, comm.Get_size())
    memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    if per_rank * sharing > memory:
        nx = case.numerics.nx
        automatic = " (automatic)" if case.numerics.nx_automatic else ""
        ranks = math.ceil(per_rank * comm.Get_size() / memory)
        key = "n" if case.sphere else "nx"
        raise CaseError(
            f"[numerics] {key} = {nx}{automatic}: needs about {per_rank / 2**30:.3g} GiB per rank"
            f" on {comm.Get_size()} rank(s), {per_rank * sharing / 2**30:.3g} GiB for the"
            f" {sharing} on this node, more than its {memory / 2**30:.3g} GiB; run on more"
            f" nodes (at least {ranks} rank(s) on nodes like this one, one per node)"
        )


def _status(stop, comm) -> int:
    """Collective: the exit status of a stop, alike on every rank: 130 when any rank
    received SIGINT, else 75."""
    return EXIT_INTERRUPTED if comm.allreduce(stop.interrupted, op=MPI.LOR) else EXIT_RESUMABLE


def _open_output(sim, case, path, comm, overwrite, resume, stop, schedule):
    """Collective: the result file to append to and the run's bookkeeping before the first step.

    Resuming: the checkpoint's state and the file cut back to it. New: the preload, checked
    against the cell, then a new file with the t = 0 entry. Returns (file, snapshots written,
    wall seconds spent before this run).
    """
    dom = sim.domain
    checkpoint = checkpoint_path(path)
    if resume:
        checkpoint = _resume_from(checkpoint, resume, comm)
        fields, attrs = read_checkpoint(checkpoint, comm, dom.x_start, dom.x_stop)
        sim.state.restore(fields, attrs)
        schedule.restore(attrs["snapshot_schedule"])
        snapshots = int(attrs["snapshots_written"])
        if dom.max(float(stop.received is not None)):  # the checkpoint is still the latest
            raise Interrupted(
                f"stopped by a signal while resuming; checkpoint {checkpoint}", _status(stop, comm)
            )
        try:
            out = ResultFile.reopen(
                path, case, dom, comm, steps=sim.surface.step_index + 1, snapshots=snapshots
            )
        except (ValueError, KeyError) as err:  # alike on every rank: the same file
            raise CaseError(f"{path} does not match its checkpoint {checkpoint}: {err}") from None
        logger.info(
            f"resuming from {checkpoint} at step {sim.surface.step_index}"
            f" (t = {sim.surface.time * case.units.time:.6g}) on {comm.Get_size()}"
            " rank(s)"
        )
        return out, snapshots, float(attrs["wall_time"])
    room = room_for_a_step(sim.domain.n, sim.state.field_count())
    free = comm.bcast(free_bytes(path) if comm.Get_rank() == 0 else None, root=0)
    if free < 2 * room:  # the new file, its first steps and a checkpoint (storage/space.py)
        raise CaseError(
            f"-o {path}: {free} bytes free on its file system, at least {2 * room} needed to start"
        )
    record = sim.preload()
    check_zone_in_cell(case, record)
    if dom.max(float(stop.received is not None)):
        raise Interrupted(
            "stopped by a signal before the first step; nothing was written", _status(stop, comm)
        )
    remove_checkpoint(checkpoint, comm)  # a stale one would pair with the new file
    out = ResultFile(path, case, dom, comm, overwrite=overwrite)
    out.append_step(record.as_dict())
    out.add_snapshot(record.time, sim.surface.u, sim.surface.traction, sim.equilibrium.gap())
    schedule.due(record)
    return out, 1, 0.0


def check_zone_in_cell(case, record):
    """Raise CaseError when the preload's cohesive zone reaches beyond MAX_ZONE_PER_CELL of
    the cell (beyond it the periodic images change the load by more than about 10 %, docs/
    model.md (M29)). ``record``: the preload's, whose a_a is the same on every rank, so every
    rank raises alike."""
    if record.cohesive_half_width > MAX_ZONE_PER_CELL * case.cell:
        need = record.cohesive_half_width / MAX_ZONE_PER_CELL
        raise CaseError(
            f"{case.cell_key()} = {case.cell * case.units.length:g}: too small"
            f" for the contact; after the preload the cohesive zone reaches"
            f" a_a = {record.cohesive_half_width * case.units.length:.4g}, more"
            f" than {MAX_ZONE_PER_CELL:g} L; need L >="
            f" {need * case.units.length:.4g}"
        )


def _resume_from(newest, resume, comm):
    """Collective: the checkpoint generation to read (``resume`` itself when it is a path,
    else the newest usable one, rank 0 deciding); a damaged newest one passed over is
    renamed ``<name>.corrupt``, so that the next checkpoint does not push the good previous
    generation out."""

    def choose():
        if isinstance(resume, str):  # chosen (and reported) by the caller
            chosen = resume
        else:
            chosen, problems = usable_checkpoint(newest)
            if chosen is None:
                return None, f"cannot resume: {'; '.join(problems) or f'no checkpoint {newest}'}"
            if problems:
                logger.warning(f"{problems[0]}; resuming from the previous checkpoint {chosen}")
        if chosen != newest and os.path.exists(newest):
            os.replace(newest, newest + ".corrupt")
        return chosen, None

    chosen, error = comm.bcast(choose() if comm.Get_rank() == 0 else None, root=0)
    if error:
        raise CaseError(error)
    return chosen


def _run(sim, case, path, comm, overwrite, resume, stop, start):
    """Collective: the body of :func:`run_case` on a built :class:`Retraction`."""
    schedule = SnapshotSchedule(case.output)
    out, snapshots, wall_before = _open_output(
        sim, case, path, comm, overwrite, resume, stop, schedule
    )
    written = [snapshots]
    keeper = Checkpoints(
        sim,
        path,
        lambda: {
            "snapshot_schedule": schedule.state(),
            "snapshots_written": written[0],
            "wall_time": wall_before + time.monotonic() - start,
        },
    )
    surface = sim.surface
    try:
        progress = Progress(case.output.progress_interval, case.units, case)
        if comm.bcast(keeper.short_of_space(), root=0):
            keeper.stop_for_space()
        while not sim.finished():
            try:
                record = sim.step()
            except StopRequested as err:  # (alike on every rank: the flag was reduced)
                keeper.save()  # the last accepted step (Retraction.step undid this one)
                raise Interrupted(
                    f"stopped by a signal during the {err}; checkpoint"
                    f" {keeper.path_checkpoint} holds step {surface.step_index}"
                    f" (t = {surface.time * case.units.time:.6g})",
                    _status(stop, comm),
                ) from None
            except NonConvergenceError as err:  # (alike on every rank: a reduced residual)
                keeper.save()  # the last accepted step (Retraction.step undid the failed one)
                raise NonConvergenceError(
                    f"{err}; checkpoint {keeper.path_checkpoint} holds"
                    f" the last accepted step, {surface.step_index}"
                ) from None
            out.append_step(record.as_dict())
            if schedule.due(record):
                out.add_snapshot(record.time, surface.u, surface.traction, sim.equilibrium.gap())
                written[0] += 1
            progress.update(surface.step_index, record)
            if surface.indenter > MAX_INDENTER_HEIGHT and not sim.finished():
                raise CaseFailure(f"no complete detachment by u_z = {MAX_INDENTER_HEIGHT} R")
            if keeper.after_step(stop):
                raise Interrupted(
                    f"stopped by a signal at step {surface.step_index}"
                    f" (t = {surface.time * case.units.time:.6g});"
                    f" checkpoint {keeper.path_checkpoint}",
                    _status(stop, comm),
                )
        out.add_snapshot(surface.time, surface.u, surface.traction, sim.equilibrium.gap())
        summary = {
            **sim.summary(),
            "wall_time": wall_before + time.monotonic() - start,
            "ranks": comm.Get_size(),
            "detachment_indenter": surface.indenter * case.units.length,
            "detachment_time": surface.time * case.units.time,
        }
        out.finish(summary)
    finally:
        out.close()
    remove_checkpoint(keeper.path_checkpoint, comm)
    if case.numerics.step_control == "fixed" and comm.Get_rank() == 0:
        try:  # advice only: a finished case stays finished whatever reading it back does
            _warn_unresolved_pull_off(case, path)
        except Exception as err:  # noqa: BLE001 (rank 0 alone: nothing may escape)
            logger.debug(f"{path}: the pull-off's resolution not checked ({err})")
    return summary


def _warn_unresolved_pull_off(case, path):
    """Rank 0, fixed steps: a warning when a contact edge moved farther in one step, up to
    the pull-off and within its protocol segment, than the accuracy's edge allowance
    (``edge_fraction`` relaxed zone widths, which adaptive steps keep): the steps did not
    resolve the pull-off, and its load may be off by more than the accuracy (a step from the
    preload straight to detachment records no tensile load at all). The jumps of an approach
    into contact or of an earlier cycle's snap-off are not the pull-off's."""
    from ..storage.reader import read_series

    series = read_series(path)
    if series.load.size < 2:
        return
    last = int(series.pull_off())  # the step of the most tensile load
    first = 0
    if series.segment is not None:  # the steps of the pull-off's segment, and the one before
        first = max(
            int(np.flatnonzero(series.segment[: last + 1] != series.segment[last]).max(initial=-1)),
            0,
        )
    widths = series.contact_half_width[first : last + 1] / case.units.length
    moved = float(abs(widths[1:] - widths[:-1]).max(initial=0.0)) / case.zone_width
    allowance = case.numerics.edge_fraction
    if moved > allowance:
        # from this case's rank 0, whichever rank of the job it is (a farm's group leader)
        logger.warning(
            f"{path}: fixed steps: a contact edge moved {moved:.3g} cohesive-zone"
            f" widths in one step before the pull-off, the accuracy allows"
            f" {allowance:.3g}; the pull-off may be off by more than the accuracy:"
            " choose a smaller dt, or adaptive steps",
            extra={"every_rank": True},
        )
