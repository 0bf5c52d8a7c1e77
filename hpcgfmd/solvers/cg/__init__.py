"""Active-set preconditioned conjugate gradients for one step's equilibrium: the default solver.

The solve loop is :mod:`.solver`; its parts are the active set of the wall (:mod:`.active_set`),
the line search (:mod:`.line_search`), the steps that reach the wall (:mod:`.wall_steps`), the
evaluation of points along a line (:mod:`.points`) and the step's energy (:mod:`.energy`).
"""

from .solver import ConstrainedCG

__all__ = ["ConstrainedCG"]
