"""Equilibrium of one time step: constrained, preconditioned conjugate gradients.

Each time step (docs/model.md, "Interface") minimises over the surface displacement u

    E(u) = 1/2 u.K u + (H - p_applied).u + sum_e Phi_e(h + u_z - u)   (per unit length)

subject to the hard wall u <= h + u_z (gap >= 0) and zero mean displacement (the q = 0 mode
of u is held at zero; its traction, the load, is the Lagrange multiplier). K is diagonal in
Fourier space, k_q = (|q|/2) Eeff, and H is the SLS history traction
(:mod:`hpcgfmd.model.material`).

Method. Polonsky-Keer-type active-set CG in the displacement, preconditioned by the Green's
function K^-1 (so the elastic part is the identity and the iteration count does not grow
like sqrt(n_x) as for plain CG or damped dynamics). Nodes on the wall that are pushed into it
form the active set (:mod:`.active_set`); the search space is the free nodes with zero mean.
CG restarts whenever nodes join the active set (Polonsky and Keer, Wear 231 (1999) 206).

Path following. The Dugdale energy is concave in u (the mean of the convex ramp
max(dmax - g, 0) over each element, times -sigma_a), so the quadratic model built from K and
the linearised adhesion is an upper bound of E: every step of length in (0, 2 alpha*) along a
CG direction, alpha* the bound's minimiser, lowers E. The same holds from every point of the
line with its own slope, so the line search goes on beyond alpha* while the energy provably
falls (:mod:`.line_search`). Steps that would cross the wall are projected or cut at the
first contact so that E still drops (:mod:`.wall_steps`). Every iteration lowers E: the
solver goes downhill from its start, the previous step's equilibrium or a guess of lower
energy, and ends in the local minimum of that basin, the physical branch.

Cost per iteration. Two FFT pairs, both intrinsic: the preconditioner K^-1 r and K d. Between
them the direction is projected in real space (pressed nodes zeroed, mean removed, nodes the
direction pushes into the wall held), so K d is not K K^-1 r = r and needs its own pair
whenever a node is pressed, i.e. while there is contact. One more pair per projected
backtracking trial and for the residual direction when a step reaches the wall (rare). Per
solve, one pair at the start unless the predictor evaluated the start
(:meth:`~hpcgfmd.solvers.step_problem.StepProblem.recall`). K u is updated incrementally,
through the running load K u + H - p_applied, also for the solution (its exact K u differs by
round-off). Between the transforms, four compiled passes over the block
(:mod:`hpcgfmd.solvers.kernels`), each reading every vector once (chunk by chunk, so that
what a pass reads again comes from the cache): after K^-1 r the projection of z (mean
removed, pressed nodes zeroed) with the three Polak-Ribiere dots (r.z, r_old.z, r.d_old), and
after their reduction d = z + beta d_old with the entry bound of d (how far d may go before a
node outside the near span enters the zone); after K d, d.K d; after the line search the
step on u, the gaps and K u + H - p_applied with the next residual, its sum and its extrema.
Everything about the wall, the active set and the cohesive law works on the span of nodes
with gap < dmax (:mod:`.points`): the trial point's and each line-search point's gaps and law,
the multiplier's fixed point; the traction of a trial point that is taken is not evaluated
again. Per solve: one read-only pass that finds a feasible start feasible (it is left in
place), the comparison with the predictor's kept vector, one pass forming the gaps, K u + H -
p_applied and the first residual, one for its extrema, and K u at the end. Buffers are
swapped, not copied, and no array of the block's size is allocated in a CG iteration or a
line-search extension; the rare projected step evaluates the energy, whose cohesive part
makes temporaries of the interaction span's size. docs/results.md has the measured cost.

Parallel layout. Every real-space vector is this rank's block of nodes
(:class:`hpcgfmd.parallel.domain.Domain`); the transforms inside ``fft.apply_diagonal`` are
the only bulk communication. An iteration adds reductions of one to four doubles (the
multiplier's fixed point, the residual's maximum with the restart test and the edge watch,
the mean of z, the CG dot products, the hold test with the entry bound, d.K d, the trial
point's slope; one per line-search extension) and one ghost-node exchange per point
evaluated; every branch is decided on those reduced values, so all ranks take it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...parallel.fft import aligned_empty
from .. import kernels
from ..active_set import ActiveSet
from ..base import NO_WATCH, EdgeWatch, EquilibriumSolver, SolveResult, register
from ..points import Point, PointEvaluator
from ..projection import project_in_place
from ..step_problem import StepProblem
from .moves import Moves
from .wall_steps import WallSteps


def _rows(n):
    """Two zeroed aligned rows of n nodes, as a tuple of views of one buffer."""
    rows = aligned_empty((2, n))
    rows[...] = 0.0
    return rows[0], rows[1]


@dataclass
class _Descent:
    """The state of one solve's iteration (CG rows, multiplier, restart flags, counts)."""

    cur: Point
    trial: Point
    probe: Point
    ir: int = 0  # rows of r and z in the stacked buffers; r_old and d_old are the other rows
    iz: int = 0
    restart: bool = True
    first_pass: bool = True
    rz_old: float = 1.0
    residual: float = np.inf
    mu: float = 0.0
    iteration: int = 0
    pending: tuple | None = None  # the next residual's sums, formed with the accepted step
    jump_tried: bool = False  # the detached minimum was tried (once per solve)


@register("cg")
class ConstrainedCG(EquilibriumSolver):
    """Active-set preconditioned CG for one step's equilibrium (see module docstring).

    Parameters
    ----------
    domain : hpcgfmd.parallel.domain.Domain
        This rank's block of nodes and the collectives.
    fft : SerialRealFFT, HalvedRealFFT or TransposedRealFFT
        Planned transforms of the grid (same block layout as ``domain``).
    law : hpcgfmd.model.interface.DugdaleMaugis
        Cohesive law.
    tolerance : float
        Convergence when max |projected residual| <= tolerance * traction_scale.
    max_iterations : int
        Iteration cap per solve.
    traction_scale : float
        Traction used to make the residual dimensionless (stress units).
    """

    starts_from_prediction = True

    def __init__(
        self, domain, fft, law, tolerance: float, max_iterations: int, traction_scale: float
    ):
        self.domain, self.fft, self.law = domain, fft, law
        self.tolerance = tolerance
        self.max_iterations = max_iterations
        self.traction_scale = traction_scale
        n = domain.local_n
        self._n = n
        self.problem = StepProblem(domain, fft, law, traction_scale)
        self._evaluator = PointEvaluator(domain, law)
        self._active = ActiveSet(domain)
        self._walls = WallSteps(domain, fft, self.problem)
        # Every buffer of a solve is made here: an iteration allocates nothing of size n.
        # (aligned: the serial transform reads and writes them in place)
        self._k_u = aligned_empty(n)  # K u at the start and the end of a solve (elastic_traction)
        self._load = np.empty(n)  # K u + H - p_applied during a solve (updated by steps)
        self._linear = np.empty(n)  # H - p_applied when a traction is applied
        # current, trial, line-search probe
        self._points = tuple(Point(n, domain.halo) for _ in range(3))
        # r and the previous r, z and d (rows swap roles), kept as views: the transform
        # recognises an array it has seen by identity (a new view costs it ~2 us to check)
        self._residuals = _rows(n)
        self._directions = _rows(n)
        self._moves = Moves(
            domain,
            fft,
            law,
            self._evaluator,
            self._active,
            self._walls,
            self._residuals,
            self._directions,
            self._load,
        )
        self._start = np.empty(n)
        self._scratch = np.empty(n)
        self._wall_scale = 0.0
        # transforms saved by StepProblem.recall, solves stopped by their edge watch,
        # line-search points beyond the bound's minimiser, solves ended detached
        self.count = dict.fromkeys(("recalled", "abandoned_solves", "detached_jumps"), 0)

    @classmethod
    def from_case(cls, case, domain, fft, law, half_q):
        """CG to the case's tolerance, residuals relative to sigma_a."""
        return cls(
            domain, fft, law, case.numerics.tolerance, case.numerics.max_iterations, case.sigma_a
        )

    @classmethod
    def describe(cls, numerics):
        return f"active-set CG to tolerance {numerics.tolerance:g}"

    def preload_solver(self):
        return self

    def solve(
        self, u, wall, ops, history, applied=None, edge_watch: EdgeWatch | None = None, watch=None
    ) -> SolveResult:
        """Collective: relax ``u`` (this rank's block of the start, length) in place to the
        equilibrium of the step (module docstring; the arguments as in
        :meth:`EquilibriumSolver.solve`). With ``edge_watch`` the solve is abandoned once the
        iterate's contact edges (first and last node on the wall) are farther than its
        ``limit`` from the given edges: the adaptive step control would reject that step
        whatever the rest of the descent does (a step beyond the fold of the attached branch
        otherwise descends through the whole snap-off only to be repeated shorter). The
        ``watch``'s stop flag rides on the iteration's reduction of the residual.
        """
        watch = NO_WATCH if watch is None else watch
        linear, on_wall_tolerance, first = self._begin(u, wall, ops, history, applied)
        it = _Descent(*self._points, pending=first)
        while True:
            r, lo, hi, count, n_free, on_s, pressed_s, local_max, joined = self._residual(
                it, on_wall_tolerance
            )
            interacting = 1.0 if hi > lo else 0.0  # a node of this rank within the range
            if edge_watch is None:
                r_max, joined_any, interacting, stop = self.domain.maxes(
                    local_max, 1.0 if joined else 0.0, interacting, watch.flag()
                )
            else:  # the iterate's contact edges in the same reduction
                left, right = self._active.contact_edges()
                r_max, joined_any, interacting, stop, minus_left, right = self.domain.maxes(
                    local_max, 1.0 if joined else 0.0, interacting, watch.flag(), -left, right
                )
                if not stop and self._active.strayed(edge_watch, -minus_left, right):
                    self.count["abandoned_solves"] += 1
                    return self._stopped(it, r_max, "abandoned")
            if stop:
                return self._stopped(it, r_max, "interrupted")
            it.residual = r_max / self.traction_scale
            watch.beat(it.iteration, it.residual)
            if it.residual <= self.tolerance or it.iteration >= self.max_iterations:
                break
            if not interacting and not it.jump_tried:
                it.jump_tried = True
                if self._detached_minimum(u, wall, ops, linear, it):
                    it.first_pass = True  # a fresh descent from u*, if one is needed at all
                    continue
            if it.first_pass or joined_any > 0.0:
                it.restart = True
            it.first_pass = False
            self._active.remember(lo, hi, pressed_s)
            d, rd, rz, entry = self._moves.direction(
                it, r, ops, lo, hi, count, n_free, on_s, pressed_s
            )
            self._moves.step(it, u, wall, r, d, rd, entry, ops, linear, self._wall_scale)
            it.ir = 1 - it.ir
            it.rz_old = rz
            it.iteration += 1
        # Put the nodes counted as contact exactly on the wall, so that every later use of
        # the state (reaction, load, contact width, predictor) sees the same contact set.
        np.copyto(u[lo:hi], wall[lo:hi], where=self._active.on_wall[: hi - lo])
        self._points = (it.cur, it.trial, it.probe)
        # K u from the running load, without a transform: the steps added exact K d, and
        # the nodes just put on the wall moved by round-off of the wall (at most 1e-14 of
        # its magnitude), which changes K u by about 1e-9 of the traction scale (measured)
        np.subtract(self._load, linear, out=self._k_u)
        return SolveResult(
            iterations=it.iteration,
            residual=it.residual,
            converged=it.residual <= self.tolerance,
            mean_traction=it.mu,
        )

    def _stopped(self, it, r_max, why):
        """The result of a solve stopped early (``why``: abandoned or interrupted)."""
        return SolveResult(
            iterations=it.iteration,
            residual=r_max / self.traction_scale,
            converged=False,
            mean_traction=it.mu,
            abandoned=True,
            interrupted=why == "interrupted",
        )

    def _begin(self, u, wall, ops, history, applied):
        """Collective: the feasible start, K u and the running load K u + H - p_applied.

        Returns the linear term H - p_applied, the gap at or below which a node counts as
        on the wall (round-off of sums of steps) and the first residual's sums (in row 0 of
        the residuals, :meth:`_residual`'s pending values).
        """
        self._wall_scale = project_in_place(self.domain, u, wall, self._start)
        linear = history if applied is None else np.subtract(history, applied, out=self._linear)
        k_u = self.problem.recalled(u, ops.stiffness)
        if k_u is not None:
            self.count["recalled"] += 1
        else:
            k_u = self.fft.apply_diagonal(u, ops.stiffness, self._k_u)
        on_wall_tolerance = 1e-14 * self._wall_scale
        # Nodes that matter for the wall and the law: gap < level (PointEvaluator).
        level = max(
            self.law.dmax if self.law.sigma_a > 0.0 else 0.0,
            np.nextafter(on_wall_tolerance, np.inf),
        )
        self._evaluator.level = level
        cur, r = self._points[0], self._residuals[0]
        total, scan = kernels.start_point(u, wall, k_u, linear, self._load, cur.gap, r, level)
        self.problem.forget()  # the kept vector lives within one step (k_u was read above)
        self._evaluator.evaluate_scanned(cur, scan)
        first = kernels.residual_span(r, cur.traction, *cur.traction_span, *cur.near, total)
        self._active.begin()
        return linear, on_wall_tolerance, first

    def _detached_minimum(self, u, wall, ops, linear, it):
        """Collective: jump to the detached equilibrium when the iterate is detached.

        Where no node is within the interaction range the energy is the convex quadratic
        1/2 u.K u + (H - p_applied).u, minimised by u* = -K^-1 (H - p_applied) (zero mean: K^-1
        has no q = 0 mode). When both the iterate and u* lie in the convex set of detached
        displacements, u* is the minimum of the basin the descent is in, reached without
        the hundreds of iterations of the snap-off's soft modes. Returns True (u = u*) or
        False (one FFT pair spent).
        """
        target = self._start
        self.fft.apply_diagonal(linear, ops.compliance, target)
        np.negative(target, out=target)
        gap = self._scratch
        np.subtract(wall, target, out=gap)
        smallest = self.domain.min(gap.min() if self._n else np.inf)
        if not smallest > self._evaluator.level:
            return False
        np.copyto(u, target)
        cur = it.cur
        np.copyto(cur.gap, gap)
        self.fft.apply_diagonal(u, ops.stiffness, self._k_u)
        np.add(self._k_u, linear, out=self._load)
        cur.ready = False
        it.pending = None
        self.count["detached_jumps"] += 1
        return True

    def _residual(self, it, on_wall_tolerance):
        """Collective: the residual r (row ir) with its pressed nodes set to mu.

        r = cohesive + applied - elastic - history traction on every node (the cohesive part
        is zero outside its span). The projected residual is r - mu on the free nodes and 0
        on the pressed ones; it is kept as r with the pressed nodes set to mu: K^-1 ignores
        the uniform part, and so do the dot products with the zero-mean z and d.
        """
        cur = it.cur
        r = self._residuals[it.ir]
        if it.pending is None:
            if not cur.ready:
                self._evaluator.evaluate(cur)
            total, high, low = kernels.residual(
                self._load, cur.traction, *cur.traction_span, *cur.near, r
            )
        else:  # formed in the pass that took the last step (Moves.step)
            (total, high, low), it.pending = it.pending, None
        lo, hi = cur.near
        it.mu, count, n_free, on_s, pressed_s = self._active.multiplier(
            r, total, cur.gap, lo, hi, on_wall_tolerance, it.mu
        )
        span_high, span_low, joined = self._active.settle(r, lo, hi, pressed_s, it.mu)
        local_max = (
            max(max(high, span_high) - it.mu, it.mu - min(low, span_low)) if self._n else 0.0
        )
        return r, lo, hi, count, n_free, on_s, pressed_s, local_max, joined

    # --- the rest of the solver interface ------------------------------------------------
    def elastic_traction(self):
        """K u of the last solve's displacement (stress; a view, valid until the next solve)."""
        return self._k_u

    def counters(self) -> dict:
        """The work counted (module docstring, :mod:`.wall_steps`, :mod:`..active_set`)."""
        walls = self._walls
        return {
            "projections": walls.projections,
            "cut_steps": walls.cut_steps,
            "residual_steps": walls.residual_steps,
            "held_steps": self._active.held_steps,
            "extensions": self._moves.extensions,
            **self.count,
        }

    def restore_counters(self, saved):
        walls = self._walls
        walls.projections, walls.cut_steps, walls.residual_steps = (
            int(saved[k]) for k in ("projections", "cut_steps", "residual_steps")
        )
        self._active.held_steps = int(saved["held_steps"])
        self._moves.extensions = int(saved["extensions"])
        self.count = {key: int(saved[key]) for key in self.count}
