"""The state protocol: each part of a run says what it holds and restores itself from it.

A run (:class:`hpcgfmd.runs.protocol.Retraction`) is made of parts: the surface, the
substrate's history, the contact edges, the predictor, the step control, the history
window, the schedule, the drive. Each part implements :class:`Stateful`: its state as named
arrays (this rank's blocks of grid fields, float64, in node order) and scalars
(rank-independent numbers, booleans, strings or small arrays), and ``restore`` from them.
The run gathers the parts' states without knowing their fields: undoing a rejected step,
writing a checkpoint and restarting on another number of ranks all go through this one
protocol. Counters of work done (iterations, solves) are not state: a part that counts
implements :class:`Counting`, which a checkpoint keeps and an undo leaves alone.

Imports nothing of hpcgfmd: every layer may use it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol


@dataclass
class State:
    """What a part holds.

    Attributes
    ----------
    arrays : dict of str to numpy.ndarray
        This rank's blocks of grid fields (views of the part's own arrays: copy them to keep).
    scalars : dict of str to object
        Rank-independent values: numbers, booleans, strings, small arrays (values, not
        views of mutable state).
    """

    arrays: dict = field(default_factory=dict)
    scalars: dict = field(default_factory=dict)


class Stateful(Protocol):
    """A part of a run: :meth:`state` and :meth:`restore` (module docstring)."""

    def state(self) -> State:
        """The part's state (arrays as views)."""

    def restore(self, state: State) -> None:
        """Continue from ``state`` (copied into the part's own arrays)."""


class Counting(Protocol):
    """A part that counts the work it does (kept by checkpoints, not undone)."""

    def counters(self) -> dict:
        """Integers, rank-independent."""

    def restore_counters(self, counters: dict) -> None:
        """Continue counting from :meth:`counters` of a checkpoint."""
