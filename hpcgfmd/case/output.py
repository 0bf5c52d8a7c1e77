"""The ``[output]`` settings of a case: snapshots, progress lines and checkpoints
(docs/case-file.md, "[output]")."""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import CaseError
from .keys import integer, number, numbers_list, shown, unknown_keys

OUTPUT_KEYS = (
    "snapshot_times",
    "snapshot_contact_widths",
    "snapshot_zero_load",
    "progress_interval",
    "checkpoint_interval",
    "checkpoint_steps",
)
PROGRESS_INTERVAL = 10.0  # wall seconds between progress lines
CHECKPOINT_INTERVAL = 600.0  # wall seconds between checkpoints


@dataclass(frozen=True)
class Output:
    """What is written besides the series (internal units R, tau; intervals in wall seconds).

    Attributes
    ----------
    snapshot_times : tuple of float
        Times at which profiles are written (ascending).
    snapshot_contact_widths : tuple of float
        Contact half-widths at which profiles are written (descending).
    snapshot_zero_load : bool
        A profile where the load first crosses zero.
    progress_interval, checkpoint_interval : float
        Wall seconds between progress lines, and between checkpoints.
    checkpoint_steps : int
        Also a checkpoint every this many steps (0: by wall time only).
    """

    snapshot_times: tuple = ()
    snapshot_contact_widths: tuple = ()
    snapshot_zero_load: bool = False
    progress_interval: float = PROGRESS_INTERVAL
    checkpoint_interval: float = CHECKPOINT_INTERVAL
    checkpoint_steps: int = 0


def resolve_output(table: dict, time_unit: float, length_unit: float) -> Output:
    """``[output]`` keys (case units) -> :class:`Output` (internal units)."""
    unknown_keys(table, "output", OUTPUT_KEYS)
    zero_load = table.get("snapshot_zero_load", False)
    if not isinstance(zero_load, bool):
        raise CaseError(f"[output] snapshot_zero_load = {shown(zero_load)}: expected true or false")
    return Output(
        snapshot_times=numbers_list(table, "output", "snapshot_times", time_unit),
        snapshot_contact_widths=tuple(
            reversed(numbers_list(table, "output", "snapshot_contact_widths", length_unit))
        ),
        snapshot_zero_load=zero_load,
        progress_interval=(
            number(table, "output", "progress_interval")
            if "progress_interval" in table
            else PROGRESS_INTERVAL
        ),
        checkpoint_interval=(
            number(table, "output", "checkpoint_interval")
            if "checkpoint_interval" in table
            else CHECKPOINT_INTERVAL
        ),
        checkpoint_steps=(
            integer(table, "output", "checkpoint_steps", 0) if "checkpoint_steps" in table else 0
        ),
    )
