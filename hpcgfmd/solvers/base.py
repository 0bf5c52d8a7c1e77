"""The equilibrium-solver interface of one time step, and the registry of solvers by name.

Every time step is an elastic problem of stiffness (|q|/2) Eeff plus a known history traction
(docs/model.md, "Substrate"), minimised over the surface displacement with the hard wall and
the cohesive law (:mod:`.step_problem`). A solver relaxes ``u`` to that step's equilibrium
on the physical branch. The run sees solvers only through :class:`EquilibriumSolver` and
picks one by the case's ``[numerics] solver`` through :func:`make_solver`.

To add a solver: subclass :class:`EquilibriumSolver`, decorate it with ``@register("name")``,
declare the ``[numerics]`` keys of its own in ``KEYS`` and import its module in
:mod:`hpcgfmd.solvers`. The case files accept its name and its keys from then on
(:mod:`hpcgfmd.case.numerics` asks the registry); nothing outside this package names a
solver.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable
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
    interrupted : bool
        A stop signal reached the solve (its ``watch``): it stopped early on every rank, ``u``
        is not an equilibrium.
    """

    iterations: int
    residual: float
    converged: bool
    mean_traction: float
    abandoned: bool = False
    interrupted: bool = False


class NoWatch:
    """The watch of a solve nobody watches: never a stop, no heartbeat.

    A solve's ``watch`` has ``flag()``, this process's stop flag (1.0: a stop signal was
    received, else 0.0), which the solver reduces with the values it reduces anyway in each
    iteration, and ``beat(iteration, residual)``, called each iteration for the run's
    progress lines (:class:`hpcgfmd.runs.watch.Watch`).
    """

    def flag(self) -> float:
        return 0.0

    def beat(self, iteration, residual=None):
        pass


NO_WATCH = NoWatch()


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


@dataclass(frozen=True)
class SolverKey:
    """A ``[numerics]`` key a solver declares for itself (an integer setting).

    Attributes
    ----------
    name : str
        The key.
    smallest : int
        The smallest value accepted.
    default : callable
        ``default(nx)``: the value when the key is left out, from the grid's nodes.
    meaning : str
        What it sets (docs/case-file.md).
    """

    name: str
    smallest: int
    default: Callable[[int], int]
    meaning: str


class EquilibriumSolver(ABC):
    """What the run needs of a solver of one step's equilibrium.

    Every method is collective over the case's communicator; arrays are this rank's block of
    nodes. ``ops`` is the step's :class:`~hpcgfmd.model.halfspace.StepOperators`,
    ``history`` the history traction H (zero mean, stress), ``wall`` is h + u_z (length),
    ``applied`` an optional prescribed surface traction (tests).

    Attributes
    ----------
    problem : hpcgfmd.solvers.step_problem.StepProblem
        The step's energy, interface traction and residual (the physics the solver solves).
    KEYS : tuple of SolverKey
        The ``[numerics]`` keys of this solver's own (class attribute).
    starts_from_prediction : bool
        True when the solver descends from its start, so that a better start (the run's
        predictor) saves work; False when it relaxes from rest whatever the start.
    """

    KEYS: ClassVar[tuple] = ()
    starts_from_prediction: ClassVar[bool] = False
    name: ClassVar[str]

    @classmethod
    @abstractmethod
    def from_case(cls, case, domain, fft, law, half_q) -> EquilibriumSolver:
        """The solver for ``case`` on this rank's ``domain`` with the planned ``fft``, the
        cohesive ``law`` and |q|/2 of the local modes ``half_q``."""

    @classmethod
    def describe(cls, numerics) -> str:
        """One line naming the method and its settings, printed at the start of a run."""
        return cls.name

    @classmethod
    def iterations_per_step(cls, numerics) -> float:
        """The iterations a step takes when the solver fixes them (its cost per step), NaN
        when they follow from the solve's convergence."""
        return math.nan

    @abstractmethod
    def solve(
        self, u, wall, ops, history, applied=None, edge_watch: EdgeWatch | None = None, watch=None
    ) -> SolveResult:
        """Collective: relax ``u`` in place to the equilibrium of the step.

        ``edge_watch``: a solver may stop early (``abandoned``) once its iterate's contact
        edges are farther than ``edge_watch.limit`` from the given ones; it may also ignore it.
        ``watch``: the run's watch (:class:`NoWatch`): a solver reduces its flag in every
        iteration and stops (``interrupted``) when any rank's is set, and beats it.
        """

    def preload_solver(self) -> EquilibriumSolver:
        """The solver of the relaxed preload (the loading-branch equilibrium, solved to the
        case's tolerance): ``self`` by default."""
        return self

    @abstractmethod
    def elastic_traction(self):
        """K u of the last solve's displacement (stress; valid until the next solve)."""

    def counters(self) -> dict:
        """Counters of the work done (integers, rank-independent; :mod:`hpcgfmd.state`)."""
        return {}

    def restore_counters(self, counters: dict):  # noqa: B027 (no counters by default)
        """Continue counting from :meth:`counters` of a checkpoint."""


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
    """The names of the registered solvers, the default first."""
    return tuple(_REGISTRY)


def solver_class(name: str) -> type:
    """The registered solver class of ``name``."""
    return _REGISTRY[name]


def make_solver(case, domain, fft, law, half_q) -> EquilibriumSolver:
    """The solver of ``case.numerics.solver`` (see :func:`register`)."""
    return _REGISTRY[case.numerics.solver].from_case(case, domain, fft, law, half_q)
