"""The sphere's validation runs: the cases and comparisons that tests/test_sphere.py asserts
and scripts/sphere_validation.py tabulates (docs/results.md, "The sphere").

The elastic adhesive sphere against the Maugis-Dugdale sphere in its periodic cell: the run's
pull-off (its most tensile load) is compared with the least load of the Maugis-Dugdale curve
in the cell (docs/model.md, (M56), (M59)); its load against the indenter's depth, both exact
observables (not the radius of a node count), with that curve: the largest distance of the
run's attached points to it, in the curve's largest depth and its |pull-off|.

The collapse at equal chi_ve (M53), the paper's Fig. 9 for the sphere: viscoelastic
retractions of different lambda0 and V_z at equal chi_ve = (pi/3) V_z lambda0^2, at equal k,
h0/R, L/R and alpha, compared by the cylinder's measure
(:func:`hpcgfmd.paper.checks.check_collapse`: the largest distance between their (Abar, Pbar)
curves up to the pull-off, in the other curve's Abar(0) and |pull-off Pbar|) against
retractions at chi_ve four times smaller.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..case import Case
from ..model import sphere_theory
from .distance import load_depth_distances

# lambda0: (L/R, n, h0/R): >= 5 points across w0, cells of 4.6-18 starting contact radii
MAUGIS_RUNS = {0.5: (3.0, 256, 0.01), 1.0: (1.5, 256, 0.01), 3.0: (0.8, 384, 0.005)}


class MaugisDugdaleCheck(NamedTuple):
    """A run against the curve (Pbar, the load in pi dgamma0 R)."""

    pull_off: float  # the run's most tensile Pbar
    reference: float  # the Maugis-Dugdale curve's least Pbar in the cell
    curve: float  # the largest distance of the run's (depth, load) points to the curve
    jkr: float  # JKR's least Pbar in the same cell (lambda0 -> infinity)
    work: float  # the run's work of separation, in pi dgamma0 R delta_s
    work_reference: float  # the curve's, from the run's preload depth to its least depth
    jumps: bool  # the curve's least depth is a jump (not its end at Abar -> 0)


def sphere_case(maugis, k, velocity, depth, cell, n, accuracy=5e-3) -> Case:
    """The SLS sphere (alpha = 1e-3) of Maugis's ``maugis``, k and V_z on an n x n cell of
    side ``cell`` (R), preloaded (relaxed) to ``depth`` (R); ``accuracy`` sets the steps."""
    return Case(
        maugis=maugis,
        modulus_ratio=k,
        velocity=velocity,
        depth=depth,
        cell=cell,
        adhesion=1e-3,
        numerics={"n": n, "accuracy": accuracy},
        geometry="sphere",
    )


def elastic_sphere(maugis, cell, n, depth, accuracy=5e-3) -> Case:
    """The elastic sphere (k = 1, V_z = 1) of :func:`sphere_case`."""
    return sphere_case(maugis, 1.0, 1.0, depth, cell, n, accuracy)


def maugis_dugdale_check(case, series) -> MaugisDugdaleCheck:
    """The run ``series`` (a :class:`~hpcgfmd.storage.reader.Series` of ``case``, a sphere)
    against the Maugis-Dugdale curve of its lambda0 in its cell."""
    load = series.load / case.load_scale
    depth = -series.indenter / case.depth_scale
    start = series.contact_half_width[0] / case.beta
    cell = case.cell / case.beta
    reference = maugis_dugdale_curve(1.05 * start, cell, case.maugis)
    attached = series.contact_half_width > 0
    curve = load_depth_distances(
        depth[attached], load[attached], reference["dbar"], reference["lbar"], reference["abar"]
    ).max()
    jkr = sphere_theory.periodic_cell(reference["abar"], cell)[0].min()
    ref_load = float(reference["lbar"].min())
    work = series.work_of_separation() / (case.load_scale * case.depth_scale)
    # the curve's radii increasing
    ref_work, jumps = curve_work(reference["lbar"][::-1], reference["dbar"][::-1], depth[0])
    return MaugisDugdaleCheck(
        float(load.min()), ref_load, float(curve), float(jkr), work, ref_work, jumps
    )


def maugis_dugdale_curve(widest, cell, maugis, points=400) -> dict:
    """The elastic sphere's exact curve in its cell: the Maugis-Dugdale force and depth of
    ``maugis`` (M56) with the cell's images (M59), at ``points`` contact radii from
    ``widest`` down to 0.02 (all a_s; ``cell`` L / a_s), as a run's series: "abar", "lbar"
    (Pbar) and "dbar". Its chords are within 2e-5 (400 radii) and 3e-6 (1201) of the curve in
    the scales of the curve error (measured against 8 times as many radii, lambda0 = 0.5-7)."""
    radii = np.linspace(widest, 0.02, points)
    load, depth = sphere_theory.periodic_cell(radii, cell, maugis)
    return {"abar": radii, "lbar": load, "dbar": depth}


def curve_work(load, depth, start):
    """The work of separation along an elastic curve under displacement control, -integral
    of min(Pbar, 0) d(-Dbar), from the stable point at the depth ``start`` (the largest
    radius there) to the least depth: where the contact jumps off, or, below lambda0 of
    about 1, the curve's end at its smallest radius (Abar -> 0, whose cohesive zone still
    holds: the run's work goes on past it). docs/model.md, "Observables", (M56).

    ``load`` and ``depth`` are the curve's Pbar and Dbar on increasing contact radii.
    Returns the work (pi dgamma0 R delta_s) and whether the least depth is a jump.
    """
    jump = int(np.argmin(depth))
    first = int(np.flatnonzero(depth <= start).max())
    receding = slice(first, jump - 1 if jump else None, -1)  # the radius shrinking
    depths, loads = depth[receding], load[receding]
    if first + 1 < depth.size:  # from ``start`` itself, between the curve's points
        share = (start - depth[first]) / (depth[first + 1] - depth[first])
        depths = np.r_[start, depths]
        loads = np.r_[load[first] + share * (load[first + 1] - load[first]), loads]
    work = -np.trapezoid(np.minimum(loads, 0.0), -depths)
    return float(work), jump > 0
