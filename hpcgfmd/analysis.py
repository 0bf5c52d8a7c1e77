"""Post-processing of a case file (reads HDF5 only; no solver imports)."""
from __future__ import annotations

from dataclasses import dataclass

import h5py
import numpy as np

from . import theory


@dataclass
class Series:
    """The /series of a case file plus the scales needed for the paper's plots.

    All arrays in the file's units; ``beta`` and ``load_scale`` in the same units.
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
        return self.contact_half_width / self.attrs["beta"]

    @property
    def lbar(self):
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
        """dgamma_eff/dgamma0 of each retraction step with contact (physics.md, Observables)."""
        x, y = self.scaled_curve()
        return theory.effective_work_ratio(x, y)


def read_series(path) -> Series:
    """Read the series and root attributes of a case file (works on unfinished files too)."""
    with h5py.File(path, "r") as f:
        attrs = {k: (v.item() if hasattr(v, "item") else v) for k, v in f.attrs.items()}
        s = f["series"]
        n = int(attrs.get("steps_complete", s["time"].shape[0]))
        return Series(attrs=attrs, **{name: s[name][:n] for name in
                                      ("time", "indenter", "load", "contact_half_width",
                                       "cohesive_half_width", "iterations", "residual", "dt")})
