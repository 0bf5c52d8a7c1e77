"""Equilibrium of one time step: constrained, preconditioned conjugate gradients.

Each time step (physics.md, "Interface") minimises over the surface displacement u

    E(u) = 1/2 u.K u + (H - p_applied).u + sum_e Phi_e(h + u_z - u)   (per unit length)

subject to the hard wall u <= h + u_z (gap >= 0) and zero mean displacement (the q = 0 mode
of u is held at zero; its traction, the load, is the Lagrange multiplier). K is diagonal in
Fourier space, k_q = (|q|/2) Eeff, and H is the SLS history traction (see ``material``).

Method. Polonsky-Keer-type active-set CG in the displacement, preconditioned by the Green's
function K^-1 (so the elastic part is the identity and the iteration count does not grow
like sqrt(n_x) as for plain CG or damped dynamics). Nodes on the wall that are pushed into it
form the active set; the search space is the free nodes with zero mean. CG restarts whenever
the active set changes (Polonsky and Keer, Wear 231 (1999) 206).

Path following. The Dugdale energy is concave in u (the mean of the convex ramp
max(dmax - g, 0) over each element, times -sigma_a), so the quadratic model built from K and
the linearised adhesion is an upper bound of E: every step of length in (0, 2 alpha*) along a
CG direction, alpha* the bound's minimiser, lowers E. The same holds from every point of the
line with its own slope, so the line search goes on beyond alpha* while the energy provably
falls (:meth:`ConstrainedCG._line_search`; without it the step was capped at 1.9 alpha* in
half of all iterations, and the iteration count fell 2.4-2.9x with it). Steps that would
cross the wall are either projected (accepted only if E drops) or cut at the first contact
(inside that interval; when the CG direction presses on a node already on the wall, the step
is taken along the projected residual instead, whose first contact is at a positive
length). Every
iteration lowers E: the solver goes downhill from its start, the previous step's equilibrium
or a guess of lower energy, and ends in the local minimum of that basin, the physical branch.

Cost per iteration. Two FFT pairs, both intrinsic: the preconditioner K^-1 r and K d. Between
them the direction is projected in real space (pressed nodes zeroed, mean removed, nodes the
direction pushes into the wall held), so K d is not K K^-1 r = r and needs its own pair
whenever a node is pressed, i.e. while there is contact. One more pair per projected
backtracking trial and for the residual direction when a step reaches the wall (rare: 2
projections in 100 steps of the default case). Per solve, one pair at the end (exact K u of
the solution) and one at the start unless the driver's predictor evaluated the start
(:meth:`ConstrainedCG._recall`). K u is updated incrementally. The elementwise work is about
15 passes over the block: r = t - (K u + H - p_applied), its sum and extrema, the mean of z,
one pass for the three CG dot products (a 2 x 2 matmul of the stacked r, r_old and z, d_old),
one axpy for d, d.Kd, the trial point's gaps, the axpy on u and the one on K u + H -
p_applied, plus three passes (the point's gaps and its span) per line-search extension.
Everything about the wall, the active set and the cohesive law works on the span of nodes
with gap < dmax (the contact and its cohesive zone, a few % of the cell), and the traction
of a trial point that is taken is not evaluated again. Buffers are swapped, not copied, and
no array of the block's size is allocated in a CG iteration or a line-search extension.
The rare projected step evaluates the energy, whose cohesive part makes temporaries of the
interaction span's size (about 45 bytes per node with gap < dmax): ``tracemalloc`` peaks of
164, 324 and 645 KiB in a solve of the default case at 2^16, 2^17 and 2^18 nodes (20 steps
in; 1-3 projections; 3.7k, 7.3k and 14.6k nodes within dmax), against blocks of 0.5-2 MiB.
Measured with ``scripts/bench_iteration.py --n 17 --steps 20`` (default case, one rank, on a
2-core machine shared with other jobs, load average 8-10; two runs of each version,
alternated): 4.0-4.2 ms per iteration = 4.6-4.9 bare pairs of time (a bare pair:
``apply_diagonal`` timed in the same run, 0.86-0.88 ms), 2.18 pairs per iteration, of which
the FFTs take 55 % (in the solve a pair costs 1.15 bare pairs: its data come from memory,
not cache) and the elementwise passes and the interpreter about 2 bare pairs; before this
layout 6.2-6.8 ms = 7.8 bare pairs, 2.32 pairs per iteration, FFTs 37 %. With the line
search (same script, load average 1.2): 3.77 ms = 4.86 bare pairs, 2.21 pairs per iteration.

Parallel layout. Every real-space vector is this rank's block of nodes
(:class:`hpcgfmd.domain.Domain`); the transforms inside ``fft.apply_diagonal`` are the only
bulk communication. Each iteration adds about eight ``Allreduce`` calls of one to three
doubles (dot products, counts, the residual's maximum with the restart test, the wall tests
with the secant's slope) and one ghost-node exchange per traction evaluation (the trial
point and the secant point); every branch is decided on those reduced values, so all ranks
take it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg.blas import daxpy

from .domain import Domain
from .interface import DugdaleMaugis, true_span
from .material import StepOperators


@dataclass
class SolveResult:
    """Outcome of one equilibrium solve.

    Attributes
    ----------
    iterations : int
        CG iterations done.
    residual : float
        max |projected residual traction| / traction scale at exit (dimensionless).
    converged : bool
        residual <= tolerance.
    mean_traction : float
        Lagrange multiplier of zero mean displacement: the uniform traction (stress units).
    abandoned : bool
        The iterate's contact edges moved beyond the caller's ``edge_watch`` limit: the
        solve stopped early, ``u`` is not an equilibrium.
    """

    iterations: int
    residual: float
    converged: bool
    mean_traction: float
    abandoned: bool = False


@dataclass
class EdgeWatch:
    """Contact edges a solve may not leave by more than ``limit`` (see ``stepping``).

    Attributes
    ----------
    left, right : float
        Contact edges of the previous step (length).
    limit : float
        Largest edge motion the caller will accept (length); beyond it the solve is
        abandoned.
    """

    left: float
    right: float
    limit: float


def project_feasible(domain, u, wall, out, work=None, wall_scale=None):
    """Collective: closest displacement with zero mean and u <= wall of the form min(u - c, wall).

    Finds the shift c with sum(min(u - c, wall)) = 0 by Newton's method on this concave,
    decreasing, piecewise-linear function of c (finite, monotone convergence).

    Parameters
    ----------
    domain : Domain
    u, wall : ndarray, shape (local_n,)
        This rank's blocks of the displacement and of the wall (length).
    out : ndarray, shape (local_n,)
        Result (may not be ``u``).
    work : ndarray of bool, shape (local_n,), optional
        Scratch mask (allocated when not given).
    wall_scale : float, optional
        ``domain.max_abs(wall)`` when the caller has it (saves a reduction).
    """
    c = 0.0
    if wall_scale is None:
        wall_scale = domain.max_abs(wall)
    wall_scale += 1e-300
    free = np.empty(u.shape, dtype=bool) if work is None else work
    for _ in range(100):
        np.subtract(u, c, out=out)
        np.less(out, wall, out=free)
        np.minimum(out, wall, out=out)
        total, count = domain.sums(out.sum(), np.count_nonzero(free))
        if count == 0:
            raise FloatingPointError("the wall leaves no free node for zero mean displacement")
        step = total / count
        if abs(step) <= 1e-15 * wall_scale:
            break
        c += step
    return out


MAX_EXTENSIONS = 8  # line-search points per iteration beyond the trial point (_line_search)


class _Point:
    """Gaps of one displacement (ghost node each side), its cohesive traction and spans.

    ``near`` is the node range [lo, hi) holding every node with gap < level (the zone of
    interaction, which contains every node on or below the wall); ``traction_span`` the
    range outside which ``traction`` is zero; ``ready`` says both match ``gap``.
    """

    __slots__ = ("gap_ext", "gap", "traction", "traction_span", "near", "ready")

    def __init__(self, n):
        self.gap_ext = np.zeros(n + 2)
        self.gap = self.gap_ext[1:-1]
        self.traction = np.zeros(n)
        self.traction_span = (0, 0)
        self.near = (0, 0)
        self.ready = False


class ConstrainedCG:
    """Active-set preconditioned CG for one step's equilibrium (see module docstring).

    Parameters
    ----------
    domain : Domain
        This rank's block of nodes and the collectives.
    fft : SerialRealFFT or TransposedRealFFT
        Planned transforms of the grid (same block layout as ``domain``).
    law : DugdaleMaugis
        Cohesive law.
    tolerance : float
        Convergence when max |projected residual| <= tolerance * traction_scale.
    max_iterations : int
        Iteration cap per solve.
    traction_scale : float
        Traction used to make the residual dimensionless (stress units).
    """

    def __init__(self, domain: Domain, fft, law: DugdaleMaugis, tolerance: float,
                 max_iterations: int, traction_scale: float):
        self.domain = domain
        self.fft = fft
        self.law = law
        self.tolerance = tolerance
        self.max_iterations = max_iterations
        self.traction_scale = traction_scale
        n = domain.local_n
        self._n = n
        # Every buffer of a solve is made here: an iteration allocates nothing of size n.
        self._k_u = np.empty(n)       # K u; exact at the end of a solve (elastic_traction)
        self._load = np.empty(n)      # K u + H - p_applied during a solve (updated by steps)
        self._linear = np.empty(n)    # H - p_applied when a traction is applied
        self._k_d = np.empty(n)
        # The current point, the trial point and a probe for the line search's extensions.
        self._points = (_Point(n), _Point(n), _Point(n))
        self._residuals = np.zeros((2, n))   # r and the previous r (rows swap roles)
        self._directions = np.zeros((2, n))  # z and d (rows swap roles)
        self._dots = np.empty((2, 2))
        self._trial = np.empty(n)
        self._scratch = np.empty(n)
        self._projected = np.empty(n)
        self._k_projected = np.empty(n)
        self._gap_energy_ext = np.empty(n + 2)
        self._work = np.empty((3, n + 2), dtype=bool)
        self._near = np.empty(n + 2, dtype=bool)
        self._mask = np.empty(n, dtype=bool)
        # Masks over the near span of the current point (views of their first entries).
        self._on_wall = np.empty(n, dtype=bool)
        self._pressed = np.empty(n, dtype=bool)
        self._pushed = np.empty(n, dtype=bool)
        self._held = np.empty(n, dtype=bool)
        self._excluded = np.empty(n, dtype=bool)
        self._pressed_before = np.zeros(n, dtype=bool)  # active set of the last iteration
        # The lowest-energy vector passed to energy() since the last solve began (the
        # driver's start of the next solve) and its K: see _recall.
        self._guess = np.empty(n)
        self._k_guess = np.empty(n)
        self._guess_stiffness = None
        self._guess_energy = np.inf
        self._spectrum_mask = None
        self._wall_scale = 0.0
        self._level = 0.0
        # Statistics: projections accepted (each lowered the energy), steps cut at the first
        # wall contact.
        self.projections = 0
        self.cut_steps = 0
        self.residual_steps = 0  # cut steps along the residual (d pressed on the wall)
        self.held_steps = 0      # iterations whose direction held on-wall nodes
        self.recalled = 0        # transforms saved by _recall
        self.abandoned = 0       # solves stopped by their edge watch
        self.extensions = 0      # line-search points beyond the bound's minimiser

    def solve(self, u, wall, ops: StepOperators, history, applied=None,
              edge_watch: EdgeWatch | None = None) -> SolveResult:
        """Collective: relax ``u`` in place to the equilibrium of the step (module docstring).

        Parameters
        ----------
        u : ndarray, shape (local_n,)
            This rank's block of the start (previous step's displacement), overwritten by
            the solution (length).
        wall : ndarray, shape (local_n,)
            h(x) + u_z: the largest admissible displacement (length).
        ops : StepOperators
            Stiffness and preconditioner of the step.
        history : ndarray, shape (local_n,)
            SLS history traction H with zero mean (stress).
        applied : ndarray, optional
            Prescribed external traction on the surface, positive upward (stress); tests only.
        edge_watch : EdgeWatch, optional
            Abandon the solve once the iterate's contact edges (first and last node on the
            wall) are farther than ``limit`` from the given edges: the caller (the adaptive
            step control) would reject that step whatever the rest of the descent does. A
            step beyond the fold of the attached branch otherwise descends through the whole
            snap-off (thousands of iterations at 2^17) only to be repeated shorter.
        """
        fft, dom, n = self.fft, self.domain, self._n
        adhesive = self.law.sigma_a > 0.0
        self._wall_scale = dom.max_abs(wall)
        project_feasible(dom, u, wall, self._trial, work=self._mask,
                         wall_scale=self._wall_scale)
        np.copyto(u, self._trial)
        linear = history if applied is None else np.subtract(history, applied, out=self._linear)
        k_u, load = self._k_u, self._load
        if self._recall(u, ops.stiffness, k_u):
            self.recalled += 1
        else:
            fft.apply_diagonal(u, ops.stiffness, k_u)
        self._guess_energy = np.inf  # forget the guess: the cache lives within one step
        np.add(k_u, linear, out=load)
        # Gaps within round-off of the wall count as contact (left by sums of steps).
        on_wall_tolerance = 1e-14 * self._wall_scale
        # Nodes that matter for the wall and the law: gap < level (see _evaluate).
        self._level = max(self.law.dmax if adhesive else 0.0,
                          np.nextafter(on_wall_tolerance, np.inf))
        # The current and the trial point (gaps and tractions), swapped when the trial is
        # taken; u is the current point's displacement.
        cur, trial, probe = self._points
        np.subtract(wall, u, out=cur.gap)
        cur.ready = False
        R, Z, dots = self._residuals, self._directions, self._dots
        ir, iz = 0, 0  # rows of r and z in R and Z; r_old and d are the other rows
        k_d, on_wall, pressed_before = self._k_d, self._on_wall, self._pressed_before
        pressed_before[:] = False
        before = (0, 0)
        restart = True
        first_pass = True
        rz_old = 1.0
        residual = np.inf
        mu = 0.0
        iteration = 0
        while True:
            if not cur.ready:
                self._evaluate(cur)
            lo, hi = cur.near
            p, q = cur.traction_span
            # Residual traction on every node: cohesive + applied - elastic - history
            # (the cohesive part is zero outside its span).
            r, r_old = R[ir], R[1 - ir]
            np.negative(load, out=r)
            r[p:q] += cur.traction[p:q]
            # Active set: nodes on the wall pushed into it once the uniform traction mu (the
            # multiplier of zero mean displacement) is removed; mu depends on the set, so
            # iterate the pair to a fixed point (2-3 passes). Only the near span [lo, hi)
            # holds on-wall nodes: the sum over the free nodes is the total minus the
            # pressed ones.
            on_s, r_s = on_wall[:hi - lo], r[lo:hi]
            np.less_equal(cur.gap[lo:hi], on_wall_tolerance, out=on_s)
            pressed_s = self._pressed[:hi - lo]
            total = r.sum()
            for _ in range(10):
                np.greater(r_s, mu, out=pressed_s)
                pressed_s &= on_s
                count = np.count_nonzero(pressed_s)
                r_free, n_free = dom.sums(total - r_s.sum(where=pressed_s) if count else total,
                                          n - count)
                mu_new = r_free / n_free
                if mu_new == mu:
                    break
                mu = mu_new
            # The projected residual is r - mu on the free nodes, 0 on the pressed ones. It
            # is kept as r_raw = (projected residual) + mu, i.e. r with the pressed nodes set
            # to mu: K^-1 ignores the uniform part, and so do the dot products with the
            # zero-mean vectors z and d.
            if count:
                np.copyto(r_s, mu, where=pressed_s)
            # Restart CG when nodes join the active set (the search space shrinks). Nodes that
            # leave it only enlarge the space: the old direction stays admissible (zero on
            # the released nodes), so conjugacy is kept, which matters when the contact edge
            # recedes by several nodes per step. (One reduction with the residual's maximum.)
            joined = self._pushed[:hi - lo]
            np.greater(pressed_s, pressed_before[lo:hi], out=joined)
            local_max = max(r.max() - mu, mu - r.min()) if n else 0.0
            if edge_watch is None:
                r_max, joined_any = dom.maxes(local_max, 1.0 if joined.any() else 0.0)
            else:  # the iterate's contact edges in the same reduction
                left, right = self._contact_nodes(on_s, lo)
                r_max, joined_any, minus_left, right = dom.maxes(
                    local_max, 1.0 if joined.any() else 0.0, -left, right)
                if self._strayed(edge_watch, -minus_left, right):
                    residual = r_max / self.traction_scale
                    self.abandoned += 1
                    return SolveResult(iterations=iteration, residual=residual,
                                       converged=False, mean_traction=mu, abandoned=True)
            residual = r_max / self.traction_scale
            if residual <= self.tolerance or iteration >= self.max_iterations:
                break
            if first_pass or joined_any > 0.0:
                restart = True
            first_pass = False
            pressed_before[before[0]:before[1]] = False
            pressed_before[lo:hi] = pressed_s
            before = (lo, hi)
            # Preconditioned residual, projected on the free nodes with zero mean (z has
            # zero sum: K^-1 has no q = 0 mode).
            z = Z[iz]
            fft.apply_diagonal(r, ops.compliance, z)
            z_s = z[lo:hi]
            z -= dom.sum(-z_s.sum(where=pressed_s) if count else 0.0) / n_free
            if count:
                np.copyto(z_s, 0.0, where=pressed_s)
            # Direction d = z + beta d_old (Polak-Ribiere+), formed in z's row by one axpy
            # once r.d = r.z + beta r.d_old says it descends; else d = z (steepest descent).
            if restart:
                rz = rd = dom.sum(r @ z)
            else:
                np.matmul(R, Z.T, out=dots)  # r.z, r.d_old, r_old.z in one pass
                rz, r_old_z, r_d = dom.sums(dots[ir, iz], dots[1 - ir, iz], dots[ir, 1 - iz])
                beta = max(0.0, (rz - r_old_z) / rz_old)
                rd = beta * r_d + rz
                if rd <= 0.0 or beta == 0.0:  # not a descent direction any more: steepest
                    rd = rz
                elif n:
                    daxpy(Z[1 - iz], z, a=beta)
            iz = 1 - iz
            d = z
            # Nodes on the wall that the (smoothed) direction pushes into it cannot move: hold
            # them this iteration and keep the zero mean on the others (projected direction).
            d_s = d[lo:hi]
            pushed_s = self._pushed[:hi - lo]
            np.greater(d_s, 0.0, out=pushed_s)
            pushed_s &= on_s
            if dom.any(pushed_s):
                rd = self._hold(r, mu, d, d_s, pushed_s, pressed_s, on_s)
            fft.apply_diagonal(d, ops.stiffness, k_d)
            d_kd = dom.dot(d, k_d)
            alpha = rd / d_kd  # minimiser of the quadratic upper bound
            # Trial point u + alpha d: only its gaps (u follows if it is taken).
            np.multiply(d, -alpha, out=trial.gap)
            trial.gap += cur.gap
            below = self._evaluate(trial) < 0.0  # trial point beyond the wall
            if adhesive:
                # phi'(alpha) = -(t(u + alpha d) - K(u + alpha d) - H + applied) . d
                #             = -((t(u + alpha d) - t(u)) . d + r.d - alpha d.K d)
                # (r.d = (t(u) - K u - H + applied) . d, mean d = 0): two dots on the spans
                # of the tractions.
                a, b = trial.traction_span
                t_trial_d, t_cur_d, reaching = dom.sums(
                    trial.traction[a:b] @ d[a:b], cur.traction[p:q] @ d[p:q],
                    1.0 if below else 0.0)
            else:
                reaching = dom.max(1.0 if below else 0.0)
            if reaching == 0.0:
                step = alpha
                if adhesive:  # the trial point becomes the line search's point
                    step, trial, probe = self._line_search(
                        cur, trial, probe, d, alpha, rd, d_kd, rd - t_cur_d, t_trial_d)
                if n:
                    daxpy(d, u, a=step)
                    daxpy(k_d, load, a=step)
                cur, trial = trial, cur
                restart = False
            else:
                self._constrained_step(u, cur, wall, r, mu, d, k_d, alpha, ops, linear)
                restart = True
            ir = 1 - ir
            rz_old = rz
            iteration += 1
        # Put the nodes counted as contact exactly on the wall, so that every later use of
        # the state (reaction, load, contact width, predictor) sees the same contact set.
        np.copyto(u[lo:hi], wall[lo:hi], where=on_wall[:hi - lo])
        self._points = (cur, trial, probe)
        fft.apply_diagonal(u, ops.stiffness, k_u)
        return SolveResult(iterations=iteration, residual=residual,
                           converged=residual <= self.tolerance, mean_traction=mu)

    def _contact_nodes(self, on_s, lo):
        """Local: positions of this rank's first and last node on the wall (+inf, -inf if none).

        ``on_s`` is the on-wall mask of the near span starting at node ``lo``; argmax finds
        the first True without allocating.
        """
        if on_s.size == 0 or not on_s.any():
            return math.inf, -math.inf
        x = self.domain.x
        return float(x[lo + int(on_s.argmax())]), float(x[lo + on_s.size - 1
                                                          - int(on_s[::-1].argmax())])

    def _strayed(self, watch, left, right):
        """True when an edge of the iterate's contact is farther than ``watch.limit`` away.

        The iterate's edges are nodes, the watched ones interpolated between nodes: two node
        spacings are allowed for the difference. An iterate without contact is no verdict: the
        start of a step (the wall has risen) and the iterates between a projection and the
        next contact have none.
        """
        if not (math.isfinite(left) and math.isfinite(right)):
            return False
        motion = max(abs(left - watch.left), abs(right - watch.right))
        return motion > watch.limit + 2.0 * self.domain.dx

    def _evaluate(self, point):
        """Collective (one ghost exchange): spans and cohesive traction of ``point.gap``.

        One comparison pass finds the node range ``near`` holding every node with
        gap < level (level = dmax, or just above the on-wall tolerance without adhesion);
        the law is evaluated on that range and one node more each side (a straddling
        element reaches them), the ghosts included, and the rest of the traction buffer is
        zeroed where it was not zero. Returns this rank's smallest gap on ``near`` (+inf if
        empty): negative when the point is beyond the wall.
        """
        m = self._n
        self.domain.fill_halo(point.gap_ext)
        near = self._near
        np.less(point.gap_ext, self._level, out=near)
        span = true_span(near) if m else None
        if span is None:
            lo = hi = p = q = 0
        else:  # near[e] is node e - 1
            lo, hi = max(span[0] - 1, 0), min(span[1], m)
            p, q = max(span[0] - 2, 0), min(span[1] + 1, m)
        point.near = (lo, hi)
        if self.law.sigma_a > 0.0:
            t = point.traction
            po, qo = point.traction_span
            if p < q:
                t[po:max(po, min(qo, p))] = 0.0
                t[min(qo, max(q, po)):qo] = 0.0
                self.law.traction(point.gap_ext[p:q + 2], out=t[p:q],
                                  work=self._work[:, :q - p + 2])
            else:
                t[po:qo] = 0.0
            point.traction_span = (p, q)
        point.ready = True
        return point.gap[lo:hi].min() if hi > lo else np.inf

    def _hold(self, r, mu, d, d_s, pushed_s, pressed_s, on_s):
        """Hold the on-wall nodes d pushes into the wall (d_s, ... on the near span).

        Returns r.d of the projected direction; d becomes the projected residual
        r - mu (zero on the pressed nodes) when that does not descend.
        """
        dom, n = self.domain, self._n
        self.held_steps += 1
        held_s = self._held[:d_s.size]
        excluded_s = self._excluded[:d_s.size]
        held_s[:] = False
        while True:  # removing the mean can push another node in
            held_s |= pushed_s
            np.logical_or(held_s, pressed_s, out=excluded_s)
            excluded = np.count_nonzero(excluded_s)
            d_keep, n_keep = dom.sums(d.sum() - d_s.sum(where=excluded_s), n - excluded)
            if n_keep == 0:  # every free node held: fall back to the residual below
                d[:] = 0.0
                break
            d -= d_keep / n_keep
            np.copyto(d_s, 0.0, where=excluded_s)
            np.greater(d_s, 0.0, out=pushed_s)
            pushed_s &= on_s
            if not dom.any(pushed_s):
                break
        rd = dom.dot(r, d)
        if rd <= 0.0:  # the projected residual lifts on-wall nodes off: descent
            np.subtract(r, mu, out=d)
            rd = dom.dot(d, d)
        return rd

    def _constrained_step(self, u, point, wall, r, mu, d, k_d, alpha, ops, linear):
        """A step u + alpha d that reaches the wall, taken so that the energy decreases.

        First choice: the Euclidean projection (zero mean, gap >= 0) of u + a d, which sets
        many nodes on the wall at once, accepted for the first a in alpha, alpha/8, ...,
        alpha/8^5 that lowers the energy (projected backtracking; measured: at the first
        retraction step a = alpha/512 was needed, 2451 nodes being pushed in by the full step).
        Otherwise the step is cut
        where the first node touches the wall: that length lies inside (0, alpha], where the
        quadratic upper bound guarantees descent. All of them restart CG. ``point.gap`` is
        wall - u; u and the running K u + H - p_applied (``_load``) are updated in place,
        the point's gaps then recomputed; r - mu is the projected residual.
        """
        dom, fft, load, gap = self.domain, self.fft, self._load, point.gap
        k_u = np.subtract(load, linear, out=self._scratch)
        energy = self._energy(u, k_u, wall, linear)
        spare = self._trial
        for trial in range(6):  # projected backtracking along the arc P(u + a d)
            step = alpha * 0.125**trial  # a full CG step can push thousands of nodes in
            np.multiply(d, step, out=spare)
            spare += u
            project_feasible(dom, spare, wall, self._projected, work=self._mask,
                             wall_scale=self._wall_scale)
            fft.apply_diagonal(self._projected, ops.stiffness, self._k_projected)
            if self._energy(self._projected, self._k_projected, wall, linear) < energy:
                np.copyto(u, self._projected)
                np.subtract(wall, u, out=gap)
                point.ready = False
                np.add(self._k_projected, linear, out=load)
                self.projections += 1
                return
        cut = self._first_contact(gap, d)
        if cut <= 0.0:
            # d presses on a node already on the wall (held nodes are excluded from d, so only
            # round-off gets here). The projected residual r moves every free node along its
            # own force, so on-wall nodes move away and its first contact is at a positive
            # length: a descent step.
            np.subtract(r, mu, out=d)
            fft.apply_diagonal(d, ops.stiffness, k_d)
            rd, d_kd = dom.sums(d @ d, d @ k_d)
            alpha = rd / d_kd
            cut = min(alpha, self._first_contact(gap, d))
            self.residual_steps += 1
        np.multiply(d, cut, out=spare)
        u += spare
        np.minimum(u, wall, out=u)  # the touching node lands on the wall exactly
        np.subtract(wall, u, out=gap)
        point.ready = False
        if self._n:
            daxpy(k_d, load, a=cut)
        self.cut_steps += 1

    def _first_contact(self, gap, d):
        """Collective: largest step length along d before a node reaches the wall (gap / d)."""
        rising, room = self._mask, self._projected
        np.greater(d, 0.0, out=rising)
        local = np.inf
        if rising.any():
            with np.errstate(divide="ignore", invalid="ignore"):
                np.divide(gap, d, out=room)
            np.logical_not(rising, out=rising)
            np.copyto(room, np.inf, where=rising)
            local = float(room.min())
        return self.domain.min(local)

    def _line_search(self, cur, trial, probe, d, alpha, rd, d_kd, c0, t_trial_d):
        """Collective: step length along d, as long as the energy provably keeps falling.

        phi(a) = E(u + a d) has phi'(a) = -(t(u + a d).d + c0 - a d.K d), c0 = r.d - t(u).d,
        and, the adhesion being concave, curvature at most d.K d. So from any point a_k with
        slope s_k < 0 the energy falls on (a_k, a_k + 2 |s_k| / d.K d): at the bound's
        minimiser alpha (the trial point, evaluated and off the wall) phi'(alpha) <= 0.
        The next length is the secant root of phi' through the last two points (the
        cohesive edge's negative stiffness makes it longer than alpha), capped at
        a_k + 1.9 |s_k| / d.K d to keep the descent. While the cap binds (the energy is
        still falling steeply: measured, half of all iterations, and nearly all near the
        snap-off, where the descent follows a soft mode) the capped point is evaluated and
        the search goes on from it: an extension costs the gaps, the cohesive traction on
        its span and one reduction, about 1/10 of an iteration with its two FFT pairs.
        A point beyond the wall ends the search at the point before. Every accepted length
        lowers E, so the solve still descends from its start (path following).

        Returns (length, point, spare): ``point`` holds the gaps and traction of
        u + length d; ``spare`` and ``cur`` are free buffers.
        """
        dom, n = self.domain, self._n
        a_prev, s_prev = 0.0, -rd
        a, s = alpha, -(t_trial_d + c0 - alpha * d_kd)
        best = trial
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
            np.multiply(d, -target, out=probe.gap)
            probe.gap += cur.gap
            below = self._evaluate(probe) < 0.0
            lo, hi = probe.traction_span
            t_probe_d, reaching = dom.sums(probe.traction[lo:hi] @ d[lo:hi] if n else 0.0,
                                           1.0 if below else 0.0)
            if reaching > 0.0:  # beyond the wall: stay at the last point
                break
            self.extensions += 1
            best, probe = probe, best
            a_prev, s_prev = a, s
            a, s = target, -(t_probe_d + c0 - target * d_kd)
            if not capped:  # the secant root: the minimum along d to its accuracy
                break
        return a, best, probe

    # --- K of vectors already transformed ------------------------------------------------
    @staticmethod
    def _keep(kept, stiffness):
        """Copy of ``stiffness`` in the buffer ``kept`` (reallocated only on a shape change)."""
        if kept is None or kept.shape != stiffness.shape:
            kept = np.empty_like(stiffness)
        np.copyto(kept, stiffness)
        return kept

    def _matches(self, u, kept_u, kept_stiffness, stiffness):
        """Local: u and the stiffness are bitwise the kept ones (a sample of u first)."""
        if kept_stiffness is None or kept_stiffness.shape != stiffness.shape:
            return False
        sample = max(1, self._n // 256)
        if np.not_equal(u[::sample], kept_u[::sample]).any():
            return False
        if np.not_equal(u, kept_u, out=self._mask).any():
            return False
        if self._spectrum_mask is None or self._spectrum_mask.shape != stiffness.shape:
            self._spectrum_mask = np.empty(stiffness.shape, dtype=bool)
        return not np.not_equal(kept_stiffness, stiffness, out=self._spectrum_mask).any()

    def _recall(self, u, stiffness, out):
        """Collective: True (and K u in ``out``) when K u is known for these exact bits.

        Kept: the lowest-energy vector passed to :meth:`energy` since the last solve began,
        with its K. The driver's predictor evaluates its guesses and the previous solution
        and starts the solve from the lowest, so the solve's first transform is saved. A
        match needs the same stiffness values and the same bits of u on every rank, so the
        result is bitwise the transform's. The cache is forgotten when a solve begins, so it
        never carries over from one step to the next: a run resumed from a checkpoint does
        the same transforms as an uninterrupted one. A miss costs a sample comparison, a
        match a full one (~0.1 pair).
        """
        same = (self._guess_energy < np.inf
                and self._matches(u, self._guess, self._guess_stiffness, stiffness))
        if self.domain.max(0.0 if same else 1.0) > 0.0:
            return False
        np.copyto(out, self._k_guess)
        return True

    # --- energies and tractions ----------------------------------------------------------
    def energy(self, u, wall, ops, history, applied=None):
        """Collective: energy of the step per unit length, divided by dx (one FFT pair).

        E/dx = 1/2 u.K u + (H - p_applied).u - sigma_a sum_e M_e (see the module docstring).
        The lowest-energy vector evaluated since the last solve began is kept with its K
        (:meth:`_recall`: the next solve starts from it without a transform).
        """
        k_u = self._k_projected
        self.fft.apply_diagonal(u, ops.stiffness, k_u)
        value = self.energy_with(u, k_u, wall, history, applied)
        if value < self._guess_energy:
            np.copyto(self._guess, u)
            np.copyto(self._k_guess, k_u)
            self._guess_stiffness = self._keep(self._guess_stiffness, ops.stiffness)
            self._guess_energy = value
        return value

    def energy_with(self, u, k_u, wall, history, applied=None):
        """Collective: energy (per unit length, divided by dx) of u with K u given."""
        value = 0.5 * float(u @ k_u) + float(history @ u)
        if applied is not None:
            value -= float(applied @ u)
        return self._interface_energy(u, wall, value)

    def _energy(self, u, k_u, wall, linear):
        """energy_with with the linear term H - p_applied given as one vector."""
        return self._interface_energy(u, wall, 0.5 * float(u @ k_u) + float(linear @ u))

    def _interface_energy(self, u, wall, value):
        gap_ext = self._gap_energy_ext
        np.subtract(wall, u, out=gap_ext[1:-1])
        self.domain.fill_halo(gap_ext)
        return self.domain.sum(value + self.law.energy(gap_ext, 1.0))

    def elastic_traction(self):
        """K u of the last solve's displacement (stress units; a view, valid until the next solve)."""
        return self._k_u

    def interface_traction(self, u, wall, history, mean_traction, out, applied=None):
        """Traction the indenter exerts on the surface at equilibrium (stress, upward positive).

        Cohesive traction on free nodes; on the wall the total reaction
        K u + H + mean_traction - applied, which balances the substrate.
        """
        gap_ext = self._gap_energy_ext
        gap = gap_ext[1:-1]
        np.subtract(wall, u, out=gap)
        self.domain.fill_halo(gap_ext)
        self.law.traction(gap_ext, out=out, work=self._work)
        contact = np.less_equal(gap, 0.0, out=self._mask)
        balance = np.add(self._k_u, history, out=self._scratch)
        balance += mean_traction
        if applied is not None:
            balance -= applied
        np.copyto(out, balance, where=contact)
        return out
