"""The viscoelastic sphere's retraction between its limits (hpcgfmd/studies/sphere_limits.py).

Independent references: the instantaneous limit (docs/model.md, (M57)), the Maugis-Dugdale
sphere with E0, dgamma0 / k and the same sigma_a in the periodic cell (M56), (M59), and its
glassy form at V_z -> infinity (the force on the instantaneous curve, the depth
k Dbar_inst + (1 - k) Dbar0); the relaxed one (E0, dgamma0); Persson-Brener's Eq. 8 (M30)
at the measured edge speed (M58), in both conventions of its time.
"""

from functools import cache

import numpy as np
import pytest

from hpcgfmd.model import sphere_theory
from hpcgfmd.studies import sphere_check, sphere_limits
from hpcgfmd.studies.distance import polyline_distances

# lambda0 = 2, k = 0.5, h0 = 0.03 R, L = 1.5 R (L / a_s = 11.3): the preload's contact
# (Abar0 = 2.0) is wider than the glassy zone (w0 / k = 0.375 a_s), so the retraction
# reaches the instantaneous curve; n = 128 puts 2.1 nodes across w0 and 4.3 across w0 / k.
FAST = dict(maugis=2.0, k=0.5, depth=0.03, cell=1.5, n=128)


@cache
def curve(velocity, maugis=2.0, k=0.5, depth=0.03, cell=1.5, n=128):
    """One retraction's SphereCurve (runs shared by the tests)."""
    import hpcgfmd

    case = sphere_check.sphere_case(maugis, k, velocity, depth, cell, n)
    return sphere_limits.sphere_curve(
        case, hpcgfmd.run(case, planner_effort="FFTW_ESTIMATE").series
    )


def test_an_infinitely_fast_retraction_is_on_the_instantaneous_curve():
    # V_z = 1000 (the retraction lasts 1e-3 tau): the bulk is glassy from the relaxed
    # preload, and once the instantaneous zone lies inside the preload's contact the force
    # against the contact radius is the instantaneous curve's exactly (M57). Measured on
    # n = 128, 256, 384: pull-off 2.6e-3, 8.1e-4, 1.1e-4 off (the grid's, falling with dx);
    # the (depth, force) points 4.7e-3 from the glassy curve on n = 128 (in Dbar0 and the
    # least force), within a node of the contact line (dD/dA ~ 1.5, dx = 0.09 a_s)
    c = curve(1000.0)
    check = sphere_limits.glassy_check(c)
    assert check.points >= 10
    assert check.pull_off == pytest.approx(check.reference, rel=5e-3)
    assert check.curve < 1e-2
    # the Maugis-Dugdale reading of the work: dgamma0 / k within the node count's radius
    # (measured 0.995-1.009; the relaxed preload itself reads 1.016 on this grid)
    assert check.work[0] > 0.98 and check.work[1] < 1.02
    # the depth is the glassy blend, not the instantaneous curve's own depth: against
    # (Dbar_inst, Pbar_inst) the same points lie far off (the preload's history)
    inside = sphere_limits.zone_inside(c)
    radii = np.linspace(0.5, c.abar[0], 400)
    pbar, dbar = sphere_theory.periodic_cell(radii, c.cell, c.maugis, 1.0 / c.k)
    scale = np.array([c.dbar[0], abs(check.reference)])
    own = polyline_distances(
        np.c_[c.dbar[inside], c.pbar[inside]] / scale, np.c_[dbar, pbar] / scale
    )
    assert own.max() > 10.0 * check.curve


def test_the_pull_off_moves_from_the_relaxed_to_the_instantaneous_limit_as_vz_grows():
    # the pull-off between the relaxed (0) and the instantaneous (1) least force in the cell:
    # measured 0.157, 0.618, 0.956, 0.995 at V_z = 0.03, 0.3, 3, 1000; each run's points up
    # to the pull-off between the limits' works, dgamma0 and dgamma0 / k, within the reading's
    # error (2 %: the relaxed preload reads 1.016 dgamma0, the glassy run at most 1.009 / k)
    fractions = []
    for velocity in (0.03, 0.3, 3.0, 1000.0):
        c = curve(velocity)
        fractions.append(sphere_limits.pull_off_fraction(c)[3])
        upto = int(np.argmin(c.pbar)) + 1
        work = sphere_limits.maugis_work(c.abar[:upto], c.pbar[:upto], c.maugis, c.cell, 4.0)
        assert np.all(np.isfinite(work))
        assert work.min() > 0.98 and work.max() < 1.02 / c.k
    assert fractions[0] > 0.0 and np.all(np.diff(fractions) > 0.0)
    assert fractions[-1] == pytest.approx(1.0, abs=1e-2)  # measured 0.995 (2.6e-3 short)


@pytest.mark.parametrize("k, velocity", [(0.5, 0.1), (0.5, 0.3), (0.1, 0.01)])
def test_the_steady_effective_work_against_persson_brener(k, velocity):
    # lambda0 = 1 (w0 / dx = 8.5 on n = 128; n = 256 moves the medians by <= 0.004, steps of
    # accuracy 1e-3 by 0.001, the speed's reach of 1-5 dx by 0.005): the steady points (the
    # two depths merged within 1.5e-2, to the pull-off), their work read from the
    # Maugis-Dugdale curve with the same sigma_a, against Eq. 8 at their edge speed
    deep, shallow = (curve(velocity, 1.0, k, depth) for depth in (0.03, 0.02))
    mask, _, _ = sphere_limits.steady_masks(deep, shallow, 1.5e-2)
    check = sphere_limits.persson_brener_check(deep, mask, 2.5 * deep.dx)
    assert check.points >= 10
    ln = check.maugis
    if k == 0.5:
        # the data follow the relaxation-time reading within 10 % (the cylinder's criterion,
        # docs/paper.md, is 15 %), Eq. 8 above them (measured -0.040 and -0.065); with the
        # retardation time Eq. 8 lies 0.10-0.11 further above (measured -0.152, -0.167)
        assert -0.1 < ln["relaxation"] < 0.0
        assert ln["retardation"] < ln["relaxation"] - 0.07
    else:
        # k = 0.1: the two readings bracket the data, neither within 10 % (measured +0.124
        # with the relaxation time, -0.182 with the retardation time)
        assert ln["relaxation"] > 0.1 and ln["retardation"] < -0.1
