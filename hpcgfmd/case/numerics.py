"""The numerics of a case: the ``[numerics]`` table resolved into a :class:`Numerics`, the
grid, the steps and the tolerances that ``accuracy`` implies where a key is left out
(docs/case-file.md, "[numerics]"; docs/numerics.md).
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass

from ..errors import CaseError
from ..model import accuracy as knob
from ..model.grid import MAX_NODES, smallest_grid
from ..solvers import registered, solver_class
from .keys import choice, integer, number, shown, unknown_keys

# Cohesive-zone resolution w/dx (w: relaxed zone width pi E0 dmax / (4 sigma_a)); the
# accuracy it buys is measured in docs/results.md ("Grid and time-step convergence").
MIN_ZONE_POINTS = 1.0  # below this (across w times the fast widening) nx is rejected
DEFAULT_STEP_PER_RANGE = 0.25  # fixed steps: the indenter moves this fraction of dmax per step
# The iteration cap of a solve: this many, plus the nodes across the geometric contact width
# 2 sqrt(2 R h0) (contact_nodes): an active-set solve lets about one node per contact edge
# off the wall per iteration, so the snap-off's last solve, which lets the whole remaining
# contact go at dt_min, needs about as many iterations as the contact has nodes.
DEFAULT_MAX_ITERATIONS = 5000
DT_MIN_PER_DEFAULT = 1.0 / 64.0  # dt_min: this fraction of the first step (<= fixed one)
FIRST_STEP_PER_DEFAULT = 1.0 / 16.0  # adaptive: the first step, doubling while errors allow
DT_MAX_DEPTH_FRACTION = 0.02  # dt_max: the indenter rises by this fraction of h0
STEP_CONTROLS = ("adaptive", "fixed")
MIN_TOLERANCE = 1e-13  # the residual's round-off floor (max norm relative to sigma_a)
# the keys every case has; each solver adds its own (SolverKey, hpcgfmd.solvers.base)
COMMON_KEYS = (
    "accuracy",
    "nx",
    "n",
    "ny",
    "dt",
    "tolerance",
    "max_iterations",
    "solver",
    "step_control",
    "dt_min",
    "dt_max",
    "edge_fraction",
    "load_tolerance",
    "time_tolerance",
)


@dataclass(frozen=True)
class Numerics:
    """Discretisation: grid points, time steps (internal units of tau), solver and its
    tolerance, each from ``[numerics]`` or from the accuracy knob (:func:`resolve_numerics`).

    Attributes
    ----------
    nx : int
        Grid nodes along x (a sphere's n: its grid is n x n).
    nx_automatic : bool
        ``nx`` was chosen by the accuracy knob.
    ny : int
        Rows of a cylinder's surface (``[numerics] ny``; 0: a line).
    square : bool
        The grid is n x n with n = nx (a sphere's).
    dt : float
        The fixed step, or the first adaptive step (tau).
    tolerance : float
        The equilibrium solves' residual traction / sigma_a.
    max_iterations : int
        A solve's iteration cap.
    accuracy : float
        The relative error asked for (docs/numerics.md, "The accuracy knob").
    solver, step_control : str
        The equilibrium solver (a name of :mod:`hpcgfmd.solvers`' registry) and the time
        steps ("adaptive" or "fixed").
    dt_min, dt_max : float
        Adaptive steps' bounds (tau).
    edge_fraction, load_tolerance, time_tolerance : float
        The adaptive steps' error targets (:mod:`hpcgfmd.solvers.stepping`).
    solver_settings : tuple of (str, int)
        The solver's own keys and values (:attr:`EquilibriumSolver.KEYS`).
    """

    nx: int
    nx_automatic: bool
    dt: float
    tolerance: float
    max_iterations: int
    accuracy: float
    solver: str
    step_control: str
    dt_min: float
    dt_max: float
    edge_fraction: float
    load_tolerance: float
    time_tolerance: float
    solver_settings: tuple = ()
    ny: int = 0
    square: bool = False

    @property
    def n(self) -> int:
        """A sphere's nodes per side (its grid is n x n); 0 for a cylinder."""
        return self.nx if self.square else 0

    @property
    def shape(self) -> tuple:
        """The grid: (nx,) for a line, (ny, nx) for a surface (a sphere's (n, n), or a
        cylinder's on ``ny`` rows)."""
        if self.square:
            return (self.nx, self.nx)
        return (self.ny, self.nx) if self.ny else (self.nx,)

    def setting(self, name: str):
        """The value of the solver's own key ``name``."""
        return dict(self.solver_settings)[name]


def numerics_keys() -> tuple:
    """Every ``[numerics]`` key: the common ones and every registered solver's own."""
    own = tuple(key.name for name in registered() for key in solver_class(name).KEYS)
    return COMMON_KEYS + tuple(dict.fromkeys(own))


def resolve_numerics(groups, table: dict) -> Numerics:
    """``[numerics]`` keys (case units) -> :class:`Numerics` (internal units), each key left
    out from the accuracy knob (:mod:`hpcgfmd.model.accuracy`) or its default.

    ``groups``: the case's checked :class:`~.groups.Groups`."""
    unknown_keys(table, "numerics", numerics_keys())
    accuracy = (
        number(table, "numerics", "accuracy") if "accuracy" in table else knob.DEFAULT_ACCURACY
    )
    if not accuracy < 0.1:
        raise CaseError(f"[numerics] accuracy = {accuracy}: expected a relative error in (0, 0.1)")
    table = _grid_keys(groups, table)
    nx, automatic = _grid(groups, table, accuracy)
    ny = _rows(groups, table, nx)
    solver = choice(table, "numerics", "solver", registered())
    step_control = choice(table, "numerics", "step_control", STEP_CONTROLS)
    steps = _steps(groups, table, step_control)
    tolerance = (
        number(table, "numerics", "tolerance")
        if "tolerance" in table
        else knob.solver_tolerance(accuracy, groups.compliant)
    )
    if not MIN_TOLERANCE <= tolerance < 1e-2:
        raise CaseError(
            f"[numerics] tolerance = {tolerance}: expected a number in [{MIN_TOLERANCE:g}, 0.01)"
        )
    return Numerics(
        nx=nx,
        nx_automatic=automatic,
        **steps,
        tolerance=tolerance,
        accuracy=accuracy,
        max_iterations=(
            integer(table, "numerics", "max_iterations", 1)
            if "max_iterations" in table
            else DEFAULT_MAX_ITERATIONS + contact_nodes(groups, nx)
        ),
        solver=solver,
        step_control=step_control,
        edge_fraction=(
            number(table, "numerics", "edge_fraction")
            if "edge_fraction" in table
            else knob.edge_fraction(accuracy)
        ),
        load_tolerance=(
            number(table, "numerics", "load_tolerance")
            if "load_tolerance" in table
            else knob.load_tolerance(accuracy)
        ),
        time_tolerance=(
            number(table, "numerics", "time_tolerance")
            if "time_tolerance" in table
            else knob.time_tolerance(accuracy)
        ),
        solver_settings=_solver_settings(table, solver, nx),
        ny=ny,
        square=groups.sphere,
    )


def _grid_keys(groups, table) -> dict:
    """The table with a sphere's ``n`` under the name ``nx`` (the nodes along x); a sphere
    takes n, a cylinder nx (and ny for a surface of rows)."""
    if groups.sphere:
        for key in ("nx", "ny"):
            if key in table:
                raise CaseError(
                    f"[numerics] {key} = {shown(table[key])}: a sphere's grid is n x n;"
                    " give [numerics] n"
                )
        table = {k: v for k, v in table.items() if k != "n"} | (
            {"nx": table["n"]} if "n" in table else {}
        )
    elif "n" in table:
        raise CaseError(
            f"[numerics] n = {shown(table['n'])}: n is a sphere's grid (n x n); a cylinder's"
            " nodes are nx (and ny rows for a surface)"
        )
    return table


def _rows(groups, table, nx) -> int:
    """The rows of a cylinder's surface (0: a line); a sphere's n x n grid checked."""
    if groups.sphere:
        if nx * nx > MAX_NODES:
            raise CaseError(
                f"[numerics] n = {nx}: a grid of n^2 = 2^{math.log2(nx * nx):.0f} nodes;"
                f" at most 2^{MAX_NODES.bit_length() - 1} are run anywhere"
            )
        return 0
    if "ny" not in table:
        return 0
    ny = table["ny"]
    if isinstance(ny, bool) or not isinstance(ny, int) or ny < 2 or ny % 2 or ny * nx > MAX_NODES:
        raise CaseError(
            f"[numerics] ny = {shown(ny)}: expected an even number of rows >= 2 (the cylinder"
            " uniform along y on a surface of ny x nx nodes)"
        )
    return ny


def _steps(groups, table, step_control) -> dict:
    """dt, dt_min and dt_max (internal units): given (case units), or from the indenter's
    travel per interaction range."""
    time_unit = groups.units.time
    if groups.sphere:
        speed, dmax = groups.indenter_speed, groups.dmax
    else:
        speed = groups.velocity * groups.adhesion ** (2.0 / 3.0)  # v_z = V_z beta^2
        dmax = groups.adhesion ** (2.0 / 3.0) / groups.maugis
    fixed_default = DEFAULT_STEP_PER_RANGE * dmax / speed
    # adaptive steps start short: the retraction starts with the steepest load change
    dt = (
        number(table, "numerics", "dt") / time_unit
        if "dt" in table
        else fixed_default * (1.0 if step_control == "fixed" else FIRST_STEP_PER_DEFAULT)
    )
    dt_min = (
        number(table, "numerics", "dt_min") / time_unit
        if "dt_min" in table
        else DT_MIN_PER_DEFAULT * min(dt, fixed_default)
    )
    dt_max = (
        number(table, "numerics", "dt_max") / time_unit
        if "dt_max" in table
        else max(DT_MAX_DEPTH_FRACTION * groups.depth / speed, dt)
    )
    # over- or underflowed; the quadratic step divides by the square of a step: normal floats
    shortest = math.sqrt(sys.float_info.min)
    for key, value in (("dt", dt), ("dt_min", dt_min)):
        if not shortest <= value < math.inf:
            given = f" = {shown(table[key])}" if key in table else " (default)"
            raise CaseError(
                f"[numerics] {key}{given}: {value:g} relaxation times, out of"
                " the floating-point range; expected a finite step of at least"
                f" {shortest:.3g} (the SLS step divides by its square)"
            )
    if dt_min > dt_max:
        raise CaseError(
            f"[numerics] dt_min = {dt_min * time_unit:g}: must not exceed"
            f" dt_max = {dt_max * time_unit:g}"
        )
    return {"dt": dt, "dt_min": dt_min, "dt_max": dt_max}


def _solver_settings(table, solver, nx) -> tuple:
    """The chosen solver's own keys (given, or their defaults). Another registered solver's
    keys are checked too and kept out: one base case may serve a study over solvers."""
    for name in registered():
        for key in solver_class(name).KEYS:
            if key.name in table:
                integer(table, "numerics", key.name, key.smallest)
    return tuple(
        (key.name, table[key.name] if key.name in table else key.default(nx))
        for key in solver_class(solver).KEYS
    )


def automatic_nx(case, accuracy, widen=True):
    """The grid ``accuracy`` asks for: the smallest size f 2^a, f in {1, 3, 9}
    (:func:`~hpcgfmd.model.grid.smallest_grid`), with both the zone points
    :func:`~hpcgfmd.model.accuracy.zone_points` (of the retraction's rate; ``widen``: with
    the fast widening) across the relaxed cohesive zone (:attr:`zone_width`) and the
    contact points :func:`~hpcgfmd.model.accuracy.contact_points` across the geometric
    contact half-width sqrt(2 R h0).

    Parameters
    ----------
    case : hpcgfmd.case.groups.Groups
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
        points = knob.zone_points(accuracy, case.chi_ve, case.modulus_ratio, case.maugis, widen)
        across_contact = (
            knob.sphere_contact_points(accuracy) if case.sphere else knob.contact_points(accuracy)
        )
    except ZeroDivisionError:  # a subnormal accuracy underflows to 0
        points = across_contact = math.inf
    if not (math.isfinite(points) and math.isfinite(across_contact)):
        raise CaseError(
            f"[numerics] accuracy = {accuracy:g}: the grid it needs is out of"
            " the floating-point range; expected a relative error in (0, 0.1)"
            " of a size a grid can reach"
        )
    return smallest_grid(
        max(
            _log2_ratio(points, case.cell, case.zone_width),
            # across the geometric contact: the cylinder's sqrt(2 R h0), the sphere's sqrt(R h0)
            _log2_ratio(
                across_contact, case.cell, math.sqrt((1.0 if case.sphere else 2.0) * case.depth)
            ),
        )
    )


def _grid(case, num, accuracy):
    """(nx, chosen automatically): given and checked, or :func:`automatic_nx`."""
    width = case.zone_width
    if "nx" not in num:
        outside = knob.unvalidated(accuracy, case.chi_ve, case.modulus_ratio, case.maugis)
        if outside is not None:
            raise CaseError(
                f"[numerics] accuracy = {accuracy:g}: its grid would have {outside} for this"
                f" case, or an explicit {'n' if case.sphere else 'nx'}"
            )
        nx = automatic_nx(case, accuracy)
        if nx > MAX_NODES:
            raise CaseError(
                f"[numerics] accuracy = {accuracy:g}: its grid would have about"
                f" 2^{math.log2(nx):.0f} nodes for this case; at most"
                f" 2^{MAX_NODES.bit_length() - 1} are run anywhere"
            )
        return nx, True
    nx = num["nx"]
    key = "n" if case.sphere else "nx"  # the case file's name of it
    if isinstance(nx, bool) or not isinstance(nx, int) or nx < 64 or nx % 2 or nx > MAX_NODES:
        raise CaseError(
            f"[numerics] {key} = {shown(nx)}: expected an even integer in"
            f" [64, 2^{MAX_NODES.bit_length() - 1}]"
        )
    # the zone the retraction's tip has: the relaxed w, wider for a fast one (the knob's
    # grids resolve it alike)
    width *= knob.fast_widening(case.chi_ve, case.modulus_ratio, case.maugis)
    points = width / (case.cell / nx)
    if points < MIN_ZONE_POINTS:
        ratio = MIN_ZONE_POINTS * case.cell / width  # inf when beyond the float range
        need = (
            max(64, 2 * math.ceil(ratio / 2))
            if math.isfinite(ratio)
            else smallest_grid(_log2_ratio(MIN_ZONE_POINTS, case.cell, width))
        )
        raise CaseError(
            f"[numerics] {key} = {nx}: resolves the cohesive zone with"
            f" {points:.3g} points; at least {MIN_ZONE_POINTS:g} is needed"
            f" ({key} >= {need}; left out, {key} follows [numerics] accuracy)"
        )
    return nx, False


def contact_nodes(case, nx) -> int:
    """Nodes of an nx grid across the geometric contact width 2 sqrt(2 R h0), which
    bounds the contact (:data:`hpcgfmd.case.groups.MIN_CELL_PER_CONTACT`)."""
    return math.ceil(2.0 * math.sqrt(2.0 * case.depth) * nx / case.cell)


def _log2_ratio(a, b, c):
    """log2(a b / c), also where a b / c leaves the float range (in logarithms then)."""
    ratio = a * b / c
    if 0.0 < ratio < math.inf:
        return math.log2(ratio)
    return math.log2(a) + math.log2(b) - math.log2(c)
