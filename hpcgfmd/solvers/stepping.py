"""Time-step control of the retraction: fixed steps, or adaptive steps with error control.

Where the time discretisation errs (docs/model.md, "Substrate" and "Protocol"):

- The SLS is integrated exactly over a step for a displacement varying linearly in time (fixed
  steps, (M8); error O(dt^2 u_tt)) or quadratically through the last two accepted states
  (adaptive steps after a segment's first, (M46); error O(dt^3 u_ttt)), so the material history is
  accurate wherever u(x, t) is smooth in t. Near a moving contact edge u_tt is concentrated: a
  node that leaves the wall changes its velocity abruptly, so the history integral of the nodes
  the edge crosses within one step errs by O(dt) each. The edge criterion bounds the nodes (the
  distance) crossed per step: the contact edges may move by at most ``edge_fraction`` of the
  relaxed cohesive-zone width w = pi E0 dmax / (4 sigma_a) per step (docs/model.md, "Scales";
  the narrowest zone of the SLS).
- The observables are sampled at the steps: the pull-off load is the most tensile SAMPLE of
  a smooth load curve L(t), which a coarse step misses by up to L'' dt^2 / 8 (the paper's
  "early pull-off" of coarse steps). The load criterion bounds the deviation of each new load
  from the straight line through the two before, e = |L_n+1 - L_pred| ~ L'' dt (dt + dt_prev)
  / 2, to ``load_tolerance`` load scales (R dgamma0^2 E0)^(1/3): the sampled minimum is then
  within about load_tolerance / 8 load scales of the curve's.
- The history's own errors: the smooth part's, estimated from the change of the curvature in
  time of u (:class:`HistoryError`), and the tip's lag, the rate error the step's history
  gives the nodes a moving edge passes (:func:`tip_lag_error`), both bounded through
  ``time_tolerance``.

Controller. After each step the error ratios e_edge = |da|max / (edge_fraction w) and e_lag
(first order in dt), e_load (second order) and e_history (third order for the linear step's
own error when steps are short against tau, higher for the quadratic step's, first to
second for long ones: its square root is between) give the next step
dt * clip(0.9 / max(e_edge, e_lag, sqrt(e_load), sqrt(e_history)), 1/4, 2), rounded down to
the grid dt_min 2^(j/4) within [dt_min, dt_max]. A step with e_edge > 2, e_load > 4,
e_history > 4 or e_lag > 4 is rejected and repeated with that shorter step (the state is
restored), unless it already is dt_min: a genuine jump of the contact (the snap-off at high
speed) is then taken at dt_min, which places it in time to dt_min.

Abandoned solves. Once the contact edges of a solve's iterate have moved more than
ABANDON_EDGE = REJECT_EDGE edge allowances, the solver stops (:meth:`AdaptiveSteps.edge_limit`)
and the step is rejected with the largest shrink, dt / 4: the step a solve going on would
get whenever its edges end beyond SAFETY / SHRINK_LIMIT = 3.6 allowances (the usual case:
the iterate's edge recedes monotonically), and a shorter one otherwise, never a longer one.
This matters past the fold of the attached branch near the snap-off: such a step otherwise
descends through the whole snap-off, thousands of CG iterations at 2^17, only to be
repeated (docs/results.md has the iterations it saves).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model.accuracy import PULL_OFF_SCALE
from ..parallel.fft import aligned_empty
from .step_kernels import clear_near_crossings, contact_sums, curvature

GROWTH_LIMIT = 2.0     # largest factor between consecutive steps
SHRINK_LIMIT = 0.25    # smallest factor (also the retry factor bound after a rejection)
SAFETY = 0.9           # aim below the error target
REJECT_EDGE = 2.0      # reject when the edge moved more than twice its allowance
REJECT_LOAD = 4.0      # ... or the load deviates more than four times its tolerance
REJECT_HISTORY = 4.0   # ... or the history's estimated error is four times its allowance
GRID_PER_OCTAVE = 4    # steps are dt_min 2^(j/4): see AdaptiveSteps._on_grid
ABANDON_EDGE = REJECT_EDGE  # edge ratio at which a solve is abandoned (module docstring)
CURVATURE_AGE = 8      # steps a smooth curvature stands in for windows with crossings ...
CURVATURE_LIFETIME = 0.05  # ... and time, in relaxation times tau (u_tt changes over tau)
REJECT_LAG = 4.0       # ... or the tip's lag error four times its allowance (jumps at crossings)
KEPT_SHARE = 0.5       # the kept errors' signed sum: held to this share of the allowance
LAG_PER_LOAD = 1.0     # pull-off error / tip lag bound, measured (tip_lag_error, M46 steps)
LAG_PER_LOAD_SPECTRUM = 4.0  # ... for relaxation times of several lengths (make_step_control)


def tip_lag_error(dt, edge_motion, zone_width, modulus_ratio, branches=None):
    """Relative error of the cohesive zone's traction from a step's linear-in-time history at
    a moving contact edge (internal units, tau = 1; docs/numerics.md, "Time steps").

    Near an edge moving at v_a = |da| / dt a node's displacement follows the passing crack
    tip, u = U(x - a(t)): its strain rate changes over the passage time w_c / v_a, w_c the
    cohesive zone's width (the relaxed w for a slow tip, up to about k^(-4/3) w for a
    glassy one, as the zone width scales with lambda^-2 and lambda with E^(-2/3)). The SLS
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


@dataclass
class StepDecision:
    """Verdict on a step just solved."""

    accepted: bool
    next_dt: float
    edge_error: float   # |da| / (edge_fraction w)
    load_error: float   # |L - L_pred| / (load_tolerance load_scale)
    history_error: float = 0.0  # the history's load error / its allowance for this step
    lag_error: float = 0.0  # the tip's lag error / its allowance (tip_lag_error)


class FixedSteps:
    """Constant step dt (the paper's method): every step is accepted."""

    adaptive = False

    def __init__(self, dt: float):
        self.dt = dt

    def first_dt(self) -> float:
        return self.dt

    def judge(self, dt, time, load, edge_motion, history_error=0.0,
              zone_width=math.nan, history_kept=None) -> StepDecision:
        return StepDecision(True, self.dt, 0.0, 0.0)

    def edge_limit(self, dt) -> float:
        """Every fixed step is accepted: no solve may be abandoned."""
        return math.inf

    def accept(self, time, load):
        pass

    def new_segment(self):
        pass

    def state(self) -> dict:
        return {}

    def restore(self, attrs):
        pass


class AdaptiveSteps:
    """Error-controlled step length (module docstring).

    Parameters
    ----------
    first_dt, dt_min, dt_max : float
        First step, bounds (time, internal units of tau).
    edge_allowance : float
        Largest contact-edge motion per step, edge_fraction * w (length, units of R).
    load_allowance : float
        Largest deviation of a load from the linear extrapolation of the two before,
        load_tolerance * load scale (load per unit length, units of E0 R).
    history_allowance : float
        Largest load error of the history integration, time_tolerance * load scale (load per
        unit length): a step's own, and KEPT_SHARE of it for the signed sum of the errors kept
        in the history over ``memory_time`` (:class:`HistoryError`, :meth:`judge`); inf: not
        controlled (the elastic solid).
    memory_time : float
        Time over which a history error persists, the retardation time tau/k (internal units;
        for a Prony series the slowest of its retardation times).
    lag_allowance : float
        Largest relative traction error of the tip's lag per step (:func:`tip_lag_error`);
        inf: not controlled.
    zone_width, modulus_ratio : float
        Relaxed cohesive-zone width w (R; the stand-in for a step's solved zone width when
        that is unknown) and k = E0 / Einf, for :func:`tip_lag_error`.
    branches : (tuple, tuple), optional
        A Prony series' E_i / E0 and tau_i (internal units), for its tip lag
        (:func:`tip_lag_error`); None: the SLS of ``modulus_ratio`` with tau = 1.
    """

    adaptive = True

    def __init__(self, first_dt, dt_min, dt_max, edge_allowance, load_allowance,
                 history_allowance=math.inf, memory_time=1.0, lag_allowance=math.inf,
                 zone_width=1.0, modulus_ratio=1.0, branches=None):
        self.dt_min, self.dt_max = dt_min, dt_max
        self.branches = branches
        self.lag_allowance = lag_allowance
        self.zone_width, self.modulus_ratio = zone_width, modulus_ratio
        self.dt = self._on_grid(first_dt)
        self.edge_allowance = edge_allowance
        self.load_allowance = load_allowance
        self.history_allowance = history_allowance
        self.memory_time = memory_time
        self.points = []  # the last two accepted (time, load)
        self.kept_history = 0.0  # signed sum of the accepted steps' kept errors, decayed
        self._kept_pending = 0.0  # ... with the step just judged

    def first_dt(self) -> float:
        return self.dt

    def _on_grid(self, dt):
        """Round down to dt_min 2^(j/4), within [dt_min, dt_max].

        Steps from a grid: runs whose loads differ by round-off (other rank counts, other
        FFT plans) choose the same steps unless a proposal falls within round-off of a grid
        point, and the step operators are reused whenever a length recurs.
        """
        if dt >= self.dt_max:
            return self.dt_max
        if dt <= self.dt_min:
            return self.dt_min
        j = math.floor(GRID_PER_OCTAVE * math.log2(dt / self.dt_min) + 1e-9)
        return min(self.dt_min * 2.0 ** (j / GRID_PER_OCTAVE), self.dt_max)

    def judge(self, dt, time, load, edge_motion, history_error=0.0,
              zone_width=math.nan, history_kept=None) -> StepDecision:
        """The verdict on a solved step of length dt ending at ``time`` with ``load``.

        ``edge_motion`` is the largest displacement of a contact edge over the step (length;
        NaN or inf when the contact appeared or vanished). ``load`` is None for an abandoned
        solve (no equilibrium: only its edge motion counts). ``history_error`` is the load
        error the step's history integration made in its own load, ``history_kept`` the part
        of it that stays in the history the next steps start from (:class:`HistoryError`;
        load per length; None: all of it).
        ``zone_width`` is the cohesive zone's width at the step's end (length; NaN: unknown,
        the relaxed width w stands in), the length a passing edge strains a node over.
        """
        edge_error = (edge_motion / self.edge_allowance if math.isfinite(edge_motion)
                      else (0.0 if math.isnan(edge_motion) else math.inf))
        load_error = 0.0
        if (load is not None and len(self.points) == 2
                and self.points[1][0] > self.points[0][0]):
            (t0, l0), (t1, l1) = self.points
            predicted = l1 + (l1 - l0) * (time - t1) / (t1 - t0)
            load_error = abs(load - predicted) / self.load_allowance
        # The errors kept in the history persist over the memory time: they add up with their
        # signs, each decaying as exp(-dt / memory_time) per step, and the sum E is the
        # history's load error, bounded by A = KEPT_SHARE times the allowance (E is an
        # estimate, not a bound as the step's own error is: held to the steps' share of the
        # accuracy, half the allowance, which is twice it). What is left of A for a step is
        # A - |E| exp(-dt / memory_time), at least A (1 - exp(-dt / memory_time)) (what
        # decays meanwhile: a coherent error per step then stays within A). A step is
        # repeated when it spent, |E_n+1| - |E_n| exp(-dt / memory_time), over four times
        # what was left; the next one is sized for its kept error, of either sign, to fit in
        # what is left after this one. Errors of random sign (crossings and solver residuals
        # read as curvature) mostly cancel in E, which leaves the next steps room; a coherent
        # error fills E and its steps are held to A (1 - exp(-dt / memory_time)) each.
        kept = history_error if history_kept is None else history_kept
        allowance = self.history_allowance * KEPT_SHARE
        share = -math.expm1(-dt / self.memory_time)
        decayed = self.kept_history * (1.0 - share)
        self._kept_pending = decayed + kept
        spent = (abs(self._kept_pending) - abs(decayed)) / max(allowance - abs(decayed),
                                                               allowance * share)
        room = max(allowance - abs(self._kept_pending) * (1.0 - share), allowance * share)
        own = abs(history_error) / self.history_allowance
        history_ratio = max(own, spent)  # for the verdict
        sizing_ratio = max(own, abs(kept) / room)  # for the next step
        zone = zone_width if zone_width > 0.0 and math.isfinite(zone_width) else self.zone_width
        lag_error = tip_lag_error(dt, edge_motion, zone, self.modulus_ratio,
                                  self.branches) / self.lag_allowance
        # first order where it binds (dt >> tau)
        worst = max(edge_error, math.sqrt(load_error), math.sqrt(sizing_ratio), lag_error)
        factor = SAFETY / worst if worst > 0.0 else GROWTH_LIMIT
        factor = min(max(factor, SHRINK_LIMIT), GROWTH_LIMIT)
        next_dt = self._on_grid(dt * factor)
        rejected = ((edge_error > REJECT_EDGE or load_error > REJECT_LOAD
                     or history_ratio > REJECT_HISTORY or lag_error > REJECT_LAG)
                    and dt > self.dt_min)
        self.dt = next_dt
        return StepDecision(not rejected, next_dt, edge_error, load_error, history_ratio,
                            lag_error)

    def edge_limit(self, dt) -> float:
        """Edge motion at which a solve of a step of length dt is abandoned, the step
        rejected and repeated with dt / 4 (length; inf at dt_min, where every step is
        accepted): see the module docstring."""
        if dt <= self.dt_min:
            return math.inf
        return ABANDON_EDGE * self.edge_allowance

    def accept(self, time, load):
        """Record an accepted step's load for the next extrapolation (a repeated preload
        at t = 0 replaces the point before)."""
        points = [p for p in self.points if p[0] < time]
        self.points = (points + [(time, load)])[-2:]
        self.kept_history, self._kept_pending = self._kept_pending, 0.0

    def new_segment(self):
        """The drive's rate changed (a protocol's segment began): the load's extrapolation
        restarts from the last point, not across the kink."""
        self.points = self.points[-1:]

    def state(self) -> dict:
        flat = [v for point in self.points for v in point]
        return {"controller_dt": self.dt, "controller_points": flat + [math.nan] * (4 - len(flat)),
                "controller_kept_history": self.kept_history}

    def restore(self, attrs):
        self.dt = float(attrs["controller_dt"])
        # (absent from checkpoints written before the kept errors were summed with signs)
        self.kept_history = float(attrs.get("controller_kept_history", 0.0))
        self._kept_pending = 0.0
        flat = [float(v) for v in attrs["controller_points"]]
        self.points = [(flat[i], flat[i + 1]) for i in (0, 2) if not math.isnan(flat[i])]


def make_step_control(case):
    """Fixed steps of ``[numerics] dt``, or adaptive steps starting from it."""
    numerics = case.numerics
    if numerics.step_control == "fixed":
        return FixedSteps(numerics.dt)
    viscous = case.k < 1.0
    material = case.material()
    # time_tolerance bounds the history's errors: the smooth part's in load scales, the
    # tip's lag as that load over the relaxed pull-off, shared for LAG_PER_LOAD. That bound
    # was calibrated and validated for one relaxation time (the SLS); a Prony series of
    # several times keeps the linear step's, four times tighter (with the SLS's bound the
    # two-branch series of docs/beyond-the-paper.md was 1.1e-2 off at accuracy 1e-2)
    one_time = len(set(material.branch_times)) == 1
    lag = numerics.time_tolerance / (
        PULL_OFF_SCALE * (LAG_PER_LOAD if one_time else LAG_PER_LOAD_SPECTRUM))
    return AdaptiveSteps(numerics.dt, numerics.dt_min, numerics.dt_max,
                         numerics.edge_fraction * case.zone_width,
                         numerics.load_tolerance * case.load_scale,
                         numerics.time_tolerance * case.load_scale if viscous else math.inf,
                         material.retardation_time,  # tau / k for the SLS, tau = 1
                         lag if viscous else math.inf, case.zone_width, case.k,
                         (material.branch_moduli, material.branch_times) if case.prony
                         else None)


class HistoryError:
    """The load error of a step's history integration, estimated from the last three states,
    and the correction of the substrate traction that removes most of it.

    The SLS step is exact for u linear in time within it (docs/model.md, (M8)); the quadratic
    through u_{n-1}, u_n and u_{n+1} gives the curvature c = u_tt / 2, and the traction the
    step missed is dp = (|q|/2) (Einf - E0) c F(dt) per mode
    (:meth:`~hpcgfmd.model.material.StandardLinearSolid.curvature_response`). Its share on the
    contact is carried by the indenter: the estimate is |sum of dp over the contact| dx. Once
    the step is accepted, dp is added to the substrate traction p_{n+1} (:meth:`correct`), so
    the history the next steps start from is exact for u quadratic in time through the last
    three states; the equilibrium of the step itself keeps its one-step error, which no
    longer accumulates over the memory time. Nodes whose contact state changed over the
    three states are left out (c = 0 there), and so are those that entered or left the
    cohesive zone, whose traction switches on or off: their u(t) has a kink, not a
    curvature, the quadratic does not describe them, and the edge criterion bounds their
    error. After a quadratic step (M46), which holds dp in its own equilibrium, nothing is
    added and the step's error is the correction's (:meth:`estimate`). Cost: one
    FFT pair per step (docs/numerics.md and docs/results.md have the measured errors).

    Crossings (the linear step's correction; a quadratic step has put the window's own
    curvature in its traction, and the estimate after it reads the smooth curvature only
    for its size). A node that changes its state switches its traction on or off and moves
    every node near it by a jump of the discrete solution, which the quadratic reads as a curvature
    of size jump / dt^2: in a window that holds a crossing the estimate does not fall with
    dt, and on coarse grids (the edge takes several steps per node) the step control would
    shrink the steps without end. u_tt is smooth in time, so such a window takes the
    curvature of the last window without a crossing, when that is at most ``CURVATURE_AGE``
    accepted steps and ``CURVATURE_LIFETIME`` relaxation times old, for its estimate and its
    correction. On fine grids, where nearly every step crosses nodes, the window's own
    curvature is used: there the jumps are small. On creeping retractions, whose steps are a
    good part of tau, the kept curvature is stale and the window's own is used too. Where
    the window's own curvature is used in a window with a crossing, it is set to 0 on every
    node within ``crossing_reach`` of a node that changed its state, not only on those
    nodes: the jump spreads over the zone of the passing tip (up to the glassy w / k), and
    read as curvature it gives errors of either sign, 20-80 times a smooth window's, whose
    signed sum walks to the kept errors' allowance on grids of a few nodes per zone and
    holds the steps at a small fraction of tau (docs/results.md, "Crossings in the
    history's estimate").

    Parameters
    ----------
    substrate : hpcgfmd.model.material.ViscoelasticHalfSpace
    fft : SerialRealFFT, HalvedRealFFT or TransposedRealFFT
    domain : hpcgfmd.parallel.domain.Domain
    crossing_reach : float, optional
        Distance from a node that changed its state within which the window's curvature is
        not read (length; the package uses w / (2 k), half the glassy zone width; 0: the
        changed nodes only).
    """

    def __init__(self, substrate, fft, domain, crossing_reach=0.0):
        self.substrate, self.fft, self.domain = substrate, fft, domain
        # in nodes (0: the changed nodes alone)
        self.reach = min(domain.n, max(0, math.ceil(crossing_reach / domain.dx - 1e-9)))
        n = domain.local_n
        self._curvature = aligned_empty(n)
        self._traction = aligned_empty(n)
        self._estimated = False  # _traction holds the last estimate's dp
        self.smooth_curvature = aligned_empty(n)  # c of the last window without a crossing
        self.smooth_curvature[:] = 0.0
        self.curvature_age = math.inf  # accepted steps since it was estimated
        self.curvature_time = -math.inf  # end time of its window
        self._lifetime = CURVATURE_LIFETIME * substrate.material.shortest_time
        self._smooth = False  # the last estimate's window had no crossing
        self._reused = False  # the last estimate took the smooth curvature
        self.previous_reused = False  # ... and so did the previous accepted one
        self._time = -math.inf  # end time of the last estimate's window
        self._response = 0.0  # curvature_response of the last estimate's step
        self._step = 0.0  # ... and its length
        # K c of the last accepted estimate's curvature c, per unit curvature response
        # (dp / response), for the error of the correction (estimate's docstring)
        self.previous_correction = aligned_empty(n)
        self.previous_correction[:] = 0.0
        self.has_previous = False  # set by correct(); restored from checkpoints

    def estimate(self, older, time_older, state_older, before, time_before, state_before,
                 after, time_after, state):
        """Collective (one FFT pair): the step's load error and the error its correction
        leaves in the history (load per unit length, signed: the kept errors of successive
        steps add up with their signs).

        The step's error |sum of dp over the contact| dx is that of this step's equilibrium
        only: :meth:`correct` removes it from the history the next steps start from. What
        stays in the history is the correction's own error, the change of the curvature
        over the step (u_ttt dt, which the quadratic through the last three states does not
        see): estimated as the difference of this estimate's dp and the previous accepted
        estimate's, taken at this step's curvature response,
        |sum over the contact of (dp - response K c_prev)| dx (an embedded third-order
        estimate: for u cubic in time it is about twice the corrected step's local error,
        tests/test_history_error.py). Where either curvature is not the window's own (the
        smooth curvature stood in for a crossing) or no accepted estimate came before, the
        step's error stands in for it.

        ``older``, ``before``, ``after``: this rank's u at the three times; ``state_*``:
        their nodes' interaction states (2 on the wall, 1 in the cohesive zone, 0 beyond;
        ``state``: after the step).

        Returns
        -------
        (float, float)
            The step's load error and the correction's (load per unit length).
        """
        h1, h0 = time_after - time_before, time_before - time_older
        c = self._curvature
        kinks, first, last = curvature(older, before, after, h0, h1, state_older,
                                       state_before, state, c)
        crossings, left, right = self.domain.marks_around(kinks, first, last)
        self._smooth = crossings == 0
        reuse = (not self._smooth and self.curvature_age <= CURVATURE_AGE
                 and time_after - self.curvature_time <= self._lifetime)
        if not self._smooth and not reuse and self.reach > 0:
            clear_near_crossings(state_older, state_before, state, self.reach, left, right, c)
        self._time = time_after
        # the missed traction (|q|/2) response c per mode (one FFT pair)
        self._response = self.substrate.material.curvature_response(h1)
        self.fft.apply_diagonal(self.smooth_curvature if reuse else c,
                                self.substrate.half_q * (self._response / self.substrate.n),
                                self._traction)
        self._estimated = True
        self._step = h1
        comparable = self.has_previous and not reuse and not self.previous_reused
        self._reused = reuse
        # (0 on a rank without nodes)
        step_part, previous = contact_sums(self._traction, self.previous_correction, state)
        kept = previous * self._response if comparable else 0.0
        step_error, change = self.domain.sums(step_part, step_part - kept)
        dx = self.domain.dx
        kept_error = (change if comparable else step_error) * dx
        if self.substrate.last_step_quadratic:
            # the quadratic step (M46) held dp in its own equilibrium: its error, in the
            # step's load and kept in the history alike, is the correction's
            return kept_error, kept_error
        return step_error * dx, kept_error

    def correct(self, substrate_traction):
        """Add the last estimate's missed traction to the accepted step's substrate traction
        (nothing when the step had no estimate), and keep its curvature when its window had
        no crossing, and its dp per unit curvature response for the next estimate's error of
        the correction; the estimate is used up."""
        if self._estimated:
            self.substrate.correct(self._traction, self._step)
            if self._response > 0.0:
                np.multiply(self._traction, 1.0 / self._response, out=self.previous_correction)
                self.has_previous, self.previous_reused = True, self._reused
            if self._smooth:
                self.smooth_curvature[:] = self._curvature
                self.curvature_age = 0
                self.curvature_time = self._time
            else:
                self.curvature_age += 1
        self._estimated = False

    def forget(self):
        """Drop the last estimate (its step was rejected or abandoned)."""
        self._estimated = False
