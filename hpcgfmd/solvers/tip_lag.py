"""The tip's lag: the error of the strain rate a step's history gives the nodes a moving
contact edge passes, as a relative error of the cohesive zone's traction
(docs/numerics.md, "Time steps", the tip-lag criterion).
"""

from __future__ import annotations

import math

LAG_PER_LOAD = 1.0  # pull-off error / tip lag bound, measured (tip_lag_error, M46 steps)
LAG_PER_LOAD_SPECTRUM = 4.0  # ... for relaxation times of several lengths (make_step_control)


def tip_lag_error(dt, edge_motion, zone_width, modulus_ratio, branches=None):
    """Relative error of the cohesive zone's traction from a step's linear-in-time history at
    a moving contact edge (internal units, tau = 1; docs/numerics.md, "Time steps").

    Near an edge moving at v_a = |da| / dt a node's displacement follows the passing crack
    tip, u = U(x - a(t)): its strain rate changes over the passage time w_c / v_a, w_c the
    cohesive zone's width (the relaxed w for a slow tip, up to w / k for a glassy one: the
    zone width pi E dmax / (4 sigma_a) is proportional to the modulus the tip sees). The SLS
    step (exact for u linear in time) sees the step's mean rate instead of the rate at its
    end, a lag of dt/2 in time when dt >> tau (the memory is shorter than the step), and of
    dt^2 / (12 tau) when dt << tau (the midpoint rule of the memory integral); as one
    expression, a relative rate error (|da| / 2 w_c) x / (x + 6), x = dt / tau, at most 1 (a
    rate cannot be more than wholly wrong; the edge criterion keeps |da| to a few w). How much the
    zone's traction depends on its rate is the sensitivity S = d ln sigma / d ln theta of
    an SLS strained at a constant rate over the passage time, theta = tau v_a / w_c:
    sigma / (E0 eps) = k + (1 - k) F(theta), F = theta (1 - exp(-1/theta)), so
    S = (1 - k) theta F'(theta) / (k + (1 - k) F). S vanishes for a relaxed tip
    (theta << k) and a glassy one (theta >> 1), and is largest in between: the creeping
    retractions, chi_ve / k of order 1. The estimate is S min(1, (|da| / 2 w_c) x / (x + 6)).
    The quadratic step (M46), which adaptive steps take, follows the rate's change within
    the step and lags far less: the estimate stays the linear step's, and its bound
    (LAG_PER_LOAD) is calibrated for the quadratic step (docs/numerics.md).

    Parameters
    ----------
    dt : float
        Step length (tau).
    edge_motion : float
        Largest contact-edge displacement of the step |da| (R); NaN or inf: none.
    zone_width : float
        Cohesive-zone width w_c (R): the solved zone's at the step's end, or the relaxed w.
    modulus_ratio : float
        k = E0 / Einf (1: elastic, no lag).
    branches : (sequence, sequence), optional
        A Prony series' E_i / E0 and tau_i / tau (more than one branch): its zone traction
        sigma / (E0 eps) = 1 + sum_i m_i F(theta_i), theta_i = tau_i v_a / w_c, whose rate
        sensitivity sums the branches' with each branch's own rate error
        (:func:`_prony_tip_lag_error`; one branch is the SLS above with k = 1 / (1 + m_1)).

    Returns
    -------
    float
        The estimated relative traction error (>= 0; about the pull-off's relative error,
        which measured 0.5-1.6 times it on creeping retractions: docs/results.md).
    """
    moved = edge_motion / zone_width
    if modulus_ratio >= 1.0 or not (math.isfinite(moved) and moved > 0.0 and dt > 0.0):
        return 0.0
    if branches is not None and len(branches[0]) > 1:
        return _prony_tip_lag_error(dt, moved, *branches)
    k, x = modulus_ratio, dt
    theta = moved / x
    decay = math.exp(-1.0 / theta)
    rate_response = theta * -math.expm1(-1.0 / theta)  # F(theta)
    slope = -math.expm1(-1.0 / theta) - decay / theta  # F'(theta)
    sensitivity = (1.0 - k) * theta * slope / (k + (1.0 - k) * rate_response)
    return sensitivity * min(1.0, 0.5 * moved * x / (x + 6.0))


def _prony_tip_lag_error(dt, moved, moduli, times):
    """:func:`tip_lag_error` of a Prony series (``moved`` = |da| / w_c > 0).

    Each branch i sees the rate error (|da| / 2 w_c) x_i / (x_i + 6), x_i = dt / tau_i (at
    most 1), weighted by its share of the traction's rate sensitivity:
    sum_i m_i theta_i F'(theta_i) min(1, ...) / (1 + sum_j m_j F(theta_j)), theta_i = tau_i
    moved / dt. For one branch, m = (1 - k) / k, this is the SLS's expression.
    """
    sensitivity, stiffness = 0.0, 1.0
    for m, tau in zip(moduli, times):
        x = dt / tau
        theta = moved / x
        decay = math.exp(-1.0 / theta)
        stiffness += m * theta * -math.expm1(-1.0 / theta)  # m F(theta)
        slope = -math.expm1(-1.0 / theta) - decay / theta  # F'(theta)
        sensitivity += m * theta * slope * min(1.0, 0.5 * moved * x / (x + 6.0))
    return sensitivity / stiffness
