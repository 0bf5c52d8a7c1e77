"""The estimated cost of a case: the single-core seconds its run takes.

Used for the farm's longest-first order, its dry run and its progress lines, and for a run's
estimate of the time left (:mod:`.progress`). Internal units (R = E0 = tau = 1); every
constant below was measured on the 33 runs of the paper's study (``python -m hpcgfmd paper``,
accuracy 1e-2, one rank each, the FFTW wisdom cached) and is checked against them by
``scripts/farm_cost.py``, which prints the predicted against the measured time of each.

The protocol is followed segment by segment (:func:`plan`), the drive's position and the
contact half-width carried from one segment to the next:

- The start: the relaxed preload at h0 with the contact half-width A0_PER_GEOMETRIC
  sqrt(2 R h0) (0.62 of the geometric one, measured on every run at h0/R = 0.05 and 0.1), or,
  before an approach, out of contact at u_z = 2 dmax.
- A retraction "until detachment" ends when the relaxed-equivalent drive
  u_eff(t) = u_z(t) + sum_i m_i v tau_i (1 - exp(-t / tau_i)) (the drive's history seen
  through each branch's relaxation, m_i = E_i / E0; for the SLS m = 1/k - 1, tau = 1) reaches
  the pull-off height U = PULL_OFF_HEIGHT beta^2 R times the viscoelastic enhancement
  :func:`enhancement` of chi_ve / k. This places the detachment time of all 33 runs within
  1 %, from creeping (V_z = 0.045, 1900 tau) to glassy retractions (V_z = 9, 1 tau).
- An approach ends at its target, a dwell after its duration; a retraction with a finite
  target at whichever of target and detachment comes first.

The steps of a segment of duration T with adaptive steps are bounded below by each criterion
of :mod:`hpcgfmd.solvers.stepping`; they combine as the norm
N = log2(dt_max / dt) + (N_max^P + N_edge^P + N_lag^P + N_load^P)^(1/P), the first term the
first step's doublings:

- travel: N_max = T / dt_max;
- edge: the contact half-width moves from a_start to a_end (0 at detachment) while an edge
  may move edge_fraction w per step: N_edge = |a_end - a_start| / (EDGE_SHARE edge_fraction w);
- tip lag (creeping retractions): the edge moving at |a_end - a_start| / T, the longest step
  whose :func:`~hpcgfmd.solvers.stepping.tip_lag_error` is within its allowance;
  N_lag = LAG_SHARE T / dt_lag;
- load: the load changes by dL (preload to pull-off) over the segment, a curvature about
  dL / T^2: N_load = sqrt(dL / load_tolerance load_scale).

Fixed steps: T / dt. Iterations per step: :func:`_iterations_per_step` of the nodes an edge
crosses per step. Seconds: (SECONDS_PER_NODE_ITERATION nx iterations + SECONDS_PER_NODE_STEP
nx steps (the step's own transforms and output)) times the large grid's factor
(nx / CACHE_NODES)^LARGE_GRID_ORDER above CACHE_NODES, + START_SECONDS.

A sphere (n x n nodes) keeps the form with its own constants, measured on the 25 runs of its
accuracy study (docs/results.md, "The knob on the sphere"; ``scripts/farm_cost.py --study``):
its contact radius SPHERE_A0 sqrt(R h0), its preload's load the JKR force there
(:func:`_preload_load`), its pull-off height and load; its load criterion takes
SPHERE_LOAD_STEPS times N_load (its load curve bends more: past the pull-off the contact
shrinks on an attached branch, and after the contact has gone the zone lets go; every step
of its fast retractions is the load's); its iterations per step follow its contact line,
SPHERE_ITERATIONS_AT_REST + SPHERE_NODE_ITERATIONS sqrt(k^(2/3) c), c the line's nodes pi (a
+ a_end) / dx times its advance per step in relaxed zone widths (a glassy step's stiffer
response needs fewer). On the study's runs, predicted / measured: steps 0.81-1.64,
iterations 0.61-1.62, seconds 0.70-1.74 (with the cylinder's constants: 0.32-1.29,
0.10-1.98 and 0.15-2.04).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..model.accuracy import PULL_OFF_SCALE
from ..model.loading import START_HEIGHT
from ..solvers import solver_class
from ..solvers.tip_lag import LAG_PER_LOAD, LAG_PER_LOAD_SPECTRUM, tip_lag_error

# Geometry and detachment (measured on the paper's runs; docstring).
A0_PER_GEOMETRIC = 0.624  # preload contact half-width / sqrt(2 R h0)
PRELOAD_LOAD = 0.5  # preload load / (E0 h0) (0.45-0.52 at L/R = 10, h0/R = 0.05-0.1)
PULL_OFF_HEIGHT = 5.19  # elastic pull-off height of the relaxed-equivalent drive, beta^2 R
# A sphere's (the enhancement the cylinder's), measured on the runs of its accuracy study
# (docs/results.md, "The knob on the sphere": lambda0 = 1-7, H0 = h0 / delta_s = 0.565, cells
# of 4.4-5.6 a0; scripts/farm_cost.py --study): the relaxed-equivalent drive at complete
# detachment, 0.740-0.850 delta_s on the elastic runs (JKR's isolated jump 3 (1/6)^(2/3) =
# 0.908, (M55), less the cell's lift); the elastic pull-off, 1.52-1.61 pi dgamma0 R; the
# preload contact radius, 1.79-2.03 sqrt(R h0) (adhesion widens a shallow preload's), whose
# JKR force (M55) is the preload's load (measured -1.07 to -1.11 pi dgamma0 R, JKR's -1.26)
SPHERE_PULL_OFF_HEIGHT, SPHERE_PULL_OFF_SCALE, SPHERE_A0 = 0.77, 1.56, 1.9
# ... its load criterion's steps over the cylinder's N_load (fitted: its fast retractions'
# steps, all the load's, were 2.6-4 times N_load) and its iterations per step (module
# docstring; fitted to the iterations of the study's runs and of 25 more in smaller cells,
# rms 33 %, each within 1.95x)
SPHERE_LOAD_STEPS = 5.0
SPHERE_ITERATIONS_AT_REST, SPHERE_NODE_ITERATIONS = 2.0, 1.88
GLASSY_SHARE = 0.83  # enhancement's glassy limit: 1 + GLASSY_SHARE (k^(-2/3) - 1)
ENHANCEMENT_RATE = 18.4  # chi_ve / k at which half of it is reached ...
ENHANCEMENT_ORDER = 0.68  # ... and the power of chi_ve / k it rises with
# Steps (fitted to the adaptive runs' accepted steps: each within 1.4x).
NORM_ORDER = 1.68  # P of the criteria's norm
EDGE_SHARE = 0.94  # the mean edge motion per step, in edge allowances
LAG_SHARE = 0.48  # the tip-lag bound's steps taken (the edge is rarely at its mean)
# Work (fitted to the runs' iterations, each within 1.5x, then to their CPU seconds: each
# within 1.8x, FFTW's wisdom cached; scripts/farm_cost.py).
ITERATIONS_AT_REST = 5.7  # CG iterations of a step whose edges cross no node
NODE_ITERATIONS = 0.52  # ... and those of the nodes crossed, NODE_ITERATIONS n^NODE_ORDER
NODE_ORDER = 1.36
SECONDS_PER_NODE_ITERATION = 1.5e-8  # one CG iteration per node (2.0 ms at 2^17)
SECONDS_PER_NODE_STEP = 7.1e-8  # a step's own work per node (history estimate, output)
START_SECONDS = 0.22  # a case's set-up and preload at the paper's sizes
# Beyond the cache a node costs more: every pass and transform stage streams from memory
# (scripts/bench_scaling.py on one rank: a step cost 1.5, 1.9 and 2.3 times the per-node
# cost of 2^17 at 2^20, 2^22 and 2^24; docs/results.md, "Scaling")
CACHE_NODES = 2**17
LARGE_GRID_ORDER = 0.17
# Memory: the peak resident set of a rank, BASE_MEMORY + MEMORY_PER_NODE nodes of its block
# (the preload's peak, its coarse levels beside the fine grid's arrays; 585-770 bytes per
# node measured from 2^20 to 2^24 on one and two ranks, docs/results.md "Scaling").
BASE_MEMORY = 140e6  # bytes: the interpreter, numpy, mpi4py, h5py and pyfftw
MEMORY_PER_NODE = 720.0  # bytes


@dataclass(frozen=True)
class SegmentCost:
    """One segment's estimate (internal units).

    Attributes
    ----------
    kind : str
        "approach", "dwell" or "retract".
    start, end : float
        The drive's value at the segment's start and (estimated) end: its position (R), or
        the applied load (E0 R) under load control.
    duration : float
        Its estimated length in time (tau).
    steps, iterations, seconds : float
        Its estimated accepted steps, solver iterations and single-core seconds.
    detaches : bool
        Whether it ends at (the estimated) complete detachment.
    width, end_width : float
        The contact half-width at its start and (estimated) end (R).
    edge_weight : float
        The share of its steps the edge criterion sets (N_edge^P / sum of N^P; 0 with fixed
        steps): those steps follow the contact edge's travel, the others the drive's.
    """

    kind: str
    start: float
    end: float
    duration: float
    steps: float
    iterations: float
    seconds: float
    detaches: bool = False
    width: float = 0.0
    end_width: float = 0.0
    edge_weight: float = 0.0


def estimated_cost(case) -> float:
    """Estimated single-core seconds of ``case`` (a validated
    :class:`~hpcgfmd.case.Case`)."""
    return START_SECONDS + sum(segment.seconds for segment in plan(case))


def estimated_steps(case) -> float:
    """Estimated accepted steps of ``case``."""
    return sum(segment.steps for segment in plan(case))


def estimated_memory(case, ranks: int = 1) -> float:
    """Estimated peak resident bytes of each of ``ranks`` ranks running ``case``."""
    return BASE_MEMORY + MEMORY_PER_NODE * math.ceil(math.prod(case.numerics.shape) / ranks)


def resources_line(case, ranks: int = 1) -> str:
    """What a run of ``case`` will take, for ``--dry-run``: steps, iterations, single-core
    hours (this model) and the memory per rank on ``ranks`` ranks."""
    segments = plan(case)
    steps = sum(s.steps for s in segments)
    iterations = sum(s.iterations for s in segments)
    hours = estimated_cost(case) / 3600.0
    memory = estimated_memory(case, ranks)
    return (
        f"estimated: {steps:.3g} steps, {iterations:.3g} solver iterations,"
        f" {hours:.3g} core-hours (single core; hpcgfmd/runs/cost.py); memory"
        f" {memory / 1e9:.3g} GB per rank on {ranks} rank(s), {ranks * memory / 1e9:.3g} GB"
        " in all"
    )


def model_line() -> str:
    """The model's constants in one line (the farm's dry run prints it)."""
    return (
        f"{SECONDS_PER_NODE_ITERATION * 2**17 * 1e3:.2g} ms per CG iteration at 2^17"
        f" nodes, {ITERATIONS_AT_REST:.3g} + {NODE_ITERATIONS:.2g} n^{NODE_ORDER:g}"
        " iterations per step of n nodes crossed; steps from the edge, tip-lag, load and"
        " dt_max criteria (hpcgfmd/runs/cost.py)"
    )


def enhancement(chi_ve: float, k: float) -> float:
    """The pull-off height over the relaxed (elastic) one at chi_ve / k: between 1 (a relaxed
    tip) and the glassy 1 + GLASSY_SHARE (k^(-2/3) - 1) (the JKR displacement's dgamma^(2/3)
    with dgamma0 / k; 4.0 at k = 0.1, measured 3.92 at chi_ve / k = 4410), rising as
    y / (1 + y), y = (chi_ve / (k ENHANCEMENT_RATE))^ENHANCEMENT_ORDER."""
    if k >= 1.0 or not chi_ve > 0.0:
        return 1.0
    y = (chi_ve / (k * ENHANCEMENT_RATE)) ** ENHANCEMENT_ORDER
    return 1.0 + GLASSY_SHARE * (k ** (-2.0 / 3.0) - 1.0) * y / (1.0 + y)


def pull_off_height(case, rate: float) -> float:
    """U: the relaxed-equivalent drive at detachment (R) for a retraction at ``rate``."""
    height = SPHERE_PULL_OFF_HEIGHT if case.sphere else PULL_OFF_HEIGHT
    return height * case.beta**2 * enhancement(_chi(case, rate), case.modulus_ratio)


def detachment_time(case, depth: float, rate: float) -> float:
    """Time (tau) from a relaxed contact at ``depth`` (R, the drive at -depth) to complete
    detachment, retracting at ``rate`` (R / tau): where u_eff reaches :func:`pull_off_height`
    (module docstring; at least the time to rise by ``depth``'s elastic share)."""
    target = pull_off_height(case, rate)
    material = case.material()
    branches = (
        list(zip(material.branch_moduli, material.branch_times)) if case.modulus_ratio < 1.0 else []
    )

    def effective(t):
        return (
            -depth + rate * t + sum(m * rate * tau * -math.expm1(-t / tau) for m, tau in branches)
        )

    low, high = 0.0, (depth + target) / rate  # u_eff >= u_z: the elastic time is an upper bound
    if effective(high) <= target or high == 0.0:
        return high
    for _ in range(100):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if effective(middle) < target else (low, middle)
    return high


def _chi(case, rate):
    """chi_ve = V_z lambda0^2 of a retraction at ``rate`` (R / tau)."""
    return rate / case.beta**2 * case.maugis**2


def _preload_load(case, depth: float) -> float:
    """The load (E0 R, a sphere's E0 R^2) of a relaxed contact at ``depth`` (R): the
    cylinder's PRELOAD_LOAD E0 h0; the sphere's JKR force (M55) at its contact radius
    :func:`_contact`, A^3 - sqrt(6 A^3) load scales (A = a / a_s)."""
    if not case.sphere:
        return PRELOAD_LOAD * depth
    cube = (_contact(depth, True) / case.beta) ** 3
    return (cube - math.sqrt(6.0 * cube)) * case.load_scale


def _contact(depth: float, sphere: bool = False) -> float:
    """Contact half-width (R) of a relaxed contact at ``depth`` (R; none at depth <= 0); a
    sphere's radius."""
    if depth <= 0.0:
        return 0.0
    return SPHERE_A0 * math.sqrt(depth) if sphere else A0_PER_GEOMETRIC * math.sqrt(2.0 * depth)


def _pull_off_load(case, rate: float) -> float:
    """The pull-off load (E0 R, negative) of a retraction at ``rate``, about the relaxed
    2D one times the enhancement."""
    scale = SPHERE_PULL_OFF_SCALE if case.sphere else PULL_OFF_SCALE
    return -scale * case.load_scale * enhancement(_chi(case, rate), case.modulus_ratio)


def plan(case) -> list:
    """The estimated :class:`SegmentCost` of each of the protocol's segments, in order."""
    if case.load_control:
        return _load_control_plan(case)
    spring = case.drive_stiffness  # inf: the drive is the indenter
    if case.starts_out_of_contact:
        position, width = START_HEIGHT * case.dmax, 0.0
    else:
        position, width = -case.depth, _contact(case.depth, case.sphere)
    out = []
    for segment in case.segments:
        start = position
        if segment.kind == "dwell":
            out.append(_estimate(case, "dwell", start, start, segment.target, width, width, 0.0))
            continue
        rate = segment.rate
        if segment.kind == "approach":
            end = min(segment.target, position)
            end_width = _contact(-end, case.sphere)
            load = abs(PRELOAD_LOAD * (max(-end, 0.0) - max(-start, 0.0)))
            out.append(
                _estimate(
                    case, "approach", start, end, (start - end) / rate, width, end_width, load
                )
            )
            position, width = end, end_width
            continue
        # a retraction: until detachment, or its target if that comes first
        if width > 0.0:
            pull_off = _pull_off_load(case, rate)
            load = _preload_load(case, max(-start, 0.0)) - pull_off
            stretch = load / spring  # the spring's share of the drive's travel
            detach = start + rate * detachment_time(case, max(-start, 0.0), rate) + stretch
        else:
            load, detach = 0.0, start
        end = min(segment.target, detach)
        detaches = end >= detach
        end_width = 0.0 if detaches else min(width, _contact(-end, case.sphere))
        out.append(
            _estimate(
                case, "retract", start, end, (end - start) / rate, width, end_width, load, detaches
            )
        )
        position, width = end, end_width
    return out


def _load_control_plan(case):
    """:func:`plan` under load control: the drive is the applied load, from the preload's."""
    load, width = PRELOAD_LOAD * case.depth, _contact(case.depth, case.sphere)
    out = []
    for segment in case.segments:
        start = load
        if segment.kind == "dwell":
            out.append(_estimate(case, "dwell", start, start, segment.target, width, width, 0.0))
            continue
        pull_off = _pull_off_load(case, case.indenter_speed)
        end = segment.target if segment.kind == "approach" else max(segment.target, pull_off)
        detaches = segment.kind == "retract" and end <= pull_off
        end_width = 0.0 if detaches else _contact(max(end, 0.0) / PRELOAD_LOAD, case.sphere)
        out.append(
            _estimate(
                case,
                segment.kind,
                start,
                end,
                abs(end - start) / segment.rate,
                width,
                end_width,
                abs(end - start),
                detaches,
            )
        )
        load, width = end, end_width
    return out


def _estimate(case, kind, start, end, duration, width, end_width, load_change, detaches=False):
    """One segment's :class:`SegmentCost`: its steps, iterations and seconds."""
    num = case.numerics
    duration = max(duration, 0.0)
    travel = abs(end_width - width)  # of each contact edge
    edge_weight = 0.0
    if duration == 0.0:
        steps = 0.0
    elif num.step_control == "fixed":
        steps = math.ceil(duration / num.dt - 1e-9)
    else:
        bounds = (
            duration / num.dt_max,
            travel / (EDGE_SHARE * num.edge_fraction * case.zone_width),
            LAG_SHARE * duration / _lag_step(case, travel / duration),
            math.sqrt(load_change / (num.load_tolerance * case.load_scale))
            * (SPHERE_LOAD_STEPS if case.sphere else 1.0),
        )
        norm = math.fsum(b**NORM_ORDER for b in bounds)
        steps = math.log2(max(num.dt_max / num.dt, 1.0)) + norm ** (1.0 / NORM_ORDER)
        edge_weight = bounds[1] ** NORM_ORDER / norm if norm > 0.0 else 0.0
    crossed = travel / case.dx / steps if steps else 0.0
    if case.sphere:  # the contact line's nodes, pi (a + a_end) / dx, times its advance in w
        crossed *= math.pi * (width + end_width) / case.zone_width
    iterations = steps * _iterations_per_step(case, crossed)
    per_node = SECONDS_PER_NODE_ITERATION * iterations + SECONDS_PER_NODE_STEP * steps
    nodes = math.prod(num.shape)  # nx on a line, n^2 on a sphere's surface
    seconds = nodes * per_node * large_grid_factor(nodes)
    return SegmentCost(
        kind,
        start,
        end,
        duration,
        steps,
        iterations,
        seconds,
        detaches,
        width,
        end_width,
        edge_weight,
    )


def large_grid_factor(nx: int) -> float:
    """The cost of a node on a grid of ``nx`` nodes over its cost within the cache."""
    return max(1.0, nx / CACHE_NODES) ** LARGE_GRID_ORDER


def _lag_step(case, edge_speed) -> float:
    """The longest step (tau) whose tip-lag error (:func:`~hpcgfmd.solvers.stepping.
    tip_lag_error`, the relaxed zone width) stays within the allowance of
    :func:`~hpcgfmd.solvers.stepping.make_step_control` at this edge speed (R / tau)."""
    num = case.numerics
    if case.modulus_ratio >= 1.0 or not edge_speed > 0.0:
        return num.dt_max
    material = case.material()
    one_time = len(set(material.branch_times)) == 1
    allowance = num.time_tolerance / (
        PULL_OFF_SCALE * (LAG_PER_LOAD if one_time else LAG_PER_LOAD_SPECTRUM)
    )
    branches = (material.branch_moduli, material.branch_times) if case.relaxation_moduli else None

    def error(dt):
        return tip_lag_error(dt, edge_speed * dt, case.zone_width, case.modulus_ratio, branches)

    low, high = math.log(num.dt_min), math.log(num.dt_max)
    if error(num.dt_max) <= allowance:
        return num.dt_max
    if error(num.dt_min) > allowance:
        return num.dt_min
    for _ in range(60):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if error(math.exp(middle)) <= allowance else (low, middle)
    return math.exp(low)


def _iterations_per_step(case, crossed: float = 0.0) -> float:
    """Solver iterations per time step: a solver's own count when it fixes it (the paper's
    damped Verlet, its pseudo steps); otherwise, the active-set CG's, ITERATIONS_AT_REST plus
    NODE_ITERATIONS crossed^NODE_ORDER for ``crossed`` nodes an edge crosses per step (each
    released node changes the active set, which the next iterations relax); a sphere's,
    SPHERE_ITERATIONS_AT_REST + SPHERE_NODE_ITERATIONS sqrt(k^(2/3) crossed), ``crossed``
    its contact line's nodes times the line's advance per step in relaxed zone widths."""
    fixed = solver_class(case.numerics.solver).iterations_per_step(case.numerics)
    if math.isnan(fixed) and case.sphere:
        return SPHERE_ITERATIONS_AT_REST + SPHERE_NODE_ITERATIONS * math.sqrt(
            case.modulus_ratio ** (2.0 / 3.0) * crossed
        )
    if math.isnan(fixed):
        return ITERATIONS_AT_REST + NODE_ITERATIONS * crossed**NODE_ORDER
    return fixed
