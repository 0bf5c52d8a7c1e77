"""The line search along a CG direction: on as long as the energy provably keeps falling.

phi(a) = E(u + a d) has phi'(a) = -(t(u + a d).d + c0 - a d.K d), c0 = r.d - t(u).d, and,
the adhesion energy being concave, curvature at most d.K d. So from any point a_k with slope
s_k < 0 the energy falls on (a_k, a_k + 2 |s_k| / d.K d): at the quadratic bound's minimiser
alpha (the trial point, evaluated and off the wall) phi'(alpha) <= 0. The next length is the
secant root of phi' through the last two points (the cohesive edge's negative stiffness makes
it longer than alpha), capped at a_k + 1.9 |s_k| / d.K d to keep the descent. While the cap
binds, the capped point is evaluated and the search goes on from it; an extension costs the
gaps, the cohesive traction on its span and one reduction, no transform. A point beyond the
wall ends the search at the point before. Every accepted length lowers E, so the solve still
descends from its start (path following).
"""

from __future__ import annotations

import math

MAX_EXTENSIONS = 8  # points per iteration beyond the trial point


def extend(evaluator, cur, trial, probe, d, alpha, rd, d_kd, c0, t_trial_d, window=None):
    """Collective: the step length along d and the point it reaches (module docstring).

    Parameters
    ----------
    evaluator : PointEvaluator
        Evaluates the probe points (gaps, cohesive traction, spans).
    cur, trial, probe : Point
        The current point u, the evaluated trial point u + alpha d, a free buffer.
    d : ndarray
        The direction (zero mean, this rank's block).
    window : tuple, optional
        (w0, w1, entry) of :meth:`PointEvaluator.evaluate_shifted`.
    alpha, rd, d_kd, c0, t_trial_d : float
        The bound's minimiser, r.d, d.K d, r.d - t(u).d and t(u + alpha d).d (global).

    Returns
    -------
    (length, point, spare, extensions)
        ``point`` holds the gaps and traction of u + length d; ``spare`` is a free buffer
        (``cur`` is free too); ``extensions`` counts the points taken beyond ``trial``.
    """
    dom = evaluator.domain
    a_prev, s_prev = 0.0, -rd
    a, s = alpha, -(t_trial_d + c0 - alpha * d_kd)
    best, taken = trial, 0
    for extension in range(MAX_EXTENSIONS + 1):
        if s >= -1e-300 * rd:
            break
        # (the first also keeps the bound from u itself: every step in (0, 2 alpha) descends)
        reach = max(a + 1.9 * (-s) / d_kd, 1.9 * alpha if extension == 0 else 0.0)
        root = a + (a - a_prev) * (-s) / (s - s_prev) if s > s_prev else math.inf
        capped = root >= reach
        target = reach if capped else root
        if not capped and target <= a * (1.0 + 1e-12):
            break
        if extension == MAX_EXTENSIONS and capped:
            target = reach  # the last point is not evaluated further: no slope needed
        # probe = u + target d, from the gaps of u (cur) as the trial point was
        smallest, t_probe_d = evaluator.evaluate_shifted(probe, cur.gap, d, target, window)
        t_probe_d, reaching = dom.sums(t_probe_d, 1.0 if smallest < 0.0 else 0.0)
        if reaching > 0.0:  # beyond the wall: stay at the last point
            break
        taken += 1
        best, probe = probe, best
        a_prev, s_prev = a, s
        a, s = target, -(t_probe_d + c0 - target * d_kd)
        if not capped:  # the secant root: the minimum along d to its accuracy
            break
    return a, best, probe, taken
