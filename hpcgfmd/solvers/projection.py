"""The feasible set of one step: zero mean displacement and the hard wall u <= h + u_z.

Used by every solver (the start of a CG solve, its projected steps, the exact projections of
the damped dynamics) and by the predictor's guesses.
"""

from __future__ import annotations

import numpy as np

from .step_kernels import below_wall, feasibility


def project_feasible(domain, u, wall, out, wall_scale=None, shift=0.0, hold_contact=False):
    """Collective: the displacement min(u - c, wall) whose mean is zero, into ``out``.

    The shift c solves f(c) = sum min(u - c, wall) = 0. f is concave, decreasing and piecewise
    linear with f'(c) = -(number of free nodes), so Newton's method from any start converges
    monotonically after its first step, exactly once the free set settles; it stops when the
    update falls below 1e-15 of the wall's magnitude, which needs a sum as accurate as
    numpy's pairwise one (with a plain vectorised running sum the 3-rank preload of
    tests/test_coarse_start.py, tolerance 1e-11, stalled at a residual of 1.4e-11). With c
    the Lagrange multiplier of the zero mean, this is the Euclidean projection onto
    {mean u = 0, u <= wall} for the nodes off the wall.

    Parameters
    ----------
    domain : hpcgfmd.parallel.domain.Domain
        This rank's block and the collectives (one reduction of two numbers per Newton step).
    u, wall : ndarray, shape (local_n,)
        This rank's blocks of the displacement and of the wall h + u_z (length).
    out : ndarray, shape (local_n,)
        The projection (must not be ``u``).
    wall_scale : float, optional
        ``domain.max_abs(wall)`` when the caller has it (saves a reduction).
    shift : float
        Start of the Newton iteration for c (a warm start: the last projection's shift).
    hold_contact : bool
        Keep the nodes with u >= wall on the wall and shift only the others: a guess that
        carries its contact with the wall keeps it (the Euclidean projection would lower
        the whole patch off the wall by c when the guess's mean is positive, and a patch of
        millions of nodes off the wall by a uniform gap costs the CG hundreds of
        iterations to land again).

    Returns
    -------
    float
        The shift after the last Newton update (length), the warm start of the next call.

    Raises
    ------
    FloatingPointError
        The wall leaves no node free, so no shift gives zero mean.
    """
    c = shift
    if wall_scale is None:
        wall_scale = domain.max_abs(wall)
    tolerance = 1e-15 * (wall_scale + 1e-300)
    for _ in range(100):
        # one compiled pass for min(u - c, wall) and its free count; the sum stays numpy's
        # pairwise one (the accuracy the stopping test needs, above)
        free = below_wall(u, c, wall, out, hold_contact)
        total, count = domain.sums(out.sum(), free)
        if count == 0:
            raise FloatingPointError("the wall leaves no free node for zero mean displacement")
        step = total / count
        if abs(step) <= tolerance:
            return c + step
        c += step
    return c


def project_in_place(domain, u, wall, scratch):
    """Collective: replace ``u`` by its projection :func:`project_feasible` (from shift 0);
    returns the wall scale max |wall| (global).

    A start that is feasible already (no node above the wall and zero mean to the Newton
    iteration's tolerance: the predictor's projected guesses, an equilibrium under a wall
    that rose) is its own projection: one pass that only reads u and the wall finds it so,
    and u is left as it is. Otherwise u is projected through ``scratch`` and copied back.
    Either way u ends as project_feasible's output (to the sign of a zero), found with the
    same sums; two reductions, as the wall scale and the first Newton step take.
    """
    moved, free, wall_max = feasibility(u, wall)
    wall_scale, moved = domain.maxes(wall_max, float(moved))
    if moved == 0.0:
        # the first Newton step's sum: of min(u, wall) = u, numpy's pairwise sum as there
        total, count = domain.sums(u.sum(), free)
        if count > 0 and abs(total / count) <= 1e-15 * (wall_scale + 1e-300):
            return wall_scale
    project_feasible(domain, u, wall, scratch, wall_scale=wall_scale)
    np.copyto(u, scratch)
    return wall_scale
