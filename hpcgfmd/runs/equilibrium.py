"""One time step's equilibrium at a given indenter position, and the record it leaves.

A step (docs/model.md, (M8), (M12)) is an elastic problem of the step's stiffness with the
substrate's history traction H, the hard wall and the cohesive law: :class:`Equilibrium`
solves it for the indenter at u_z (the wall h + u_z), forms the interface traction, advances
the substrate's state and measures the contact. Displacement control solves each step once;
the compliant drive (:mod:`.drive`) solves it at several indenter positions, each from the
last solve below the balance carried along by the indenter (:meth:`Equilibrium.anchor`).
Every method is collective over the case's communicator.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from ..errors import NonConvergenceError
from ..model.geometry import SURFACE_SERIES
from ..parallel.fft import aligned_empty
from .watch import StopRequested


@dataclass
class StepRecord:
    """Observables of one time step (internal units): one entry of the series.

    ``edges`` (the contact's left and right edges) is kept for the step control, not
    written. ``surface`` holds a surface's measures (:data:`SURFACE_SERIES`, from
    :class:`~hpcgfmd.model.geometry.ContactMeasure`'s areas and line), None on a line.
    """

    time: float
    indenter: float
    load: float
    contact_half_width: float
    cohesive_half_width: float
    iterations: int
    residual: float
    dt: float
    drive: float = math.nan  # the spring's far end (compliant drive; else the indenter)
    segment: int = 0  # the protocol's segment the step belongs to
    edges: tuple = field(default=(math.nan, math.nan), repr=False)
    surface: tuple | None = field(default=None, repr=False)

    def as_dict(self):
        """The series entries (under load control the drive is the applied load)."""
        values = asdict(self)
        del values["edges"], values["surface"]
        if self.surface is not None:
            values.update(zip(SURFACE_SERIES, self.surface))
        return {**values, "applied_load": self.drive}


class Equilibrium:
    """The equilibrium solves of one case's steps (module docstring).

    Parameters
    ----------
    run : Retraction
        The run whose surface (:class:`~.surface.Surface`), substrate, solver, geometry and
        schedule the solves use and advance.
    """

    def __init__(self, run):
        self.run = run
        n = run.domain.local_n
        self.history = aligned_empty(n)  # H of the step being solved
        self.history[:] = 0.0
        self.wall = np.empty(n)  # h + u_z
        self.iterations = 0  # of every solve, the rejected steps' too
        self._step = None  # (ops, dt, step_before, edge_watch, solver, relaxed)
        self._anchor = None  # (u_z, u, nodes within range) of the last solve below a balance

    def begin(self, ops, dt, step_before=None, edge_watch=None, solver=None, relaxed=False):
        """The step to solve: its operators, length and step before; ``relaxed``: the
        preload (recorded at dt = 0, the substrate relaxed: dt = inf)."""
        self._step = (ops, dt, step_before, edge_watch, solver or self.run.solver, relaxed)
        self._anchor = None

    @property
    def can_shorten(self) -> bool:
        """The step control may still shorten this step (it watches the solve's edges)."""
        return self._step[3] is not None

    def where(self) -> str:
        """The step and time, for messages."""
        surface = self.run.surface
        return f"step {surface.step_index} (t = {surface.time:.6g})"

    def solve(self, indenter: float) -> StepRecord | None:
        """Collective: the step's equilibrium with the indenter at ``indenter``, started
        from the anchor carried along by the indenter (if any), else from the current u;
        None when the solve was abandoned by the edge watch."""
        run, surface = self.run, self.run.surface
        ops, dt, step_before, watch, solver, relaxed = self._step
        if self._anchor is not None:
            z, u, near = self._anchor
            np.add(u, (indenter - z) * near, out=surface.u)
        surface.indenter = indenter
        self.place(indenter)
        result = solver.solve(
            surface.u, self.wall, ops, self.history, edge_watch=watch, watch=run.watch
        )
        self.iterations += result.iterations
        if result.interrupted:  # (alike on every rank: the flag is reduced)
            raise StopRequested(run.watch.phase)
        if result.abandoned:
            return None
        if not math.isfinite(result.residual):  # a reduced value: every rank raises
            raise FloatingPointError(self._non_finite(result.residual))
        if not result.converged:
            raise NonConvergenceError(
                f"{self.where()}: residual {result.residual:.3g} above tolerance"
                f" {run.case.numerics.tolerance:g} after {result.iterations} iterations;"
                " raise [numerics] max_iterations or reduce dt"
            )
        solver.problem.interface_traction(
            surface.u,
            solver.elastic_traction(),
            self.wall,
            self.history,
            result.mean_traction,
            surface.traction,
        )
        run.substrate.update(
            solver.elastic_traction(),
            self.history,
            math.inf if relaxed else dt,
            None if relaxed else step_before,
        )
        return self._record(result, 0.0 if relaxed else dt)

    def anchor(self):
        """Keep the last solve as the start of the next ones: its u, with the nodes within
        the interaction range carried along by the indenter."""
        surface = self.run.surface
        self._anchor = (surface.indenter, surface.u.copy(), self.gap() <= self.run.case.dmax)

    def place(self, indenter: float):
        """The wall h + u_z of the indenter at ``indenter`` (this rank's block, length)."""
        return np.add(self.run.profile, indenter, out=self.wall)

    def gap(self):
        """This rank's block of the gap g = h + u_z - u (length)."""
        return self.wall - self.run.surface.u

    def _record(self, result, dt) -> StepRecord:
        run, surface = self.run, self.run.surface
        measure = run.geometry.measure(run.domain, self.gap(), run.case.dmax)
        load = -run.domain.sum(surface.traction.sum()) * run.domain.node_area
        return StepRecord(
            time=surface.time,
            indenter=surface.indenter,
            drive=surface.drive,
            segment=run.schedule.index,
            load=load,
            contact_half_width=measure.contact,
            cohesive_half_width=measure.zone,
            iterations=result.iterations,
            residual=result.residual,
            dt=dt,
            edges=measure.edges,
            surface=None if measure.areas is None else (*measure.areas, *measure.line),
        )

    def _non_finite(self, residual) -> str:
        """Collective: one line naming the step and the state arrays that hold non-finite
        values (after a solve whose residual was not finite)."""
        run = self.run
        arrays = {
            "u": run.surface.u,
            "history": self.history,
            "substrate traction": run.substrate.traction,
            "traction": run.surface.traction,
        }
        bad = run.domain.maxes(*(float(not np.isfinite(a).all()) for a in arrays.values()))
        where = ", ".join(name for name, flag in zip(arrays, bad) if flag) or "none of the state"
        surface = run.surface
        return (
            f"step {surface.step_index} (t = {surface.time:.6g} tau): the equilibrium"
            f" solve's residual is {residual}; non-finite values in: {where}"
        )
