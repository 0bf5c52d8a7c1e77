"""A run's state gathered from its parts: for undoing a rejected step and for checkpoints.

Each part implements the state protocol of :mod:`hpcgfmd.state` (named arrays and scalars,
and restore from them); :class:`RunState` holds the parts by name and never looks inside
them. In a checkpoint a part ``p``'s array ``a`` is the field ``p.a`` and its scalar ``s``
the attribute ``p.s``; its counters are attributes ``counters.p.c``.

Invariant: after :meth:`RunState.save` and any number of attempts at a step,
:meth:`RunState.revert` puts every part back to the saved state; counters are not state and
keep the work of the attempts.
"""

from __future__ import annotations

import numpy as np

from ..state import State

COUNTERS = "counters"


class RunState:
    """The parts of a run, by name.

    Parameters
    ----------
    parts : dict of str to Stateful
        The parts whose state makes the run's (the order is the checkpoint's).
    counting : dict of str to Counting
        The parts that count work (solvers, transforms, the drive's solves, ...).
    """

    def __init__(self, parts: dict, counting: dict):
        self.parts = parts
        self.counting = counting
        self._saved = None  # name -> State of copies (save)

    # --- undo --------------------------------------------------------------------------
    def save(self):
        """Keep every part's state (copies into buffers made once)."""
        first = self._saved is None
        if first:
            self._saved = {}
        for name, part in self.parts.items():
            state = part.state()
            kept = self._saved.get(name)
            if kept is None or kept.arrays.keys() != state.arrays.keys():
                kept = self._saved[name] = State(
                    {key: np.empty_like(a) for key, a in state.arrays.items()}
                )
            for key, array in state.arrays.items():
                np.copyto(kept.arrays[key], array)
            kept.scalars = dict(state.scalars)

    def revert(self):
        """Put every part back to the state of the last :meth:`save`."""
        for name, part in self.parts.items():
            part.restore(self._saved[name])

    def saved(self, name: str) -> State:
        """The saved state of part ``name`` (read only): the state before the step."""
        return self._saved[name]

    # --- checkpoints -------------------------------------------------------------------
    def gather(self) -> tuple[dict, dict]:
        """(fields, attributes) of a checkpoint: every part's arrays (this rank's blocks) and
        scalars, and every counter, under their qualified names."""
        fields, attrs = {}, {}
        for name, part in self.parts.items():
            state = part.state()
            fields.update({f"{name}.{key}": a for key, a in state.arrays.items()})
            attrs.update({f"{name}.{key}": v for key, v in state.scalars.items()})
        for name, part in self.counting.items():
            attrs.update({f"{COUNTERS}.{name}.{key}": v for key, v in part.counters().items()})
        return fields, attrs

    def restore(self, fields: dict, attrs: dict):
        """Continue from :meth:`gather`'s fields and attributes (of any rank count)."""
        for name, part in self.parts.items():
            part.restore(State(_qualified(fields, name), _qualified(attrs, name)))
        for name, part in self.counting.items():
            part.restore_counters(_qualified(attrs, f"{COUNTERS}.{name}"))

    def counters(self) -> dict:
        """Every part's counters, merged (for the run's summary)."""
        merged = {}
        for part in self.counting.values():
            merged.update(part.counters())
        return merged

    def field_count(self) -> int:
        """The number of grid fields a checkpoint holds."""
        return sum(len(part.state().arrays) for part in self.parts.values())


def _qualified(values: dict, prefix: str) -> dict:
    """The entries of ``values`` named ``prefix.key``, by ``key``."""
    start = prefix + "."
    return {
        key[len(start) :]: value
        for key, value in values.items()
        if key.startswith(start) and "." not in key[len(start) :]
    }
