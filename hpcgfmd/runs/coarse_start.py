"""Coarse-to-fine start of the preload: the relaxed indentation solved on coarser grids first.

The preload (:meth:`hpcgfmd.runs.protocol.Retraction.preload`) starts from a flat surface;
from there the active-set CG needs a number of iterations that grows with the grid (about
n_x^0.4: the contact's active set is found a few nodes per restart). Started from the
solution of the same problem on a grid of half the nodes, interpolated, the fine solve only
corrects the interpolation error near the contact and cohesive-zone edges. Applied
recursively, the levels halve n_x down to the coarsest grid that still resolves the
cohesive zone (``MIN_ZONE_NODES`` nodes across the relaxed zone width w) and has at least
``MIN_LEVEL_NODES`` nodes; their total work is below one fine solve of the same iteration
count, as each level has half the nodes of the next.

Invariants. Only the start of the fine solve changes: it still descends to the local energy
minimum of the loading branch to the case's tolerance, so the preload's equilibrium is the
same to that tolerance (the relaxed adhesive indentation has one loading-branch minimum for
a given depth; docs/model.md, "Protocol"). Each coarse level is an ordinary preload of the
same case with ``nx`` halved, on the same ranks; its result is gathered on every rank and
interpolated linearly (coarse node j sits on fine node 2j; odd fine nodes take the mean of
their neighbours, periodically), then shifted to zero mean (the q = 0 mode of u is held at
zero). The fine solver projects the start onto the wall (u <= h + u_z), which the chords
between coarse nodes on the parabola exceed by at most dx^2 / (2R) per coarse interval.
Rank independence: every level is collective and deterministic on any number of ranks.
"""

from __future__ import annotations

import dataclasses
import logging

import numpy as np

log = logging.getLogger(__name__)

#: Coarsest level: at least this many nodes across the relaxed cohesive-zone width w
#: (coarser grids misplace the zone's edges by more than the fine solve saves).
MIN_ZONE_NODES = 2.0
#: ... and at least this many nodes in the cell (below, a flat start is as cheap).
MIN_LEVEL_NODES = 4096
#: Residual tolerance of the coarse levels (relative to sigma_a): their solution is a start,
#: its error at most the coarse grid's discretisation error, far above the case's tolerance.
COARSE_TOLERANCE = 1e-4


def coarser_nx(case) -> int | None:
    """The n_x of the next coarser level, or None when ``case``'s grid is the coarsest.

    Halves n_x when the halved grid is even (every grid is), keeps ``MIN_LEVEL_NODES`` nodes and
    ``MIN_ZONE_NODES`` nodes across the zone width w (internal units: ``case.zone_width``).
    """
    nx = case.numerics.nx
    if nx % 4 or nx // 2 < MIN_LEVEL_NODES:
        return None
    if case.zone_width / (case.cell / (nx // 2)) < MIN_ZONE_NODES:
        return None
    return nx // 2


def preload_grids(case) -> list:
    """The preload's grids, coarsest first, ending with ``case``'s own."""
    grids = [case.numerics.nx]
    while (nx := coarser_nx(coarse_case(case, grids[0]))) is not None:
        grids.insert(0, nx)
    return grids


def coarse_case(case, nx: int):
    """``case`` on ``nx`` nodes, solved to the coarse levels' tolerance."""
    tolerance = max(case.numerics.tolerance, COARSE_TOLERANCE)
    return dataclasses.replace(
        case, numerics=dataclasses.replace(case.numerics, nx=nx, tolerance=tolerance)
    )


def prolong(coarse_full: np.ndarray, x_start: int, x_stop: int) -> np.ndarray:
    """Linear interpolation of a periodic field on n/2 nodes to the fine nodes
    [x_start, x_stop) of the grid of n nodes (coarse node j = fine node 2j).

    Parameters
    ----------
    coarse_full : ndarray, shape (n/2,)
        The whole coarse field (length).
    x_start, x_stop : int
        This rank's block of fine node indices.

    Returns
    -------
    ndarray, shape (x_stop - x_start,)
    """
    index = np.arange(x_start, x_stop)
    left = coarse_full[(index // 2) % coarse_full.size]
    right = coarse_full[((index + 1) // 2) % coarse_full.size]
    return 0.5 * (left + right)  # even nodes: left == right


def coarse_start(case, domain, planner_effort: str, level, watch=None):
    """Collective: this rank's block of the fine preload's start, or None (no coarser level).

    Parameters
    ----------
    case : Case
        The case (internal units); its ``numerics.nx`` is the fine grid of ``domain``.
    domain : Domain
        The fine grid's domain (its communicator and this rank's block).
    planner_effort : str
        FFTW planner flag of the coarse levels' transforms.
    level : callable
        ``level(case, comm, planner_effort=..., watch=...)`` builds a coarse level's protocol
        (the caller's class, :class:`hpcgfmd.runs.protocol.Retraction`: a coarse level is an
        ordinary preload, which starts from its own coarser level in turn).
    watch : hpcgfmd.runs.watch.Watch, optional
        The run's watch, which the coarse levels share.

    Returns
    -------
    start : ndarray or None
        The interpolated coarse preload, zero mean (length).
    levels : list of (int, int)
        (n_x, preload iterations) of every coarser level solved, coarsest first.
    """
    nx = coarser_nx(case)
    if nx is None:
        return None, []
    coarse = level(coarse_case(case, nx), domain.comm, planner_effort=planner_effort, watch=watch)
    try:
        record = coarse.preload()
        levels = coarse.preload_levels + [(nx, record.iterations)]
        full = coarse.domain.segment(coarse.surface.u, 0, nx)
    finally:
        coarse.close()
    start = prolong(full, domain.x_start, domain.x_stop)
    start -= domain.sum(start.sum()) / domain.n
    return start, levels
