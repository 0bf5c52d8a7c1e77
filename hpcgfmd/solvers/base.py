"""The equilibrium-solver interface of one time step, and the registry of solvers by name.

Every time step is an elastic problem of stiffness (|q|/2) Eeff plus a known history traction
(docs/model.md, "Substrate"), minimised over the surface displacement with the hard wall and
the cohesive law (docs/model.md, "Interface"). A solver relaxes ``u`` to that step's
equilibrium on the physical branch. The protocol (:mod:`hpcgfmd.runs.protocol`) sees solvers
only through :class:`EquilibriumSolver` and picks one by the case's ``[numerics] solver``
through :func:`make_solver`; it never branches on the name or probes attributes.

To add a solver: subclass :class:`EquilibriumSolver`, decorate it with
``@register("name")``, import its module in :mod:`hpcgfmd.solvers` and add the name to
``hpcgfmd.model.numerics.SOLVERS`` (the case-file vocabulary; a test holds the two equal).
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar

_REGISTRY: dict = {}


@dataclass
class SolveResult:
    """Outcome of one equilibrium solve.

    Attributes
    ----------
    iterations : int
        Iterations done (CG iterations, or pseudo steps of damped dynamics).
    residual : float
        max |projected residual traction| / traction scale at exit (dimensionless).
    converged : bool
        The solver's own criterion is met.
    mean_traction : float
        Lagrange multiplier of zero mean displacement: the uniform traction (stress units).
    abandoned : bool
        The iterate's contact edges moved beyond the caller's ``edge_watch`` limit: the
        solve stopped early, ``u`` is not an equilibrium.
    """

    iterations: int
    residual: float
    converged: bool
    mean_traction: float
    abandoned: bool = False


@dataclass
class EdgeWatch:
    """Contact edges a solve may not leave by more than ``limit`` (:mod:`.stepping`).

    Attributes
    ----------
    left, right : float
        Contact edges of the previous step (length).
    limit : float
        Largest edge motion the caller will accept (length); beyond it the solve may be
        abandoned.
    """

    left: float
    right: float
    limit: float


class EquilibriumSolver(ABC):
    """What the protocol needs of a solver of one step's equilibrium.

    Every method is collective over the case's communicator; arrays are this rank's block of
    nodes. ``ops`` is the step's :class:`~hpcgfmd.model.material.StepOperators`, ``history``
    the SLS history traction H (zero mean, stress), ``wall`` is h(x) + u_z (length),
    ``applied`` an optional prescribed surface traction (tests).

    Attributes
    ----------
    starts_from_prediction : bool
        True when the solver descends from its start, so that a better start (the protocol's
        predictor) saves work; False when it relaxes from rest whatever the start (damped
        dynamics starting from u_n).
    """

    starts_from_prediction: ClassVar[bool] = False

    @classmethod
    @abstractmethod
    def from_case(cls, case, domain, fft, law, half_q) -> "EquilibriumSolver":
        """The solver for ``case`` on this rank's ``domain`` with the planned ``fft``, the
        cohesive ``law`` and |q|/2 of the local modes ``half_q``."""

    @classmethod
    def describe(cls, numerics) -> str:
        """One line naming the method and its settings, printed at the start of a run."""
        return cls.name

    @abstractmethod
    def solve(self, u, wall, ops, history, applied=None,
              edge_watch: EdgeWatch | None = None) -> SolveResult:
        """Collective: relax ``u`` in place to the equilibrium of the step.

        ``edge_watch``: a solver may stop early (``abandoned``) once its iterate's contact
        edges are farther than ``edge_watch.limit`` from the given ones; it may also ignore it.
        """

    @abstractmethod
    def preload_solver(self) -> "EquilibriumSolver":
        """The solver of the relaxed preload (the loading-branch equilibrium, solved to the
        case's tolerance): ``self``, or a solver that shares this one's statistics."""

    @abstractmethod
    def energy(self, u, wall, ops, history, applied=None, stiffness_u=None) -> float:
        """Collective: the step's energy per unit length divided by dx (one FFT pair; none
        when ``stiffness_u``, K u under ``ops``, is given)."""

    @abstractmethod
    def elastic_traction(self):
        """K u of the last solve's displacement (stress; valid until the next solve)."""

    @abstractmethod
    def interface_traction(self, u, wall, history, mean_traction, out, applied=None):
        """Collective: traction of the indenter on the surface at equilibrium into ``out``."""

    @abstractmethod
    def statistics(self) -> dict:
        """Counters of the work done (integers, rank-independent), for the summary and the
        checkpoint."""

    @abstractmethod
    def restore_statistics(self, saved: dict):
        """Continue counting from :meth:`statistics` of a checkpoint (missing keys: 0)."""


def register(name: str):
    """Class decorator: make a solver available as ``[numerics] solver = name``."""
    def add(cls):
        if name in _REGISTRY:
            raise ValueError(f"solver {name!r} is registered twice")
        cls.name = name
        _REGISTRY[name] = cls
        return cls
    return add


def registered() -> tuple:
    """The names of the registered solvers."""
    return tuple(_REGISTRY)


def solver_class(name: str) -> type:
    """The registered solver class of ``name``."""
    return _REGISTRY[name]


def make_solver(case, domain, fft, law, half_q) -> EquilibriumSolver:
    """The solver of ``case.numerics.solver`` (see :func:`register`)."""
    return _REGISTRY[case.numerics.solver].from_case(case, domain, fft, law, half_q)
