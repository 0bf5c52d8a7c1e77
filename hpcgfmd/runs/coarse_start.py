"""Coarse-to-fine start of the preload: the relaxed indentation solved on coarser grids first.

The preload (:meth:`hpcgfmd.runs.protocol.Retraction.preload`) starts from a flat surface;
from there the active-set CG needs a number of iterations that grows with the grid (about
n_x^0.4: the contact's active set is found a few nodes per restart). Started from the
solution of the same problem on a grid of half the nodes, interpolated, the fine solve only
corrects the interpolation error near the contact and cohesive-zone edges. Applied
recursively, the levels halve n_x down to a grid of at least ``MIN_LEVEL_NODES`` nodes; their
total work is below one fine solve of the same iteration count, as each level has half the
nodes of the next.

A level whose grid has fewer than ``MIN_ZONE_NODES`` nodes across the relaxed zone width w
solves the same case with a smaller Maugis parameter lambda_c = lambda0 sqrt(w / (MIN_ZONE_NODES
dx)), the work of adhesion (alpha) kept: its zone, w lambda0^2 / lambda_c^2 (docs/model.md
(M23)), has those nodes. A JKR-like contact's size depends on the work of adhesion, not on
lambda, to O(1 / lambda^2) (Baney-Hui, (M26)): the coarse contact is the fine one's but for
its edges, which the finer levels move by a few nodes. Without it a large lambda0 (a real
elastomer's hundreds) would leave one level, solved from flat, whose active set grows a few
nodes per iteration across a contact of millions. The levels stop where lambda_c would fall
below ``MIN_COARSE_MAUGIS`` (the contact no longer JKR-like) or the contact half-width
sqrt(2 R h0) below ``MIN_CONTACT_NODES`` nodes.

Invariants. Only the start of the fine solve changes: it still descends to the local energy
minimum of the loading branch to the case's tolerance, so the preload's equilibrium is the
same to that tolerance (the relaxed adhesive indentation has one loading-branch minimum for
a given depth; docs/model.md, "Protocol"). Each coarse level is an ordinary preload of the
same case with ``nx`` halved (and lambda0 coarsened as above), on the same ranks; its result
is gathered on every rank and
interpolated linearly (coarse node j sits on fine node 2j; odd fine nodes take the mean of
their neighbours, periodically), then shifted to zero mean (the q = 0 mode of u is held at
zero). The fine solver projects the start onto the wall (u <= h + u_z), which the chords
between coarse nodes on the parabola exceed by at most dx^2 / (2R) per coarse interval.
Rank independence: every level is collective and deterministic on any number of ranks.
"""

from __future__ import annotations

import dataclasses
import gc
import logging
import math

import numpy as np

log = logging.getLogger(__name__)

#: A level has at least this many nodes across its cohesive-zone width (coarser zones
#: misplace their edges by more than the fine solve saves): its lambda is coarsened to it.
MIN_ZONE_NODES = 2.0
#: The coarsest level has at least this many nodes in the cell (below, a flat start is as
#: cheap) ...
MIN_LEVEL_NODES = 4096
#: ... a coarsened lambda of at least this (the contact JKR-like: its size within about 1 %
#: of the fine one's, docs/model.md (M26)) ...
MIN_COARSE_MAUGIS = 5.0
#: ... and at least this many nodes across the geometric contact half-width sqrt(2 R h0).
MIN_CONTACT_NODES = 64.0
#: Residual tolerance of the coarse levels (relative to sigma_a): their solution is a start,
#: its error at most the coarse grid's discretisation error, far above the case's tolerance.
COARSE_TOLERANCE = 1e-4


def coarser_nx(case) -> int | None:
    """The n_x of the next coarser level, or None when ``case``'s grid is the coarsest.

    Halves n_x when the halved grid is even (every grid is), keeps ``MIN_LEVEL_NODES`` nodes,
    ``MIN_CONTACT_NODES`` across sqrt(2 R h0), and a zone of ``MIN_ZONE_NODES`` nodes with a
    lambda of at least ``MIN_COARSE_MAUGIS`` (:func:`coarse_maugis`).
    """
    nx = case.numerics.nx
    if nx % 4 or nx // 2 < MIN_LEVEL_NODES:
        return None
    if math.sqrt(2.0 * case.depth) / (case.cell / (nx // 2)) < MIN_CONTACT_NODES:
        return None
    maugis = coarse_maugis(case, nx // 2)
    if maugis < case.maugis and maugis < MIN_COARSE_MAUGIS:
        return None
    return nx // 2


def coarse_maugis(case, nx: int) -> float:
    """The lambda of ``case``'s level on ``nx`` nodes: lambda0, or lambda0 sqrt(w / (MIN_ZONE_NODES
    dx)) where the grid has fewer than MIN_ZONE_NODES nodes across w (module docstring)."""
    points = case.zone_width / (case.cell / nx)
    if points >= MIN_ZONE_NODES:
        return case.maugis
    return case.maugis * math.sqrt(points / MIN_ZONE_NODES)


def preload_grids(case) -> list:
    """The preload's grids, coarsest first, ending with ``case``'s own."""
    grids = [case.numerics.nx]
    while (nx := coarser_nx(coarse_case(case, grids[0]))) is not None:
        grids.insert(0, nx)
    return grids


def coarse_case(case, nx: int):
    """``case`` on ``nx`` nodes, solved to the coarse levels' tolerance, its lambda coarsened
    where the grid does not resolve w (:func:`coarse_maugis`)."""
    from ..case import Case

    tolerance = max(case.numerics.tolerance, COARSE_TOLERANCE)
    numerics = dataclasses.replace(case.numerics, nx=nx, tolerance=tolerance)
    maugis = coarse_maugis(case, nx)
    if maugis == case.maugis:
        return dataclasses.replace(case, numerics=numerics)
    return Case(
        maugis=maugis,
        modulus_ratio=None if case.relaxation_moduli else case.modulus_ratio,
        velocity=case.velocity,
        depth=case.depth,
        cell=case.cell,
        adhesion=case.adhesion,
        numerics=numerics,
        output=case.output,
        relaxation_moduli=case.relaxation_moduli,
        relaxation_times=case.relaxation_times,
        drive_stiffness=case.drive_stiffness,
        protocol=case.protocol,
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
    # the level's arrays hang in reference cycles: free them now, not at the next collection
    # (the preload's peak memory would hold every level beside the fine grid)
    del coarse
    gc.collect()
    start = prolong(full, domain.x_start, domain.x_stop)
    start -= domain.sum(start.sum()) / domain.n
    return start, levels
