"""The substrate's material: a generalized Maxwell solid (Prony series), the standard linear
solid (SLS, Zener) being its one-branch case.

Relaxation modulus (docs/model.md, (M5) and (M38)):

    E*(t) = E0 + sum_i E_i exp(-t / tau_i),   i = 1..m,   Einf = E0 + sum_i E_i,

a spring E0 in parallel with m Maxwell branches (spring E_i, relaxation time tau_i). The SLS
of the paper (Eqs. 2-3) is m = 1 with E_1 = Einf - E0 and tau_1 = tau; the elastic solid is
m = 1 with E_1 = 0 (k = 1). Each branch integrates exactly over a step dt with the
displacement linear in time (M40); with a_i = exp(-dt / tau_i) and phi_i = tau_i (1 - a_i) /
dt the step's modulus is Eeff = E0 + sum_i E_i phi_i (M7). The quadratic step (M46) adds the
curvature response sum_i E_i F_i(dt), F the integral of :func:`curvature_integral`.

All moduli are plane-strain effective moduli E* = E / (1 - nu^2). Pure Python and numpy:
the stepping of the half-space mode by mode is :mod:`.halfspace`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class StepFactors:
    """Coefficients of one exact step of length dt (docs/model.md, (M7), (M40)).

    Attributes
    ----------
    decays : tuple of float
        a_i = exp(-dt / tau_i) of each branch, dimensionless.
    weights : tuple of float
        E_i phi_i, phi_i = tau_i (1 - a_i) / dt (stress).
    e_eff : float
        Eeff = E0 + sum_i E_i phi_i (stress).
    e_history : float
        E0 (1 - a_1) - Eeff: the weight of G_n = (|q|/2) u_n in the history of (M8) when the
        first branch's stress is p_n - E0 G_n - sum_{i>1} S_i (stress).
    """

    decays: tuple
    weights: tuple
    e_eff: float
    e_history: float


@dataclass(frozen=True)
class GeneralizedMaxwell:
    """Prony series E*(t) = E0 + sum_i E_i exp(-t / tau_i) (module docstring).

    Parameters
    ----------
    e_relaxed : float
        E0 > 0, the relaxed plane-strain modulus (t -> infinity), stress.
    branch_moduli : tuple of float
        E_i >= 0 of each Maxwell branch, stress (a single E_1 = 0: the elastic solid).
    branch_times : tuple of float
        tau_i > 0 of each branch, time.
    e_instantaneous : float, optional
        Einf = E0 + sum_i E_i (stress); given, it is kept as given (the SLS of k stores
        Einf = E0 / k itself rather than its sum).
    """

    e_relaxed: float
    branch_moduli: tuple
    branch_times: tuple
    e_instantaneous: float = field(default=math.nan)

    def __post_init__(self):
        moduli, times = tuple(map(float, self.branch_moduli)), tuple(map(float, self.branch_times))
        if not moduli or len(moduli) != len(times):
            raise ValueError(
                "branch_moduli and branch_times: expected two lists of one length >= 1"
            )
        if not (
            all(e >= 0.0 for e in moduli) and all(t > 0.0 for t in times) and self.e_relaxed > 0.0
        ):
            raise ValueError("expected E0 > 0, branch moduli >= 0 and branch times > 0")
        if math.isnan(self.e_instantaneous):
            einf = self.e_relaxed + math.fsum(moduli)
        else:
            einf = float(self.e_instantaneous)
        # normalised once at construction (a frozen dataclass's own idiom)
        object.__setattr__(self, "branch_moduli", moduli)
        object.__setattr__(self, "branch_times", times)
        object.__setattr__(self, "e_instantaneous", einf)

    @classmethod
    def standard_linear(
        cls, e_relaxed: float, e_instantaneous: float, relaxation_time: float
    ) -> GeneralizedMaxwell:
        """The SLS E*(t) = E0 + (Einf - E0) exp(-t / tau) (M5): one branch of Einf - E0."""
        return cls(e_relaxed, (e_instantaneous - e_relaxed,), (relaxation_time,), e_instantaneous)

    @property
    def branches(self) -> int:
        """m, the number of Maxwell branches."""
        return len(self.branch_moduli)

    @property
    def relaxation_time(self) -> float:
        """The reference time tau_r = sum_i E_i tau_i / sum_i E_i (M41): tau for the SLS and
        for branches of one time (time; tau_1 for the elastic solid)."""
        total = math.fsum(self.branch_moduli)
        if total == 0.0 or len(set(self.branch_times)) == 1:
            return self.branch_times[0]
        return math.fsum(e * t for e, t in zip(self.branch_moduli, self.branch_times)) / total

    @property
    def shortest_time(self) -> float:
        """min_i tau_i, the fastest memory (time)."""
        return min(self.branch_times)

    @property
    def retardation_time(self) -> float:
        """The creep compliance's slowest time (time): tau Einf / E0 = tau / k for the SLS
        and branches of one time (M9).

        The retardation times are -1/s at the zeros of s E~(s) = E0 + sum_i E_i s tau_i /
        (1 + s tau_i) (the Laplace transform of (M38)); they interlace the relaxation times,
        and the slowest lies in (tau_max, tau_max Einf / E0]: the root in s of
        (-1/tau_max, 0), found by bisection to round-off (brentq).
        """
        times = self.branch_times
        if len(set(times)) == 1:
            return times[0] * self.e_instantaneous / self.e_relaxed
        moduli, slowest = np.asarray(self.branch_moduli), max(times)
        times = np.asarray(times)

        def modulus(s):
            return self.e_relaxed + float(np.sum(moduli * s * times / (1.0 + s * times)))

        # the bracket's ends: just above the pole at -1/tau_max (the sum -> -inf) and the
        # bound -E0 / (tau_max Einf) (where the modulus is >= 0)
        high = -self.e_relaxed / (slowest * self.e_instantaneous)
        low = -1.0 / slowest * (1.0 - 1e-15)
        if modulus(high) <= 0.0:
            return -1.0 / high
        from scipy import optimize  # only a spectrum of times needs it

        return -1.0 / optimize.brentq(modulus, low, high, xtol=1e-300, rtol=1e-15)

    def step_factors(self, dt: float) -> StepFactors:
        """Factors of the exact step over dt (M7), (M40); dt = inf is the relaxed solid
        (a_i = phi_i = 0, Eeff = E0: the preload)."""
        decays, weights = [], []
        for e, tau in zip(self.branch_moduli, self.branch_times):
            x = dt / tau
            decays.append(math.exp(-x))
            weights.append(e * (-math.expm1(-x) / x))  # phi without cancellation at small dt
        e_eff = self.e_relaxed + math.fsum(weights)
        return StepFactors(
            tuple(decays), tuple(weights), e_eff, self.e_relaxed * (1.0 - decays[0]) - e_eff
        )

    def curvature_response(self, dt: float) -> float:
        """sum_i E_i F_i(dt): the step's traction error per unit curvature of u (stress
        time^2; (M46)). The step exact for u linear in time misses (|q|/2) c times this per
        mode when u(t_n + s) = u_n + v s + c s^2. Zero for the elastic solid."""
        return math.fsum(self.branch_curvature_responses(dt))

    def branch_curvature_responses(self, dt: float) -> np.ndarray:
        """E_i F_i(dt) of each branch (stress time^2)."""
        return np.array(
            [e * curvature_integral(dt, t) for e, t in zip(self.branch_moduli, self.branch_times)]
        )

    def relaxation_modulus(self, t):
        """E*(t) (M38), stress; t in time units (array or float)."""
        t = np.asarray(t, dtype=float)
        return self.e_relaxed + sum(
            e * np.exp(-t / tau) for e, tau in zip(self.branch_moduli, self.branch_times)
        )

    def complex_modulus(self, omega):
        """E*(omega) = E0 + sum_i E_i i omega tau_i / (1 + i omega tau_i) (M42), stress."""
        omega = np.asarray(omega, dtype=float)
        return self.e_relaxed + sum(
            e * 1j * omega * tau / (1.0 + 1j * omega * tau)
            for e, tau in zip(self.branch_moduli, self.branch_times)
        )

    def creep_compliance(self, t):
        """J(t) of the SLS and of branches of one time: 1/E0 - (1/E0 - 1/Einf)
        exp(-t / retardation time) (M9), 1/stress."""
        if len(set(self.branch_times)) != 1:
            raise ValueError("the closed-form creep compliance is that of one relaxation time")
        e0, einf = self.e_relaxed, self.e_instantaneous
        return 1.0 / e0 - (1.0 / e0 - 1.0 / einf) * np.exp(-np.asarray(t) / self.retardation_time)


def curvature_integral(dt: float, tau: float) -> float:
    """F(dt) = integral_0^dt exp(-(dt - s)/tau) (2 s - dt) ds (time^2; docs/model.md, (M46)).

    A Maxwell element of relaxation time tau, stepped exactly for u linear in time, misses
    E c F(dt) of its stress when u(t_n + s) = u_n + v s + c s^2:

        F(dt) = dt tau (1 + a) - 2 tau^2 (1 - a),   a = exp(-dt/tau),

    F ~ dt^3 / (6 tau) for dt << tau and ~ dt tau for dt >> tau.
    """
    x = dt / tau
    if x < 1e-2:  # the closed form cancels: its series, x^3/6 - x^4/12 + x^5/40
        return tau * tau * x**3 * (1.0 / 6.0 - x / 12.0 + x * x / 40.0)
    a = math.exp(-x)
    return dt * tau * (1.0 + a) - 2.0 * tau * tau * (1.0 - a)
