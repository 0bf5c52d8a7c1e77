"""The viscoelastic periodic half-space, stepped in time one Fourier mode at a time.

Per mode q != 0 the surface traction of a generalized Maxwell solid (:mod:`.material`) is
p = (|q|/2) (E0 u + sum_i s_i), each branch stress obeying ds_i/dt + s_i / tau_i = E_i du/dt
(docs/model.md, (M39)). Integrated exactly over a step dt with u linear in time (M40), every
time step is an elastic problem of stiffness (|q|/2) Eeff plus a known history traction:

    p_{n+1} = (|q|/2) Eeff u_{n+1} + H_n,
    H_n = a_1 p_n + (E0 (1 - a_1) - Eeff) G_n + sum_{i>1} (a_i - a_1) S_i,n

with G = (|q|/2) u and S_i = (|q|/2) s_i. The first branch's stress is not stored: it is
p_n - E0 G_n - sum_{i>1} S_i,n, which turns sum_i a_i S_i - (Eeff - E0) G_n of (M40) into
the form above. For one branch (the SLS of the paper) H_n is (M8) exactly, evaluated as the
paper's exact SLS step; further branches add their terms. The quadratic step (M46) takes u
quadratic in time through u_{n-1}, u_n and u_{n+1}: modulus Eeff' = Eeff + R / (dt (dt + h))
and history H' = H - R (G_n / (dt (dt + h)) + (G_n - G_{n-1}) / (h (dt + h))), R the
curvature response sum_i E_i F_i(dt), h the step before; each stored branch gains
E_i F_i(dt) c.

The state is p_n, G_n, G_{n-1} and S_i,n (i > 1), all real-space blocks of this rank: the
mode-diagonal maps commute with the transform, so the history needs no transform, and
G_{n+1} = K u_{n+1} / Eeff comes with the step's solve (K the step's stiffness). Numpy and
one compiled loop (:mod:`.history_kernels`); no MPI.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from ..state import State
from .history_kernels import sls_history
from .material import GeneralizedMaxwell

KEPT_LENGTHS = 6  # (step, step before) pairs whose operators a half-space keeps


@dataclass
class StepOperators:
    """Mode-diagonal data of one time step (already divided by n for the unnormalised irfft).

    Attributes
    ----------
    stiffness : ndarray, shape of this rank's spectrum
        k_q / n = (|q|/2) Eeff / n, zero at q = 0 (stress/length).
    compliance : ndarray, shape of this rank's spectrum
        1 / (k_q n), zero at q = 0: the preconditioner (length/stress).
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

    ``step_before`` None (after the preload, or a segment's first step) or ``dt`` infinite
    (the relaxed preload): the linear step. Otherwise (R / (dt (dt + h)), R / (h (dt + h)))
    with R = material.curvature_response(dt) (stress time^2): the modulus added to Eeff and
    the weight of G_n - G_{n-1} in the history.
    """
    if step_before is None or not math.isfinite(dt):
        return None
    response = material.curvature_response(dt)
    return (response / (dt * (dt + step_before)), response / (step_before * (dt + step_before)))


class Substrate(ABC):
    """What a run needs of a substrate stepped in time (collective nowhere: local blocks).

    Attributes
    ----------
    material : GeneralizedMaxwell
    half_q : ndarray
        |q|/2 of each Fourier mode this rank holds, in the transform's local order (1/length).
    n : int
        Grid nodes (the transforms' normalisation).
    traction : ndarray
        p_n, the substrate traction of the last accepted state (stress), this rank's block.
    last_step_quadratic : bool
        The last :meth:`update` was a quadratic step (M46).
    """

    @abstractmethod
    def operators(self, dt: float, step_before=None) -> StepOperators:
        """Stiffness and preconditioner of a step of length dt (dt = inf: relaxed)."""

    @abstractmethod
    def history(self, dt: float, out, step_before=None):
        """The history traction H of a step of length dt into ``out`` (stress)."""

    @abstractmethod
    def state_elastic_traction(self, dt: float, out, step_before=None):
        """K(dt) u_n of the state's displacement under a step's stiffness (stress)."""

    @abstractmethod
    def update(self, elastic_traction, history, dt: float, step_before=None):
        """After a step's solve: the new state from K u_{n+1} and the step's history."""

    @abstractmethod
    def correct(self, missed, dt: float):
        """Add the traction a linear step of length dt missed to the state."""

    @abstractmethod
    def state(self) -> State:
        """The substrate's state (:mod:`hpcgfmd.state`)."""

    @abstractmethod
    def restore(self, state: State):
        """Continue from :meth:`state`."""


class MaxwellHalfSpace(Substrate):
    """Per-mode generalized Maxwell stepping of the periodic half-space (module docstring).

    Holds the operators of a step (recomputed only when dt or the step before changes; the
    last few kept: adaptive steps recur on a grid of lengths) and the state. A step may be
    solved more than once (the compliant drive's search): :meth:`history` keeps the state at
    the step's start, from which every :meth:`update` of that step starts.

    Parameters
    ----------
    material : GeneralizedMaxwell
    half_q : ndarray
        |q|/2 of each Fourier mode this rank holds, in the transform's local order (1/length).
    n : int
        Grid nodes.
    local_n : int
        Nodes of this rank's real-space block.
    """

    def __init__(self, material: GeneralizedMaxwell, half_q, n: int, local_n: int):
        self.material = material
        self.half_q = half_q
        self.n = n
        stored = material.branches - 1  # the first branch's stress is implied by p
        self.traction = np.zeros(local_n)  # p_n
        self.relaxed = np.zeros(local_n)  # G_n = (|q|/2) u_n
        self.relaxed_before = np.zeros(local_n)  # G_{n-1}
        self.branches = np.zeros((stored, local_n))  # S_i,n, i > 1
        self.last_step_quadratic = False
        # the step's start (for the updates of a step solved more than once)
        self._relaxed_start = np.zeros(local_n)
        self._before_start = np.zeros(local_n) if stored else None
        self._branches_start = np.zeros((stored, local_n))
        self._scratch = np.empty(local_n) if stored else None
        self._key = None
        self._kept = {}  # (dt, h) -> step data, least recently used first

    # --- a step ------------------------------------------------------------------------
    def operators(self, dt: float, step_before=None) -> StepOperators:
        """Stiffness (|q|/2) Eeff(dt) (Eeff' for the quadratic step) and its preconditioner;
        dt = inf is the relaxed solid."""
        self._prepare(dt, step_before)
        return self._step.operators

    def history(self, dt: float, out, step_before=None):
        """History traction H of a step of length dt (module docstring; H' of (M46) given
        ``step_before``) into ``out`` (stress); local, no transform. The state is kept as
        the step's start for :meth:`update`."""
        self._prepare(dt, step_before)
        step = self._step
        added, weight = step.terms if step.terms is not None else (0.0, 0.0)
        sls_history(
            self.relaxed,
            self.traction,
            self.relaxed_before,
            step.e_history,
            step.decays[0],
            added,
            weight,
            step.terms is not None,
            out,
            self._relaxed_start,
        )
        if len(self.branches):
            self._branches_start[:] = self.branches
            self._before_start[:] = self.relaxed_before
            for decay, branch in zip(step.decays[1:], self.branches):
                np.multiply(branch, decay - step.decays[0], out=self._scratch)
                out += self._scratch
        return out

    def state_elastic_traction(self, dt: float, out, step_before=None):
        """K(dt) u_n = Eeff(dt) G_n (Eeff' G_n for the quadratic step) of the state's
        displacement under a step of length dt (stress; local, no transform)."""
        self._prepare(dt, step_before)
        return np.multiply(self.relaxed, self._step.modulus, out=out)

    def update(self, elastic_traction, history, dt: float, step_before=None):
        """After a step's solve: p_{n+1} = K u_{n+1} + H, G_{n+1} = K u_{n+1} / Eeff (Eeff'),
        G_{n-1} = the start's G_n, and each stored branch S_i = a_i S_i,n + E_i phi_i
        (G_{n+1} - G_n) [+ E_i F_i(dt) c], from the step's start (:meth:`history`)."""
        self._prepare(dt, step_before)
        step = self._step
        np.add(elastic_traction, history, out=self.traction)
        self.relaxed_before[:] = self._relaxed_start
        np.multiply(elastic_traction, 1.0 / step.modulus, out=self.relaxed)
        self.last_step_quadratic = step.terms is not None
        if not len(self.branches):
            return
        change = np.subtract(self.relaxed, self._relaxed_start, out=self._scratch)
        for decay, weight, branch, start in zip(
            step.decays[1:], step.weights[1:], self.branches, self._branches_start
        ):
            np.multiply(start, decay, out=branch)
            branch += weight * change
        if self.last_step_quadratic:  # c (in G's units) times E_i F_i(dt)
            h = step_before
            curvature = change * (1.0 / (dt * (dt + h)))
            curvature -= (self._relaxed_start - self._before_start) * (1.0 / (h * (dt + h)))
            for response, branch in zip(step.responses[1:], self.branches):
                branch += response * curvature

    def correct(self, missed, dt: float):
        """Add the traction a linear step of length dt missed to p, and to each stored branch
        its share E_i F_i(dt) / sum_j E_j F_j(dt) (the first branch's share follows through
        p); nothing after a quadratic step, which holds it."""
        if self.last_step_quadratic:
            return
        self.traction += missed
        if len(self.branches):
            shares = self.material.branch_curvature_responses(dt)
            total = shares.sum()
            if total > 0.0:
                for share, branch in zip(shares[1:] / total, self.branches):
                    branch += share * missed

    def _prepare(self, dt, step_before=None):
        key = (dt, step_before)
        if key == self._key:
            return
        step = self._kept.pop(key, None)
        if step is None:
            step = _StepData.of(self.material, self.half_q, self.n, dt, step_before)
        self._kept[key] = step
        if len(self._kept) > KEPT_LENGTHS:
            del self._kept[next(iter(self._kept))]  # the least recently used
        self._step, self._key = step, key

    # --- state -------------------------------------------------------------------------
    def state(self) -> State:
        arrays = {
            "traction": self.traction,
            "relaxed": self.relaxed,
            "relaxed_before": self.relaxed_before,
        }
        arrays.update({f"branch_{i + 2}": branch for i, branch in enumerate(self.branches)})
        return State(arrays)

    def restore(self, state: State):
        for name, block in self.state().arrays.items():
            block[:] = state.arrays[name]


@dataclass
class _StepData:
    """The operators and factors of one (dt, step before) pair."""

    operators: StepOperators
    decays: tuple
    weights: tuple
    e_history: float
    modulus: float  # Eeff, or Eeff' of the quadratic step
    terms: tuple | None  # quadratic_terms
    responses: np.ndarray | None  # E_i F_i(dt) of the quadratic step

    @classmethod
    def of(cls, material, half_q, n, dt, step_before):
        factors = material.step_factors(dt)
        terms = quadratic_terms(material, dt, step_before)
        modulus = factors.e_eff + (terms[0] if terms else 0.0)
        responses = (
            material.branch_curvature_responses(dt) if terms and material.branches > 1 else None
        )
        return cls(
            StepOperators.from_modulus(half_q, modulus, n),
            factors.decays,
            factors.weights,
            factors.e_history,
            modulus,
            terms,
            responses,
        )
