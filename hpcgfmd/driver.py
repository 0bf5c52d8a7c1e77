"""The retraction protocol of one case (physics.md, "Protocol"; paper Eq. 16).

1. Preload (t = 0): adhesive indentation of the RELAXED substrate (elastic, E0) from a flat
   surface to u_z = -h0, solved as one elastic problem (the loading-branch equilibrium); the
   material history starts fully relaxed, p_n = (|q| E0 / 2) u_n.
2. Retraction: u_z(t) = -h0 + v_z t, one exact SLS step of length dt per time step, each an
   elastic problem of stiffness (|q|/2) Eeff with the history traction
   H = a p_n + (|q|/2)(E0 (1 - a) - Eeff) u_n, until no node has g <= dmax (complete
   detachment). Displacement control: jumps of the contact are recorded, never a stop.

Internal units R = E0 = tau = 1 throughout; the output file converts to the case's units.
"""
from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass

import numpy as np

from .config import Case
from .fft import RealFFT
from .interface import DugdaleMaugis, edge_positions
from .material import StandardLinearSolid
from .solver import ConstrainedCG, StepOperators

logger = logging.getLogger(__name__)


class NonConvergenceError(RuntimeError):
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


class Retraction:
    """State and stepping of one case (serial).

    Parameters
    ----------
    case : Case
        The validated case (internal units).
    """

    def __init__(self, case: Case):
        self.case = case
        n = case.numerics.nx
        self.n = n
        self.dx = case.cell / n
        self.x = (np.arange(n) - n // 2) * self.dx  # indenter axis on node n/2
        self.profile = self.x**2 / 2.0  # h(x) = x^2 / (2R), paper Eq. 1, R = 1
        self.half_q = np.pi * np.arange(n // 2 + 1) / case.cell  # |q|/2 per rfft mode
        self.material = StandardLinearSolid(1.0, 1.0 / case.k, 1.0)
        self.law = DugdaleMaugis(case.sigma_a, case.dmax)
        self.fft = RealFFT(n)
        self.solver = ConstrainedCG(self.fft, self.law, case.numerics.tolerance,
                                    case.numerics.max_iterations, case.sigma_a)
        self.u = np.zeros(n)  # surface displacement, upward positive
        self.substrate_traction = np.zeros(n)  # p_n (q != 0 part) of the SLS history
        self.history = np.zeros(n)
        self.wall = np.empty(n)
        self.traction = np.zeros(n)  # interface traction on the substrate, attractive positive
        self.time = 0.0
        self.indenter = -case.depth
        self.step_index = 0
        self.total_iterations = 0
        self._mean_traction = 0.0
        self._history_diag = None
        self._ops = None

    # --- one equilibrium -------------------------------------------------------------
    def _equilibrate(self, ops, dt):
        np.add(self.profile, self.indenter, out=self.wall)
        result = self.solver.solve(self.u, self.wall, ops, self.history)
        if not math.isfinite(result.residual):
            raise FloatingPointError(f"solver produced a non-finite residual at t = {self.time}")
        if not result.converged:
            raise NonConvergenceError(
                f"step {self.step_index} (t = {self.time:.6g}): residual {result.residual:.3g}"
                f" above tolerance {self.case.numerics.tolerance:g} after"
                f" {result.iterations} iterations; raise [numerics] max_iterations or reduce dt")
        self._mean_traction = result.mean_traction
        self.solver.interface_traction(self.u, self.wall, self.history, result.mean_traction,
                                       self.traction)
        # Substrate traction of the new state, p_{n+1} = K u + H (zero mean).
        np.add(self.solver._k_u, self.history, out=self.substrate_traction)
        self.total_iterations += result.iterations
        return self._record(result, dt)

    def _record(self, result, dt):
        gap = self.wall - self.u
        left, right = edge_positions(self.x, gap, 0.0, 1.5)
        zl, zr = edge_positions(self.x, gap, self.case.dmax, 1.0)
        return StepRecord(time=self.time, indenter=self.indenter,
                          load=-float(self.traction.sum()) * self.dx,
                          contact_half_width=0.5 * (right - left) if left == left else 0.0,
                          cohesive_half_width=0.5 * (zr - zl) if zl == zl else 0.0,
                          iterations=result.iterations, residual=result.residual, dt=dt)

    # --- protocol ----------------------------------------------------------------------
    def preload(self) -> StepRecord:
        """Relaxed adhesive indentation to u_z = -h0 (the t = 0 state)."""
        factors = self.material.step_factors(math.inf)
        ops = StepOperators.from_modulus(self.half_q, factors.e_eff, self.n)
        self.history[:] = 0.0
        return self._equilibrate(ops, 0.0)

    def step(self) -> StepRecord:
        """Advance one retraction time step of length [numerics] dt."""
        dt = self.case.numerics.dt
        if self._ops is None:
            factors = self.material.step_factors(dt)
            self._ops = StepOperators.from_modulus(self.half_q, factors.e_eff, self.n)
            self._decay = factors.decay
            self._history_diag = self.half_q * (factors.e_history / self.n)
        # History traction H = a p_n + (|q|/2)(E0 (1 - a) - Eeff) u_n (physics.md).
        self.fft.apply_diagonal(self.u, self._history_diag, self.history)
        self.history += self._decay * self.substrate_traction
        self.step_index += 1
        self.time = self.step_index * dt
        self.indenter = -self.case.depth + self.case.velocity * self.time
        return self._equilibrate(self._ops, dt)

    def detached(self) -> bool:
        """True when no node is within the interaction range (complete detachment)."""
        return bool(np.all(self.wall - self.u > self.case.dmax))

    def gap(self):
        return self.wall - self.u


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
