"""When a run writes its checkpoint, and the writing itself (collective over the case's ranks).

A run keeps its whole state (:mod:`.run_state`) in a checkpoint next to its result file every
``[output] checkpoint_interval`` seconds of wall time and/or every ``checkpoint_steps`` steps,
when a rank receives SIGTERM or SIGUSR1, before it stops on a full disk, and after a solve
that failed to converge (the last accepted step). One reduction per step decides for all
ranks: a signal on any rank, rank 0's clock, rank 0's free space.
"""

from __future__ import annotations

import errno
import os
import time

from ..errors import CaseFailure
from ..storage.checkpoint import checkpoint_path, write_checkpoint
from ..storage.space import free_bytes, room_for_a_step


class Checkpoints:
    """The checkpoints of one run (module docstring).

    Parameters
    ----------
    sim : Retraction
        The run.
    path : str
        Its result file (the checkpoint is :func:`~hpcgfmd.storage.checkpoint.checkpoint_path`).
    extra : callable
        ``extra()``: the attributes the caller adds (the snapshot schedule, the snapshots
        written, the wall time so far).
    """

    def __init__(self, sim, path, extra):
        self.sim, self.path, self.extra = sim, path, extra
        self.comm = sim.domain.comm
        self.path_checkpoint = checkpoint_path(path)
        self.every = sim.case.output.checkpoint_steps
        self.interval = sim.case.output.checkpoint_interval
        self.last = time.monotonic()
        # the next step's output and one checkpoint must fit (storage/space.py)
        self.room = room_for_a_step(sim.domain.n, sim.state.field_count())

    def save(self):
        """Collective: write the checkpoint of the run's state now."""
        sim = self.sim
        fields, attrs = sim.state.gather()
        attrs.update(case_identity=sim.case.identity(), **self.extra())
        try:
            write_checkpoint(
                self.path_checkpoint, self.comm, sim.domain.n, sim.domain.x_start, fields, attrs
            )
        except OSError as err:  # alike on every rank: rank 0's free space was broadcast
            if err.errno != errno.ENOSPC:
                raise
            raise CaseFailure(
                f"disk full at step {sim.surface.step_index}: {err.strerror}"
            ) from None
        self.last = time.monotonic()

    def short_of_space(self) -> bool:
        """Rank 0: the file system cannot take another step and a checkpoint."""
        return self.comm.Get_rank() == 0 and free_bytes(self.path) < self.room

    def stop_for_space(self):
        """Collective: checkpoint and stop the run (disk full)."""
        self.save()
        free = free_bytes(self.path) if self.comm.Get_rank() == 0 else 0
        raise CaseFailure(
            f"disk full: {os.path.dirname(os.path.abspath(self.path))} has"
            f" {free} bytes free, a step and a checkpoint need {self.room};"
            f" stopped at step {self.sim.surface.step_index} with checkpoint"
            f" {self.path_checkpoint}: free space and run the same command"
            " again"
        )

    def after_step(self, stop) -> bool:
        """Collective, after every accepted step: checkpoint when it is due, stop on a full
        disk; True when a stop signal was received (the checkpoint is then written)."""
        by_time = self.comm.Get_rank() == 0 and time.monotonic() - self.last >= self.interval
        by_step = self.every > 0 and self.sim.surface.step_index % self.every == 0
        signalled, timed, short = self.sim.domain.maxes(
            float(stop.received is not None), float(by_time), float(self.short_of_space())
        )
        if short:
            self.stop_for_space()
        if signalled or timed or by_step:
            self.save()
        return bool(signalled)
