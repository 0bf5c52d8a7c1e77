"""Generalized Maxwell (Prony series) half-space, one Fourier mode at a time.

The relaxation modulus (docs/model.md, "Generalized Maxwell (Prony series) substrate", (M38)):

    E*(t) = E0 + sum_i E_i exp(-t / tau_i),   i = 1..m,

a spring E0 in parallel with m Maxwell branches (spring E_i, relaxation time tau_i). Per mode
q != 0 the surface traction is p = (|q|/2) (E0 u + sum_i s_i), each branch stress obeying
ds_i/dt + s_i / tau_i = E_i du/dt (M39). Integrated exactly over a step dt for u linear in
time within it, with a_i = exp(-dt/tau_i) and phi_i = tau_i (1 - a_i) / dt (M40):

    s_i,n+1 = a_i s_i,n + E_i phi_i (u_{n+1} - u_n)
    p_{n+1} = (|q|/2) Eeff u_{n+1} + H_n,   Eeff = E0 + sum_i E_i phi_i,
    H_n = sum_i a_i S_i,n - (sum_i E_i phi_i) G_n,

with S_i = (|q|/2) s_i (the branch tractions) and G = (|q|/2) u (the traction of the relaxed
spring per unit modulus) held in real space: mode-diagonal maps commute with the transform,
so the history needs no transform at all, and G_{n+1} = (K u_{n+1}) / Eeff comes with the
solve. One branch is the standard linear solid of :mod:`.material` (tau = tau_1,
Einf = E0 + E_1: (M8) is (M40) with a p_n = a (E0 G_n + S_1,n)). The quadratic step (M46)
takes u quadratic in time through u_{n-1}, u_n, u_{n+1}: each branch gains E_i F_i(dt) c,
c = ((G_{n+1} - G_n) / dt - (G_n - G_{n-1}) / h) / (dt + h) (h the step before), and the
step's modulus and history change as the SLS's (:func:`.material.quadratic_terms`).
All moduli are plane-strain effective moduli E* = E / (1 - nu^2).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .material import StepOperators, curvature_integral, quadratic_terms


@dataclass(frozen=True)
class GeneralizedMaxwell:
    """Prony series E*(t) = E0 + sum_i E_i exp(-t / tau_i) (docs/model.md, (M38)).

    Parameters
    ----------
    e_relaxed : float
        E0 > 0, the relaxed plane-strain modulus (t -> infinity), stress units.
    branch_moduli : tuple of float
        E_i > 0 of each Maxwell branch, stress units.
    branch_times : tuple of float
        tau_i > 0 of each branch, time units.
    """

    e_relaxed: float
    branch_moduli: tuple
    branch_times: tuple

    def __post_init__(self):
        moduli = np.asarray(self.branch_moduli, dtype=float)
        times = np.asarray(self.branch_times, dtype=float)
        if moduli.ndim != 1 or moduli.shape != times.shape or moduli.size == 0:
            raise ValueError("branch_moduli and branch_times: expected two lists of one"
                             " length >= 1")
        if not (np.all(moduli > 0.0) and np.all(times > 0.0) and self.e_relaxed > 0.0):
            raise ValueError("moduli and times must be > 0")
        object.__setattr__(self, "branch_moduli", tuple(float(v) for v in moduli))
        object.__setattr__(self, "branch_times", tuple(float(v) for v in times))

    @property
    def e_instantaneous(self) -> float:
        """Einf = E0 + sum_i E_i, the modulus at t = 0 (stress units)."""
        return self.e_relaxed + math.fsum(self.branch_moduli)

    @property
    def relaxation_time(self) -> float:
        """The reference time tau_r = sum_i E_i tau_i / sum_i E_i (M41): the integral of
        (E*(t) - E0) over time divided by (Einf - E0); tau for the SLS (time units)."""
        return (math.fsum(e * t for e, t in zip(self.branch_moduli, self.branch_times))
                / math.fsum(self.branch_moduli))

    @property
    def shortest_time(self) -> float:
        """min_i tau_i, the fastest memory (time units)."""
        return min(self.branch_times)

    @property
    def retardation_time(self) -> float:
        """The creep compliance's slowest time lambda (time units; the SLS's tau / k).

        The retardation times are -1/s at the zeros of s E~(s) = E0 + sum_i E_i s tau_i /
        (1 + s tau_i) (the Laplace transform of (M38)); they interlace the relaxation times,
        and the slowest lies in (tau_max, tau_max Einf / E0]: the root in s of
        (-1/tau_max, 0), found by bisection to round-off (brentq).
        """
        moduli, times = np.asarray(self.branch_moduli), np.asarray(self.branch_times)
        slowest = times.max()

        def modulus(s):
            return self.e_relaxed + float(np.sum(moduli * s * times / (1.0 + s * times)))

        # the bracket's ends: just above the pole at -1/tau_max (the sum -> -inf) and at the
        # bound -E0 / (tau_max Einf) (where the modulus is >= 0)
        high = -self.e_relaxed / (slowest * self.e_instantaneous)
        low = -1.0 / slowest * (1.0 - 1e-15)
        if modulus(high) <= 0.0:  # one branch (or branches of one time): the bound is exact
            return -1.0 / high
        from scipy import optimize  # only a Prony case needs it: not every process's import

        return -1.0 / optimize.brentq(modulus, low, high, xtol=1e-300, rtol=1e-15)

    def step_factors(self, dt: float):
        """(a_i, E_i phi_i, Eeff) of the exact step over dt (M40); dt = inf: the relaxed solid.

        Returns
        -------
        decays : ndarray
            a_i = exp(-dt / tau_i), dimensionless.
        weights : ndarray
            E_i phi_i, phi_i = tau_i (1 - a_i) / dt (stress units).
        e_eff : float
            E0 + sum_i E_i phi_i (stress units).
        """
        x = dt / np.asarray(self.branch_times)  # dt = inf: a_i = phi_i = 0
        decays = np.exp(-x)
        weights = np.asarray(self.branch_moduli) * (-np.expm1(-x) / x)
        return decays, weights, self.e_relaxed + math.fsum(weights)

    def curvature_response(self, dt: float) -> float:
        """sum_i E_i F_i(dt): the step's traction error per unit curvature of u, the branch
        sum of :func:`~hpcgfmd.model.material.curvature_integral` (stress time^2)."""
        return math.fsum(self.branch_curvature_responses(dt))

    def branch_curvature_responses(self, dt: float) -> np.ndarray:
        """E_i F_i(dt) of each branch (stress time^2; their sum is :meth:`curvature_response`)."""
        return np.array([e * curvature_integral(dt, t)
                         for e, t in zip(self.branch_moduli, self.branch_times)])

    def relaxation_modulus(self, t):
        """E*(t) (M38), stress units; t in time units (array or float)."""
        t = np.asarray(t, dtype=float)
        return self.e_relaxed + sum(e * np.exp(-t / tau) for e, tau
                                    in zip(self.branch_moduli, self.branch_times))

    def complex_modulus(self, omega):
        """E*(omega) = E0 + sum_i E_i i omega tau_i / (1 + i omega tau_i) (M42), stress units."""
        omega = np.asarray(omega, dtype=float)
        return self.e_relaxed + sum(e * 1j * omega * tau / (1.0 + 1j * omega * tau)
                                    for e, tau in zip(self.branch_moduli, self.branch_times))


class MaxwellHalfSpace:
    """Per-mode generalized Maxwell stepping of the periodic half-space (module docstring).

    Holds the state beyond u: the branch tractions S_i and the relaxed traction G = (|q|/2) u,
    this rank's real-space blocks (:meth:`fields`, checkpointed with the rest). The history
    of a step needs no transform; :meth:`update` advances the branches after a solve.

    Parameters
    ----------
    material : GeneralizedMaxwell
    half_q : ndarray
        |q|/2 of each Fourier mode this rank holds, in the FFT's local order (1/length).
    n : int
        Grid points.
    local_n : int
        Nodes of this rank's real-space block.
    """

    def __init__(self, material: GeneralizedMaxwell, half_q, n: int, local_n: int):
        self.material = material
        self.half_q = half_q
        self.n = n
        count = len(material.branch_moduli)
        self.branch_tractions = np.zeros((count, local_n))  # S_i
        self.relaxed_traction = np.zeros(local_n)  # G = (|q|/2) u of the accepted state
        self.relaxed_before = np.zeros(local_n)  # G_{n-1}, for the quadratic step (M46)
        self.last_step_quadratic = False  # the last update's step was the quadratic one
        # S_i,n and G_n of the step's start: a step may be solved more than once (the
        # compliant drive's search), each update starts from them
        self._branches_start = np.zeros((count, local_n))
        self._relaxed_start = np.zeros(local_n)
        self._before_start = np.zeros(local_n)  # G_{n-1} of the step's start
        self._next = np.empty(local_n)
        self._key = None

    def field_names(self):
        """Names of the state fields this half-space adds (checkpoint and undo)."""
        return ("relaxed_traction", "relaxed_before") + tuple(
            f"branch_traction_{i}" for i in range(len(self.branch_tractions)))

    def fields(self):
        """{name: this rank's block} of the state fields (views, not copies)."""
        named = {"relaxed_traction": self.relaxed_traction,
                 "relaxed_before": self.relaxed_before}
        named.update({f"branch_traction_{i}": s for i, s in enumerate(self.branch_tractions)})
        return named

    def restore(self, fields, fft=None, u=None, u_before=None):
        """Set the state fields from ``fields`` (:meth:`fields`' names). Collective when they
        lack G_{n-1} (checkpoints written before it was kept): from ``u_before`` (u_{n-1}, or
        ``u`` when it is None) by one transform."""
        for name, block in self.fields().items():
            if name in fields:
                block[:] = fields[name]
            elif name == "relaxed_before":
                fft.apply_diagonal(u if u_before is None else u_before,
                                   self.half_q * (1.0 / self.n), block)
            else:
                raise KeyError(name)

    def state_elastic_traction(self, dt, out, step_before=None):
        """K(dt) u_n = Eeff(dt) G_n (Eeff' G_n for the quadratic step) of the state's
        displacement under a step of length dt (stress units; local, no transform)."""
        self._prepare(dt, step_before)
        return np.multiply(self.relaxed_traction, self._modulus, out=out)

    def operators(self, dt: float, step_before=None) -> StepOperators:
        """Stiffness (|q|/2) Eeff(dt) (Eeff' for the quadratic step) and its preconditioner;
        dt = inf is the relaxed solid."""
        self._prepare(dt, step_before)
        return self._ops

    def history(self, fft, u, substrate_traction, dt, out, step_before=None):
        """The history traction H of a step of length dt (M40; H' of (M46) given
        ``step_before``) into ``out`` (stress units).

        Local (no transform): H = sum_i a_i S_i - (sum_i E_i phi_i) G. ``fft``, ``u`` and
        ``substrate_traction`` are not needed: the branch state holds the history. The
        state S_i,n, G_n is kept as the step's start for :meth:`update`.
        """
        self._prepare(dt, step_before)
        self._branches_start[:] = self.branch_tractions
        self._relaxed_start[:] = self.relaxed_traction
        self._before_start[:] = self.relaxed_before
        np.multiply(self.relaxed_traction, -self._weight_sum, out=out)
        for decay, branch in zip(self._decays, self.branch_tractions):
            if decay > 0.0:
                out += decay * branch
        if self._terms is not None:
            added, weight = self._terms
            out -= (added + weight) * self.relaxed_traction
            out += weight * self.relaxed_before
        return out

    def update(self, elastic_traction, history, dt, substrate_traction, step_before=None):
        """After a step's solve: the new substrate traction p = K u + H (M40, (M46)) and the
        branch state, S_i = a_i S_i,n + E_i phi_i (G_{n+1} - G_n) [+ E_i F_i(dt) c] with
        G_{n+1} = K u / Eeff, from the step's start (:meth:`history`; all zero before the
        preload, whose dt = inf has a_i = phi_i = 0): a step solved again updates from the
        same start. G_{n-1} becomes the start's G_n."""
        self._prepare(dt, step_before)
        np.add(elastic_traction, history, out=substrate_traction)
        self.relaxed_before[:] = self._relaxed_start
        np.multiply(elastic_traction, 1.0 / self._modulus, out=self.relaxed_traction)
        np.subtract(self.relaxed_traction, self._relaxed_start, out=self._next)
        for decay, weight, branch, start in zip(self._decays, self._weights,
                                                self.branch_tractions, self._branches_start):
            np.multiply(start, decay, out=branch)
            branch += weight * self._next
        self.last_step_quadratic = self._terms is not None
        if self.last_step_quadratic:
            # c (in G's units) times E_i F_i(dt): (G_{n+1} - G_n) / dt is _next / dt
            h = step_before
            curvature = self._next * (1.0 / (dt * (dt + h)))
            curvature -= (self._relaxed_start - self._before_start) * (1.0 / (h * (dt + h)))
            for response, branch in zip(self._branch_responses, self.branch_tractions):
                branch += response * curvature

    def correct(self, missed, dt, substrate_traction):
        """Add the missed traction of a linear step of length dt to p and to each branch in
        proportion to its share E_i F_i(dt) of the curvature response; nothing after a
        quadratic step, which holds it."""
        if self.last_step_quadratic:
            return
        substrate_traction += missed
        shares = self.material.branch_curvature_responses(dt)
        total = shares.sum()
        if total > 0.0:
            for share, branch in zip(shares / total, self.branch_tractions):
                branch += share * missed

    def _prepare(self, dt, step_before=None):
        key = (dt, step_before)
        if key != self._key:
            self._decays, self._weights, e_eff = self.material.step_factors(dt)
            self._weight_sum = math.fsum(self._weights)
            self._terms = quadratic_terms(self.material, dt, step_before)
            self._modulus = e_eff + (self._terms[0] if self._terms else 0.0)
            if self._terms:
                self._branch_responses = self.material.branch_curvature_responses(dt)
            self._ops = StepOperators.from_modulus(self.half_q, self._modulus, self.n)
            self._key = key
