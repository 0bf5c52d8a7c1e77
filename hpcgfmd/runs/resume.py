"""Whether ``run`` continues a case from its checkpoint, decided before anything is computed.

The same command resumes when the output file and its checkpoint both exist (``--restart``
demands it); the checkpoint must be complete and unaltered (its digest), belong to the same
case (its identity hash, :meth:`~hpcgfmd.case.Case.identity`), and the output file
must hold at least the steps and snapshots the checkpoint counts. A damaged newest checkpoint
gives way to the previous generation, with a warning. Anything else is a
:class:`~hpcgfmd.errors.UsageError` naming the file, with nothing touched.
:func:`prepare_output` takes the output's lock with that decision: the command line and
:func:`hpcgfmd.run` start every run through it.
"""

from __future__ import annotations

import logging
import os

import h5py

from ..errors import UsageError
from ..storage.checkpoint import (
    checkpoint_path,
    previous_path,
    read_checkpoint_attrs,
    usable_checkpoint,
)
from ..storage.lock import acquire_output_lock, check_output_path

logger = logging.getLogger(__name__)


def prepare_output(comm, case, output, overwrite, restart=False):
    """Collective: take ``output``'s lock and decide whether the run continues from its
    checkpoint; before anything is computed or written.

    Returns
    -------
    lock : hpcgfmd.storage.lock.OutputLock or None
        Held until the caller releases it (rank 0; None on the other ranks).
    resume : str or None
        The checkpoint to continue from (:func:`resume_wanted`), or None for a new file.

    Raises
    ------
    UsageError
        Another process writes ``output``, its directory is missing or not writable, it is a
        directory, or its checkpoint does not fit the case.
    OutputExistsError
        ``output`` exists without a checkpoint to continue from, and ``overwrite`` is false.
    """
    lock = acquire_output_lock(comm, output)
    try:
        resume = resume_wanted(comm, case, output, restart, overwrite)
        if not resume:  # rank 0 looks, all ranks raise alike (caches differ between nodes)
            verdict = None
            if comm.Get_rank() == 0:
                try:
                    check_output_path(output, overwrite)
                except UsageError as err:
                    verdict = (type(err), str(err))
            verdict = comm.bcast(verdict, root=0)
            if verdict is not None:
                raise verdict[0](verdict[1])
    except BaseException:
        if lock is not None:
            lock.release()
        raise
    return lock, resume


def resume_wanted(comm, case, output, restart, overwrite):
    """Collective: the checkpoint to continue from (its path), or None for a new run.

    Rank 0 reads the files and broadcasts its verdict, so every rank decides alike even on a
    file system whose caches differ between nodes.
    """
    verdict = None
    if comm.Get_rank() == 0:
        try:
            verdict = (_check_resume(case, output, restart, overwrite), None)
        except UsageError as err:
            verdict = (None, str(err))
    resume, error = comm.bcast(verdict, root=0)
    if error:
        raise UsageError(error)
    return resume


def _check_resume(case, output, restart, overwrite):
    """Rank 0's verdict (module docstring); UsageError naming the file that does not fit."""
    newest = checkpoint_path(output)
    have_output = os.path.exists(output)
    have_checkpoint = os.path.exists(newest) or os.path.exists(previous_path(newest))
    if not restart and (overwrite or not (have_output and have_checkpoint)):
        return None
    if not have_checkpoint:
        raise UsageError(f"--restart: no checkpoint {newest} for -o {output}")
    if not have_output:
        raise UsageError(f"--restart: checkpoint {newest} exists but its output {output} does not")
    checkpoint, problems = usable_checkpoint(newest)
    if checkpoint is None:
        raise UsageError(
            f"cannot resume -o {output}: "
            + "; ".join(problems)
            + " (pass --overwrite to start the case again)"
        )
    if problems:
        logger.warning(f"{problems[0]}; resuming from the previous checkpoint {checkpoint}")
    try:
        saved = read_checkpoint_attrs(checkpoint)
        identity = str(saved["case_identity"])
    except (OSError, KeyError, ValueError) as err:
        raise UsageError(f"{checkpoint}: not an hpcgfmd checkpoint ({err})") from None
    if identity != case.identity():
        raise UsageError(
            f"{checkpoint}: checkpoint of a different case (identity {identity},"
            f" this case {case.identity()}); choose another -o or remove it"
        )
    try:
        with h5py.File(output, "r") as f:
            written = (
                str(f.attrs["case_identity"]),
                int(f.attrs["steps_complete"]),
                int(f["snapshots"].attrs["complete"]),
            )
    except (OSError, KeyError) as err:
        raise UsageError(f"-o {output}: not the output of this checkpoint ({err})") from None
    needed = (identity, int(saved["surface.step_index"]) + 1, int(saved["snapshots_written"]))
    if written[0] != identity or written[1] < needed[1] or written[2] < needed[2]:
        raise UsageError(
            f"-o {output}: does not match checkpoint {checkpoint} (case"
            f" {written[0]}, {written[1]} steps, {written[2]} snapshots written;"
            f" the checkpoint needs case {needed[0]}, {needed[1]} steps,"
            f" {needed[2]} snapshots)"
        )
    return checkpoint
