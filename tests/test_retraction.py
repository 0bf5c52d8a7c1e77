"""Whole retractions against the analytic limits (elastic Baney-Hui / JKR, relaxed, fast).

Small cell (L/R = 2, h0/R = 0.03, alpha = 1e-4: abar_c(0) ~ 4.7) so that the grids are small.
Grids resolve the relaxed cohesive zone with w/dx = 4 to 6 (lambda = 3.5: worst error 5.2 %,
1.1 %, 0.6 %, 0.5 % at w/dx = 1.5, 3, 6, 12, measured), lambda = 7 with w/dx = 6.
The issue's "JKR within 1 % for lambda >= 7" is not testable at lambda = 7: the exact
Baney-Hui curve there is itself 2.1 % from JKR in this measure (O(1/lambda^2); test_theory
checks that approach), so lambda = 7 is held to Baney-Hui.
The periodic cell's image curvature is corrected with theory.periodic_load_factor (about 1 %
here). Errors are measured relative to max(|Lbar|, |Lbar at pull-off|): near zero load a
relative error in Lbar alone means nothing.
"""

import numpy as np
import pytest
from mpi4py import MPI

from cases import case_text
from hpcgfmd.case import parse_case
from hpcgfmd.model import theory
from hpcgfmd.runs.single_case import run_case
from hpcgfmd.storage.reader import read_series


def retraction(tmp_path, lam, k, velocity, nx, dt=None, name="case"):
    text = case_text(
        f"nx = {nx}\naccuracy = 1e-3" + (f"\ndt = {dt}" if dt else ""),
        maugis=lam,
        modulus_ratio=k,
        velocity=velocity,
    )
    path = tmp_path / f"{name}.h5"
    run_case(parse_case(text), path, MPI.COMM_SELF)
    return read_series(path)


def middle(s, lo=0.2, hi=0.9):
    """Steps whose contact half-width lies in [lo, hi] of the initial one."""
    a = s.contact_half_width
    return (a >= lo * a[0]) & (a <= hi * a[0])


def md_reference(s, lam, m):
    """Baney-Hui load at the computed contact widths of the steps in mask m."""
    lbar = theory.maugis_dugdale(s.abar[m], lam)[0]
    return lbar * theory.periodic_load_factor(s.contact_half_width[m], s.attrs["cell"])


def worst_error(s, m, ref):
    scale = np.maximum(np.abs(ref), abs(s.lbar.min()))
    return np.max(np.abs(s.lbar[m] - ref) / scale)


# measured at lambda0 = 1: 1.24 %, 0.42 %, 0.31 % at nx = 1024, 2048, 4096 (the sampled
# widths of accuracy 1e-3 include the worst-resolved ones)
@pytest.mark.parametrize("lam, nx", [(1.0, 2048), (3.5, 4096)])
def test_elastic_retraction_follows_baney_hui(tmp_path, lam, nx):
    s = retraction(tmp_path, lam, 1.0, 1.0, nx)
    m = middle(s)
    assert m.sum() > 20
    assert worst_error(s, m, md_reference(s, lam, m)) < 0.01


@pytest.fixture(scope="module")
def elastic_lambda7(tmp_path_factory):
    # w/dx = 6 (0.67 % measured; 1.75 % at w/dx = 3). Elastic: the result does not depend on
    # dt, so the indenter moves dmax per step (dt = dmax / v_z = 1/7 here) to save steps.
    return retraction(tmp_path_factory.mktemp("lam7"), 7.0, 1.0, 1.0, 16384, dt=1.0 / 7.0)


@pytest.mark.slow
def test_elastic_retraction_lambda7_follows_baney_hui(elastic_lambda7):
    s = elastic_lambda7
    m = middle(s)
    assert m.sum() > 20
    assert worst_error(s, m, md_reference(s, 7.0, m)) < 0.01


@pytest.mark.slow
def test_slow_viscoelastic_retraction_follows_relaxed_curve(tmp_path):
    # V_z = 1e-6 (chi_ve = 1.2e-5): dt = 7e4 tau, the overstress (Einf - E0) tau / dt of the
    # moving edge is 1e-4 of E0. (At V_z = 1e-4 it was 1.2 % and the curve lay 1.15 % off:
    # small chi_ve alone does not make the edge relaxed.)
    s = retraction(tmp_path, 3.5, 0.1, 1e-6, 4096)
    m = middle(s)
    assert worst_error(s, m, md_reference(s, 3.5, m)) < 0.01


def test_fast_retraction_between_limits_with_hysteresis(tmp_path):
    # chi_ve = 12. The elastic tests above put the numerical error of Lbar below 1 % of the
    # pull-off load on this kind of grid, so the margins asserted here (10 % in the effective
    # work, 5 % of the pull-off load in Lbar) are far outside what discretisation can produce.
    s = retraction(tmp_path, 3.5, 0.1, 1.0, 2048)
    m = middle(s, 0.2, 0.7)
    work = s.effective_work()[m[s.contact_half_width > 0]]
    # Between the relaxed (dgamma0) and instantaneous (dgamma0 / k) JKR lines.
    assert np.all(work > 1.1) and np.all(work < 1.0 / 0.1), work
    # Hysteresis: at equal contact width the retraction load is more tensile than on the
    # relaxed loading branch (the elastic E0 equilibrium curve, Baney-Hui with lambda0).
    margin = 0.05 * abs(s.lbar.min())
    assert np.all(s.lbar[m] < md_reference(s, 3.5, m) - margin)
