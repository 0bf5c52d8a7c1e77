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
  time of u (:class:`~.history_error.HistoryError`), and the tip's lag, the rate error the
  step's history gives the nodes a moving edge passes (:func:`~.tip_lag.tip_lag_error`), both
  bounded through
  ``time_tolerance``.

Controller. After each step the error ratios e_edge = |da|max / (edge_fraction w) and e_lag
(first order in dt), e_load (second order) and e_history (third order for the linear step's
own error when steps are short against tau, higher for the quadratic step's, first to
second for long ones: its square root is between) give the next step
dt * clip(0.9 / max(e_edge, e_lag, sqrt(e_load), sqrt(e_history)), 1/4, 2), rounded down to
the grid dt_min 2^(j/4) within [dt_min, dt_max]. A step with e_edge > 2, e_load > 4,
e_history > 4 or e_lag > 4 is rejected and repeated with that shorter step (the state is
restored), unless it already is dt_min: a genuine jump of the contact (the snap-off at high
speed) is then taken at dt_min, which places it in time to dt_min. Past a retraction's
pull-off a step whose contact vanishes is taken up to a longer length, the snap-off's bound
(:mod:`.snap_off`: the jump then moves the work of separation by at most its share and
nothing up to the pull-off), instead of being halved toward the fold in slow solves.

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
from abc import ABC, abstractmethod
from dataclasses import dataclass

from ..model.accuracy import PULL_OFF_SCALE, snap_off_share
from ..state import State
from .snap_off import SnapOff
from .tip_lag import LAG_PER_LOAD, LAG_PER_LOAD_SPECTRUM, tip_lag_error

GROWTH_LIMIT = 2.0  # largest factor between consecutive steps
SHRINK_LIMIT = 0.25  # smallest factor (also the retry factor bound after a rejection)
SAFETY = 0.9  # aim below the error target
REJECT_EDGE = 2.0  # reject when the edge moved more than twice its allowance
REJECT_LOAD = 4.0  # ... or the load deviates more than four times its tolerance
REJECT_HISTORY = 4.0  # ... or the history's estimated error is four times its allowance
REJECT_LAG = 4.0  # ... or the tip's lag error four times its allowance (jumps at crossings)
GRID_PER_OCTAVE = 4  # steps are dt_min 2^(j/4): see AdaptiveSteps._on_grid
ABANDON_EDGE = REJECT_EDGE  # edge ratio at which a solve is abandoned (module docstring)
KEPT_SHARE = 0.5  # the kept errors' signed sum: held to this share of the allowance


@dataclass
class StepOutcome:
    """What a solved (or abandoned) step of length ``dt`` gives the step control.

    Attributes
    ----------
    dt, time : float
        The step's length and end time (tau).
    load : float or None
        The step's load (load per length); None for an abandoned solve (no equilibrium:
        only its edge motion counts).
    edge_motion : float
        Largest displacement of a contact edge over the step (length; NaN: nothing to
        compare, inf: the contact appeared or vanished).
    history_error : float
        The load error the step's history integration made in its own load (load per
        length; :class:`~.history_error.HistoryError`).
    history_kept : float or None
        The part of it that stays in the history the next steps start from (None: all).
    zone_width : float
        The cohesive zone's width at the step's end (length; NaN: unknown, the relaxed w
        stands in), the length a passing edge strains a node over.
    """

    dt: float
    time: float
    load: float | None
    edge_motion: float
    history_error: float = 0.0
    history_kept: float | None = None
    zone_width: float = math.nan


@dataclass
class StepDecision:
    """Verdict on a step just solved."""

    accepted: bool
    next_dt: float
    edge_error: float = 0.0  # |da| / (edge_fraction w)
    load_error: float = 0.0  # |L - L_pred| / (load_tolerance load_scale)
    history_error: float = 0.0  # the history's load error / its allowance for this step
    lag_error: float = 0.0  # the tip's lag error / its allowance (tip_lag_error)


class StepControl(ABC):
    """What a run needs of a time-step control (its state is a part of the run's,
    :mod:`hpcgfmd.state`).

    Attributes
    ----------
    dt : float
        The next step's length (tau).
    adaptive : bool
        Steps are error-controlled (the quadratic step and the history's estimate apply).
    """

    adaptive = False
    dt: float

    @abstractmethod
    def judge(self, outcome: StepOutcome) -> StepDecision:
        """The verdict on a solved step; sets :attr:`dt` to the next step's length."""

    def edge_limit(self, dt) -> float:
        """Edge motion at which a solve of a step of length dt may be abandoned (length;
        inf: never)."""
        return math.inf

    def accept(self, time, load, cut_from=None, drive=math.nan):
        """An accepted step ended at ``time`` with ``load`` and the drive at ``drive``.
        ``cut_from``: the length proposed before the step was cut to a segment's end (the
        next one is that, unless the cut step's errors asked for less)."""
        if cut_from is not None:
            self.dt = max(self.dt, cut_from)

    def new_segment(self):  # noqa: B027 (nothing to forget by default)
        """The drive's rate changed (a protocol's segment began)."""

    def state(self) -> State:
        return State(scalars={"dt": self.dt})

    def restore(self, state: State):
        self.dt = float(state.scalars["dt"])


class FixedSteps(StepControl):
    """Constant step dt (the paper's method): every step is accepted."""

    def __init__(self, dt: float):
        self.dt = dt

    def judge(self, outcome: StepOutcome) -> StepDecision:
        return StepDecision(True, self.dt)

    def accept(self, time, load, cut_from=None, drive=math.nan):
        pass


class AdaptiveSteps(StepControl):
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
        in the history over ``memory_time`` (:class:`~.history_error.HistoryError`,
        :meth:`judge`); inf: not controlled (the elastic solid).
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
    snap_off_share : float
        The work of separation's share the snap-off's placement may take (:mod:`.snap_off`;
        0: every jump of the contact is placed to dt_min).
    """

    adaptive = True

    def __init__(
        self,
        first_dt,
        dt_min,
        dt_max,
        edge_allowance,
        load_allowance,
        history_allowance=math.inf,
        memory_time=1.0,
        lag_allowance=math.inf,
        zone_width=1.0,
        modulus_ratio=1.0,
        branches=None,
        snap_off_share=0.0,
    ):
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
        self._judged_dt = math.inf  # the length of the step just judged
        self.snap_off = SnapOff(snap_off_share, load_allowance)

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

    def judge(self, outcome: StepOutcome) -> StepDecision:
        """The verdict on a solved step (:class:`StepOutcome`), and the next step's length
        (module docstring): the worst error ratio sizes it, a ratio over its rejection bound
        repeats the step shorter unless it is already dt_min."""
        dt = self._judged_dt = outcome.dt
        edge_error = self._edge_ratio(outcome.edge_motion)
        load_error = self._load_ratio(outcome)
        history_ratio, sizing_ratio = self._history_ratios(outcome)
        zone = (
            outcome.zone_width
            if outcome.zone_width > 0.0 and math.isfinite(outcome.zone_width)
            else self.zone_width
        )
        lag_error = (
            tip_lag_error(dt, outcome.edge_motion, zone, self.modulus_ratio, self.branches)
            / self.lag_allowance
        )
        # (the load's and the history's errors are of higher order in dt: square roots)
        worst = max(edge_error, math.sqrt(load_error), math.sqrt(sizing_ratio), lag_error)
        factor = SAFETY / worst if worst > 0.0 else GROWTH_LIMIT
        factor = min(max(factor, SHRINK_LIMIT), GROWTH_LIMIT)
        next_dt = self._on_grid(dt * factor)
        # a contact that vanished (or appeared) in a solved step is a jump, taken when the
        # step is short enough to place it (:meth:`jump_dt`)
        jumped = outcome.load is not None and math.isinf(outcome.edge_motion)
        rejected = (
            edge_error > REJECT_EDGE
            or load_error > REJECT_LOAD
            or history_ratio > REJECT_HISTORY
            or lag_error > REJECT_LAG
        ) and dt > (self.jump_dt() if jumped else self.dt_min)
        self.dt = next_dt
        return StepDecision(not rejected, next_dt, edge_error, load_error, history_ratio, lag_error)

    def _edge_ratio(self, edge_motion):
        """|da| over the edge allowance (0 with nothing to compare, inf for a contact that
        appeared or vanished)."""
        if math.isfinite(edge_motion):
            return edge_motion / self.edge_allowance
        return 0.0 if math.isnan(edge_motion) else math.inf

    def _load_ratio(self, outcome):
        """The load's deviation from the line through the two loads before, over its
        allowance (0 without two points or a load)."""
        if (
            outcome.load is None
            or len(self.points) < 2
            or not (self.points[1][0] > self.points[0][0])
        ):
            return 0.0
        (t0, l0), (t1, l1) = self.points
        predicted = l1 + (l1 - l0) * (outcome.time - t1) / (t1 - t0)
        return abs(outcome.load - predicted) / self.load_allowance

    def _history_ratios(self, outcome):
        """(the verdict's ratio, the next step's sizing ratio) of the history's errors.

        The errors kept in the history persist over the memory time: they add up with their
        signs, each decaying as exp(-dt / memory_time) per step, and the sum E is the
        history's load error, bounded by A = KEPT_SHARE times the allowance (E is an
        estimate, not a bound as the step's own error is: held to the steps' share of the
        accuracy, half the allowance, which is twice it). What is left of A for a step is
        A - |E| exp(-dt / memory_time), at least A (1 - exp(-dt / memory_time)) (what decays
        meanwhile: a coherent error per step then stays within A). A step is repeated when
        it spent, |E_n+1| - |E_n| exp(-dt / memory_time), over four times what was left; the
        next one is sized for its kept error, of either sign, to fit in what is left after
        this one. Errors of random sign (crossings and solver residuals read as curvature)
        mostly cancel in E, which leaves the next steps room; a coherent error fills E and
        its steps are held to A (1 - exp(-dt / memory_time)) each.
        """
        error = outcome.history_error
        kept = error if outcome.history_kept is None else outcome.history_kept
        allowance = self.history_allowance * KEPT_SHARE
        share = -math.expm1(-outcome.dt / self.memory_time)
        decayed = self.kept_history * (1.0 - share)
        self._kept_pending = decayed + kept
        spent = (abs(self._kept_pending) - abs(decayed)) / max(
            allowance - abs(decayed), allowance * share
        )
        room = max(allowance - abs(self._kept_pending) * (1.0 - share), allowance * share)
        own = abs(error) / self.history_allowance
        return max(own, spent), max(own, abs(kept) / room)

    def jump_dt(self) -> float:
        """The longest step in which the contact may vanish (or appear): dt_min, or past a
        retraction's pull-off the snap-off's bound (:mod:`.snap_off`) rounded down to the
        grid of steps."""
        if self.snap_off.bound <= self.dt_min:
            return self.dt_min
        return self._on_grid(self.snap_off.bound)

    def edge_limit(self, dt) -> float:
        """Edge motion at which a solve of a step of length dt is abandoned, the step
        rejected and repeated with dt / 4 (length; inf up to :meth:`jump_dt`, where a solve
        may descend to a jump of the contact): see the module docstring."""
        if dt <= self.jump_dt():
            return math.inf
        return ABANDON_EDGE * self.edge_allowance

    def accept(self, time, load, cut_from=None, drive=math.nan):
        """Record an accepted step's load for the next extrapolation (a repeated preload
        at t = 0 replaces the point before); a step cut short by a segment's end
        (``cut_from``: the length proposed before the cut) is followed by that length
        unless the cut step's errors asked for less."""
        if cut_from is not None and self.dt >= self._judged_dt:
            self.dt = max(self.dt, cut_from)
        points = [p for p in self.points if p[0] < time]
        self.points = (points + [(time, load)])[-2:]
        self.kept_history, self._kept_pending = self._kept_pending, 0.0
        self.snap_off.accept(time, load, drive)

    def new_segment(self):
        """The drive's rate changed (a protocol's segment began): the load's extrapolation
        restarts from the last point, not across the kink; the snap-off's pull-off and
        work start afresh."""
        self.points = self.points[-1:]
        self.snap_off.new_segment()

    def state(self) -> State:
        flat = [v for point in self.points for v in point]
        return State(
            scalars={
                "dt": self.dt,
                "points": flat + [math.nan] * (4 - len(flat)),
                "kept_history": self.kept_history,
                "snap_off": self.snap_off.state(),
            }
        )

    def restore(self, state: State):
        s = state.scalars
        self.dt = float(s["dt"])
        self.kept_history = float(s["kept_history"])
        self._kept_pending = 0.0
        flat = [float(v) for v in s["points"]]
        self.points = [(flat[i], flat[i + 1]) for i in (0, 2) if not math.isnan(flat[i])]
        if "snap_off" in s:  # (checkpoints of earlier versions: placed to dt_min until a step)
            self.snap_off.restore(s["snap_off"])


def make_step_control(case) -> StepControl:
    """Fixed steps of ``[numerics] dt``, or adaptive steps starting from it."""
    numerics = case.numerics
    if numerics.step_control == "fixed":
        return FixedSteps(numerics.dt)
    material = case.material()
    viscous = case.modulus_ratio < 1.0
    # time_tolerance bounds the history's errors: the smooth part's in load scales, the
    # tip's lag as that load over the relaxed pull-off, shared for LAG_PER_LOAD. That bound
    # was calibrated and validated for one relaxation time (the SLS); a Prony series of
    # several times keeps the linear step's, four times tighter (with the SLS's bound the
    # two-branch series of docs/beyond-the-paper.md was 1.1e-2 off at accuracy 1e-2)
    one_time = len(set(material.branch_times)) == 1
    lag = numerics.time_tolerance / (
        PULL_OFF_SCALE * (LAG_PER_LOAD if one_time else LAG_PER_LOAD_SPECTRUM)
    )
    return AdaptiveSteps(
        numerics.dt,
        numerics.dt_min,
        numerics.dt_max,
        numerics.edge_fraction * case.zone_width,
        numerics.load_tolerance * case.load_scale,
        numerics.time_tolerance * case.load_scale if viscous else math.inf,
        material.retardation_time,  # tau / k for the SLS, tau = 1
        lag if viscous else math.inf,
        case.zone_width,
        case.modulus_ratio,
        (material.branch_moduli, material.branch_times) if material.branches > 1 else None,
        0.0 if case.compliant else snap_off_share(numerics.load_tolerance),
    )
