"""Standard linear solid (Zener) half-space, one Fourier mode at a time.

Per mode q != 0 (docs/model.md, "Substrate"; paper Eq. 14 with the corrected factor |q|/2):

    p + tau dp/dt = (|q|/2) (E0 u + tau Einf du/dt)

integrated exactly over a step dt for u linear in time within the step. With
a = exp(-dt/tau), phi = tau (1 - a) / dt and Eeff = E0 + (Einf - E0) phi:

    p_{n+1} = (|q|/2) Eeff u_{n+1} + [a p_n + (|q|/2) (E0 (1 - a) - Eeff) u_n]

so each time step is an elastic problem of stiffness (|q|/2) Eeff plus a known history
traction. The quadratic step (docs/model.md, (M46)) takes u quadratic in time through
u_{n-1}, u_n and u_{n+1} instead: it adds (|q|/2) R c, R = (Einf - E0) F(dt) (F the
curvature integral of (M46), :func:`curvature_integral`) and c = ((u_{n+1} - u_n) / dt -
(u_n - u_{n-1}) / h) / (dt + h) (h the step before), which is linear in u_{n+1}, so the step
stays an elastic problem, of modulus Eeff + R / (dt (dt + h)). All moduli are plane-strain
effective moduli E* = E / (1 - nu^2).
Numpy and one compiled loop (:mod:`.history_kernels`): it acts on whatever block of modes
the caller owns (in any order).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .history_kernels import sls_history

KEPT_LENGTHS = 6  # (step, step before) pairs whose operators a substrate keeps (2 spectra each)


@dataclass(frozen=True)
class StepFactors:
    """Coefficients of one exact SLS step of length dt.

    Attributes
    ----------
    decay : float
        a = exp(-dt/tau), dimensionless.
    e_eff : float
        Effective modulus of the step, Eeff = E0 + (Einf - E0) phi (stress units).
    e_history : float
        Coefficient of u_n in the history term, E0 (1 - a) - Eeff (stress units).
    """

    decay: float
    e_eff: float
    e_history: float


@dataclass(frozen=True)
class StandardLinearSolid:
    """SLS with relaxation modulus E*(t) = E0 + (Einf - E0) exp(-t/tau) (paper Eq. 3).

    Parameters
    ----------
    e_relaxed : float
        E0, relaxed plane-strain modulus (t -> infinity), stress units.
    e_instantaneous : float
        Einf >= E0, instantaneous plane-strain modulus (t -> 0), stress units.
        Einf == E0 is the purely elastic solid.
    relaxation_time : float
        tau, time units.
    """

    e_relaxed: float
    e_instantaneous: float
    relaxation_time: float

    @property
    def branch_moduli(self) -> tuple:
        """(Einf - E0,): the SLS as a one-branch Prony series (:mod:`.prony`)."""
        return (self.e_instantaneous - self.e_relaxed,)

    @property
    def branch_times(self) -> tuple:
        """(tau,)."""
        return (self.relaxation_time,)

    def step_factors(self, dt: float) -> StepFactors:
        """Factors of the exact step over dt (docs/model.md, "Substrate").

        ``dt = math.inf`` gives the relaxed (elastic E0) problem used for the preload.
        """
        e0, einf, tau = self.e_relaxed, self.e_instantaneous, self.relaxation_time
        x = dt / tau  # dt = inf gives decay = phi = 0: Eeff = E0, no history
        decay = math.exp(-x)
        phi = -math.expm1(-x) / x  # tau (1 - a) / dt without cancellation at small dt
        e_eff = e0 + (einf - e0) * phi
        return StepFactors(decay=decay, e_eff=e_eff, e_history=e0 * (1.0 - decay) - e_eff)

    def curvature_response(self, dt: float) -> float:
        """(Einf - E0) F(dt): the step's traction error per unit curvature of u (stress time^2).

        The exact step assumes u linear in time within it. For u(t_n + s) = u_n + v s + c s^2
        the traction at the step's end misses (|q|/2) (Einf - E0) c F(dt) per mode
        (:func:`curvature_integral`). Zero for the elastic solid.
        """
        return (self.e_instantaneous - self.e_relaxed) * curvature_integral(
            dt, self.relaxation_time)

    @property
    def shortest_time(self) -> float:
        """tau, the fastest (only) memory time (time units)."""
        return self.relaxation_time

    @property
    def retardation_time(self) -> float:
        """tau Einf / E0 = tau / k, the creep compliance's time (M9) (time units)."""
        return self.relaxation_time * self.e_instantaneous / self.e_relaxed

    def relaxation_modulus(self, t):
        """E*(t) = E0 + (Einf - E0) exp(-t/tau) (M5), stress units; t in time units."""
        t = np.asarray(t, dtype=float)
        e0, einf, tau = self.e_relaxed, self.e_instantaneous, self.relaxation_time
        return e0 + (einf - e0) * np.exp(-t / tau)

    def complex_modulus(self, omega):
        """E*(omega) = E0 + (Einf - E0) i omega tau / (1 + i omega tau) (stress units)."""
        omega = np.asarray(omega, dtype=float)
        e0, einf, tau = self.e_relaxed, self.e_instantaneous, self.relaxation_time
        return e0 + (einf - e0) * 1j * omega * tau / (1.0 + 1j * omega * tau)

    def creep_compliance(self, t):
        """J(t) = 1/E0 - (1/E0 - 1/Einf) exp(-t E0 / (Einf tau)) (docs/model.md, "Substrate")."""
        e0, einf, tau = self.e_relaxed, self.e_instantaneous, self.relaxation_time
        return 1.0 / e0 - (1.0 / e0 - 1.0 / einf) * np.exp(-np.asarray(t) * e0 / (einf * tau))


def curvature_integral(dt: float, tau: float) -> float:
    """F(dt) = integral_0^dt exp(-(dt - s)/tau) (2 s - dt) ds (time^2; docs/model.md, (M8)).

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


@dataclass
class StepOperators:
    """Mode-diagonal data of one time step (already divided by n for the unnormalised irfft).

    Attributes
    ----------
    stiffness : ndarray, shape of this rank's spectrum
        k_q / n = (|q|/2) Eeff / n, zero at q = 0 (stress/length units).
    compliance : ndarray, shape of this rank's spectrum
        1 / (k_q n), zero at q = 0: the preconditioner (length/stress units).
    """

    stiffness: np.ndarray
    compliance: np.ndarray

    @classmethod
    def from_modulus(cls, half_q, modulus, n):
        """Operators for stiffness (|q|/2) * modulus; ``half_q`` is |q|/2 per local mode."""
        stiffness = half_q * (modulus / n)
        compliance = np.zeros_like(half_q)
        moving = half_q > 0.0  # the q = 0 mode (rigid motion) is held by the zero mean
        compliance[moving] = 1.0 / (half_q[moving] * modulus * n)
        return cls(stiffness, compliance)


def quadratic_terms(material, dt, step_before):
    """The quadratic step's coefficients (docs/model.md, (M46)), or None for the linear step.

    Parameters
    ----------
    material : StandardLinearSolid or GeneralizedMaxwell
    dt, step_before : float
        The step's length and the accepted step's before it, h (time units); ``step_before``
        None (after the preload or a start from a given u) or ``dt`` infinite (the relaxed
        preload): the linear step.

    Returns
    -------
    (float, float) or None
        (R / (dt (dt + h)), R / (h (dt + h))) with R = curvature_response(dt) (stress
        time^2): the modulus added to Eeff and the weight of G_n - G_{n-1} in the history.
    """
    if step_before is None or not math.isfinite(dt):
        return None
    response = material.curvature_response(dt)
    return (response / (dt * (dt + step_before)),
            response / (step_before * (dt + step_before)))


class ViscoelasticHalfSpace:
    """Per-mode SLS time stepping of the periodic half-space (docs/model.md, "Substrate").

    Holds the operators of a step (recomputed only when dt or the step before changes;
    the last few kept) and forms the
    history traction H = a p_n + (|q|/2)(E0 (1 - a) - Eeff) u_n from the previous state.
    After the step's equilibrium u_{n+1}, the substrate traction is p_{n+1} = K u_{n+1} + H.

    The state is p_n, G_n = (|q|/2) u_n and G_{n-1}, all in real space: mode-diagonal maps
    commute with the transform, so H = a p_n + (E0 (1 - a) - Eeff) G_n needs no transform,
    and G_{n+1} = (K u_{n+1}) / Eeff comes with the solve (as for the Prony series,
    :mod:`.prony`). Only a state that starts from a given u (:meth:`start`) costs one.

    Given the step before, h (``step_before``), a step is the quadratic one (module
    docstring, (M46)): modulus Eeff' = Eeff + R / (dt (dt + h)) and history
    H' = H - R (G_n / (dt (dt + h)) + (G_n - G_{n-1}) / (h (dt + h))); then
    p_{n+1} = K' u_{n+1} + H' and G_{n+1} = K' u_{n+1} / Eeff'. Every method of a step takes
    the same ``step_before``.

    Parameters
    ----------
    material : StandardLinearSolid
    half_q : ndarray
        |q|/2 of each Fourier mode this rank holds, in the FFT's local order (1/length).
    n : int
        Grid points.
    local_n : int, optional
        Nodes of this rank's real-space block (default n: one rank).
    """

    def __init__(self, material: StandardLinearSolid, half_q, n: int, local_n: int = None):
        self.material = material
        self.half_q = half_q
        self.n = n
        local_n = n if local_n is None else local_n
        self.relaxed_traction = np.zeros(local_n)  # G_n
        self.relaxed_before = np.zeros(local_n)  # G_{n-1}
        self._relaxed_start = np.zeros(local_n)  # G_n of the step being solved
        self.last_step_quadratic = False  # the last update's step was the quadratic one
        self._key = None
        self._kept = {}  # (dt, h) -> (operators, decay, e_history, modulus, terms), LRU first

    def operators(self, dt: float, step_before=None) -> StepOperators:
        """Stiffness (|q|/2) Eeff(dt) (Eeff' for the quadratic step) and its preconditioner;
        dt = inf is the relaxed solid."""
        self._prepare(dt, step_before)
        return self._ops

    def start(self, fft, u, out=None):
        """Collective (one FFT pair): G = (|q|/2) u of the displacement ``u`` into ``out``
        (default the state's G_n: a state not reached by :meth:`update`, a given start)."""
        fft.apply_diagonal(u, self.half_q * (1.0 / self.n),
                           self.relaxed_traction if out is None else out)

    def history(self, fft, u, substrate_traction, dt, out, step_before=None):
        """History traction H of a step of length dt (M8; H' of (M46) given ``step_before``)
        into ``out`` (stress units).

        Local (no transform): H = a p_n + (E0 (1 - a) - Eeff) G_n, G_n = (|q|/2) u_n of the
        state (:meth:`update`, :meth:`start`); ``fft`` and ``u`` are not needed. The state's
        G_n is kept as the step's start for :meth:`update` (a step may be solved more than
        once: the compliant drive's search).
        """
        self._prepare(dt, step_before)
        added, weight = self._terms if self._terms is not None else (0.0, 0.0)
        sls_history(self.relaxed_traction, substrate_traction, self.relaxed_before,
                    self._e_history, self._decay, added, weight, self._terms is not None,
                    out, self._relaxed_start)
        return out

    def state_elastic_traction(self, dt, out, step_before=None):
        """K(dt) u_n = Eeff(dt) G_n (Eeff' G_n for the quadratic step) of the state's
        displacement under a step of length dt (stress units; local, no transform)."""
        self._prepare(dt, step_before)
        return np.multiply(self.relaxed_traction, self._modulus, out=out)

    def field_names(self):
        """Names of the state fields beyond u and p: G_n and G_{n-1}."""
        return ("relaxed_traction", "relaxed_before")

    def fields(self):
        """{name: this rank's block} of the state fields beyond u and p (views)."""
        return {"relaxed_traction": self.relaxed_traction,
                "relaxed_before": self.relaxed_before}

    def restore(self, fields, fft=None, u=None, u_before=None):
        """Set G_n and G_{n-1} from ``fields``; collective when they lack them (checkpoints
        written before they were kept): G_n from ``u``, G_{n-1} from ``u_before`` (u_{n-1},
        or u when it is None) by one transform each."""
        if "relaxed_traction" in fields:
            self.relaxed_traction[:] = fields["relaxed_traction"]
        else:
            self.start(fft, u)
        if "relaxed_before" in fields:
            self.relaxed_before[:] = fields["relaxed_before"]
        else:
            self.start(fft, u if u_before is None else u_before, self.relaxed_before)

    def update(self, elastic_traction, history, dt, substrate_traction, step_before=None):
        """After a step's solve: the substrate traction p_{n+1} = K u_{n+1} + H (M8, (M46)),
        G_{n+1} = (K u_{n+1}) / Eeff (Eeff') and G_{n-1} = the step's start G_n."""
        self._prepare(dt, step_before)
        np.add(elastic_traction, history, out=substrate_traction)
        self.relaxed_before[:] = self._relaxed_start
        np.multiply(elastic_traction, 1.0 / self._modulus, out=self.relaxed_traction)
        self.last_step_quadratic = self._terms is not None

    def correct(self, missed, dt, substrate_traction):
        """Add the traction the linear step of length dt missed to p (the whole history);
        nothing after a quadratic step, which holds it."""
        if not self.last_step_quadratic:
            substrate_traction += missed

    def _prepare(self, dt, step_before=None):
        key = (dt, step_before)
        if key == self._key:
            return
        # Adaptive steps recur on a grid of lengths (dt_min 2^(j/4)): the last few pairs'
        # operators are kept rather than remade at every change.
        kept = self._kept.pop(key, None)
        if kept is None:
            f = self.material.step_factors(dt)
            terms = quadratic_terms(self.material, dt, step_before)
            modulus = f.e_eff + (terms[0] if terms else 0.0)
            kept = (StepOperators.from_modulus(self.half_q, modulus, self.n), f.decay,
                    f.e_history, modulus, terms)
        self._kept[key] = kept
        if len(self._kept) > KEPT_LENGTHS:
            del self._kept[next(iter(self._kept))]  # the least recently used
        self._ops, self._decay, self._e_history, self._modulus, self._terms = kept
        self._key = key
