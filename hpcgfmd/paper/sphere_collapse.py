"""The sphere's collapse at equal chi_ve (the paper's Fig. 9 for the sphere; docs/model.md,
(M53)): the cases and the check that tests/test_sphere.py asserts and
``scripts/sphere_validation.py --collapse`` tabulates (docs/figures/sphere-collapse.md).

Pairs lambda0 and 2 lambda0 retracted at equal chi_ve = (pi/3) V_z lambda0^2 are compared by
:func:`hpcgfmd.paper.checks.check_collapse` over their whole (Abar, Pbar) curves, against
pairs at chi_ve four times apart.
"""

from __future__ import annotations

import math

from ..case import Case
from . import checks, curves

# The collapse's common groups: k = 0.2 (a pull-off up to 5 times the relaxed one), h0/R =
# 0.01, L/R = 1 and alpha = 1e-3 (a_s = 0.133 R: the contact starts at Abar = 1.5, 5 of its
# radii across the cell, w0 = 0.1 R / lambda0^2 (M53)); chi_ve 0.1 and 0.4, where the
# pull-off rises fastest with chi_ve (|Pbar| 1.5 relaxed, about 2.2 and 3.1 here, 7.5 glassy).
COLLAPSE_GROUPS = dict(modulus_ratio=0.2, depth=0.01, cell=1.0, adhesion=1e-3)
COLLAPSE_CHI = (0.1, 0.4)
# (lambda0, n) pairs: lambda0 and 2 lambda0 with V_z four times smaller; w0/dx = 0.1 n /
# lambda0^2. The first three: >= 2.1 points across w0 of the finer lambda0 (on 4.3-17 of the
# other); then lambda0 = 3 and 6 on the tests' grids (1.06 across lambda0 = 6's w0) and on
# grids 2 and 3 (and 4 and 3) times finer: the grid's share of the distance.
COLLAPSE_PAIRS = (
    ((1.5, 384), (3.0, 384)),
    ((2.0, 384), (4.0, 384)),
    ((3.0, 192), (6.0, 384)),
    ((3.0, 384), (6.0, 768)),
    ((3.0, 768), (6.0, 1152)),
)


def collapse_sphere(maugis, chi_ve, n, accuracy=5e-3) -> Case:
    """The viscoelastic sphere of Maugis's ``maugis`` retracted at V_z = 3 chi_ve / (pi
    lambda0^2) (M53) on an n x n grid, with :data:`COLLAPSE_GROUPS`."""
    return Case(
        maugis=maugis,
        velocity=3.0 * chi_ve / (math.pi * maugis**2),
        **COLLAPSE_GROUPS,
        numerics={"n": n, "accuracy": accuracy},
        geometry="sphere",
    )


def collapse_check(series) -> checks.Check:
    """:func:`hpcgfmd.paper.checks.check_collapse` over whole curves of sphere runs
    (:class:`~hpcgfmd.storage.reader.Series`): values "chi_ve=c" (the largest distance within
    each pair of equal chi_ve), "chi_ve=a vs b" (the smallest between neighbouring chi_ve) and
    "ratio" (the largest within over the smallest between)."""
    return checks.check_collapse([curves.Retraction.from_series(s) for s in series])[0]
