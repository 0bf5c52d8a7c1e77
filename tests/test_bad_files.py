"""Files that are not readable hpcgfmd output: `info`, `plot` and `hpcgfmd.open` refuse them
alike (docs/output.md, "Reading it").

Each kind of bad file goes through the real commands (status 2, exactly one stderr line naming
the file and what is expected, no traceback, no PNG) and through the Python API
(:class:`~hpcgfmd.errors.ResultFileError`). A file of a run killed between two appends (series
one entry longer than ``steps_complete``) is legitimate and still reads.
"""

import ctypes
import os
import shutil
import subprocess
import sys

import h5py
import numpy as np
import pytest

import cases
import hpcgfmd
from hpcgfmd.errors import ResultFileError
from hpcgfmd.storage.result_file import SERIES

NAME = "bad.h5"


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    """A real output file of `python -m hpcgfmd run` (small elastic case, about a second)."""
    directory = tmp_path_factory.mktemp("good")
    (directory / "case.toml").write_text(
        cases.case_text("nx = 1024", maugis=1.0, modulus_ratio=1.0)
    )
    done = subprocess.run(
        [sys.executable, "-m", "hpcgfmd", "run", "case.toml", "-o", "out.h5"],
        cwd=directory,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    return directory / "out.h5"


# --- the bad files: each builder makes tmp_path / NAME ---------------------------------------


def missing(path, good):
    pass


def directory(path, good):
    path.mkdir()


def empty(path, good):
    path.write_bytes(b"")


def not_hdf5(path, good):
    path.write_text((good.parent / "case.toml").read_text())  # a case file, not its output


def foreign(path, good):
    with h5py.File(path, "w") as f:  # another program's HDF5 file
        f["temperature"] = np.linspace(270.0, 300.0, 31)
        f.create_group("run")["pressure"] = np.ones((4, 3))
        f.attrs["program"] = "elsewhere"


def foreign_with_series(path, good):
    with h5py.File(path, "w") as f:  # a /series group, but no config attribute
        f.create_group("series")["time"] = np.arange(5.0)


def _edited(path, good, edit):
    shutil.copyfile(good, path)
    with h5py.File(path, "r+") as f:
        edit(f, int(f.attrs["steps_complete"]))


def series_truncated(path, good):
    _edited(path, good, lambda f, n: f["series/load"].resize((n // 2,)))


def series_one_short(path, good):
    # a kill between appends leaves series one entry longer, never shorter
    _edited(path, good, lambda f, n: f["series/load"].resize((n - 1,)))


def snapshots_truncated(path, good):
    _edited(
        path,
        good,
        lambda f, n: f["snapshots/gap"].resize(
            (int(f["snapshots"].attrs["complete"]) - 1, f["snapshots/x"].shape[0])
        ),
    )


def cut_short(path, good):
    data = good.read_bytes()
    path.write_bytes(data[: len(data) // 2])  # HDF5 cannot open it


def cut_short_and_padded(path, good):
    data = good.read_bytes()  # the length HDF5 expects, the second half zeros: it opens, but
    half = len(data) // 2  # its datasets cannot be read
    path.write_bytes(data[:half] + bytes(len(data) - half))


def unreadable(path, good):
    shutil.copyfile(good, path)
    path.chmod(0)


BAD = [  # builder, words of the message
    (missing, ["no such file"]),
    (directory, ["is a directory"]),
    (empty, ["empty file", "not an HDF5 file"]),
    (not_hdf5, ["not an HDF5 file"]),
    (foreign, ["an HDF5 file but not hpcgfmd output", "no /series group", "no config"]),
    (foreign_with_series, ["not hpcgfmd output", "no config attribute"]),
    (series_truncated, ["dataset /series/load is shorter than steps_complete", "truncated"]),
    (series_one_short, ["dataset /series/load is shorter than steps_complete", "truncated"]),
    (snapshots_truncated, ["dataset /snapshots/gap is shorter than complete", "truncated"]),
    (cut_short, ["HDF5 cannot open", "cut short"]),
    (cut_short_and_padded, ["cannot be read", "cut short"]),
    (unreadable, ["cannot be opened", "Permission denied"]),
]
IDS = [build.__name__ for build, _ in BAD]


# --- unreadable files as root -----------------------------------------------------------------

PR_CAPBSET_DROP, CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH = 24, 1, 2


def _obey_file_modes():
    """preexec_fn: drop the capabilities that let root read any file (the child stays root)."""
    libc = ctypes.CDLL(None, use_errno=True)
    for cap in (CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH):
        if libc.prctl(PR_CAPBSET_DROP, cap, 0, 0, 0) != 0:
            raise OSError(ctypes.get_errno(), "prctl(PR_CAPBSET_DROP)")


def preexec_for(build, path):
    """None, or for an unreadable file under root the preexec_fn under which it is unreadable
    (skips the test if root cannot drop those capabilities)."""
    if build is not unreadable:
        return None
    if os.geteuid() != 0:
        return None  # chmod 000 does it
    if not sys.platform.startswith("linux"):
        pytest.skip(
            "running as root: chmod 000 does not stop root, and dropping"
            " CAP_DAC_OVERRIDE needs Linux"
        )
    try:
        probe = subprocess.run(
            [sys.executable, "-c", f"open({str(path)!r}, 'rb')"],
            preexec_fn=_obey_file_modes,
            capture_output=True,
            text=True,
        )
    except subprocess.SubprocessError as err:
        pytest.skip(
            f"running as root: chmod 000 does not stop root, and CAP_DAC_OVERRIDE"
            f" cannot be dropped here ({err})"
        )
    if "PermissionError" not in probe.stderr:
        pytest.skip("running as root: the file stays readable without CAP_DAC_OVERRIDE")
    return _obey_file_modes


# --- the tests --------------------------------------------------------------------------------


def check_message(message, path, words):
    assert "\n" not in message.strip() and "Traceback" not in message, message
    assert path in message and "expected" in message, message
    for word in words:
        assert word in message, (word, message)


@pytest.mark.parametrize("command", ["info", "plot"])
@pytest.mark.parametrize("build, words", BAD, ids=IDS)
def test_command_refuses_with_one_line_and_status_2(good, tmp_path, build, words, command):
    build(tmp_path / NAME, good)
    preexec = preexec_for(build, tmp_path / NAME)
    done = subprocess.run(
        [sys.executable, "-m", "hpcgfmd", command, NAME],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
        preexec_fn=preexec,
    )
    assert done.returncode == 2, (done.returncode, done.stderr)
    assert len(done.stderr.splitlines()) == 1 and done.stderr.strip(), done.stderr
    check_message(done.stderr, NAME, words)
    assert done.stdout == ""
    assert not list(tmp_path.rglob("*.png"))  # plot wrote nothing


@pytest.mark.parametrize("build, words", BAD, ids=IDS)
def test_open_raises_result_file_error(good, tmp_path, build, words):
    path = str(tmp_path / NAME)
    build(tmp_path / NAME, good)
    preexec = preexec_for(build, path)
    if preexec is None:
        with pytest.raises(ResultFileError) as err:
            hpcgfmd.open(path)
        message = str(err.value)
    else:  # root reads any file: open it in a child without that capability
        script = (
            "import sys, hpcgfmd\nfrom hpcgfmd.errors import ResultFileError\n"
            "try:\n    hpcgfmd.open(sys.argv[1])\nexcept ResultFileError as err:\n"
            "    print(err)\nelse:\n    sys.exit('no ResultFileError')\n"
        )
        done = subprocess.run(
            [sys.executable, "-c", script, path],
            capture_output=True,
            text=True,
            timeout=120,
            preexec_fn=preexec,
        )
        assert done.returncode == 0, done.stderr
        message = done.stdout
    check_message(message, path, words)


def test_run_killed_between_two_appends_still_reads(good, tmp_path):
    """Some series and snapshot rows one entry past steps_complete / complete: cut, not refused."""
    reference = hpcgfmd.open(good)
    path = tmp_path / "killed.h5"
    shutil.copyfile(good, path)
    with h5py.File(path, "r+") as f:
        n, s = int(f.attrs["steps_complete"]), int(f["snapshots"].attrs["complete"])
        for name in SERIES[:3]:  # killed after three of the series had their entry
            f["series"][name].resize((n + 1,))
            f["series"][name][n] = 1e300
        f["snapshots/time"].resize((s + 1,))
        f["snapshots/surface"].resize((s + 1, f["snapshots/x"].shape[0]))
    opened = hpcgfmd.open(path)
    for name in SERIES:
        np.testing.assert_array_equal(getattr(opened.series, name), getattr(reference.series, name))
    np.testing.assert_array_equal(opened.snapshots.surface, reference.snapshots.surface)
    np.testing.assert_array_equal(opened.snapshots.time, reference.snapshots.time)
    for command in ("info", "plot"):
        done = subprocess.run(
            [sys.executable, "-m", "hpcgfmd", command, "killed.h5"],
            cwd=tmp_path,
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert done.returncode == 0, done.stderr
    assert (tmp_path / "killed.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
