"""HDF5 output of one case, readable with plain h5py at every moment of the run.

Layout (all values in the case's units: R, E0, tau with ``[case]`` input; SI with
``[physical]``):

/                 attrs: hpcgfmd_version, config (case file text), lambda0, lambda_inf, k, Vz,
                  chi_ve, alpha, depth, cell, zone_points, nx, dt, tolerance, beta, load_scale,
                  length_unit/stress_unit/time_unit, vbar_convention, finished (bool),
                  steps_complete, with a [[protocol]] protocol_kinds (approach, dwell,
                  retract per segment), and when finished the run summary (steps, iterations,
                  wall_time, detachment_indenter, ...)
/series/          one entry per time step, preload end (t = 0) included:
                  time, indenter (u_z), load (per unit length, compressive positive),
                  contact_half_width, cohesive_half_width, iterations, residual, dt;
                  with a compliant drive also drive (the spring's far end), under load
                  control applied_load; with a [[protocol]] also segment (its index);
                  ``time`` is an HDF5 dimension scale attached to every other series
/snapshots/       time (s,), surface u, pressure p (traction on the substrate, attractive
                  positive), gap (each (s, nx)); x (nx,); attr complete; ``time`` and ``x``
                  are the dimension scales of the profiles' two axes

Every dataset has a ``units`` attribute (``R``, ``E0 R``, ``tau``, ... with ``[case]`` input;
``m``, ``N/m``, ``s``, ``Pa`` with ``[physical]``; ``1`` for counts and dimensionless values),
so that netCDF tools (xarray with h5netcdf) open the groups with labelled coordinates. Files
written before the scales existed have the same datasets and read the same way.

Parallel writing: every rank of the communicator opens the file (h5py ``mpio`` driver) and
calls every :class:`ResultFile` method collectively with identical arguments, except the field
blocks. Each rank owns the contiguous grid block [x_start, x_stop) (possibly empty) and writes
only that part of ``/snapshots/x`` and of each snapshot row; rank 0 alone writes the scalar
entries (series, snapshot times); attributes and dataset extents are set by all ranks alike
(HDF5 requires identical metadata calls on every rank).

Crash safety: the file is created after the preload, every step is appended, the root
attribute ``steps_complete`` is then raised, and the file is flushed (H5Fflush writes all
metadata), so a run killed between two steps leaves a file with every step done so far
(tested with SIGKILL); a kill between two datasets' appends can leave some series one entry
longer, and readers truncate the series to ``steps_complete`` (``/snapshots`` to its
``complete``). HDF5 without SWMR is not journaled: a kill in the middle of a flush can still
damage the file, which is why the checkpoint (written aside and renamed) is the restart
point, not this file. ``finished`` is set last.
:meth:`ResultFile.reopen` resumes such a file from a checkpoint's step and snapshot counts.
"""

from __future__ import annotations

import os

import numpy as np

from .. import __version__
from ..model.geometry import SURFACE_SERIES
from .hdf5 import check_blocks, open_file, write_block

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
SERIES_UNITS = {
    "time": "time",
    "indenter": "length",
    "load": "load",
    "contact_half_width": "length",
    "cohesive_half_width": "length",
    "iterations": None,
    "residual": None,
    "dt": "time",
    "drive": "length",
    "applied_load": "load",
    "segment": None,
    "contact_area": "area",
    "cohesive_area": "area",
    "contact_line_radius": "length",
    "out_of_roundness": None,
}
_INT_SERIES = ("iterations", "segment")
FIELDS = ("surface", "pressure", "gap")
# the names of the grid's axes in the order of its shape (their dimension scales)
AXES = {1: ("x",), 2: ("y", "x")}


def series_names(case):
    """The /series datasets of ``case``: :data:`SERIES`; ``drive`` with a compliant drive,
    ``applied_load`` under load control; ``segment`` with a protocol; a sphere's areas and
    contact line (:data:`~hpcgfmd.model.geometry.SURFACE_SERIES`)."""
    drive = ("applied_load",) if case.load_control else ("drive",) if case.compliant else ()
    surface = SURFACE_SERIES if case.sphere else ()
    return SERIES + drive + (("segment",) if case.protocol else ()) + surface


def unit_names(case) -> dict:
    """The ``units`` attribute of each dimension for ``case`` (a sphere's load is a force)."""
    names = dict(UNIT_NAMES[case.form])
    if case.sphere:
        names["load"] = names["force"]
    return names


FIELD_UNITS = {"surface": "length", "pressure": "stress", "gap": "length"}
# The ``units`` attribute of each dimension, by input form.
UNIT_NAMES = {
    "case": {
        "time": "tau",
        "length": "R",
        "area": "R^2",
        "load": "E0 R",
        "force": "E0 R^2",
        "stress": "E0",
        None: "1",
    },
    "physical": {
        "time": "s",
        "length": "m",
        "area": "m^2",
        "load": "N/m",
        "force": "N",
        "stress": "Pa",
        None: "1",
    },
}


# --- the result file --------------------------------------------------------------------------


class ResultFile:
    """Writer of one case's HDF5 file; every method is collective over ``comm``.

    Parameters
    ----------
    path : str or Path
        Output file; must not exist unless ``overwrite`` (the caller decides).
    case : hpcgfmd.case.Case
        The case (internal units); its ``units`` convert to the file's units.
    grid : hpcgfmd.parallel.domain.Domain
        The surface grid: its ``shape``, its ``axes`` (the global coordinates of each axis,
        internal length units) and this rank's block ``[x_start, x_stop)`` along the first
        axis (possibly empty).
    comm : mpi4py.MPI.Comm
        Ranks writing the file together.
    overwrite : bool
        Replace an existing file.
    """

    def __init__(self, path, case, grid, comm, overwrite=False):
        first, stop = grid.first_axis_block
        check_blocks(comm, grid.shape[0], first, stop)
        if not overwrite and os.path.exists(path):  # mpio's "w-" raises a bare OSError
            raise FileExistsError(f"{path}: file exists")
        self._setup(open_file(path, "w" if overwrite else "w-", comm), case, comm, first)
        self._write_attributes(case)
        names = unit_names(case)
        series = self.file.create_group("series")
        for name in series_names(case):
            dtype = "i8" if name in _INT_SERIES else "f8"
            ds = series.create_dataset(
                name, shape=(0,), maxshape=(None,), dtype=dtype, chunks=(1024,)
            )
            ds.attrs["units"] = names[SERIES_UNITS[name]]
        _attach(series["time"], [series[name] for name in series_names(case) if name != "time"], 0)
        self._create_snapshots(grid, names)
        self.file.flush()

    def _write_attributes(self, case):
        """The root attributes: the case, its groups, numerics and scales (file units)."""
        attrs, num, units = self.file.attrs, case.numerics, case.units
        attrs["hpcgfmd_version"] = __version__
        attrs["config"] = case.text
        attrs["case_identity"] = case.identity()  # what a resumed run or the farm compares
        for key, value in case.groups().items():
            attrs[key] = value
        attrs["nx"] = num.nx
        attrs["geometry"] = case.geometry
        attrs["shape"] = list(num.shape)
        attrs["dt"] = num.dt * units.time
        attrs["tolerance"] = num.tolerance
        attrs["solver"] = num.solver
        attrs["step_control"] = num.step_control
        attrs["dt_min"] = num.dt_min * units.time
        attrs["dt_max"] = num.dt_max * units.time
        attrs["edge_fraction"] = num.edge_fraction
        attrs["load_tolerance"] = num.load_tolerance
        attrs["time_tolerance"] = num.time_tolerance
        attrs["accuracy"] = num.accuracy
        for key, value in num.solver_settings:  # the solver's own keys
            attrs[key] = value
        attrs["beta"] = case.beta * units.length
        attrs["dmax"] = case.dmax * units.length
        attrs["load_scale"] = case.load_scale * case.load_unit
        attrs["length_unit"] = units.length
        attrs["stress_unit"] = units.stress
        attrs["time_unit"] = units.time
        attrs["vbar_convention"] = (
            "vbar = 2 pi rhodot tau / (k c0): retardation time tau/k,"
            " see hpcgfmd.model.theory.persson_brener"
        )
        if case.protocol:
            attrs["protocol_kinds"] = [segment.kind for segment in case.protocol]
        attrs["finished"] = False
        attrs["steps_complete"] = 0  # entries of /series fully written (readers truncate to it)

    def _create_snapshots(self, grid, names):
        """/snapshots: the axes (x, y, ...) and the growing profiles of the grid's shape."""
        snaps = self.file.create_group("snapshots")
        axes = []
        for name, values in zip(AXES[len(grid.shape)], grid.axes()):
            axis = snaps.create_dataset(name, shape=values.shape, dtype="f8")
            axis.attrs["units"] = names["length"]
            write_block(axis, 0, values * self.units.length if self.comm.rank == 0 else np.empty(0))
            axes.append(axis)
        times = snaps.create_dataset("time", shape=(0,), maxshape=(None,), dtype="f8", chunks=(64,))
        times.attrs["units"] = names["time"]
        meaning = {
            "surface": "displacement u, upward positive (length)",
            "pressure": "traction on the substrate, attractive positive (stress)",
            "gap": "g = h + u_z - u (length)",
        }
        shape = tuple(grid.shape)
        profiles = []
        for name in FIELDS:
            ds = snaps.create_dataset(
                name, shape=(0,) + shape, maxshape=(None,) + shape, dtype="f8", chunks=(1,) + shape
            )
            ds.attrs["meaning"] = meaning[name]
            ds.attrs["units"] = names[FIELD_UNITS[name]]
            profiles.append(ds)
        _attach(times, profiles, 0)
        for dimension, axis in enumerate(reversed(axes)):  # the last axis is x
            _attach(axis, profiles, len(shape) - dimension)
        snaps.attrs["complete"] = 0

    def _setup(self, file, case, comm, x_start):
        self.file, self.comm, self.x_start = file, comm, x_start
        self.series_names = series_names(case)
        self.units = case.units
        self._scale = {
            "time": case.units.time,
            "length": case.units.length,
            "area": case.units.length**2,
            "load": case.load_unit,
            None: 1.0,
        }

    @classmethod
    def reopen(cls, path, case, grid, comm, steps, snapshots):
        """Reopen an existing result file to resume a run (collective).

        Parameters
        ----------
        path : str or Path
            Result file written by an earlier (killed) run of the same case.
        case : hpcgfmd.case.Case
            The case (for the units).
        grid : hpcgfmd.parallel.domain.Domain
            The surface grid (its shape must be the file's) and this rank's block.
        comm : mpi4py.MPI.Comm
            Ranks writing from now on (any number).
        steps, snapshots : int
            Entries of /series and /snapshots to keep (those of the checkpoint resumed
            from); later ones are dropped. At most ``steps_complete`` and ``complete``.

        Returns
        -------
        ResultFile
            Marked unfinished, with the case's text and identity; the next
            :meth:`append_step` writes entry ``steps``.
        """
        self = cls.__new__(cls)
        file = open_file(path, "r+", comm)
        try:
            have = (int(file.attrs["steps_complete"]), int(file["snapshots"].attrs["complete"]))
            shape = file["snapshots/surface"].shape[1:]
            if shape != tuple(grid.shape):
                raise ValueError(f"{path}: has a grid of {shape} nodes, not {tuple(grid.shape)}")
            if not (0 <= steps <= have[0] and 0 <= snapshots <= have[1]):
                raise ValueError(
                    f"{path}: cannot resume at {steps} steps and {snapshots}"
                    f" snapshots, the file holds {have[0]} and {have[1]}"
                )
        except BaseException:
            file.close()
            raise
        self._setup(file, case, comm, grid.first_axis_block[0])
        file.attrs["finished"] = False  # before truncating: a kill now leaves an unfinished file
        # the case as it runs on (it may differ in what its identity leaves out: [output],
        # max_iterations), under the identity of this version
        file.attrs["config"] = case.text
        file.attrs["case_identity"] = case.identity()
        for name in self.series_names:
            file["series"][name].resize((steps,))
        file.attrs["steps_complete"] = steps
        snaps = file["snapshots"]
        snaps["time"].resize((snapshots,))
        for name in FIELDS:
            snaps[name].resize((snapshots,) + shape)
        snaps.attrs["complete"] = snapshots
        file.flush()
        return self

    def append_step(self, values: dict):
        """Append one time step's series entries and flush (collective).

        Parameters
        ----------
        values : dict
            One scalar per name of :data:`SERIES`, internal units (rank-independent; rank 0's
            are written).
        """
        series = self.file["series"]
        i = series["time"].shape[0]
        for name in self.series_names:
            ds = series[name]
            ds.resize((i + 1,))
            scalar = [values[name] * self._scale[SERIES_UNITS[name]]] if self.comm.rank == 0 else []
            write_block(ds, i, scalar)
        self.file.attrs["steps_complete"] = i + 1  # after every dataset holds the step
        self.file.flush()

    def add_snapshot(self, time, surface, pressure, gap):
        """Append one snapshot row and flush (collective).

        Parameters
        ----------
        time : float
            Time of the snapshot (internal units; rank-independent).
        surface, pressure, gap : ndarray
            This rank's blocks (flat, or of its block's shape; possibly empty) of the surface
            displacement (length), the traction on the substrate (stress) and the gap
            (length), internal units.
        """
        snaps = self.file["snapshots"]
        i = snaps["time"].shape[0]
        shape = snaps["surface"].shape[1:]
        snaps["time"].resize((i + 1,))
        write_block(snaps["time"], i, [time * self.units.time] if self.comm.rank == 0 else [])
        for name, field, scale in (
            ("surface", surface, self.units.length),
            ("pressure", pressure, self.units.stress),
            ("gap", gap, self.units.length),
        ):
            snaps[name].resize((i + 1,) + shape)
            block = np.asarray(field).reshape((-1,) + shape[1:])  # whole but the first axis
            write_block(snaps[name], self.x_start, block * scale, row=i)
        snaps.attrs["complete"] = i + 1
        self.file.flush()

    def finish(self, summary: dict):
        """Store the run summary and mark the file finished, the last write (collective).

        Parameters
        ----------
        summary : dict
            Attribute name to scalar or string, in the file's units. Rank 0's dict is stored
            on every rank: HDF5 needs identical attribute writes and e.g. wall times differ.
        """
        for key, value in self.comm.bcast(summary, root=0).items():
            self.file.attrs[key] = value
        self.file.attrs["finished"] = True
        self.file.flush()

    def close(self):
        """Close the file (collective)."""
        self.file.close()


def _attach(scale, datasets, axis):
    """Make ``scale`` a dimension scale named after itself and attach it to ``axis`` of each
    dataset (collective metadata under mpio: every rank makes the same calls)."""
    scale.make_scale(scale.name.rsplit("/", 1)[-1])
    for ds in datasets:
        ds.dims[axis].attach_scale(scale)
