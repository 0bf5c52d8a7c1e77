"""One writer per output file: an exclusive lock on ``<output>.lock`` for the whole run.

Two runs started on the same output (a job resubmitted while the first still runs, two job
array elements given the same ``-o``) would write one HDF5 file from two processes and destroy
it. The first run holds an advisory ``flock`` on ``<output>.lock``; the second finds it held
and refuses before computing anything. The kernel releases a ``flock`` when its process ends,
however it ends (SIGKILL, node crash of a local file system), so a crashed run leaves no
stale lock: the file may remain, unlocked, and the next run takes it over.

Protocol (safe against a run that removes the file while another opens it): open or create
the file, ``flock(LOCK_EX | LOCK_NB)``, then check that the path still names the locked inode
(else retry); on release, unlink the path first and unlock after. The holder's pid and host
are written into the file for the message of the run that is refused.

Network file systems: Lustre and NFSv4 honour ``flock`` across nodes when mounted with it
(Lustre ``-o flock``); where ``flock`` is not supported at all (ENOSYS, ENOLCK, EOPNOTSUPP) the
run warns once and goes on unlocked.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import logging
import os
import socket

from ..errors import OutputExistsError, UsageError

logger = logging.getLogger(__name__)
UNSUPPORTED = (errno.ENOSYS, errno.ENOLCK, errno.EOPNOTSUPP)  # no flock on this file system


def lock_path(output) -> str:
    """The lock file of an output file: ``<output>.lock``."""
    return os.fspath(output) + ".lock"


class OutputLock:
    """The held lock of one output file (rank 0's; see :func:`acquire_output_lock`)."""

    def __init__(self, path, fd):
        self.path, self._fd = path, fd

    def release(self):
        """Remove the lock file and unlock (idempotent; nothing for a lock not taken)."""
        if self._fd is None:
            return
        with contextlib.suppress(FileNotFoundError):
            os.unlink(self.path)
        os.close(self._fd)  # closing the last descriptor releases the flock
        self._fd = None


def _lock_or_refuse(output) -> OutputLock:
    """Rank 0: take the lock of ``output``, or raise UsageError (one line) naming the holder,
    a missing directory or an unwritable one."""
    path = lock_path(output)
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise UsageError(f"-o {output}: directory {directory} does not exist")
    for _ in range(10):  # retries only when a holder removed the file in between
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as err:
            raise UsageError(
                f"-o {output}: cannot write in {directory} ({os.strerror(err.errno)})"
            ) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as err:
            try:
                holder = os.pread(fd, 200, 0).decode(errors="replace").strip()
            except OSError:
                holder = ""
            os.close(fd)
            if err.errno in UNSUPPORTED:
                with contextlib.suppress(OSError):  # locks nothing: not left behind
                    os.unlink(path)
                logger.warning(
                    f"-o {output}: this file system does not support flock"
                    f" ({os.strerror(err.errno)}); running without the output lock"
                )
                return OutputLock(path, None)
            if err.errno in (errno.EWOULDBLOCK, errno.EACCES):
                raise UsageError(
                    f"-o {output}: being written by {holder or 'another process'}"
                    f" (lock {path}); wait for it to end or choose another -o"
                ) from None
            raise UsageError(
                f"-o {output}: cannot lock {path} ({os.strerror(err.errno)})"
            ) from None
        try:
            same = os.stat(path).st_ino == os.fstat(fd).st_ino
        except OSError:
            same = False
        if same:
            try:  # best effort: the holder's name is for the message of a refused run
                os.ftruncate(fd, 0)
                os.pwrite(fd, f"pid {os.getpid()} on {socket.gethostname()}\n".encode(), 0)
            except OSError:
                pass
            return OutputLock(path, fd)
        os.close(fd)  # the holder removed it while we opened it: take the new one
    raise UsageError(f"-o {output}: cannot lock {path} (it keeps being replaced)")


def acquire_output_lock(comm, output) -> OutputLock | None:
    """Collective: rank 0 takes the lock of ``output`` (returned; None on other ranks).

    Raises
    ------
    UsageError
        On every rank alike, when another process holds the lock, or the output's directory
        is missing or cannot be written.
    """
    lock, error = None, None
    if comm.Get_rank() == 0:
        try:
            lock = _lock_or_refuse(output)
        except UsageError as err:
            error = str(err)
        except OSError as err:  # e.g. a file system gone stale: still one line
            error = f"-o {output}: cannot lock {lock_path(output)} ({err.strerror})"
    error = comm.bcast(error, root=0)
    if error:
        raise UsageError(error)
    return lock


def check_output_path(path, overwrite):
    """A file to be written at ``path``: its directory exists, it is not a directory, and it
    does not exist unless ``overwrite``.

    Raises
    ------
    UsageError
        A missing directory, or ``path`` is a directory (one line naming it).
    OutputExistsError
        ``path`` exists and ``overwrite`` is false.
    """
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise UsageError(f"-o {path}: directory {directory} does not exist")
    if os.path.isdir(path):
        raise UsageError(f"-o {path}: is a directory; give a file name")
    if os.path.exists(path) and not overwrite:
        raise OutputExistsError(
            f"-o {path}: file exists; choose another name or pass"
            " --overwrite (overwrite=True from Python)"
        )
