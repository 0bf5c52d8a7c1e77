"""One accuracy knob: the numerics a case needs for a relative error of its pull-off load and
load-area curve (``[numerics] accuracy``; docs/numerics.md, "The accuracy knob").

The error is split into shares: the grid (the cohesive zone's resolution, and the contact's
for the load-area curve's contact width), the time steps
(the edge motion per step, the sampling of the load curve, the SLS history's integration)
and the equilibrium solver's tolerance. Each share follows from a measured law below; the
absolute load errors are in units of the relaxed 2D pull-off, 1.74 load scales (the
Maugis-Dugdale minimum of docs/model.md, (M26): 1.744 for lambda0 >= 3.5, 1.739 at 1.5, 1.724
at 1, 1.61 at 0.5), which no pull-off of the SLS undercuts from lambda0 = 1.5 on; below, the
error counted against it is up to 8 % (lambda0 = 0.5) larger than against the pull-off.
The laws were calibrated on the cases of docs/results.md ("The accuracy knob") and validated
on others.
"""

from __future__ import annotations

import math

DEFAULT_ACCURACY = 5e-3
PULL_OFF_SCALE = 1.74  # |relaxed pull-off| in load scales: the error's absolute unit
GRID_SHARE, STEP_SHARE = 0.5, 0.5
# Grid: pull-off error C (dx / w_eff)^P (elastic lambda = 3.5: 2.3 %, 0.5 %, 0.1 % at
# w/dx = 1.5, 3, 6).
GRID_ERROR, GRID_ORDER = 0.056, 2.2
# Edge motion: pull-off error about EDGE_ERROR f^2 at an edge allowance of f zone widths.
EDGE_ERROR = 2.5e-4
EDGE_FRACTION_RANGE = (0.25, 4.0)
# The most tensile sample of a load curve sampled with deviations e from the line through the
# two loads before misses the curve's minimum by about e / 8.
SAMPLING = 8.0
SOLVER_SHARE, SOLVER_RANGE = 0.5, (1e-8, 5e-3)
SOLVER_SHARE_COMPLIANT, SOLVER_RANGE_COMPLIANT = 0.02, (1e-8, 1e-4)
# Contact width: a contact edge between nodes is held by the node on the wall and then
# jumps (lattice trapping), so the load-area curve's half-width a_c moves in a staircase
# about CONTACT_ERROR dx / a_geo off the converged curve, a_geo = sqrt(2 R h0) the geometric
# contact half-width (measured up to 1.3 on lambda0 = 1, where the zone's grid is coarse
# against the contact), held to CONTACT_SHARE of the accuracy.
CONTACT_ERROR, CONTACT_SHARE = 1.3, 0.75
SPHERE_CONTACT = 2.1  # a sphere's points across sqrt(R h0), times sqrt(accuracy)


# Creeping retractions: below chi_ve / k = CREEP_RATE the grid needs (CREEP_RATE k /
# chi_ve)^(1/3) times the elastic law's points, at most CREEP_CAP times.
CREEP_RATE = 20.0
CREEP_CAP = 3.0


# Fast retractions: above chi_ve / k = CREEP_RATE the zone widens toward the glassy w / k,
# taken as (chi_ve / (CREEP_RATE k))^(1/3), at most 1 / k times, where the glassy tip is
# still JKR-like (lambda0 k^(2/3) >= GLASSY_MAUGIS).
GLASSY_MAUGIS = 1.0


# A fast retraction starts from the relaxed preload: until its edge is fast, its load-area
# points see the relaxed zone, which the widening leaves coarse. Their error is about
# C (dx / w)^RELAXED_ORDER, held to RELAXED_SHARE of the accuracy by a floor under the
# widened grid (docs/results.md, "The knob at large lambda0"). C = RELAXED_ERROR from
# lambda0 = 30 (lambda0 = 30, k = 0.2, V_z = 0.26: curve errors 3.4e-2, 1.4e-2, 8.6e-3,
# 3.5e-3, 1.9e-3 at w/dx = 0.58, 0.78, 1.17, 2.33, 3.11), RELAXED_ERROR_LOW up to lambda0 =
# 14 (the widened grids without the floor: (7, 0.1, 2, 0.02) 4.0e-3 at 0.85 and 4.4e-3 at
# 1.13, (14, 0.2, 0.5, 0.02) 4.3e-3 at 1.13 and 3.0e-3 at 1.51, whole curve errors, up to
# 5.6e-3 (dx / w)^1.5), log-linear in lambda0 between (:func:`relaxed_error`).
RELAXED_ERROR, RELAXED_ORDER, RELAXED_SHARE = 1.1e-2, 1.5, 0.75
RELAXED_ERROR_LOW = 5.6e-3
RELAXED_MAUGIS = (14.0, 30.0)  # lambda0 up to which C is RELAXED_ERROR_LOW, from which ...


def zone_points(accuracy, chi_ve=math.inf, k=1.0, lambda0=math.inf, widen=True):
    """Grid points across the relaxed cohesive zone w for the grid's share of ``accuracy``.

    The elastic law C (dx/w)^P, times the creep factor :func:`creep_factor` and over the
    fast widening :func:`fast_widening` (``widen``; without it, the relaxed zone is resolved
    as the elastic law asks: the grid of the accuracy study's references), but never below
    :func:`relaxed_points` (nor above the unwidened grid).
    """
    points = (GRID_ERROR / (GRID_SHARE * accuracy)) ** (1.0 / GRID_ORDER) * creep_factor(chi_ve, k)
    if not widen:
        return points
    floor = min(points, relaxed_points(accuracy, lambda0))
    return max(points / fast_widening(chi_ve, k, lambda0), floor)


# The fewest points across the zone each law was measured on: the elastic law from 1.5 (2.3e-2
# at lambda0 = 3.5), the relaxed floor from 0.58 (3.4e-2 at lambda0 = 30). A coarser grid's
# error is an extrapolation the knob does not vouch for (:func:`unvalidated`).
MIN_ELASTIC_POINTS, MIN_RELAXED_POINTS = 1.5, 0.58


def unvalidated(accuracy, chi_ve=math.inf, k=1.0, lambda0=math.inf):
    """None when the grid of ``accuracy`` lies within its laws' measured range; else why
    not and the coarsest accuracy that does, as "<why>; ... <= <accuracy>".

    The points across the zone the tip sees (the elastic law's, times the creep factor)
    must be at least MIN_ELASTIC_POINTS; where the widening's floor sets the grid, the
    relaxed zone's points at least MIN_RELAXED_POINTS.
    """
    elastic = (GRID_ERROR / (GRID_SHARE * accuracy)) ** (1.0 / GRID_ORDER) * creep_factor(chi_ve, k)
    if elastic < MIN_ELASTIC_POINTS:
        coarsest = (
            GRID_ERROR / GRID_SHARE / (MIN_ELASTIC_POINTS / creep_factor(chi_ve, k)) ** (GRID_ORDER)
        )
        return (
            f"{elastic:.2g} points across the cohesive zone, fewer than the"
            f" {MIN_ELASTIC_POINTS:g} its error law was measured on; accuracy <= {_down(coarsest)}"
        )
    widened = elastic / fast_widening(chi_ve, k, lambda0)
    floor = relaxed_points(accuracy, lambda0)
    if widened < floor < MIN_RELAXED_POINTS:
        coarsest = RELAXED_ERROR / RELAXED_SHARE / MIN_RELAXED_POINTS**RELAXED_ORDER
        return (
            f"{floor:.2g} points across the relaxed cohesive zone w (a fast retraction's"
            f" floor), fewer than the {MIN_RELAXED_POINTS:g} its error law was measured on;"
            f" accuracy <= {_down(coarsest)}"
        )
    return None


def _down(value) -> str:
    """``value`` to two significant digits, rounded down (a bound that holds as printed)."""
    scale = 10.0 ** (math.floor(math.log10(value)) - 1)
    return f"{math.floor(value / scale) * scale:.2g}"


def relaxed_error(lambda0=math.inf):
    """The coefficient C of the relaxed start's curve error C (dx / w)^RELAXED_ORDER on a
    widened grid: RELAXED_ERROR_LOW up to lambda0 = 14, RELAXED_ERROR from lambda0 = 30,
    log-linear in lambda0 between (0.89 a power of lambda0; the measurements are above the
    constants and in docs/results.md, "The knob at large lambda0")."""
    low, high = RELAXED_MAUGIS
    if not lambda0 > low:
        return RELAXED_ERROR_LOW
    if lambda0 >= high:
        return RELAXED_ERROR
    power = math.log(RELAXED_ERROR / RELAXED_ERROR_LOW) / math.log(high / low)
    return RELAXED_ERROR_LOW * (lambda0 / low) ** power


def relaxed_points(accuracy, lambda0=math.inf):
    """The fewest points across the relaxed zone w a widened grid keeps:
    (C / (RELAXED_SHARE accuracy))^(1 / RELAXED_ORDER), C = :func:`relaxed_error`, so that
    the load-area points of the retraction's relaxed start stay within the accuracy (from
    lambda0 = 30: 0.81, 1.3, 2.1 and 6.0 points at 2e-2, 1e-2, 5e-3 and 1e-3; up to lambda0 =
    14: 0.58, 0.82, 1.3 and 3.8). Never fewer than MIN_RELAXED_POINTS, the coarsest grid the
    law was measured on, where the large-lambda0 law keeps that many: a smaller lambda0
    lowers the floor but does not move the accuracy beyond which the knob refuses a grid
    (:func:`unvalidated`)."""
    points = (relaxed_error(lambda0) / (RELAXED_SHARE * accuracy)) ** (1.0 / RELAXED_ORDER)
    largest = (RELAXED_ERROR / (RELAXED_SHARE * accuracy)) ** (1.0 / RELAXED_ORDER)
    return max(points, min(MIN_RELAXED_POINTS, largest))


def sphere_contact_points(accuracy):
    """A sphere's grid points across sqrt(R h0) (the Hertz radius of its preload): the
    pull-off's error on the triangle-law grid falls as dx^2 (docs/results.md, "The sphere":
    2.6e-3, 6.3e-4 and 1.2e-4 at 16, 31 and 62 points across the starting contact radius of
    an elastic sphere at lambda0 = 1), so SPHERE_CONTACT / sqrt(accuracy) points: 30 at 5e-3.
    With the zone rule it holds 19 sphere runs within their accuracy (lambda0 = 1-7, k = 0.1
    and 1, V_z = 0.01-10; docs/results.md, "The knob on the sphere").
    """
    return SPHERE_CONTACT / math.sqrt(accuracy)


def contact_points(accuracy):
    """Grid points across the geometric contact half-width sqrt(2 R h0) for the load-area
    curve: CONTACT_ERROR / (CONTACT_SHARE accuracy).

    The curve error is a distance in units of the initial contact half-width, and a pinned
    edge puts a_c up to about CONTACT_ERROR dx / sqrt(2 R h0) off it (first order in dx: the
    edge is located between nodes by (M36), but the discrete edge itself sticks to a node
    and jumps). It binds where the cohesive zone is wide against the contact (lambda0 about
    1, shallow contacts, fine accuracies), where the zone's grid would leave a few tens of
    nodes across sqrt(2 R h0); elsewhere the zone's grid is finer. The coefficient is the
    largest measured where this staircase is the curve's error (it falls as dx); larger
    ratios of curve error to dx / sqrt(2 R h0) on zone-set grids are the zone's error,
    which falls faster.
    The measurements are in docs/results.md ("The accuracy knob").
    """
    return CONTACT_ERROR / (CONTACT_SHARE * accuracy)


def fast_widening(chi_ve, k, lambda0):
    """How much wider than the relaxed w the zone of a fast retraction is resolved:
    max(1, min((chi_ve / (CREEP_RATE k))^(1/3), 1 / k)) where the glassy Maugis
    parameter lambda0 k^(2/3) is at least GLASSY_MAUGIS, 1 elsewhere.

    The zone width is proportional to the modulus the tip sees (w = pi E dmax / (4 sigma_a)):
    between the relaxed E0 and the glassy E0 / k, toward the latter as chi_ve / k, the
    edge's speed against the retardation time, grows (the mirror of :func:`creep_factor`):
    the grid error of a fast retraction is far below the elastic law's at the relaxed w.
    Where the glassy tip is DMT-like (lambda0 k^(2/3) < GLASSY_MAUGIS: its zone wider than
    its contact) the contact, not the zone, sets the grid, and there is no widening.
    At most 1 / k, the glassy zone's own width; 1 for the elastic solid. Validated up to
    3.66 on the accuracy tables and up to 6.04 on the paper's fast cases against their
    converged 2^17 references. The measurements are in docs/results.md ("Grid and time-step
    convergence",
    "The accuracy knob", "Rules of the steps and the grid").
    """
    if k >= 1.0 or not chi_ve > 0.0 or lambda0 * k ** (2.0 / 3.0) < GLASSY_MAUGIS:
        return 1.0
    rate = (chi_ve / (CREEP_RATE * k)) ** (1.0 / 3.0)
    return max(1.0, min(rate, 1.0 / k))


def creep_factor(chi_ve, k):
    """More points across w for a creeping retraction:
    max(1, min(CREEP_CAP, (CREEP_RATE k / chi_ve)^(1/3))).

    chi_ve / k measures the edge's speed against the retardation time tau / k (chi_ve,
    paper Eq. 22, against tau). Where it is small the contact edge creeps across the nodes,
    pinned by the grid between crossings, and the dissipation it sees follows that stick
    and slip: the pull-off converges slower than on an elastic solid and is off more at
    equal w/dx. The factor is fitted to the points such cases need and validated on others
    (docs/results.md, "The accuracy knob"). Capped at CREEP_CAP: the relaxed limit is the
    elastic solid's, so the cap over-resolves very slow retractions. 1 for the elastic
    solid (k = 1).
    """
    if k >= 1.0 or not chi_ve > 0.0:
        return 1.0
    return max(1.0, min(CREEP_CAP, (CREEP_RATE * k / chi_ve) ** (1.0 / 3.0)))


def edge_fraction(accuracy):
    """Edge motion per step, in relaxed zone widths, for half the steps' share."""
    low, high = EDGE_FRACTION_RANGE
    return min(high, max(low, math.sqrt(0.5 * STEP_SHARE * accuracy / EDGE_ERROR)))


def load_tolerance(accuracy):
    """Deviation of a load from the line through the two before, in load scales: a quarter of
    the steps' share of the pull-off error."""
    return SAMPLING * 0.25 * STEP_SHARE * accuracy * PULL_OFF_SCALE


def snap_off_share(load_tolerance):
    """The work of separation's relative share the snap-off's placement takes
    (:mod:`hpcgfmd.solvers.snap_off`): the load tolerance's own share of the accuracy, a
    quarter of the steps' share (``load_tolerance`` in load scales, as :func:`load_tolerance`
    gives it)."""
    return load_tolerance / (SAMPLING * PULL_OFF_SCALE)


def time_tolerance(accuracy):
    """Load error of the SLS history allowed by the estimate, load scales: a step's own,
    and the one kept in the history accumulated over the retardation time
    (:class:`~hpcgfmd.solvers.stepping.HistoryError`).

    The whole error in units of the relaxed pull-off, twice the steps' share: the estimates
    are conservative (the pull-off error they let through is a fraction of the allowance).
    The signed sum of the kept errors, an estimate rather than a bound, is held to
    :data:`~hpcgfmd.solvers.stepping.KEPT_SHARE` of it. The validation is in
    docs/results.md ("The accuracy knob", "Fast retractions").
    """
    return accuracy * PULL_OFF_SCALE


def solver_tolerance(accuracy, compliant=False):
    """Residual traction / sigma_a at which a solve has converged: half the accuracy within
    [1e-8, 5e-3] under displacement control, 0.02 accuracy within [1e-8, 1e-4] with a
    compliant drive or under load control.

    The residual is a nodal maximum, and the load (its mean) errs far less: on the paper's
    cases at accuracy 5e-3, tolerances from 1e-3 to 5e-3 moved the pull-off by at most
    1e-4 of itself. What bounds the share is the load-area curve: a node near a contact
    edge that a loose solve leaves on the wall moves a_c by a node spacing, and with the
    whole accuracy as the tolerance (7, 0.1, 2, 0.02) at 5e-3 was 6.5e-3 off in the curve
    (4.4e-3 with half of it, 4.3e-3 with a fifth). A drive that lets go where its spring
    line touches the load curve is decided at a fold of the curve, where a load error moves
    the let-go point by its square root: the compliant drive keeps the tighter share. The
    measurements are in docs/results.md ("The solver's share", and
    "The paper's four cases" for the soft spring).
    """
    low, high = SOLVER_RANGE_COMPLIANT if compliant else SOLVER_RANGE
    return min(high, max(low, (SOLVER_SHARE_COMPLIANT if compliant else SOLVER_SHARE) * accuracy))
