"""Reading a case file back: the series, the snapshots, the pull-off (no solver imports).

Works on finished files, on files of a running or killed case (the series are cut to the
entries completely written, ``steps_complete``), and on files written before the datasets had
dimension scales and units.
"""
from __future__ import annotations

from dataclasses import dataclass

import h5py
import numpy as np

from ..model import theory

SERIES = ("time", "indenter", "load", "contact_half_width", "cohesive_half_width",
          "iterations", "residual", "dt")


@dataclass
class Series:
    """The /series of a case file plus the scales needed for the paper's plots.

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

    @property
    def abar(self):
        """Contact half-width a_c / beta."""
        return self.contact_half_width / self.attrs["beta"]

    @property
    def lbar(self):
        """Load in load scales, L_n / (R dgamma0^2 E0)^(1/3)."""
        return self.load / self.attrs["load_scale"]

    def pull_off(self):
        """Index of the most tensile load (the pull-off point of displacement control)."""
        return int(np.argmin(self.load))

    def scaled_curve(self):
        """(x, y) = (Lbar / sqrt(abar), (pi/4) abar^(3/2)) over the steps with contact (Fig. 5a)."""
        keep = self.contact_half_width > 0
        ab, lb = self.abar[keep], self.lbar[keep]
        return lb / np.sqrt(ab), np.pi / 4.0 * ab**1.5

    def effective_work(self):
        """dgamma_eff/dgamma0 of each step with contact (docs/model.md, "Observables")."""
        x, y = self.scaled_curve()
        return theory.effective_work_ratio(x, y)


@dataclass
class Snapshots:
    """Profiles at chosen moments: ``time`` (s,), ``x`` (n,), ``surface`` u, ``pressure`` (the
    traction on the substrate, attractive positive) and ``gap``, each (s, n); file units."""

    time: np.ndarray
    x: np.ndarray
    surface: np.ndarray
    pressure: np.ndarray
    gap: np.ndarray


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
        The case file read (None for a run kept in memory).
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
        return bool(self.attrs.get("finished", False))

    @property
    def groups(self) -> dict:
        """The dimensionless groups stored with the case."""
        return {key: self.attrs[key] for key in ("lambda0", "lambda_inf", "k", "Vz", "chi_ve",
                                                 "alpha", "depth", "cell") if key in self.attrs}

    def pull_off(self) -> PullOff:
        """The pull-off point: the most tensile load of the series."""
        s = self.series
        if not s.load.size:
            raise ValueError(f"{self.path}: no step written yet")
        i = s.pull_off()
        return PullOff(index=i, load=float(s.load[i]), lbar=float(s.lbar[i]),
                       contact_half_width=float(s.contact_half_width[i]),
                       abar=float(s.abar[i]), indenter=float(s.indenter[i]),
                       time=float(s.time[i]))


def _attrs(f):
    return {k: (v.item() if hasattr(v, "item") else v) for k, v in f.attrs.items()}


def read_series(path) -> Series:
    """Read the series and root attributes of a case file (works on unfinished files too)."""
    with h5py.File(path, "r") as f:
        return _series(f)


def _series(f) -> Series:
    attrs = _attrs(f)
    s = f["series"]
    n = int(attrs.get("steps_complete", s["time"].shape[0]))
    return Series(attrs=attrs, **{name: s[name][:n] for name in SERIES})


def read_result(path) -> Result:
    """The series, the snapshots and the attributes of a case file (finished or not)."""
    with h5py.File(path, "r") as f:
        series = _series(f)
        snaps = f["snapshots"]
        count = int(snaps.attrs.get("complete", snaps["time"].shape[0]))
        snapshots = Snapshots(time=snaps["time"][:count], x=snaps["x"][:],
                              **{name: snaps[name][:count] for name in
                                 ("surface", "pressure", "gap")})
    return Result(path=str(path), attrs=series.attrs, series=series, snapshots=snapshots)
