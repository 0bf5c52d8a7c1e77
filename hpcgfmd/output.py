"""HDF5 output of one case, readable with plain h5py at every moment of the run.

Layout (all values in the case's units: R, E0, tau with ``[case]`` input; SI with
``[physical]``):

/                 attrs: hpcgfmd_version, config (case file text), lambda0, lambda_inf, k, Vz,
                  chi_ve, alpha, depth, cell, zone_points, nx, dt, tolerance, beta, load_scale,
                  length_unit/stress_unit/time_unit, finished (bool), and when finished:
                  steps, iterations, wall_time, detachment_indenter
/series/          one entry per time step, preload end (t = 0) included:
                  time, indenter (u_z), load (per unit length, compressive positive),
                  contact_half_width, cohesive_half_width, iterations, residual, dt
/snapshots/       time (s,), surface u, pressure p (traction on the substrate, attractive
                  positive), gap (each (s, nx)); x (nx,)

Crash safety: the file is created after the preload, every step is appended, the root
attribute ``steps_complete`` is then raised, and the file is flushed (H5Fflush writes all
metadata), so a killed run leaves a file with every step done so far; a kill between two
datasets' appends can leave some series one entry longer, and readers truncate the series to
``steps_complete`` (``/snapshots`` to its ``complete``). ``finished`` is set last. The file is
written by one process (serial h5py driver).
"""
from __future__ import annotations

import h5py
import numpy as np

from . import __version__

SERIES = ("time", "indenter", "load", "contact_half_width", "cohesive_half_width",
          "iterations", "residual", "dt")
SERIES_UNITS = {"time": "time", "indenter": "length", "load": "load",
                "contact_half_width": "length", "cohesive_half_width": "length",
                "iterations": None, "residual": None, "dt": "time"}
_INT_SERIES = ("iterations",)


class CaseFile:
    """Writer of one case's HDF5 file (serial).

    Parameters
    ----------
    path : str or Path
        Output file; must not exist (the caller decides about overwriting).
    case : hpcgfmd.config.Case
        The case (internal units); its ``units`` convert to the file's units.
    x : ndarray
        Grid positions (internal units).
    """

    def __init__(self, path, case, x, overwrite=False):
        self.units = case.units
        self._scale = {"time": case.units.time, "length": case.units.length,
                       "load": case.units.load, None: 1.0}
        self.file = h5py.File(path, "w" if overwrite else "w-")
        attrs = self.file.attrs
        attrs["hpcgfmd_version"] = __version__
        attrs["config"] = case.text
        for key, value in case.groups().items():
            attrs[key] = value
        attrs["nx"] = case.numerics.nx
        attrs["dt"] = case.numerics.dt * case.units.time
        attrs["tolerance"] = case.numerics.tolerance
        attrs["beta"] = case.beta * case.units.length
        attrs["load_scale"] = case.load_scale * case.units.load
        attrs["length_unit"] = case.units.length
        attrs["stress_unit"] = case.units.stress
        attrs["time_unit"] = case.units.time
        attrs["vbar_convention"] = ("vbar = 2 pi rhodot tau / (k c0): retardation time tau/k,"
                                    " see hpcgfmd.theory.persson_brener")
        attrs["finished"] = False
        attrs["steps_complete"] = 0  # entries of /series fully written (readers truncate to it)
        series = self.file.create_group("series")
        for name in SERIES:
            dtype = "i8" if name in _INT_SERIES else "f8"
            series.create_dataset(name, shape=(0,), maxshape=(None,), dtype=dtype, chunks=(1024,))
        snaps = self.file.create_group("snapshots")
        n = x.shape[0]
        snaps.create_dataset("x", data=x * case.units.length)
        snaps.create_dataset("time", shape=(0,), maxshape=(None,), dtype="f8", chunks=(64,))
        meaning = {"surface": "displacement u, upward positive (length)",
                   "pressure": "traction on the substrate, attractive positive (stress)",
                   "gap": "g = h + u_z - u (length)"}
        for name in ("surface", "pressure", "gap"):
            ds = snaps.create_dataset(name, shape=(0, n), maxshape=(None, n), dtype="f8",
                                      chunks=(1, n))
            ds.attrs["meaning"] = meaning[name]
        snaps.attrs["complete"] = 0
        self.file.flush()

    def append_step(self, values: dict):
        """Append one time step's series entries (internal units) and flush."""
        series = self.file["series"]
        for name in SERIES:
            ds = series[name]
            i = ds.shape[0]
            ds.resize((i + 1,))
            ds[i] = values[name] * self._scale[SERIES_UNITS[name]]
        self.file.attrs["steps_complete"] = i + 1  # after every dataset holds the step
        self.file.flush()

    def add_snapshot(self, time, surface, pressure, gap):
        """Append one snapshot of the surface displacement, traction and gap (internal units)."""
        snaps = self.file["snapshots"]
        i = snaps["time"].shape[0]
        snaps["time"].resize((i + 1,))
        snaps["time"][i] = time * self.units.time
        for name, field, scale in (("surface", surface, self.units.length),
                                   ("pressure", pressure, self.units.stress),
                                   ("gap", gap, self.units.length)):
            snaps[name].resize((i + 1, surface.shape[0]))
            snaps[name][i] = field * scale
        snaps.attrs["complete"] = i + 1
        self.file.flush()

    def finish(self, summary: dict):
        """Store the run summary and mark the file finished (the last write)."""
        for key, value in summary.items():
            self.file.attrs[key] = value
        self.file.attrs["finished"] = True
        self.file.flush()

    def close(self):
        self.file.close()
