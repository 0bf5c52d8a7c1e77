"""The Python API (hpcgfmd.Case, run, open), the netCDF view of the result file (xarray with
h5netcdf), files of the older layout, the solver registry, and the command line's logging."""

import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

import hpcgfmd
from cases import GROUPS, case_text, physical_text
from hpcgfmd.case import parse_case
from hpcgfmd.errors import CaseError
from hpcgfmd.solvers import registered

REPO = Path(__file__).resolve().parents[1]
ELASTIC = {**GROUPS, "maugis": 1.0, "modulus_ratio": 1.0}  # fast: about 80 steps at nx = 1024


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """A small elastic case run through the API into a file, with snapshots."""
    path = tmp_path_factory.mktemp("api") / "case.h5"
    case = hpcgfmd.Case(
        **ELASTIC,
        numerics={"nx": 1024},
        output={"snapshot_contact_widths": [0.1], "snapshot_zero_load": True},
    )
    result = hpcgfmd.run(case, path, planner_effort="FFTW_ESTIMATE")
    return path, case, result


def test_case_from_keywords_equals_the_case_file():
    keywords = hpcgfmd.Case(**GROUPS, numerics={"nx": 2048, "edge_fraction": 0.25})
    text = case_text("nx = 2048\nedge_fraction = 0.25")
    assert keywords.identity() == parse_case(text).identity()
    # the generated case file gives the same case again
    assert parse_case(keywords.text).identity() == keywords.identity()
    assert hpcgfmd.Case.from_toml(text).identity() == keywords.identity()


def test_case_from_a_path(tmp_path):
    (tmp_path / "c[1].toml").write_text(case_text("nx = 4096"))  # "[" in a path: still a path
    for source in (tmp_path / "c[1].toml", str(tmp_path / "c[1].toml")):
        assert hpcgfmd.Case.from_toml(source).numerics.nx == 4096


@pytest.mark.parametrize(
    "change, words",
    [
        ({"maugis": -1.0}, ["[case] maugis", "-1.0", "> 0"]),
        ({"modulus_ratio": 2.0}, ["modulus_ratio", "2.0", "(0, 1]"]),
        ({"numerics": {"nx": 63}}, ["[numerics] nx", "63", "even integer"]),
        ({"output": {"checkpoint_steps": -2}}, ["checkpoint_steps", "-2"]),
        # so fast that a step's square underflows (the SLS step divides by it)
        ({"velocity": 1e160}, ["[numerics] dt (default)", "at least 1.49e-154"]),
    ],
)
def test_case_keywords_are_validated_like_the_file(change, words):
    with pytest.raises(CaseError) as err:
        hpcgfmd.Case(**{**GROUPS, **change})
    assert all(word in str(err.value) for word in words), str(err.value)


def test_run_in_memory_leaves_nothing_and_matches_the_file(written, tmp_path, monkeypatch):
    path, case, on_file = written
    monkeypatch.setenv("TMPDIR", str(tmp_path))  # where the temporary file goes
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", None)
    in_memory = hpcgfmd.run(case, planner_effort="FFTW_ESTIMATE")
    assert in_memory.path is None and list(tmp_path.iterdir()) == []
    np.testing.assert_array_equal(in_memory.series.load, on_file.series.load)
    np.testing.assert_array_equal(in_memory.snapshots.gap, on_file.snapshots.gap)


def test_open_gives_the_results_of_the_file(written):
    path, case, result = written
    opened = hpcgfmd.open(path)
    assert opened.finished and opened.path == str(path)
    with h5py.File(path) as f:  # the file itself, read without the API
        load = f["series/load"][:]
        surface = f["snapshots/surface"][:]
    np.testing.assert_array_equal(opened.series.load, load)
    np.testing.assert_array_equal(opened.snapshots.surface, surface)
    assert opened.snapshots.surface.shape == (4, 1024)  # t = 0, a_c = 0.1, zero load, end
    pull_off = opened.pull_off()
    assert pull_off.load == load.min() and pull_off.index == int(np.argmin(load))
    assert pull_off.lbar == pytest.approx(load.min() / case.load_scale, rel=1e-12)
    assert opened.groups["lambda0"] == 1.0 and opened.groups["k"] == 1.0
    assert opened.groups == pytest.approx(case.groups(), rel=1e-15)  # every group, stored


def test_xarray_opens_series_and_snapshots_with_coordinates(written):
    xarray = pytest.importorskip("xarray")
    path, _, result = written
    series = xarray.open_dataset(path, group="series", engine="h5netcdf")
    assert list(series.coords) == ["time"] and series["load"].dims == ("time",)
    np.testing.assert_array_equal(series["time"].values, result.series.time)
    assert series["load"].attrs["units"] == "E0 R" and series["time"].attrs["units"] == "tau"
    assert series["iterations"].attrs["units"] == "1"
    snaps = xarray.open_dataset(path, group="snapshots", engine="h5netcdf")
    assert set(snaps.coords) == {"time", "x"}
    assert snaps["surface"].dims == ("time", "x") and snaps["pressure"].attrs["units"] == "E0"
    np.testing.assert_array_equal(snaps["x"].values, result.snapshots.x)
    series.close()
    snaps.close()


def test_physical_units_in_si(tmp_path):
    xarray = pytest.importorskip("xarray")
    text = physical_text(
        "nx = 1024",
        modulus_instantaneous="1e6",
        relaxation_time="2.0",
        work_of_adhesion="0.1",
        interaction_range="1e-6",
        depth="3e-5",
        cell_length="2e-3",
    )
    hpcgfmd.run(text, tmp_path / "p.h5", planner_effort="FFTW_ESTIMATE")
    series = xarray.open_dataset(tmp_path / "p.h5", group="series", engine="h5netcdf")
    assert {name: series[name].attrs["units"] for name in ("time", "load", "indenter")} == {
        "time": "s",
        "load": "N/m",
        "indenter": "m",
    }
    series.close()


def strip_to_the_older_layout(path):
    """Remove the dimension scales and units, as files written before them had none."""
    with h5py.File(path, "r+") as f:
        for group in ("series", "snapshots"):
            for ds in f[group].values():
                for dim in ds.dims:
                    for scale in list(dim.values()):
                        dim.detach_scale(scale)
            for ds in f[group].values():
                for name in ("CLASS", "NAME", "REFERENCE_LIST", "DIMENSION_LIST", "units"):
                    if name in ds.attrs:
                        del ds.attrs[name]


def test_files_of_the_older_layout_stay_readable(written, tmp_path):
    path, _, result = written
    old = tmp_path / "old.h5"
    old.write_bytes(Path(path).read_bytes())
    strip_to_the_older_layout(old)
    with h5py.File(old) as f:
        assert not any("units" in ds.attrs for ds in f["series"].values())
    opened = hpcgfmd.open(old)
    np.testing.assert_array_equal(opened.series.load, result.series.load)
    for command in ("info", "plot"):
        done = subprocess.run(
            [sys.executable, "-m", "hpcgfmd", command, str(old)],
            capture_output=True,
            text=True,
            timeout=120,
            cwd=tmp_path,
        )
        assert done.returncode == 0, done.stderr
    assert (
        "pull-off"
        in subprocess.run(
            [sys.executable, "-m", "hpcgfmd", "info", str(old)], capture_output=True, text=True
        ).stdout
    )
    assert (tmp_path / "old.png").stat().st_size > 10000


def test_the_example_runs_and_draws(tmp_path):
    png = tmp_path / "example.png"
    done = subprocess.run(
        [sys.executable, str(REPO / "docs" / "examples" / "retraction.py"), str(png)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr
    assert "pull-off Lbar = -6.3" in done.stdout  # the small viscoelastic case, measured -6.3587
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["example.png"]  # nothing else left


def test_every_registered_solver_and_its_keys_are_accepted():
    # the registry is the case files' vocabulary: each solver by name, with its own keys
    from hpcgfmd.case.numerics import numerics_keys
    from hpcgfmd.solvers import solver_class

    assert registered()[0] == "cg"  # the default
    for name in registered():
        keys = {key.name: key.smallest for key in solver_class(name).KEYS}
        assert set(keys) <= set(numerics_keys())
        numerics = "\n".join(
            [f'solver = "{name}"', "nx = 1024"]
            + [f"{key} = {smallest}" for key, smallest in keys.items()]
        )
        case = parse_case(case_text(numerics))
        assert case.numerics.solver == name
        assert dict(case.numerics.solver_settings) == keys


def test_quiet_and_log_file(tmp_path):
    (tmp_path / "c.toml").write_text(case_text("nx = 1024", maugis=1.0, modulus_ratio=1.0))

    def run(*options):
        return subprocess.run(
            [sys.executable, "-m", "hpcgfmd", "run", "c.toml", "--overwrite", *options],
            capture_output=True,
            text=True,
            timeout=120,
            cwd=tmp_path,
        )

    loud = run()
    assert loud.returncode == 0 and "finished:" in loud.stdout and "lambda0 = 1" in loud.stdout
    quiet = run("--quiet", "--log", "run.log")
    assert quiet.returncode == 0 and quiet.stdout == "" and quiet.stderr == ""
    log = (tmp_path / "run.log").read_text()
    assert "finished:" in log and "lambda0 = 1" in log and " INFO " in log
    missing = run("--log", os.path.join("no", "such", "dir", "run.log"))
    assert missing.returncode == 2 and missing.stderr.count("\n") == 1
    assert "--log" in missing.stderr and "Traceback" not in missing.stderr


@pytest.mark.parametrize(
    "change, words",
    [
        ({"numerics": 1024}, ["numerics = 1024", "dict", "[numerics]"]),
        ({"numerics": [("nx", 1024)]}, ["numerics = ", "dict", "[numerics]"]),
        ({"output": "x.h5"}, ["output = 'x.h5'", "dict", "[output]"]),
    ],
)
def test_settings_that_are_not_tables_are_named(change, words):
    with pytest.raises(CaseError) as err:
        hpcgfmd.Case(**{**GROUPS, **change})
    assert all(word in str(err.value) for word in words), str(err.value)


def test_numpy_values_are_the_numbers_they_hold():
    # a sweep script looping over numpy arrays gives the case of the same Python numbers
    plain = hpcgfmd.Case(
        **{**GROUPS, "modulus_ratio": None},
        relaxation_moduli=[3.0, 6.0],
        relaxation_times=[0.1, 1.45],
        numerics={"nx": 2048},
        output={"snapshot_times": [0.0, 1.0]},
    )
    numpy = hpcgfmd.Case(
        **{key: np.float64(value) for key, value in GROUPS.items() if key != "modulus_ratio"},
        modulus_ratio=None,
        relaxation_moduli=np.array([3.0, 6.0]),
        relaxation_times=np.array([0.1, 1.45]),
        numerics={"nx": np.int64(2048)},
        output={"snapshot_times": np.array([0.0, 1.0])},
    )
    assert numpy.identity() == plain.identity() and numpy.text == plain.text
    narrow = hpcgfmd.Case(**{**GROUPS, "maugis": np.float32(3.5), "velocity": np.int32(1)})
    assert narrow.maugis == 3.5 and narrow.velocity == 1.0


@pytest.mark.parametrize("source", [42, None, b"[case]"])
def test_a_case_source_of_another_type_is_named(source):
    for call in (hpcgfmd.Case.from_toml, hpcgfmd.run):
        with pytest.raises(CaseError) as err:
            call(source)
        assert f"case = {source!r}" in str(err.value) and "TOML text" in str(err.value)


def test_an_unreadable_case_file_is_named(tmp_path):
    missing = tmp_path / "missing.toml"
    with pytest.raises(CaseError) as err:
        hpcgfmd.Case.from_toml(missing)
    assert str(err.value).startswith(f"{missing}: cannot read case file")


def test_run_refuses_outputs_it_cannot_write_before_computing(tmp_path):
    from mpi4py import MPI

    from hpcgfmd.errors import OutputExistsError, UsageError
    from hpcgfmd.storage.lock import acquire_output_lock

    case = hpcgfmd.Case(**ELASTIC, numerics={"nx": 1024})
    quick = {"planner_effort": "FFTW_ESTIMATE"}
    for path, overwrite, words in [
        (tmp_path / "none" / "x.h5", False, ["does not exist"]),
        (tmp_path, True, ["is a directory"]),
    ]:
        with pytest.raises(UsageError) as err:
            hpcgfmd.run(case, path, overwrite=overwrite, **quick)
        assert str(path) in str(err.value) and all(w in str(err.value) for w in words)
    with pytest.raises(ValueError, match="planner_effort = 'FAST'"):
        hpcgfmd.run(case, tmp_path / "y.h5", planner_effort="FAST")
    (tmp_path / "mine.h5").write_bytes(b"mine")
    with pytest.raises(FileExistsError) as err:
        hpcgfmd.run(case, tmp_path / "mine.h5", **quick)
    assert isinstance(err.value, OutputExistsError)
    # one writer per output, also with overwrite: the lock held elsewhere refuses the run
    lock = acquire_output_lock(MPI.COMM_SELF, str(tmp_path / "mine.h5"))
    try:
        with pytest.raises(UsageError, match="being written by pid"):
            hpcgfmd.run(case, tmp_path / "mine.h5", overwrite=True, **quick)
    finally:
        lock.release()
    assert (tmp_path / "mine.h5").read_bytes() == b"mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine.h5"]
    hpcgfmd.run(case, tmp_path / "mine.h5", overwrite=True, **quick)  # free again


def test_run_continues_an_interrupted_case_bitwise(tmp_path):
    # a run stopped after a checkpoint (Interrupted) is continued by the same call
    from mpi4py import MPI

    from cases import StopAtStep
    from hpcgfmd.errors import Interrupted
    from hpcgfmd.runs.single_case import run_case

    case = hpcgfmd.Case(**GROUPS, numerics={"nx": 1024})
    quick = {"planner_effort": "FFTW_ESTIMATE"}
    whole = hpcgfmd.run(case, tmp_path / "whole.h5", **quick)
    with StopAtStep(20) as signals, pytest.raises(Interrupted):
        run_case(case, tmp_path / "parts.h5", MPI.COMM_SELF, stop=signals, **quick)
    parts = hpcgfmd.run(case, tmp_path / "parts.h5", **quick)
    assert parts.attrs["finished"] and parts.attrs["steps"] == whole.attrs["steps"] > 20
    for name in ("time", "load", "contact_half_width", "iterations"):
        np.testing.assert_array_equal(
            getattr(parts.series, name), getattr(whole.series, name), err_msg=name
        )
    assert not os.path.exists(tmp_path / "parts.checkpoint.h5")
