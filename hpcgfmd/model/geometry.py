"""The indenter's shape, and the contact measures it defines on the surface grid.

The rigid, frictionless indenter is a model object: its profile h over the surface's nodes
(docs/model.md, (M1)) and the measures of the contact it makes (the contact and cohesive-zone
extents the series record, located between nodes). The grid's shape is the domain's
(:class:`hpcgfmd.parallel.domain.Domain`): the solvers and the step control see flat blocks
of nodes; only the indenter and its measures know the surface's dimension.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .interface import edge_positions

#: a surface's series: its contact and cohesive areas, the contact line's mean radius and
#: out-of-roundness (:meth:`Sphere.measure`), in the order of ContactMeasure's areas and line
SURFACE_SERIES = ("contact_area", "cohesive_area", "contact_line_radius", "out_of_roundness")


@dataclass(frozen=True)
class ContactMeasure:
    """The contact of one state (length units).

    Attributes
    ----------
    edges : (float, float)
        Left and right edges of intimate contact (g <= 0) along a line through the axis; NaN
        without contact (a sphere's: -a_c and a_c).
    contact : float
        Contact half-width a_c, a sphere's contact radius (0 without contact).
    zone : float
        Outer half-width a_a of the cohesive zone g <= dmax, a sphere's outer radius (0
        without one).
    areas : (float, float) or None
        A surface's contact area and the area with g <= dmax (area units); None on a line.
    line : (float, float) or None
        A surface's contact line: its mean radius and its out-of-roundness (:class:`Sphere`).
    """

    edges: tuple
    contact: float
    zone: float
    areas: tuple | None = None
    line: tuple | None = None


@dataclass(frozen=True)
class Cylinder:
    """A rigid parabolic cylinder on a periodic line (plane strain; paper Eq. 1).

    h(x) = x^2 / (2 R) (M1), the axis on node n/2 of the grid.

    Parameters
    ----------
    radius : float
        R (length; 1 in internal units).
    """

    radius: float = 1.0

    #: the surface's dimension (a line)
    dimensions = 1

    def profile(self, coordinates):
        """h at the nodes whose coordinates are given ((x,) or (x, y): this rank's nodes,
        length); on a surface the cylinder's axis runs along y."""
        x = coordinates[0]
        return x**2 / (2.0 * self.radius)

    def measure(self, domain, gap, dmax) -> ContactMeasure:
        """Collective: the contact edges and half-widths of the gap ``gap`` (this rank's block).

        The contact edge is extrapolated with the (x - a)^(3/2) gap of an intimate contact
        edge, the cohesive zone's linearly (docs/model.md, "Discretisation", (M36)).
        """
        left, right = edge_positions(domain, gap, 0.0, 1.5)
        zone_left, zone_right = edge_positions(domain, gap, dmax, 1.0)
        return ContactMeasure(
            (left, right),
            0.5 * (right - left) if left == left else 0.0,
            0.5 * (zone_right - zone_left) if zone_left == zone_left else 0.0,
        )


@dataclass(frozen=True)
class Sphere:
    """A rigid paraboloid on a square periodic cell (docs/model.md, "The sphere").

    h(x, y) = (x^2 + y^2) / (2 R), the axis on node (n/2, n/2) of the grid: the sphere of the
    Hertz, JKR and Maugis-Dugdale theories.

    Parameters
    ----------
    radius : float
        R (length; 1 in internal units).
    """

    radius: float = 1.0

    #: the surface's dimension (a plane)
    dimensions = 2

    def profile(self, coordinates):
        """h at the nodes whose coordinates (x, y) are given (this rank's nodes, length)."""
        x, y = coordinates
        return (x * x + y * y) / (2.0 * self.radius)

    def measure(self, domain, gap, dmax) -> ContactMeasure:
        """Collective (a row exchange and two reductions): the contact and cohesive areas and
        radii of the gap ``gap`` (this rank's block), and the contact line.

        The areas count the nodes with g <= 0 and g <= dmax, each for its cell dx dy (their
        error is the lattice's, at most about one ring of nodes). The radii are the
        equivalent ones, sqrt(A / pi). The contact line is the set of contact nodes with a
        neighbour (along x or y) off contact; the edge lies between such a node and that
        neighbour, so its mean radius is the nodes' mean distance from the contact's
        centroid plus dx / 2, and its out-of-roundness the spread of those distances,
        (max - min) / (2 mean): 0 for a circle on a fine lattice, about dx / a from the
        lattice's staircase, more when the contact is not round.
        """
        x, y = domain.coordinates
        closed = gap <= 0.0
        xc, yc = x[closed], y[closed]
        count, zone_count, sx, sy = domain.sums(
            xc.size, np.count_nonzero(gap <= dmax), xc.sum(), yc.sum()
        )
        area, zone_area = count * domain.node_area, zone_count * domain.node_area
        radius, zone_radius = math.sqrt(area / math.pi), math.sqrt(zone_area / math.pi)
        line = _contact_line(domain, gap, closed, sx / max(count, 1.0), sy / max(count, 1.0))
        edges = (-radius, radius) if count else (math.nan, math.nan)
        return ContactMeasure(edges, radius, zone_radius, (area, zone_area), line)


def _contact_line(domain, gap, closed, cx, cy):
    """Collective: (mean radius, out-of-roundness) of the contact line about (cx, cy)
    (:meth:`Sphere.measure`); (0, 0) without contact."""
    nx, m = domain.shape[-1], domain.local_n
    extended = np.empty(m + 2 * nx)
    extended[nx : nx + m] = gap
    domain.fill_halo(extended)
    line = np.zeros(m, dtype=bool)
    if m:
        rows = closed.reshape(-1, nx)
        below = extended[:m].reshape(-1, nx) > 0.0  # the neighbour one row down is open
        above = extended[2 * nx :].reshape(-1, nx) > 0.0
        open_row = ~rows
        sideways = np.roll(open_row, 1, axis=1) | np.roll(open_row, -1, axis=1)
        line = (rows & (below | above | sideways)).ravel()
    x, y = domain.coordinates
    r = np.hypot(x[line] - cx, y[line] - cy)
    count, total = domain.sums(r.size, r.sum())
    if not count:
        return (0.0, 0.0)
    largest, negative_smallest = domain.maxes(
        r.max() if r.size else -math.inf, -r.min() if r.size else -math.inf
    )
    mean = total / count
    spread = (largest + negative_smallest) / (2.0 * mean) if mean > 0.0 else 0.0
    return (mean + 0.5 * domain.dx, spread)


GEOMETRIES = {"cylinder": Cylinder, "sphere": Sphere}
