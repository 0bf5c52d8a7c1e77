"""The loading protocol of one case (docs/model.md, "Protocol"; paper Eq. 16).

1. Start (t = 0): the preload, adhesive indentation of the RELAXED substrate (elastic, E0)
   from a flat surface to u_z = -h0, solved as one elastic problem (the loading-branch
   equilibrium); the material history starts fully relaxed, p_n = (|q| E0 / 2) u_n. A
   protocol that starts with an approach starts instead out of contact, flat and relaxed,
   the apex at u_z = 2 dmax (:data:`~hpcgfmd.model.loading.START_HEIGHT`).
2. Segments (:mod:`.schedule`): the drive follows the protocol's approaches, dwells and
   retractions, by default the paper's u_z(t) = -h0 + v_z t until no node has g <= dmax
   (complete detachment). One exact step of length dt per time step, each an elastic problem
   of stiffness (|q|/2) Eeff with a history traction H: the SLS's
   H = a p_n + (|q|/2)(E0 (1 - a) - Eeff) u_n (M8), or a Prony series' from its branch
   tractions (M40). With adaptive steps every step after a segment's first takes u
   quadratic in time through the last two accepted states instead (M46): modulus and
   history change, the step stays an elastic problem. Steps end exactly where segments
   do. Displacement control: jumps of the contact (into contact on an approach, off it on a
   retraction) are recorded, never a stop.

A compliant drive (``drive_stiffness`` k_s, :mod:`.drive`): the indenter hangs on a spring
whose far end, the drive, moves as u_z did; each step the indenter position is the unknown
that balances the spring (docs/model.md, "Protocol", (M43)); k_s = 0 is load control, the
protocol moving the applied load. Where the attached branch has
no balance left the indenter jumps: the step control shrinks the steps towards the jump and
takes it at dt_min, as it does a snap-off.

Internal units R = E0 = tau = 1 throughout; the output file converts to the case's units.
Every method is collective over the case's communicator: each rank holds its block of the
surface (:class:`hpcgfmd.parallel.domain.Domain`) and its share of the Fourier modes.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import NonConvergenceError
from ..model.case import Case
from ..model.interface import DugdaleMaugis
from ..model.loading import START_HEIGHT
from ..model.halfspace import MaxwellHalfSpace
from ..parallel.domain import Domain
from ..parallel.fft import aligned_empty, plan_real_fft
from ..solvers import make_solver
from ..solvers.predictor import Predictor
from ..solvers.step_kernels import all_beyond
from ..solvers.stepping import make_step_control
from .coarse_start import coarse_start
from .contact_edges import ContactEdges
from .drive import CompliantDrive
from .history_window import HistoryWindow
from .schedule import Schedule


@dataclass
class StepRecord:
    """Observables of one time step (internal units)."""

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

    def as_dict(self):
        """The series entries (under load control the drive is the applied load)."""
        return {**self.__dict__, "applied_load": self.drive}


def non_finite_report(sim, residual):
    """Collective: one line naming the step, the time and the state arrays of ``sim`` (a
    :class:`Retraction`) that hold non-finite values (after a solve whose residual was not
    finite)."""
    names = ("u", "history", "substrate_traction", "traction")
    bad = sim.domain.maxes(*(float(not np.isfinite(getattr(sim, name)).all())
                             for name in names))
    where = ", ".join(name for name, flag in zip(names, bad) if flag) or "none of the state"
    return (f"step {sim.step_index} (t = {sim.time:.6g} tau): the equilibrium solve's"
            f" residual is {residual}; non-finite values in: {where}")


class Retraction:
    """State and stepping of one case on the ranks of ``comm``.

    Parameters
    ----------
    case : Case
        The validated case (internal units).
    comm : mpi4py.MPI.Comm
        The ranks sharing this case (collective construction: plans the FFT).
    planner_effort : str
        FFTW planner flag (FFTW_MEASURE for runs, FFTW_ESTIMATE for quick tests).
    """

    FIELDS = ("u", "u_previous", "u_before_previous", "substrate_traction",
              "traction") + HistoryWindow.FIELDS

    def __init__(self, case: Case, comm, planner_effort="FFTW_MEASURE"):
        self.case = case
        n = case.numerics.nx
        self.n = n
        self.dx = case.cell / n
        self.planner_effort = planner_effort
        self.fft = plan_real_fft(comm, n, planner_effort=planner_effort)
        self.domain = Domain(comm, n, case.cell, self.fft.x_blocks)
        self.x = self.domain.x  # this rank's nodes; the indenter axis is on node n/2
        self.profile = self.x**2 / 2.0  # h(x) = x^2 / (2R), paper Eq. 1, R = 1
        self.half_q = np.pi * np.abs(self.fft.wavenumber) / case.cell  # |q|/2 per local mode
        self.substrate = MaxwellHalfSpace(case.material(), self.half_q, n, self.domain.local_n)
        substrate_fields = tuple(f"substrate.{name}" for name in self.substrate.state().arrays)
        self.field_names = self.FIELDS + substrate_fields
        self.law = DugdaleMaugis(case.sigma_a, case.dmax)
        self.solver = make_solver(case, self.domain, self.fft, self.law, self.half_q)
        self.steps = make_step_control(case)
        self.predictor = Predictor(self.domain, 4.0 * case.zone_width / case.k)
        # the history's time error, estimated where the step control uses it
        # (crossings: half the glassy zone width, w / (2 k), HistoryError's docstring)
        self.history_window = (HistoryWindow(self.substrate, self.fft, self.domain,
                                             self.profile, case.dmax,
                                             0.5 * case.zone_width / case.k)
                               if self.steps.adaptive and case.k < 1.0 else None)
        n = self.domain.local_n  # from here on: this rank's block
        # (aligned: the serial transform reads u and writes the history in place)
        self.u = aligned_empty(n)  # surface displacement, upward positive
        self.u[:] = 0.0
        self.substrate_traction = self.substrate.traction  # p_n (q != 0 part) of the history
        self.history = aligned_empty(n)
        self.history[:] = 0.0
        self.wall = np.empty(n)
        self.traction = np.zeros(n)  # interface traction on the substrate, attractive positive
        self.time = 0.0
        self.indenter = -case.depth
        self.drive = -case.depth  # Z(t) (the indenter itself without a spring)
        self.spring = CompliantDrive(case) if case.compliant else None
        self.schedule = Schedule(case.segments, case.load_control)
        self.step_index = 0
        self.total_iterations = 0
        self.rejected_steps = 0  # adaptive steps repeated with a shorter dt
        self.preload_iterations = 0
        self.preload_levels = []  # (nx, iterations) of the coarser preload levels (coarse_start)
        self.dt_previous = None  # length of the last accepted step (None after the preload)
        # adaptive steps of a viscous solid take the quadratic step (M46) once a step was
        # accepted; fixed steps keep the paper's linear one (M8)
        self.quadratic_history = self.steps.adaptive and case.k < 1.0
        self._step_before = None  # the step before of the step being solved (None: linear)
        self.edges = ContactEdges()  # of the last two steps
        self._reverted = ("u", "u_previous", "u_before_previous", "substrate_traction",
                          "traction", *substrate_fields)
        self._saved = {name: np.empty(n) for name in self._reverted}
        self._absent = np.zeros(n)  # a field the state does not have yet (read only)
        self._stiffness_u = np.empty(n)  # K u_n under a step's stiffness (the predictor's)
        self._gap_before = np.empty(n)  # the gap and contact of u_n under the last wall
        self._contact_before = np.empty(n, dtype=bool)

    # --- one equilibrium -------------------------------------------------------------
    def _equilibrate(self, ops, dt, solver, edge_watch=None, substrate_dt=None):
        """Solve the step; None when the solve was abandoned by ``edge_watch``.

        ``substrate_dt``: the step length the substrate's state advances by, when it is not
        ``dt`` (the preload: dt = 0 is recorded, the relaxed solid is dt = inf).
        """
        np.add(self.profile, self.indenter, out=self.wall)
        result = solver.solve(self.u, self.wall, ops, self.history, edge_watch=edge_watch)
        self.total_iterations += result.iterations
        if result.abandoned:
            return None
        if not math.isfinite(result.residual):  # a reduced value: every rank raises
            raise FloatingPointError(non_finite_report(self, result.residual))
        if not result.converged:
            raise NonConvergenceError(
                f"step {self.step_index} (t = {self.time:.6g}): residual {result.residual:.3g}"
                f" above tolerance {self.case.numerics.tolerance:g} after"
                f" {result.iterations} iterations; raise [numerics] max_iterations or reduce dt")
        solver.interface_traction(self.u, self.wall, self.history, result.mean_traction,
                                  self.traction)
        # Substrate traction of the new state, p_{n+1} = K u + H (zero mean), and the
        # substrate's own state
        self.substrate.update(solver.elastic_traction(), self.history,
                              dt if substrate_dt is None else substrate_dt,
                              None if substrate_dt is not None else self._step_before)
        return self._record(result, dt)

    def _record(self, result, dt):
        contact, zone = self.edges.record(self.domain, self.wall - self.u, self.case.dmax)
        return StepRecord(time=self.time, indenter=self.indenter, drive=self.drive,
                          segment=self.schedule.index,
                          load=-self.domain.sum(self.traction.sum()) * self.dx,
                          contact_half_width=contact, cohesive_half_width=zone,
                          iterations=result.iterations, residual=result.residual, dt=dt)

    # --- protocol ----------------------------------------------------------------------
    def preload(self) -> StepRecord:
        """The t = 0 state: the relaxed adhesive indentation to u_z = -h0, started from its
        solution on coarser grids when there are any (:mod:`.coarse_start`), else flat; or,
        when the protocol starts with an approach, the flat relaxed surface out of reach."""
        self.history[:] = 0.0
        if self.case.starts_out_of_contact:
            self.indenter = self.drive = START_HEIGHT * self.case.dmax
            self.u[:] = 0.0
        else:
            start, self.preload_levels = coarse_start(self.case, self.domain,
                                                      self.planner_effort, type(self))
            if start is not None:
                self.u[:] = start
        record = self._equilibrate(self.substrate.operators(math.inf), 0.0,
                                   self.solver.preload_solver(), substrate_dt=math.inf)
        if self.spring is not None:  # the spring holds the start's load
            self.drive = record.drive = self.spring.hold(self.indenter, record.load)
        self.schedule.begin(self.drive)
        self.preload_iterations = record.iterations
        self.steps.accept(record.time, record.load)
        return record

    def step(self) -> StepRecord:
        """Advance one accepted retraction time step (fixed or error-controlled length).

        A step whose error ratios exceed the rejection bounds (:mod:`hpcgfmd.solvers.stepping`)
        is undone and repeated with the shorter step the controller proposes; the iterations
        of the rejected attempts count in ``total_iterations``. A solve that reaches the
        iteration cap undoes the step too and raises NonConvergenceError: the state is then
        the last accepted step's.
        """
        proposed = self.steps.dt
        dt, end = self.schedule.cut(self.time, proposed)
        while True:
            self._save()
            try:
                record = self._advance(dt, end)
            except NonConvergenceError:
                # back to the last accepted step, which a checkpoint can keep: a higher
                # iteration cap continues from there
                self._revert()
                raise
            if record is None:  # abandoned: its edges moved too far, the verdict is known
                decision = self.steps.judge(dt, self.time, None, math.inf)
            else:
                step_error, kept = self._history_error()
                decision = self.steps.judge(
                    dt, record.time, record.load, self.edges.motion(), step_error,
                    record.cohesive_half_width - record.contact_half_width, kept)
            if decision.accepted:
                break
            self.rejected_steps += 1
            self._revert()
            proposed = decision.next_dt
            dt, end = self.schedule.cut(self.time, proposed)
        if end is not None and self.steps.dt >= dt:
            # a step cut short by the segment's end: the next one as proposed before the cut
            self.steps.dt = max(self.steps.dt, proposed)
        self.steps.accept(record.time, record.load)
        if self.history_window is not None:  # the corrected history; u_n becomes u_{n-1}
            self.history_window.accept(self.substrate_traction, self._saved["u"],
                                       self._saved_attrs["time"],
                                       self._saved_attrs["indenter"])
        if self.spring is not None:
            self.spring.accept(float(self._saved_attrs["indenter"]), self.indenter,
                               record.load, dt)
        self.dt_previous = dt
        return record

    def _history_error(self):
        """Collective: the load error of the last step's history and the part of it kept in
        the history after the correction (:class:`HistoryWindow`; 0 without one)."""
        if self.history_window is None:
            return 0.0, 0.0
        return self.history_window.estimate(
            self._saved["u"], float(self._saved_attrs["time"]),
            float(self._saved_attrs["indenter"]), self.u, self.time, self.indenter)

    def _advance(self, dt, end=None) -> StepRecord | None:
        """One step of length dt from the current state (paper Eq. 14; docs/model.md (M8), (M40)),
        ending at the segment's end time ``end`` when it is given.

        None when the solve was abandoned because its contact edges strayed beyond what the
        step control accepts (:meth:`~hpcgfmd.solvers.stepping.AdaptiveSteps.edge_limit`).
        """
        # the quadratic step spans the step before, which must lie in the same segment: the
        # drive's kink at a segment's start is not a curvature (the linear step is exact
        # there), and neither is the history estimate's window across it
        first_of_segment = 0 < self.step_index == self.schedule.start_step
        if first_of_segment and self.history_window is not None:
            self.history_window.restart()
        before = self._step_before = (
            self.dt_previous if self.quadratic_history and not first_of_segment else None)
        self.substrate.history(dt, self.history, before)
        gap_before = np.subtract(self.wall, self.u, out=self._gap_before)
        contact = np.less_equal(gap_before, 0.0, out=self._contact_before)
        self.step_index += 1
        if end is not None:  # the segment's end, exactly
            self.time = end
        elif self.steps.adaptive:
            self.time += dt
        else:  # no accumulated round-off over many equal steps
            self.time = self.schedule.fixed_time(self.step_index, dt)
        indenter_before = self.indenter
        self.drive = self.schedule.value(self.time)
        if self.spring is not None:  # the indenter's guess: its last rate
            self.indenter = self.spring.guess(indenter_before, dt)
        else:
            self.indenter = self.drive
        ops = self.substrate.operators(dt, before)
        np.add(self.profile, self.indenter, out=self.wall)
        if self.solver.starts_from_prediction:
            ratio = 1.0 if self.dt_previous is None else dt / self.dt_previous
            rise = (self.indenter - indenter_before if self.case.compliant
                    else self.schedule.rate() * dt)
            self.predictor.start(
                self.u, self.wall, gap_before, contact, rise, ratio,
                self.edges.current, self.edges.previous,
                lambda v, k_v=None: self.solver.energy(v, self.wall, ops, self.history,
                                                       stiffness_u=k_v),
                self.substrate.state_elastic_traction(dt, self._stiffness_u, before))
        if self.spring is not None:
            return self.spring.balance(self, ops, dt)
        return self._equilibrate(ops, dt, self.solver, self.edge_watch(dt))

    def equilibrate(self, ops, dt, edge_watch):
        """Collective: the step's equilibrium at the current indenter position (the
        compliant drive's search, :meth:`~hpcgfmd.runs.drive.CompliantDrive.balance`)."""
        return self._equilibrate(ops, dt, self.solver, edge_watch)

    def edge_watch(self, dt):
        """The limit on the solve's edge motion, or None (no contact before, or at dt_min)."""
        return self.edges.watch(self.steps.edge_limit(dt))

    def _save(self):
        """Keep the state before a step, to undo a rejected one (the fields :meth:`_revert`
        restores: the older state and the history estimate's change only once a step is
        accepted)."""
        fields, attrs = self.state()
        for name in self._reverted:
            self._saved[name][:] = fields[name]
        self._saved_attrs = attrs

    def _revert(self):
        self.restore(self._saved, self._saved_attrs, statistics=False)

    def detached(self) -> bool:
        """Collective: True when no node is within the interaction range (complete detachment)."""
        beyond = all_beyond(self.wall, self.u, self.case.dmax)  # (True on an empty block)
        return self.domain.min(1.0 if beyond else 0.0) > 0.0

    def finished(self) -> bool:
        """Collective: True when the protocol is over (after the last step's segment ended;
        the paper's protocol: at complete detachment)."""
        segment = self.schedule.index
        over = self.schedule.after_step(self.time, self.step_index, self.detached())
        if self.schedule.index != segment:
            self.steps.new_segment()
        return over

    def close(self):
        """Collective: release the transform's resources (its shared-memory window)."""
        self.fft.close()

    def gap(self):
        """This rank's block of the gap g = h + u_z - u (length)."""
        return self.wall - self.u

    # --- checkpoint ----------------------------------------------------------------------
    def state(self):
        """The full state after a step: (this rank's field blocks, rank-independent scalars).

        With it, :meth:`restore` continues the run exactly (the history H and the wall are
        recomputed from it at the next step): the fields of :attr:`field_names` (those of
        :attr:`FIELDS` and the substrate's), the clock, the
        contact edges of the last two steps, the predictor's, the step control's and the
        solver's state.
        """
        predicted, attrs = self.predictor.state(self.u)
        window = self.history_window
        fields = {"u": self.u, "substrate_traction": self.substrate_traction,
                  "traction": self.traction, **predicted,
                  **(window.fields(self._absent) if window
                     else dict.fromkeys(HistoryWindow.FIELDS, self._absent))}
        fields.update({f"substrate.{name}": block
                       for name, block in self.substrate.state().arrays.items()})
        attrs.update(time=self.time, indenter=self.indenter, step_index=self.step_index,
                     total_iterations=self.total_iterations, fft_pairs=self.fft.pairs,
                     rejected_steps=self.rejected_steps,
                     dt_previous=math.nan if self.dt_previous is None else self.dt_previous,
                     **self.edges.attrs(),
                     drive=self.drive)
        attrs.update(window.attrs() if window else HistoryWindow.empty_attrs())
        attrs.update(self.solver.statistics())
        attrs.update(self.steps.state())
        if self.spring is not None:
            attrs.update(self.spring.state())
        attrs.update(self.schedule.state())
        return fields, attrs

    def restore(self, fields, attrs, statistics=True):
        """Continue from :meth:`state` (this rank's blocks, possibly of another rank count).

        ``statistics=False`` keeps the counters of the work done (undoing a rejected step:
        its work was done).
        """
        self.u[:] = fields["u"]
        self.substrate_traction[:] = fields["substrate_traction"]
        self.traction[:] = fields["traction"]
        # (G_{n-1} of checkpoints written before it was kept: from u_{n-1}, the predictor's
        # or the history window's)
        u_before = (fields["u_previous"] if attrs.get("has_previous")
                    else fields.get("u_older")
                    if not math.isnan(float(attrs.get("time_older", math.nan))) else None)
        from ..state import State
        self.substrate.restore(State({name: fields[f"substrate.{name}"]
                                      for name in self.substrate.state().arrays}))
        self.time = float(attrs["time"])
        self.indenter = float(attrs["indenter"])
        # (absent from checkpoints before the compliant drive: displacement control)
        self.drive = float(attrs.get("drive", self.indenter))
        if self.spring is not None:
            self.spring.restore(attrs, statistics)
        # (checkpoints before protocols: the paper's retraction from the drive's start)
        self.schedule.restore(attrs, float(attrs.get("drive_start", -self.case.depth)))
        self.step_index = int(attrs["step_index"])
        self.edges.restore(attrs)
        if statistics:
            if self.history_window is not None:
                self.history_window.restore(
                    fields, attrs, lambda t: -self.case.depth + self.case.indenter_speed * t)
            self.predictor.restore(fields, attrs)
            self.total_iterations = int(attrs["total_iterations"])
            self.fft.pairs = int(attrs["fft_pairs"])
            self.rejected_steps = int(attrs["rejected_steps"])
            dt_previous = float(attrs["dt_previous"])
            self.dt_previous = None if math.isnan(dt_previous) else dt_previous
            self.solver.restore_statistics(attrs)
            self.steps.restore(attrs)
        else:  # the predictor's u_{n-1} and u_{n-2} go back too, its counters stay
            choices, rejected = self.predictor.choices, self.predictor.rejected
            self.predictor.restore(fields, attrs)
            self.predictor.choices, self.predictor.rejected = choices, rejected
        np.add(self.profile, self.indenter, out=self.wall)

    def summary(self) -> dict:
        """Counters of the run so far (rank-independent), for the output file's summary."""
        return {"steps": self.step_index, "iterations": self.total_iterations,
                "spring_solves": self.spring.solves if self.spring else 0,
                "fft_pairs": self.fft.pairs, "rejected_steps": self.rejected_steps,
                "rejected_predictions": self.predictor.rejected,
                "moving_edge_predictions": self.predictor.choices[1],
                **self.solver.statistics()}
