"""Free space on the output's file system, checked before the run writes, never discovered by
a failed write.

HDF5 is not journaled: a write that fails for want of space (ENOSPC) in the middle of an append
or a flush can leave the file damaged, and under the ``mpio`` driver the library has been seen
to crash when it then closes the file (a segmentation fault after "Unable to flush cached
data"). So the run asks the file system first (``statvfs``, rank 0) whether the next step's
writes AND one checkpoint still fit, with a margin for HDF5's chunk allocations and metadata;
when they do not, it writes that checkpoint while it still can and stops with one line
(:class:`~hpcgfmd.errors.CaseFailure`, exit 1): once space is freed the same command resumes
from it. The check is a guard, not a reservation: another process filling the disk between
the check and the write is not covered.
"""

from __future__ import annotations

import os

MARGIN = 256 * 1024  # bytes: HDF5 metadata and a new chunk of every series (8 x 8 KiB)


def free_bytes(path) -> int:
    """Bytes available to this user on the file system of ``path`` (a file or directory)."""
    path = os.fspath(path)
    directory = path if os.path.isdir(path) else os.path.dirname(os.path.abspath(path))
    st = os.statvfs(directory)
    return st.f_bavail * st.f_frsize


def checkpoint_bytes(n, fields) -> int:
    """Size of a checkpoint of ``fields`` float64 arrays of ``n`` nodes, with its metadata."""
    return 8 * n * fields + 64 * 1024


def step_bytes(n, snapshot_fields=3) -> int:
    """Largest output one step appends: its series entries and one snapshot of ``n`` nodes."""
    return 8 * n * snapshot_fields + 1024


def room_for_a_step(n, fields) -> int:
    """Free bytes a run needs before each step: the step's output, a checkpoint of ``fields``
    arrays of ``n`` nodes, and the margin."""
    return step_bytes(n) + checkpoint_bytes(n, fields) + MARGIN
