"""Reading a result file back: the series, the snapshots, the pull-off (no solver imports).

Works on finished files and on files of a running or killed case (the series are cut to
the entries completely written, ``steps_complete``).

Anything else raises :class:`~hpcgfmd.errors.ResultFileError` with a one-line message naming
the path, what is wrong and what is expected: a missing path, a directory, a file that cannot
be opened, an empty or non-HDF5 file, an HDF5 file of another program (no ``/series`` group or
no ``config`` attribute), a result file cut short on disk (HDF5 cannot open it or read a
dataset), and series or snapshots shorter than ``steps_complete`` (``complete``). A kill
between two appends leaves some series one entry *longer* than ``steps_complete``
(:mod:`hpcgfmd.storage.result_file`); such files are legitimate and read as before.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import h5py
import numpy as np

from ..errors import ResultFileError
from ..model import sphere_theory, theory
from ..model.geometry import SURFACE_SERIES
from ..model.loading import cycle_of

SERIES = (
    "time",
    "indenter",
    "load",
    "contact_half_width",
    "cohesive_half_width",
    "iterations",
    "residual",
    "dt",
)
OPTIONAL_SERIES = ("drive", "applied_load", "segment") + SURFACE_SERIES


@dataclass
class Series:
    """The /series of a result file plus the scales needed for the paper's plots.

    All arrays in the file's units (one entry per step, t = 0 first); ``attrs`` holds the
    root attributes, among them ``beta`` and ``load_scale`` in the same units.
    """

    attrs: dict
    time: np.ndarray
    indenter: np.ndarray
    load: np.ndarray
    contact_half_width: np.ndarray
    cohesive_half_width: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    dt: np.ndarray
    drive: np.ndarray | None = None  # the compliant drive's end; None: displacement control
    applied_load: np.ndarray | None = None  # under load control; else None
    segment: np.ndarray | None = None  # the protocol's segment of each step; None: the paper's
    # a sphere's: contact and cohesive areas, the contact line's mean radius and roundness
    contact_area: np.ndarray | None = None
    cohesive_area: np.ndarray | None = None
    contact_line_radius: np.ndarray | None = None
    out_of_roundness: np.ndarray | None = None

    @property
    def abar(self) -> np.ndarray:
        """Contact half-width a_c / beta."""
        return self.contact_half_width / self.attrs["beta"]

    @property
    def lbar(self) -> np.ndarray:
        """Load in load scales, L_n / (R dgamma0^2 E0)^(1/3)."""
        return self.load / self.attrs["load_scale"]

    def pull_off(self) -> int:
        """Index of the most tensile load (the pull-off point of displacement control)."""
        return int(np.argmin(self.load))

    @property
    def sphere(self) -> bool:
        """The file is a sphere's (its load a force, its widths radii)."""
        return self.attrs.get("geometry") == "sphere"

    def scaled_curve(self) -> tuple[np.ndarray, np.ndarray]:
        """(x, y) over the steps with contact, in which JKR is a line of slope 1: the
        cylinder's (Lbar / sqrt(abar), (pi/4) abar^(3/2)) (Fig. 5a, (M25)), the sphere's
        (Pbar / Abar^(3/2), Abar^(3/2)) ((M55))."""
        keep = self.contact_half_width > 0
        references = sphere_theory if self.sphere else theory
        return references.scaled_curve(self.abar[keep], self.lbar[keep])

    def effective_work(self) -> np.ndarray:
        """dgamma_eff/dgamma0 of each step with contact (docs/model.md, "Observables")."""
        x, y = self.scaled_curve()
        references = sphere_theory if self.sphere else theory
        return references.effective_work_ratio(x, y)

    def work_of_separation(self) -> float:
        """The work the drive did against the tensile load while retracting (docs/model.md,
        "Observables"): -sum (min(L_i, 0) + min(L_i-1, 0))/2 (Z_i - Z_i-1) over the steps
        with Z_i > Z_i-1 (Z the drive, or the indenter without one). File units: load x
        length (per unit length on a line, an energy on a surface). NaN under load control,
        whose indenter the load lets fly off."""
        if self.applied_load is not None:
            return math.nan
        position = self.drive if self.drive is not None else self.indenter
        tensile = np.minimum(self.load, 0.0)
        advance = np.diff(position)
        work = -0.5 * (tensile[1:] + tensile[:-1]) * advance
        return float(math.fsum(work[advance > 0.0]))

    def cycles(self) -> list[Cycle]:
        """Per cycle of the protocol (a cycle ends with its retraction; the paper's protocol
        is one): its steps, pull-off and the work the drive did, -sum (L_i + L_i-1)/2 (Z_i -
        Z_i-1) over the cycle's steps (docs/model.md, (M45)): the energy dissipated per unit
        length when the cycle starts and ends detached (the hysteresis loop's area). Under
        load control the work is NaN (a load lets the indenter fly off)."""
        kinds = self.attrs.get("protocol_kinds", ["retract"])
        segment = self.segment if self.segment is not None else np.zeros(self.time.size, dtype=int)
        cycle = np.array([cycle_of(kinds, int(i)) for i in segment], dtype=int)
        position = self.drive if self.drive is not None else self.indenter
        work = -0.5 * (self.load[1:] + self.load[:-1]) * np.diff(position)
        summaries = []
        for c in np.unique(cycle):
            steps = np.flatnonzero(cycle == c)
            i = steps[np.argmin(self.load[steps])]
            area = (
                math.nan
                if self.applied_load is not None
                else float(math.fsum(work[steps[steps > 0] - 1]))
            )
            summaries.append(
                Cycle(
                    index=int(c),
                    first=int(steps[0]),
                    last=int(steps[-1]),
                    pull_off=float(self.load[i]),
                    lbar=float(self.lbar[i]),
                    indenter=float(self.indenter[i]),
                    time=float(self.time[i]),
                    work=area,
                )
            )
        return summaries


@dataclass
class Cycle:
    """One cycle of a protocol (file units): its first and last step, its most tensile load
    (``lbar`` in load scales) with the indenter and time there, and the drive's ``work`` over
    it (load x length per unit length; the dissipated energy of a closed cycle)."""

    index: int
    first: int
    last: int
    pull_off: float
    lbar: float
    indenter: float
    time: float
    work: float


@dataclass
class Snapshots:
    """Profiles at chosen moments: ``time`` (s,), ``x`` (n,), ``surface`` u, ``pressure`` (the
    traction on the substrate, attractive positive) and ``gap``, each (s, n) on a line and
    (s, ny, nx) on a surface, whose ``y`` (ny,) is given too (None on a line); file units."""

    time: np.ndarray
    x: np.ndarray
    surface: np.ndarray
    pressure: np.ndarray
    gap: np.ndarray
    y: np.ndarray | None = None


@dataclass
class PullOff:
    """The most tensile point of a retraction (file units; ``lbar``, ``abar`` scaled)."""

    index: int
    load: float
    lbar: float
    contact_half_width: float
    abar: float
    indenter: float
    time: float


@dataclass
class Result:
    """One case's results: what :func:`hpcgfmd.open` and :func:`hpcgfmd.run` return.

    Attributes
    ----------
    path : str or None
        The result file read (None for a run kept in memory).
    attrs : dict
        The file's root attributes: the case file text (``config``), the groups, the scales,
        ``finished`` and, when finished, the run summary.
    series : Series
    snapshots : Snapshots
    """

    path: str | None
    attrs: dict
    series: Series
    snapshots: Snapshots

    @property
    def finished(self) -> bool:
        """The run reached its end (complete detachment, or the protocol's last segment)."""
        return bool(self.attrs.get("finished", False))

    @property
    def groups(self) -> dict:
        """The dimensionless groups stored with the case: the keys of
        :meth:`hpcgfmd.case.Case.groups` found in the file."""
        return {
            key: self.attrs[key]
            for key in (
                "lambda0",
                "lambda_inf",
                "k",
                "Vz",
                "chi_ve",
                "alpha",
                "depth",
                "cell",
                "zone_points",
                "relaxation_moduli",
                "relaxation_times",
                "drive_stiffness",
            )
            if key in self.attrs
        }

    def pull_off(self) -> PullOff:
        """The pull-off point: the most tensile load of the series."""
        s = self.series
        if not s.load.size:
            raise ValueError(f"{self.path}: no step written yet")
        i = s.pull_off()
        return PullOff(
            index=i,
            load=float(s.load[i]),
            lbar=float(s.lbar[i]),
            contact_half_width=float(s.contact_half_width[i]),
            abar=float(s.abar[i]),
            indenter=float(s.indenter[i]),
            time=float(s.time[i]),
        )


EXPECTED = "expected an hpcgfmd output file (the HDF5 file `python -m hpcgfmd run` writes)"
SNAPSHOT_FIELDS = ("surface", "pressure", "gap")
REQUIRED_ATTRS = ("config", "beta", "load_scale")  # written by every version


def _reason(err) -> str:
    """An exception's message on one line."""
    return " ".join(str(err).split()) or type(err).__name__


def _bad(path, problem, expected=EXPECTED) -> ResultFileError:
    return ResultFileError(f"{path}: {problem}; {expected}")


def _check_file(path) -> str:
    """``path`` as a string if it is a readable, non-empty HDF5 file, else ResultFileError."""
    name = os.fspath(path)
    if not os.path.exists(name):
        raise _bad(name, "no such file")
    if os.path.isdir(name):
        raise _bad(name, "is a directory")
    try:
        with open(name, "rb") as raw:
            empty = not raw.read(1)
    except OSError as err:
        raise _bad(
            name,
            f"cannot be opened: {err.strerror or _reason(err)}",
            "expected a readable hpcgfmd output file",
        ) from None
    if empty:
        raise _bad(name, "empty file (0 bytes), not an HDF5 file")
    try:
        hdf5 = h5py.is_hdf5(name)
    except OSError as err:
        raise _bad(name, f"cannot be opened: {_reason(err)}") from None
    if not hdf5:
        raise _bad(name, "not an HDF5 file")
    return name


def _read(path, snapshots: bool):
    """(Series, Snapshots or None) of the result file ``path``; ResultFileError if unreadable."""
    name = _check_file(path)
    try:
        f = h5py.File(name, "r")
    except OSError as err:
        raise _bad(
            name,
            f"an HDF5 file that HDF5 cannot open (cut short or damaged?): {_reason(err)}",
            "expected a complete hpcgfmd output file",
        ) from None
    try:
        with f:
            series = _series(f, name)
            return series, (_snapshots(f, name) if snapshots else None)
    except ResultFileError:
        raise
    except (OSError, KeyError, ValueError, TypeError, RuntimeError) as err:
        # metadata that HDF5 cannot read (a file cut short or damaged)
        raise _bad(
            name,
            f"cannot be read (cut short or damaged?): {_reason(err)}",
            "expected a complete hpcgfmd output file",
        ) from None


# a Prony series' and a protocol's lists, any length
LIST_ATTRS = ("relaxation_moduli", "relaxation_times", "protocol_kinds", "shape")


def _attrs(f):
    """The file's attributes: numbers as Python scalars, a Prony series' lists as lists."""
    return {
        k: (np.atleast_1d(v).tolist() if k in LIST_ATTRS else v.item() if hasattr(v, "item") else v)
        for k, v in f.attrs.items()
    }


def _dataset(f, path, name, ndim):
    """The dataset ``name`` of ``f``, checked to exist with ``ndim`` dimensions."""
    if not isinstance(f.get(name), h5py.Dataset):
        raise _bad(
            path, f"hpcgfmd output without dataset /{name} (damaged, or written by another program)"
        )
    ds = f[name]
    if ds.ndim != ndim:
        raise _bad(path, f"dataset /{name} has {ds.ndim} dimensions, not {ndim}")
    return ds


def _count(path, attrs, key, datasets, owner):
    """Entries complete: the attribute ``key`` (every dataset must hold that many)."""
    lengths = {name: ds.shape[0] for name, ds in datasets.items()}
    if key not in attrs:
        raise _bad(
            path,
            f"no attribute {owner}{key} (written by another program or an earlier version)",
            "expected an hpcgfmd result file",
        )
    n = attrs[key]
    if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or n < 0:
        raise _bad(path, f"attribute {owner}{key} = {n!r} is not a count")
    for name, length in lengths.items():
        if length < n:
            # a kill between two appends leaves datasets one entry longer, never shorter
            raise _bad(
                path,
                f"dataset {name} is shorter than {key} ({length} < {n} entries; truncated)",
                f"expected at least {key} entries in every"
                " dataset of a complete hpcgfmd output file",
            )
    return int(n)


def _values(path, ds, selection):
    """Read ``ds[selection]``, or ResultFileError naming the dataset."""
    try:
        return ds[selection]
    except (OSError, ValueError, TypeError, RuntimeError) as err:
        raise _bad(
            path,
            f"dataset {ds.name} cannot be read (cut short or damaged?): {_reason(err)}",
            "expected a complete hpcgfmd output file",
        ) from None


def _series(f, path) -> Series:
    missing = [
        what
        for what, absent in (
            ("no /series group", not isinstance(f.get("series"), h5py.Group)),
            ("no config attribute", "config" not in f.attrs),
        )
        if absent
    ]
    if missing:
        raise _bad(path, f"an HDF5 file but not hpcgfmd output: {' and '.join(missing)}")
    attrs = _attrs(f)
    for key in REQUIRED_ATTRS:
        if key not in attrs:
            raise _bad(path, f"hpcgfmd output without root attribute {key} (damaged?)")
    names = SERIES + tuple(name for name in OPTIONAL_SERIES if name in f["series"])
    datasets = {f"/series/{name}": _dataset(f, path, f"series/{name}", 1) for name in names}
    n = _count(path, attrs, "steps_complete", datasets, "/")
    return Series(
        attrs=attrs,
        **{name: _values(path, ds, slice(0, n)) for name, ds in zip(names, datasets.values())},
    )


def _snapshots(f, path) -> Snapshots:
    if not isinstance(f.get("snapshots"), h5py.Group):
        raise _bad(
            path,
            "hpcgfmd output without the /snapshots group (damaged, or written by another program)",
        )
    snaps = f["snapshots"]
    x = _dataset(f, path, "snapshots/x", 1)
    y = _dataset(f, path, "snapshots/y", 1) if "y" in snaps else None
    axes = (x,) if y is None else (y, x)
    rows = {"/snapshots/time": _dataset(f, path, "snapshots/time", 1)}
    rows.update(
        {
            f"/snapshots/{name}": _dataset(f, path, f"snapshots/{name}", 1 + len(axes))
            for name in SNAPSHOT_FIELDS
        }
    )
    for name in SNAPSHOT_FIELDS:
        grid = rows[f"/snapshots/{name}"].shape[1:]
        nodes = tuple(axis.shape[0] for axis in axes)
        if grid != nodes:
            raise _bad(
                path, f"dataset /snapshots/{name} has a grid of {grid} nodes but its axes {nodes}"
            )
    count = _count(path, _attrs(snaps), "complete", rows, "/snapshots ")
    values = {name: _values(path, ds, slice(0, count)) for name, ds in rows.items()}
    return Snapshots(
        time=values["/snapshots/time"],
        x=_values(path, x, slice(None)),
        y=None if y is None else _values(path, y, slice(None)),
        **{name: values[f"/snapshots/{name}"] for name in SNAPSHOT_FIELDS},
    )


def read_series(path: str | os.PathLike) -> Series:
    """Read the series and root attributes of a result file (works on unfinished files too).

    Raises
    ------
    ResultFileError
        ``path`` is not a readable hpcgfmd output file (see the module docstring).
    """
    return _read(path, snapshots=False)[0]


def read_result(path: str | os.PathLike) -> Result:
    """The series, the snapshots and the attributes of a result file (finished or not).

    Raises
    ------
    ResultFileError
        ``path`` is not a readable hpcgfmd output file (see the module docstring).
    """
    series, snapshots = _read(path, snapshots=True)
    return Result(path=os.fspath(path), attrs=series.attrs, series=series, snapshots=snapshots)
