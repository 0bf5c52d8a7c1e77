"""Whole retractions against the analytic limits (elastic Baney-Hui / JKR, relaxed, fast).

Small cell (L/R = 2, h0/R = 0.03, alpha = 1e-4: abar_c(0) ~ 4.7) so that the grids are small.
The periodic cell's image curvature is corrected with theory.periodic_load_factor (about 1 %
here). Errors are measured relative to max(|Lbar|, |Lbar at pull-off|): near zero load a
relative error in Lbar alone means nothing.
"""
import numpy as np
import pytest

from hpcgfmd import theory
from hpcgfmd.analysis import read_series
from hpcgfmd.config import parse_case
from hpcgfmd.runner import run_case


def retraction(tmp_path, lam, k, velocity, nx, dt=None, name="case"):
    text = (f"[case]\nmaugis = {lam}\nmodulus_ratio = {k}\nvelocity = {velocity}\n"
            f"depth = 0.03\ncell = 2.0\nadhesion = 1e-4\n[numerics]\nnx = {nx}\n"
            + (f"dt = {dt}\n" if dt else ""))
    path = tmp_path / f"{name}.h5"
    run_case(parse_case(text), path, printer=lambda line: None)
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


@pytest.mark.parametrize("lam, nx", [(1.0, 1024), (3.5, 2048)])
def test_elastic_retraction_follows_baney_hui(tmp_path, lam, nx):
    s = retraction(tmp_path, lam, 1.0, 1.0, nx)
    m = middle(s)
    assert m.sum() > 20
    assert worst_error(s, m, md_reference(s, lam, m)) < 0.01


def test_elastic_retraction_follows_jkr_for_large_maugis(tmp_path):
    s = retraction(tmp_path, 7.0, 1.0, 1.0, 4096, name="jkr")
    m = middle(s)
    ref = theory.jkr_load(s.abar[m]) * theory.periodic_load_factor(s.contact_half_width[m], 2.0)
    assert worst_error(s, m, ref) < 0.01


def test_slow_viscoelastic_retraction_follows_relaxed_curve(tmp_path):
    # chi_ve = V_z lambda0^2 = 1.2e-3: the material relaxes fully within each step.
    s = retraction(tmp_path, 3.5, 0.1, 1e-4, 2048)
    m = middle(s)
    assert worst_error(s, m, md_reference(s, 3.5, m)) < 0.01


def test_fast_retraction_between_limits_with_hysteresis(tmp_path):
    # chi_ve = 12: effective work of adhesion between dgamma0 and dgamma0/k = 10 dgamma0.
    s = retraction(tmp_path, 3.5, 0.1, 1.0, 2048)
    m = middle(s, 0.2, 0.7)
    work = theory.effective_work_ratio(*[v[m[s.contact_half_width > 0]]
                                         for v in s.scaled_curve()])
    assert np.all(work > 1.2) and np.all(work < 10.0), work
    # Hysteresis: at equal contact width the retraction load is more tensile than on the
    # relaxed loading branch (elastic E0, Baney-Hui lambda0), by a clear margin.
    assert np.all(s.lbar[m] < md_reference(s, 3.5, m) - 0.5)
