"""Equilibrium solvers of one time step, the projection onto the feasible set, the predictor of a
step's start, and the time-step control.

Imports :mod:`hpcgfmd.model` and :mod:`hpcgfmd.parallel` only. Importing this package
registers every solver (:func:`.base.make_solver` picks one by ``[numerics] solver``).
"""

from . import cg, verlet  # noqa: F401  (registration)
from .base import EdgeWatch, EquilibriumSolver, SolveResult, make_solver, registered, solver_class

__all__ = [
    "EdgeWatch",
    "EquilibriumSolver",
    "SolveResult",
    "make_solver",
    "registered",
    "solver_class",
]
