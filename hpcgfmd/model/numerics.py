"""The numerics of a case: the ``[numerics]`` table resolved into a :class:`Numerics`, the
grid, the steps and the tolerances that ``accuracy`` implies where a key is left out
(docs/case-file.md, "[numerics]"; docs/numerics.md).
"""
from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass

from ..errors import CaseError
from . import accuracy as knob
from .grid import smallest_grid
from .keys import choice, integer, number, shown, unknown_keys

# Cohesive-zone resolution w/dx (w: relaxed zone width pi E0 dmax / (4 sigma_a)); the
# accuracy it buys is measured in docs/results.md ("Grid and time-step convergence").
MIN_ZONE_POINTS = 1.0      # below this (across w times the fast widening) nx is rejected
DEFAULT_STEP_PER_RANGE = 0.25  # fixed steps: the indenter moves this fraction of dmax per step
# The iteration cap of a solve: this many, plus the nodes across the geometric contact width
# 2 sqrt(2 R h0) (contact_nodes): an active-set solve lets about one node per contact edge
# off the wall per iteration, so the snap-off's last solve, which lets the whole remaining
# contact go at dt_min, needs about as many iterations as the contact has nodes.
DEFAULT_MAX_ITERATIONS = 5000
DT_MIN_PER_DEFAULT = 1.0 / 64.0     # dt_min: this fraction of the first step (<= fixed one)
FIRST_STEP_PER_DEFAULT = 1.0 / 16.0  # adaptive: the first step, doubling while errors allow
DT_MAX_DEPTH_FRACTION = 0.02        # dt_max: the indenter rises by this fraction of h0
PAPER_EQUILIBRATION_PER_ROOT_N = 1024  # the paper authors' code: 256 * 4 * sqrt(nx) pseudo steps
SOLVERS = ("cg", "paper")  # the names of hpcgfmd.solvers' registry
STEP_CONTROLS = ("adaptive", "fixed")
MIN_TOLERANCE = 1e-13      # the residual's round-off floor (max norm relative to sigma_a)
BYTES_PER_POINT = 320      # about 40 float64 work arrays per grid point
BYTES_PER_BRANCH = 24      # a Prony branch's traction, its step start and its undo copy
NUMERICS_KEYS = ("accuracy", "nx", "dt", "tolerance", "max_iterations", "solver",
                 "step_control", "dt_min", "dt_max", "edge_fraction", "load_tolerance",
                 "time_tolerance", "equilibration_steps")


@dataclass(frozen=True)
class Numerics:
    """Discretisation: grid points, time steps (internal units of tau), solver and its tolerance.

    With ``step_control = "adaptive"`` ``dt`` is the first step; ``edge_fraction`` (of the
    relaxed cohesive-zone width) and ``load_tolerance`` (in load scales) are the error
    targets of :mod:`hpcgfmd.solvers.stepping`. ``equilibration_steps`` is the paper solver's
    fixed number of pseudo time steps per time step.
    """

    nx: int
    nx_automatic: bool
    dt: float
    tolerance: float
    max_iterations: int
    accuracy: float = knob.DEFAULT_ACCURACY
    solver: str = "cg"
    step_control: str = "adaptive"
    dt_min: float = 0.0
    dt_max: float = math.inf
    edge_fraction: float = 0.5
    load_tolerance: float = 0.01
    time_tolerance: float = 0.01
    equilibration_steps: int = 0


def resolve_numerics(case, num: dict) -> Numerics:
    """``[numerics]`` keys (case units) -> :class:`Numerics` (internal units), defaults.

    ``case``: the :class:`~hpcgfmd.model.case.Case` whose groups, units and forms are
    resolved already (its numerics are what this makes)."""
    unknown_keys(num, "numerics", NUMERICS_KEYS)
    accuracy = (number(num, "numerics", "accuracy") if "accuracy" in num
                else knob.DEFAULT_ACCURACY)
    if not accuracy < 0.1:
        raise CaseError(f"[numerics] accuracy = {accuracy}: expected a relative error in"
                        " (0, 0.1)")
    nx, automatic = _grid(case, num, accuracy)
    time_unit = case.units.time
    solver = choice(num, "numerics", "solver", SOLVERS)
    step_control = choice(num, "numerics", "step_control", STEP_CONTROLS)
    speed = case.Vz * case.alpha ** (2.0 / 3.0)  # v_z = V_z beta^2, beta^2 = alpha^(2/3)
    dmax = case.alpha ** (2.0 / 3.0) / case.lambda0
    fixed_default = DEFAULT_STEP_PER_RANGE * dmax / speed
    # adaptive steps start short: the retraction starts with the steepest load change
    dt = (number(num, "numerics", "dt") / time_unit if "dt" in num
          else fixed_default * (1.0 if step_control == "fixed" else FIRST_STEP_PER_DEFAULT))
    dt_min = (number(num, "numerics", "dt_min") / time_unit if "dt_min" in num
              else DT_MIN_PER_DEFAULT * min(dt, fixed_default))
    dt_max = (number(num, "numerics", "dt_max") / time_unit if "dt_max" in num
              else max(DT_MAX_DEPTH_FRACTION * case.depth / speed, dt))
    # over- or underflowed; the SLS step divides by the square of a step (M46): a normal float
    shortest = math.sqrt(sys.float_info.min)
    for key, value in (("dt", dt), ("dt_min", dt_min)):
        if not shortest <= value < math.inf:
            given = f" = {shown(num[key])}" if key in num else " (default)"
            raise CaseError(f"[numerics] {key}{given}: {value:g} relaxation times, out of"
                            " the floating-point range; expected a finite step of at least"
                            f" {shortest:.3g} (the SLS step divides by its square)")
    if dt_min > dt_max:
        raise CaseError(f"[numerics] dt_min = {dt_min * time_unit:g}: must not exceed"
                        f" dt_max = {dt_max * time_unit:g}")
    if "equilibration_steps" in num:
        equilibration = integer(num, "numerics", "equilibration_steps", 1)
    else:
        equilibration = round(PAPER_EQUILIBRATION_PER_ROOT_N * math.sqrt(nx))
    tolerance = (number(num, "numerics", "tolerance") if "tolerance" in num
                 else knob.solver_tolerance(accuracy, case.compliant))
    if not MIN_TOLERANCE <= tolerance < 1e-2:
        raise CaseError(f"[numerics] tolerance = {tolerance}: expected a number in"
                        f" [{MIN_TOLERANCE:g}, 0.01)")
    return Numerics(
        nx=nx, nx_automatic=automatic, dt=dt, tolerance=tolerance, accuracy=accuracy,
        max_iterations=(integer(num, "numerics", "max_iterations", 1)
                        if "max_iterations" in num
                        else DEFAULT_MAX_ITERATIONS + contact_nodes(case, nx)),
        solver=solver, step_control=step_control, dt_min=dt_min, dt_max=dt_max,
        edge_fraction=(number(num, "numerics", "edge_fraction") if "edge_fraction" in num
                       else knob.edge_fraction(accuracy)),
        load_tolerance=(number(num, "numerics", "load_tolerance")
                        if "load_tolerance" in num else knob.load_tolerance(accuracy)),
        time_tolerance=(number(num, "numerics", "time_tolerance")
                        if "time_tolerance" in num else knob.time_tolerance(accuracy)),
        equilibration_steps=equilibration)


def automatic_nx(case, accuracy, widen=True):
    """The grid ``accuracy`` asks for: the smallest size f 2^a, f in {1, 3, 9}
    (:func:`~hpcgfmd.model.grid.smallest_grid`), with both the zone points
    :func:`~hpcgfmd.model.accuracy.zone_points` (of the retraction's rate; ``widen``: with
    the fast widening) across the relaxed cohesive zone (:attr:`zone_width`) and the
    contact points :func:`~hpcgfmd.model.accuracy.contact_points` across the geometric
    contact half-width sqrt(2 R h0).

    Parameters
    ----------
    case : hpcgfmd.model.case.Case
        Its groups (lambda0, k, chi_ve), cell L/R, depth h0/R and zone width w (R).
    accuracy : float
        The relative error asked for, in (0, 0.1).
    widen : bool
        Divide the zone points by the fast widening (False: the accuracy study's references).

    Returns
    -------
    int
        Grid nodes.

    Raises
    ------
    CaseError
        When the grid is beyond the floating-point range (a subnormal accuracy).
    """
    try:
        points = knob.zone_points(accuracy, case.chi_ve, case.k, case.lambda0, widen)
        across_contact = knob.contact_points(accuracy)
    except ZeroDivisionError:  # a subnormal accuracy underflows to 0
        points = across_contact = math.inf
    if not (math.isfinite(points) and math.isfinite(across_contact)):
        raise CaseError(f"[numerics] accuracy = {accuracy:g}: the grid it needs is out of"
                        " the floating-point range; expected a relative error in (0, 0.1)"
                        " of a size a grid can reach")
    return smallest_grid(max(_log2_ratio(points, case.cell, case.zone_width),
                             _log2_ratio(across_contact, case.cell,
                                         math.sqrt(2.0 * case.depth))))


def _grid(case, num, accuracy):
    """(nx, chosen automatically): given and checked, or :func:`automatic_nx`."""
    width = case.zone_width
    if "nx" not in num:
        nx = automatic_nx(case, accuracy)
        _check_memory(nx, True, len(case.relaxation_moduli))
        return nx, True
    nx = num["nx"]
    if isinstance(nx, bool) or not isinstance(nx, int) or nx < 64 or nx % 2:
        raise CaseError(f"[numerics] nx = {shown(nx)}: expected an even integer >= 64")
    _check_memory(nx, False, len(case.relaxation_moduli))  # first: nx may exceed floats
    # the zone the retraction's tip has: the relaxed w, wider for a fast one (the knob's
    # grids resolve it alike)
    width *= knob.fast_widening(case.chi_ve, case.k, case.lambda0)
    points = width / (case.cell / nx)
    if points < MIN_ZONE_POINTS:
        ratio = MIN_ZONE_POINTS * case.cell / width  # inf when beyond the float range
        need = (max(64, 2 * math.ceil(ratio / 2)) if math.isfinite(ratio)
                else smallest_grid(_log2_ratio(MIN_ZONE_POINTS, case.cell, width)))
        raise CaseError(f"[numerics] nx = {nx}: resolves the cohesive zone with"
                        f" {points:.3g} points; at least {MIN_ZONE_POINTS:g} is needed"
                        f" (nx >= {need}; left out, nx follows [numerics] accuracy)")
    return nx, False


def contact_nodes(case, nx) -> int:
    """Nodes of an nx grid across the geometric contact width 2 sqrt(2 R h0), which
    bounds the contact (:data:`hpcgfmd.model.case.MIN_CELL_PER_CONTACT`)."""
    return math.ceil(2.0 * math.sqrt(2.0 * case.depth) * nx / case.cell)


def _log2_ratio(a, b, c):
    """log2(a b / c), also where a b / c leaves the float range (in logarithms then)."""
    ratio = a * b / c
    if 0.0 < ratio < math.inf:
        return math.log2(ratio)
    return math.log2(a) + math.log2(b) - math.log2(c)


def _check_memory(nx, automatic, branches=0):
    memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    size = nx * (BYTES_PER_POINT + BYTES_PER_BRANCH * branches)
    if size > memory:
        gib = (f"{size / 2**30:.1f}" if size.bit_length() < 1000  # else beyond float range
               else f"2^{size.bit_length() - 31}")
        raise CaseError(f"[numerics] nx = {nx}{' (automatic)' if automatic else ''}: needs"
                        f" about {gib} GiB, more than the {memory / 2**30:.1f} GiB of this"
                        " machine")
