"""The loading protocol of one case (docs/model.md, "Protocol"; paper Eq. 16).

1. Start (t = 0): the preload, adhesive indentation of the RELAXED substrate (elastic, E0)
   from a flat surface to u_z = -h0, solved as one elastic problem (the loading-branch
   equilibrium); the material history starts fully relaxed. A protocol that starts with an
   approach starts instead out of contact, flat and relaxed, the apex at u_z = 2 dmax
   (:data:`~hpcgfmd.model.loading.START_HEIGHT`).
2. Segments (:mod:`.schedule`): the drive follows the protocol's approaches, dwells and
   retractions, by default the paper's u_z(t) = -h0 + v_z t until no node has g <= dmax
   (complete detachment). One exact step of length dt per time step, each an elastic problem
   of stiffness (|q|/2) Eeff with a history traction H ((M8), (M40)); with adaptive steps
   every step after a segment's first takes u quadratic in time through the last two
   accepted states (M46). Steps end exactly where segments do. Displacement control: jumps
   of the contact (into contact on an approach, off it on a retraction) are recorded, never
   a stop. A compliant drive (``drive_stiffness``, :mod:`.drive`) balances the indenter on
   its spring every step; k_s = 0 is load control.

The run is made of parts (:mod:`hpcgfmd.state`): the surface, the substrate's history, the
contact edges, the predictor, the step control, the history window, the schedule and the
drive. :class:`~.run_state.RunState` gathers their states without knowing their fields, to
undo a rejected step and to write checkpoints. Internal units R = E0 = tau = 1 throughout.
Every method is collective over the case's communicator.
"""

from __future__ import annotations

import math
import time

from ..errors import NonConvergenceError
from ..model.grid import grid_label
from ..model.halfspace import MaxwellHalfSpace
from ..model.interface import DugdaleMaugis
from ..model.loading import START_HEIGHT
from ..parallel.domain import Domain
from ..parallel.fft import PLANNING_TIMELIMIT, aligned_empty, plan_real_fft
from ..solvers import make_solver
from ..solvers.predictor import Predictor
from ..solvers.step_kernels import all_beyond
from ..solvers.stepping import StepOutcome, make_step_control
from .coarse_start import coarse_start, preload_grids
from .contact_edges import ContactEdges
from .drive import CompliantDrive
from .equilibrium import Equilibrium, StepRecord
from .history_window import HistoryWindow
from .progress import duration_text
from .run_state import RunState
from .schedule import Schedule
from .surface import Surface
from .watch import StopRequested, Watch

PLANNING_NOTED = 2**18  # grids from this size say when they plan their transforms
# A preload level started from the one below takes a few to a few tens of iterations (the
# default case's levels 8 to 31, docs/results.md "Scaling"): the estimate before one ran.
STARTED_LEVEL_ITERATIONS = 12
# A sphere's radial moving-edge guess moves the gap within this many glassy zone widths w / k
# of the contact's radius (elastic lambda0 = 5 on 768^2 at 1e-2: 0.5, 1, 2 and 4 took 1921, 1511,
# 1479 and 1497 iterations, 1773 without the guess; docs/results.md, "The sphere")
RADIAL_WINDOW = 2.0


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

    def __init__(self, case, comm, planner_effort="FFTW_MEASURE", watch=None):
        self.case, self.planner_effort = case, planner_effort
        self.watch = Watch() if watch is None else watch
        self.n = case.numerics.nx  # nodes along x (the preload's levels are named by it)
        shape = case.numerics.shape
        self.fft = _planned(comm, shape, planner_effort, self.watch)
        self.domain = Domain(comm, shape, case.cell, self.fft.x_blocks)
        self.surface_grid = self.domain.dimensions == 2
        self.geometry = case.indenter()
        self.profile = self.geometry.profile(self.domain.coordinates)
        half_q = self.fft.half_wavenumbers(case.cell)  # |q|/2 per local mode
        self.substrate = MaxwellHalfSpace(
            case.material(), half_q, self.domain.n, self.domain.local_n
        )
        law = DugdaleMaugis(case.sigma_a, case.dmax)
        self.solver = make_solver(case, self.domain, self.fft, law, half_q)
        self.steps = make_step_control(case)
        self.predictor = Predictor(
            self.domain,
            4.0 * case.zone_width / case.modulus_ratio,
            RADIAL_WINDOW * case.zone_width / case.modulus_ratio if case.sphere else None,
        )
        # adaptive steps of a viscous solid estimate the history's time error and take the
        # quadratic step (M46) once a step was accepted; fixed steps keep the linear one (M8)
        self.quadratic = self.steps.adaptive and case.modulus_ratio < 1.0
        # (crossings: half the glassy zone width, w / (2 k), HistoryError's docstring; on a
        # surface the nodes that changed their state alone)
        self.window = (
            HistoryWindow(
                self.substrate,
                self.fft,
                self.domain,
                self.profile,
                case.dmax,
                0.0 if self.surface_grid else 0.5 * case.zone_width / case.modulus_ratio,
            )
            if self.quadratic
            else None
        )
        self.surface = Surface(self.domain.local_n, -case.depth)
        self.schedule = Schedule(case.segments, case.load_control)
        self.spring = CompliantDrive(case) if case.compliant else None
        self.edges = ContactEdges()
        self.equilibrium = Equilibrium(self)
        self._k_u = aligned_empty(self.domain.local_n)  # K u_n under a step's stiffness
        self.state = _run_state(self)
        self.rejected_steps = 0  # adaptive steps repeated with a shorter dt
        self.preload_iterations = 0
        self.preload_levels = []  # (nx, iterations) of the coarser preload levels

    # --- protocol ----------------------------------------------------------------------
    def preload(self) -> StepRecord:
        """The t = 0 state: the relaxed adhesive indentation to u_z = -h0, started from its
        solution on coarser grids when there are any (:mod:`.coarse_start`), else flat; or,
        when the protocol starts with an approach, the flat relaxed surface out of reach."""
        surface, case, watch = self.surface, self.case, self.watch
        if case.starts_out_of_contact:
            surface.indenter = surface.drive = START_HEIGHT * case.dmax
        elif not self.surface_grid:  # (a surface's preload starts flat)
            if watch.levels is None:  # the finest level: the grids of all
                watch.levels = preload_grids(case)
            start, self.preload_levels = coarse_start(
                case, self.domain, self.planner_effort, type(self), watch
            )
            if start is not None:
                surface.u[:] = start
        self.equilibrium.begin(
            self.substrate.operators(math.inf),
            math.inf,
            solver=self.solver.preload_solver(),
            relaxed=True,
        )
        started = time.monotonic()
        watch.enter(f"preload{_level(watch.levels, self.n)}")
        record = self.equilibrium.solve(surface.indenter)
        seconds = time.monotonic() - started
        if self.surface_grid:
            if seconds >= 1.0:
                watch.note(_surface_line(self.domain.shape, record.iterations, seconds))
        else:
            _note_level(watch, self.n, record.iterations, seconds)
        self.edges.advance(record.edges)
        if self.spring is not None:  # the spring holds the start's load
            surface.drive = record.drive = self.spring.hold(surface.indenter, record.load)
        self.schedule.begin(surface.drive)
        self.preload_iterations = record.iterations
        self.steps.accept(record.time, record.load, drive=surface.drive)
        return record

    def step(self) -> StepRecord:
        """Advance one accepted time step (fixed or error-controlled length).

        A step whose error ratios exceed the rejection bounds (:mod:`hpcgfmd.solvers.stepping`)
        is undone (every part's state, :mod:`.run_state`) and repeated with the shorter step
        the controller proposes. A solve that reaches the iteration cap undoes the step too
        and raises NonConvergenceError: the state is then the last accepted step's.
        """
        proposed = self.steps.dt
        dt, end = self.schedule.cut(self.surface.time, proposed)
        while True:
            self.state.save()
            try:
                record = self._advance(dt, end)
            except (NonConvergenceError, StopRequested):
                self.state.revert()  # a checkpoint keeps the last accepted step
                raise
            decision = self.steps.judge(self._outcome(record, dt))
            if decision.accepted:
                break
            self.rejected_steps += 1
            self.state.revert()
            proposed = decision.next_dt
            dt, end = self.schedule.cut(self.surface.time, proposed)
        self._accept(record, dt, proposed if end is not None else None)
        return record

    def _outcome(self, record, dt) -> StepOutcome:
        """Collective: what the step control judges of an attempt (None: abandoned)."""
        if record is None:
            return StepOutcome(dt, self.surface.time, None, math.inf)
        self.edges.advance(record.edges)
        error, kept = 0.0, 0.0
        if self.window is not None:
            before = self.state.saved("surface")
            error, kept = self.window.estimate(
                before.arrays["u"],
                float(before.scalars["time"]),
                float(before.scalars["indenter"]),
                self.surface.u,
                self.surface.time,
                self.surface.indenter,
            )
        return StepOutcome(
            dt,
            record.time,
            record.load,
            self.edges.motion(),
            error,
            kept,
            record.cohesive_half_width - record.contact_half_width,
        )

    def _accept(self, record, dt, cut_from):
        """The attempt is the new state: the controllers and the history window move on."""
        self.steps.accept(record.time, record.load, cut_from, self.surface.drive)
        before = self.state.saved("surface")
        if self.window is not None:  # the corrected history; u_n becomes u_{n-1}
            self.window.accept(
                before.arrays["u"], before.scalars["time"], before.scalars["indenter"]
            )
        if self.spring is not None:
            self.spring.accept(
                float(before.scalars["indenter"]), self.surface.indenter, record.load, dt
            )
        self.surface.dt_previous = dt

    def _advance(self, dt, end=None) -> StepRecord | None:
        """One step of length dt from the current state ((M8), (M40), (M46)), ending at the
        segment's end time ``end`` when it is given; None when the solve was abandoned
        (its contact edges strayed beyond what the step control accepts)."""
        surface, schedule = self.surface, self.schedule
        # the quadratic step spans the step before, which must lie in the same segment: the
        # drive's kink at a segment's start is no curvature, and no history window spans it
        first_of_segment = 0 < surface.step_index == schedule.start_step
        if first_of_segment and self.window is not None:
            self.window.restart()
        before = surface.dt_previous if self.quadratic and not first_of_segment else None
        equilibrium = self.equilibrium
        self.substrate.history(dt, equilibrium.history, before)
        equilibrium.place(surface.indenter)
        gap_before = equilibrium.gap()  # under the last step's wall
        surface.step_index += 1
        self.watch.enter(f"solve of step {surface.step_index}")
        if end is not None:  # the segment's end, exactly
            surface.time = end
        elif self.steps.adaptive:
            surface.time += dt
        else:  # no accumulated round-off over many equal steps
            surface.time = schedule.fixed_time(surface.step_index, dt)
        indenter_before = surface.indenter
        surface.drive = schedule.value(surface.time)
        indenter = (
            self.spring.guess(indenter_before, dt) if self.spring is not None else surface.drive
        )
        ops = self.substrate.operators(dt, before)
        equilibrium.begin(ops, dt, before, self.edges.watch(self.steps.edge_limit(dt)))
        if self.solver.starts_from_prediction:
            rise = indenter - indenter_before if self.case.compliant else schedule.rate() * dt
            self._predict(ops, dt, before, indenter, gap_before, rise)
        if self.spring is not None:
            return self.spring.balance(equilibrium, surface.drive, indenter)
        return equilibrium.solve(indenter)

    def _predict(self, ops, dt, before, indenter, gap_before, rise):
        """Collective: start the solve from the predictor's best guess (:mod:`.predictor`)."""
        surface, wall = self.surface, self.equilibrium.place(indenter)
        ratio = 1.0 if surface.dt_previous is None else dt / surface.dt_previous
        history = self.equilibrium.history
        self.predictor.start(
            surface.u,
            wall,
            gap_before,
            gap_before <= 0.0,
            rise,
            ratio,
            self.edges.current,
            self.edges.previous,
            lambda v, k_v=None: self.solver.problem.energy(v, wall, ops, history, stiffness_u=k_v),
            self.substrate.state_elastic_traction(dt, self._k_u, before),
        )

    def detached(self) -> bool:
        """Collective: True when no node is within the interaction range (complete detachment)."""
        wall = self.equilibrium.place(self.surface.indenter)
        beyond = all_beyond(wall, self.surface.u, self.case.dmax)  # (True on an empty block)
        return self.domain.min(1.0 if beyond else 0.0) > 0.0

    def finished(self) -> bool:
        """Collective: True when the protocol is over (after the last step's segment ended;
        the paper's protocol: at complete detachment)."""
        segment = self.schedule.index
        over = self.schedule.after_step(self.surface.time, self.surface.step_index, self.detached())
        if self.schedule.index != segment:
            self.steps.new_segment()
        return over

    def close(self):
        """Collective: release the transform's resources (its shared-memory window)."""
        self.fft.close()

    # --- counters ------------------------------------------------------------------------
    def counters(self) -> dict:
        """The run's own counters (iterations of every solve, rejected steps, the preload's)."""
        return {
            "iterations": self.equilibrium.iterations,
            "rejected_steps": self.rejected_steps,
            "preload_iterations": self.preload_iterations,
        }

    def restore_counters(self, counters: dict):
        self.equilibrium.iterations = int(counters["iterations"])
        self.rejected_steps = int(counters["rejected_steps"])
        self.preload_iterations = int(counters["preload_iterations"])

    def summary(self) -> dict:
        """Counters of the run so far (rank-independent), for the output file's summary."""
        return {"steps": self.surface.step_index, "spring_solves": 0, **self.state.counters()}


def _planned(comm, shape, planner_effort, watch):
    """Collective: the real FFT of a grid of ``shape`` on ``comm``, planned with a line
    before a large grid's planning and after a slow one."""
    nodes = math.prod(shape)
    label = " x ".join(grid_label(k) for k in shape)
    large = nodes >= PLANNING_NOTED
    if large:
        watch.note(
            f"planning the transforms of {label} nodes on {comm.Get_size()} rank(s)"
            f" ({planner_effort}, each plan at most {PLANNING_TIMELIMIT:g} s)"
        )
    watch.enter(f"planning of the transforms of {label} nodes")
    started = time.monotonic()
    fft = plan_real_fft(comm, shape if len(shape) > 1 else shape[0], planner_effort=planner_effort)
    if large:
        watch.note(f"planned in {time.monotonic() - started:.1f} s")
    return fft


def _level(levels, n) -> str:
    """ ", level k of K (2^a nodes)" of the preload's grid n among ``levels`` (or "")."""
    if not levels or n not in levels:
        return ""
    return f", level {levels.index(n) + 1} of {len(levels)} ({grid_label(n)} nodes)"


def _surface_line(shape, iterations, seconds) -> str:
    """The line after a surface's preload (one level: it starts flat)."""
    label = " x ".join(grid_label(k) for k in shape)
    return f"preload ({label} nodes): {iterations} iterations, {seconds:.1f} s"


def _note_level(watch, n, iterations, seconds):
    """A line after a preload level, when there are several or it was slow, with the time
    the finer ones will take: each starts from the level below and takes about as many
    iterations as the last such level (STARTED_LEVEL_ITERATIONS before any), at this
    level's seconds per node and iteration."""
    levels = watch.levels or [n]
    if len(levels) == 1 and seconds < 1.0:
        return
    line = f"preload{_level(levels, n)}: {iterations} iterations, {seconds:.1f} s"
    index = levels.index(n) if n in levels else len(levels) - 1
    if index > 0:  # a level started from the one below
        watch.started_iterations = iterations
    finer = levels[index + 1 :]
    if finer and iterations:
        expected = watch.started_iterations or STARTED_LEVEL_ITERATIONS
        rest = seconds / (n * iterations) * sum(finer) * expected
        line += f"; the finer levels about {duration_text(rest)}"
    watch.note(line)


def _run_state(run) -> RunState:
    """The parts of ``run`` whose states make the run's, and the parts that count work."""
    parts = {
        "surface": run.surface,
        "substrate": run.substrate,
        "edges": run.edges,
        "steps": run.steps,
        "schedule": run.schedule,
        "predictor": run.predictor,
        "window": run.window,
        "drive": run.spring,
    }
    counting = {
        "run": run,
        "solver": run.solver,
        "predictor": run.predictor,
        "fft": run.fft,
        "drive": run.spring,
    }
    return RunState(
        {k: v for k, v in parts.items() if v is not None},
        {k: v for k, v in counting.items() if v is not None},
    )
