"""The indenter's shape, and the contact measures it defines on the surface grid.

The rigid, frictionless indenter is a model object: its profile h over the surface's nodes
(docs/model.md, (M1)) and the measures of the contact it makes (the contact and cohesive-zone
extents the series record, located between nodes). The grid's shape is the domain's
(:class:`hpcgfmd.parallel.domain.Domain`): the solvers and the step control see flat blocks
of nodes; only the indenter and its measures know the surface's dimension.
"""

from __future__ import annotations

from dataclasses import dataclass

from .interface import edge_positions


@dataclass(frozen=True)
class ContactMeasure:
    """The contact of one state (length units).

    Attributes
    ----------
    edges : (float, float)
        Left and right edges of intimate contact (g <= 0); NaN without contact.
    contact : float
        Contact half-width a_c (0 without contact).
    zone : float
        Outer half-width of the cohesive zone a_a, g <= dmax (0 without one).
    """

    edges: tuple
    contact: float
    zone: float


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
        """h at the nodes whose coordinates are given ((x,): this rank's nodes, length)."""
        (x,) = coordinates
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
