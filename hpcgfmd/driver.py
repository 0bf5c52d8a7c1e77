"""The retraction protocol of one case (physics.md, "Protocol"; paper Eq. 16).

1. Preload (t = 0): adhesive indentation of the RELAXED substrate (elastic, E0) from a flat
   surface to u_z = -h0, solved as one elastic problem (the loading-branch equilibrium); the
   material history starts fully relaxed, p_n = (|q| E0 / 2) u_n.
2. Retraction: u_z(t) = -h0 + v_z t, one exact SLS step of length dt per time step, each an
   elastic problem of stiffness (|q|/2) Eeff with the history traction
   H = a p_n + (|q|/2)(E0 (1 - a) - Eeff) u_n, until no node has g <= dmax (complete
   detachment). Displacement control: jumps of the contact are recorded, never a stop.

Internal units R = E0 = tau = 1 throughout; the output file converts to the case's units.
Every method is collective over the case's communicator: each rank holds its block of the
surface (:class:`hpcgfmd.domain.Domain`) and its share of the Fourier modes.
"""
from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass

import numpy as np

from .config import Case
from .domain import Domain
from .fft import plan_real_fft
from .interface import DugdaleMaugis, edge_positions
from .material import StandardLinearSolid, ViscoelasticHalfSpace
from .solver import ConstrainedCG, EdgeWatch, project_feasible
from .stepping import AdaptiveSteps, FixedSteps

logger = logging.getLogger(__name__)


class CaseFailure(RuntimeError):
    """A case cannot be completed; raised on every rank of the case alike (reduced values)."""


class NonConvergenceError(CaseFailure):
    """The equilibrium solver did not reach the tolerance within max_iterations."""


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

    def as_dict(self):
        return dict(self.__dict__)


def make_solver(case, domain, fft, law, half_q):
    """The equilibrium solver of ``[numerics] solver``: "cg" (default) or "paper"."""
    numerics = case.numerics
    if numerics.solver == "paper":
        from .gfmd import DampedVerletGFMD
        return DampedVerletGFMD(domain, fft, law, half_q, 1.0, numerics.equilibration_steps,
                                case.sigma_a)
    return ConstrainedCG(domain, fft, law, numerics.tolerance, numerics.max_iterations,
                         case.sigma_a)


def make_step_control(case):
    """Fixed steps of [numerics] dt, or adaptive steps starting from it (``stepping``)."""
    numerics = case.numerics
    if numerics.step_control == "fixed":
        return FixedSteps(numerics.dt)
    return AdaptiveSteps(numerics.dt, numerics.dt_min, numerics.dt_max,
                         numerics.edge_fraction * case.zone_width,
                         numerics.load_tolerance * case.load_scale)


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

    def __init__(self, case: Case, comm, planner_effort="FFTW_MEASURE"):
        self.case = case
        n = case.numerics.nx
        self.n = n
        self.dx = case.cell / n
        self.fft = plan_real_fft(comm, n, planner_effort=planner_effort)
        self.domain = Domain(comm, n, case.cell, self.fft.x_blocks)
        self.x = self.domain.x  # this rank's nodes; the indenter axis is on node n/2
        self.profile = self.x**2 / 2.0  # h(x) = x^2 / (2R), paper Eq. 1, R = 1
        self.half_q = np.pi * np.abs(self.fft.wavenumber) / case.cell  # |q|/2 per local mode
        self.substrate = ViscoelasticHalfSpace(StandardLinearSolid(1.0, 1.0 / case.k, 1.0),
                                               self.half_q, n)
        self.law = DugdaleMaugis(case.sigma_a, case.dmax)
        self.solver = make_solver(case, self.domain, self.fft, self.law, self.half_q)
        # The preload is the same loading-branch equilibrium for every solver: CG solves it
        # to the tolerance (the paper's method would need its own loading phase).
        self.preload_solver = (self.solver if isinstance(self.solver, ConstrainedCG) else
                               ConstrainedCG(self.domain, self.fft, self.law,
                                             case.numerics.tolerance,
                                             case.numerics.max_iterations, case.sigma_a))
        self.steps = make_step_control(case)
        n = self.domain.local_n  # from here on: this rank's block
        self.u = np.zeros(n)  # surface displacement, upward positive
        self.u_previous = None  # displacement of the step before, for the predictor
        self.substrate_traction = np.zeros(n)  # p_n (q != 0 part) of the SLS history
        self.history = np.zeros(n)
        self.wall = np.empty(n)
        self.traction = np.zeros(n)  # interface traction on the substrate, attractive positive
        self.time = 0.0
        self.indenter = -case.depth
        self.step_index = 0
        self.total_iterations = 0
        self.rejected_steps = 0  # adaptive steps repeated with a shorter dt
        self.preload_iterations = 0
        self.dt_previous = None  # length of the last accepted step (None after the preload)
        self._saved = {name: np.empty(n) for name in ("u", "u_previous", "substrate_traction",
                                                       "traction")}
        self.rejected_predictions = 0
        self.predictor_choice = [0, 0]  # steps started from (linear, moving-edge) guesses
        self._edges = (np.nan, np.nan)  # contact edges of the last step
        self._edges_previous = None

    # --- one equilibrium -------------------------------------------------------------
    def _equilibrate(self, ops, dt, solver=None, edge_watch=None):
        """Solve the step; None when the solve was abandoned by ``edge_watch`` (CG only)."""
        solver = self.solver if solver is None else solver
        np.add(self.profile, self.indenter, out=self.wall)
        if edge_watch is None:
            result = solver.solve(self.u, self.wall, ops, self.history)
        else:
            result = solver.solve(self.u, self.wall, ops, self.history, edge_watch=edge_watch)
        if result.abandoned:
            self.total_iterations += result.iterations
            return None
        if not math.isfinite(result.residual):
            raise FloatingPointError(f"solver produced a non-finite residual at t = {self.time}")
        if not result.converged:
            raise NonConvergenceError(
                f"step {self.step_index} (t = {self.time:.6g}): residual {result.residual:.3g}"
                f" above tolerance {self.case.numerics.tolerance:g} after"
                f" {result.iterations} iterations; raise [numerics] max_iterations or reduce dt")
        solver.interface_traction(self.u, self.wall, self.history, result.mean_traction,
                                  self.traction)
        # Substrate traction of the new state, p_{n+1} = K u + H (zero mean).
        np.add(solver.elastic_traction(), self.history, out=self.substrate_traction)
        self.total_iterations += result.iterations
        return self._record(result, dt)

    def _record(self, result, dt):
        gap = self.wall - self.u
        left, right = edge_positions(self.domain, gap, 0.0, 1.5)
        self._edges_previous, self._edges = self._edges, (left, right)
        zl, zr = edge_positions(self.domain, gap, self.case.dmax, 1.0)
        return StepRecord(time=self.time, indenter=self.indenter,
                          load=-self.domain.sum(self.traction.sum()) * self.dx,
                          contact_half_width=0.5 * (right - left) if left == left else 0.0,
                          cohesive_half_width=0.5 * (zr - zl) if zl == zl else 0.0,
                          iterations=result.iterations, residual=result.residual, dt=dt)

    # --- protocol ----------------------------------------------------------------------
    def preload(self) -> StepRecord:
        """Relaxed adhesive indentation to u_z = -h0 (the t = 0 state)."""
        self.history[:] = 0.0
        record = self._equilibrate(self.substrate.operators(math.inf), 0.0, self.preload_solver)
        self.preload_iterations = record.iterations
        self.steps.accept(record.time, record.load)
        return record

    def step(self) -> StepRecord:
        """Advance one accepted retraction time step (fixed or error-controlled length).

        An adaptive step whose error ratios exceed the rejection bounds (``stepping``) is
        undone and repeated with the shorter step the controller proposes; the iterations of
        the rejected attempts count in ``total_iterations``.
        """
        dt = self.steps.dt
        while True:
            self._save()
            record = self._advance(dt)
            if record is None:  # abandoned: its edges moved too far, the verdict is known
                decision = self.steps.judge(dt, self.time, None, math.inf)
            else:
                decision = self.steps.judge(dt, record.time, record.load, self._edge_motion())
            if decision.accepted:
                break
            self.rejected_steps += 1
            self._revert()
            dt = decision.next_dt
        self.steps.accept(record.time, record.load)
        self.dt_previous = dt
        return record

    def _advance(self, dt) -> StepRecord | None:
        """One SLS step of length dt from the current state (paper Eq. 14, physics.md).

        None when the solve was abandoned because its contact edges strayed beyond what the
        step control accepts (:meth:`stepping.AdaptiveSteps.edge_limit`).
        """
        self.substrate.history(self.fft, self.u, self.substrate_traction, dt, self.history)
        contact = self.wall - self.u <= 0.0
        self.step_index += 1
        if self.steps.adaptive:
            self.time += dt
        else:  # no accumulated round-off over many equal steps
            self.time = self.step_index * dt
        self.indenter = -self.case.depth + self.case.velocity * self.time
        ops = self.substrate.operators(dt)
        if self.case.numerics.solver == "cg":  # the paper's method starts from u_n itself
            ratio = 1.0 if self.dt_previous is None else dt / self.dt_previous
            self._predict(self.case.velocity * dt, contact, ops, ratio)
            return self._equilibrate(ops, dt, edge_watch=self._edge_watch(dt))
        np.add(self.profile, self.indenter, out=self.wall)
        return self._equilibrate(ops, dt)

    def _edge_watch(self, dt):
        """The limit on the solve's edge motion, or None (no contact before, or at dt_min)."""
        limit = self.steps.edge_limit(dt)
        left, right = self._edges
        if not (math.isfinite(limit) and math.isfinite(left) and math.isfinite(right)):
            return None
        return EdgeWatch(left, right, limit)

    def _edge_motion(self):
        """Largest contact-edge displacement of the last step; inf if the contact (dis)appeared."""
        if self._edges_previous is None:
            return math.nan
        before = np.isfinite(self._edges_previous)
        after = np.isfinite(self._edges)
        if not before.any() and not after.any():
            return math.nan
        if not (before.all() and after.all()):
            return math.inf
        return float(np.max(np.abs(np.subtract(self._edges, self._edges_previous))))

    def _save(self):
        """Keep the state before a step, to undo a rejected one."""
        saved = self._saved
        saved["u"][:] = self.u
        saved["substrate_traction"][:] = self.substrate_traction
        saved["traction"][:] = self.traction
        if self.u_previous is not None:
            saved["u_previous"][:] = self.u_previous
        self._saved_scalars = (self.time, self.indenter, self.step_index, self._edges,
                               self._edges_previous, self.u_previous is not None)

    def _revert(self):
        saved = self._saved
        self.u[:] = saved["u"]
        self.substrate_traction[:] = saved["substrate_traction"]
        self.traction[:] = saved["traction"]
        (self.time, self.indenter, self.step_index, self._edges, self._edges_previous,
         had_previous) = self._saved_scalars
        if had_previous:
            self.u_previous[:] = saved["u_previous"]
        else:
            self.u_previous = None
        np.add(self.profile, self.indenter, out=self.wall)

    def _predict(self, rise, contact, ops, ratio):
        """Start the step from the lowest-energy of three feasible guesses.

        The path is defined by descent from the previous equilibrium u_n (feasible for the
        new step, the wall having risen); a guess replaces it only if its energy is lower:
        - linear extrapolation u_n + r (u_n - u_{n-1}) (r = dt_n+1 / dt_n), with the contact
          nodes of step n put
          exactly on the new wall (extrapolation lands there only to round-off, and a gap of
          1e-18 would free the whole patch);
        - the same with the gap profile around each contact edge translated by the edge's
          last displacement (a peeling edge moves with its shape), which frees the nodes the
          edge will pass instead of leaving CG to unzip them one by one.
        After the preload, u_{n-1} is taken as u_n with the contact lowered by the rise.
        """
        gap_before = self.wall - self.u
        np.add(self.profile, self.indenter, out=self.wall)
        if self.u_previous is None:
            self.u_previous = self.u - rise * contact
            ratio = 1.0
        linear = self.u + ratio * (self.u - self.u_previous)
        np.copyto(linear, self.wall, where=contact)
        m = self.domain.local_n
        candidates = {}
        for kind, guess in enumerate((linear, self._moving_edges(linear, gap_before, ratio))):
            if guess is None:
                continue
            try:
                candidates[kind] = project_feasible(self.domain, guess, self.wall, np.empty(m))
            except FloatingPointError:  # no feasible point of that form (tiny grids): skip it
                pass
        self.u_previous[:] = self.u
        energies = {kind: self.solver.energy(c, self.wall, ops, self.history)
                    for kind, c in candidates.items()}
        best = min(energies, key=energies.get) if energies else None
        if best is not None and energies[best] <= self.solver.energy(self.u, self.wall, ops,
                                                                      self.history):
            self.u[:] = candidates[best]
            self.predictor_choice[best] += 1
        else:
            self.rejected_predictions += 1

    def _moving_edges(self, linear, gap_before, ratio):
        """Guess with the gap near each contact edge translated by the edge's last motion."""
        if self._edges_previous is None or not np.all(np.isfinite(self._edges)):
            return None
        window = 4.0 * self.case.zone_width / self.case.k  # widest cohesive zone (Einf)
        gap = self.wall - linear
        dom = self.domain
        for edge, previous in zip(self._edges, self._edges_previous):
            shift = ratio * (edge - previous)
            if not np.isfinite(shift) or shift == 0.0:
                continue
            near = np.abs(self.x - edge) < window + abs(shift)
            # the shifted positions x - shift of the window's nodes lie in this segment
            reach = window + 2.0 * abs(shift)
            first = int(np.floor((edge - reach) / self.dx)) + self.n // 2 - 1
            last = int(np.ceil((edge + reach) / self.dx)) + self.n // 2 + 1
            length = min(last - first + 1, self.n)
            values = dom.segment(gap_before, first, length)
            gap[near] = np.interp(self.x[near] - shift, dom.position(first + np.arange(length)),
                                  values)
        np.maximum(gap, 0.0, out=gap)
        return self.wall - gap

    def detached(self) -> bool:
        """Collective: True when no node is within the interaction range (complete detachment)."""
        return self.domain.all(self.wall - self.u > self.case.dmax)

    def close(self):
        """Collective: release the transform's resources (its shared-memory window)."""
        close = getattr(self.fft, "close", None)
        if close is not None:
            close()

    def gap(self):
        """This rank's block of the gap g = h + u_z - u (length)."""
        return self.wall - self.u

    # --- checkpoint ----------------------------------------------------------------------
    FIELDS = ("u", "u_previous", "substrate_traction", "traction")

    def state(self):
        """The full state after a step: (this rank's field blocks, rank-independent scalars).

        With it, :meth:`restore` continues the run exactly (the history H and the wall are
        recomputed from it at the next step).
        """
        has_previous = self.u_previous is not None
        fields = {"u": self.u, "substrate_traction": self.substrate_traction,
                  "traction": self.traction,
                  "u_previous": self.u_previous if has_previous else np.zeros_like(self.u)}
        edges_previous = self._edges_previous or (np.nan, np.nan)
        attrs = {"time": self.time, "indenter": self.indenter, "step_index": self.step_index,
                 "total_iterations": self.total_iterations,
                 "rejected_predictions": self.rejected_predictions,
                 "predictor_choice": np.array(self.predictor_choice),
                 "edges": np.array(self._edges), "edges_previous": np.array(edges_previous),
                 "has_previous": has_previous,
                 "has_edges_previous": self._edges_previous is not None,
                 "fft_pairs": self.fft.pairs, "projections": self.solver.projections,
                 "rejected_steps": self.rejected_steps,
                 "dt_previous": math.nan if self.dt_previous is None else self.dt_previous,
                 "cut_steps": self.solver.cut_steps,
                 "residual_steps": self.solver.residual_steps,
                 "abandoned_solves": getattr(self.solver, "abandoned", 0)}
        attrs.update(self.steps.state())
        return fields, attrs

    def restore(self, fields, attrs):
        """Continue from :meth:`state` (this rank's blocks, possibly of another rank count)."""
        self.u[:] = fields["u"]
        self.substrate_traction[:] = fields["substrate_traction"]
        self.traction[:] = fields["traction"]
        self.u_previous = fields["u_previous"].copy() if attrs["has_previous"] else None
        self.time = float(attrs["time"])
        self.indenter = float(attrs["indenter"])
        self.step_index = int(attrs["step_index"])
        self.total_iterations = int(attrs["total_iterations"])
        self.rejected_predictions = int(attrs["rejected_predictions"])
        self.predictor_choice = [int(v) for v in attrs["predictor_choice"]]
        self._edges = tuple(float(v) for v in attrs["edges"])
        self._edges_previous = (tuple(float(v) for v in attrs["edges_previous"])
                                if attrs["has_edges_previous"] else None)
        self.fft.pairs = int(attrs["fft_pairs"])
        self.solver.projections = int(attrs["projections"])
        self.solver.cut_steps = int(attrs["cut_steps"])
        self.solver.residual_steps = int(attrs["residual_steps"])
        if hasattr(self.solver, "abandoned"):
            self.solver.abandoned = int(attrs.get("abandoned_solves", 0))
        self.rejected_steps = int(attrs["rejected_steps"])
        dt_previous = float(attrs["dt_previous"])
        self.dt_previous = None if math.isnan(dt_previous) else dt_previous
        self.steps.restore(attrs)
        np.add(self.profile, self.indenter, out=self.wall)


class Progress:
    """Prints a progress line every ``interval`` seconds of wall time."""

    def __init__(self, interval, printer=print):
        self.interval = interval
        self.printer = printer
        self.start = time.monotonic()
        self.last = self.start
        self.first_width = None

    def update(self, step, record: StepRecord, units):
        now = time.monotonic()
        if self.first_width is None:
            self.first_width = record.contact_half_width
        if now - self.last < self.interval:
            return
        self.last = now
        elapsed = now - self.start
        done = 1.0 - record.contact_half_width / self.first_width if self.first_width else 0.0
        eta = f"{elapsed * (1.0 - done) / done:.0f} s" if done > 0.02 else "?"
        self.printer(f"step {step:6d}  t = {record.time * units.time:.5g}"
                     f"  load = {record.load * units.load:.5g}"
                     f"  a_c = {record.contact_half_width * units.length:.5g}"
                     f"  iterations = {record.iterations:4d}"
                     f"  elapsed {elapsed:.0f} s, left ~{eta} (from contact width)")
