"""The moves of one active-set CG iteration: the search direction and the step along it
(:mod:`.solver` runs the iteration; its module docstring has the method)."""

from __future__ import annotations

from ...parallel.fft import aligned_empty
from .. import kernels
from ..points import PointEvaluator
from . import line_search


class Moves:
    """The direction and the step of a CG iteration on this rank's block.

    Parameters
    ----------
    domain : hpcgfmd.parallel.domain.Domain
    fft : hpcgfmd.parallel.real_fft.RealFFT
    law : hpcgfmd.model.interface.DugdaleMaugis
    evaluator : hpcgfmd.solvers.points.PointEvaluator
        The points along a line (their gaps, spans and cohesive traction).
    active : hpcgfmd.solvers.active_set.ActiveSet
    walls : hpcgfmd.solvers.cg.wall_steps.WallSteps
        The steps that reach the wall.
    residuals, directions : tuple of two ndarray
        The solve's rows of r and r_old, and of z and d_old (rows swap roles).
    load : ndarray
        The running K u + H - p_applied (the steps update it).

    Attributes
    ----------
    extensions : int
        Line-search points beyond the quadratic bound's minimiser.
    """

    def __init__(self, domain, fft, law, evaluator, active, walls, residuals, directions, load):
        self.domain, self.fft, self.law = domain, fft, law
        self._evaluator, self._active, self._walls = evaluator, active, walls
        self._residuals, self._directions, self._load = residuals, directions, load
        self._n = domain.local_n
        self._k_d = aligned_empty(self._n)  # (aligned: the transform writes it in place)
        self.extensions = 0

    def direction(self, it, r, ops, lo, hi, count, n_free, on_s, pressed_s):
        """Collective: the search direction d (row iz), r.d, r.z and the entry length of d.

        z = K^-1 r projected on the free nodes with zero mean (z has zero sum: K^-1 has no
        q = 0 mode); d = z + beta d_old (Polak-Ribiere+), formed in z's row by one axpy once
        r.d = r.z + beta r.d_old says it descends, else d = z. On-wall nodes that d pushes
        into the wall are held (:meth:`ActiveSet.hold`). The entry length (global): no node
        outside the near span [lo, hi) of the current point comes within the interaction
        range along d before it (:func:`kernels.entry_bound`), formed in the pass that
        forms d and reduced with the hold test.
        """
        dom, R, Z = self.domain, self._residuals, self._directions
        ir, iz = it.ir, it.iz
        z = Z[iz]
        gap, level, margin = it.cur.gap, self._evaluator.level, max(hi - lo, 16)
        self.fft.apply_diagonal(r, ops.compliance, z)
        shift = dom.sum(-kernels.masked_sum(z, lo, hi, pressed_s) if count else 0.0) / n_free
        rz, r_old_z, r_d, entry = kernels.project_direction(
            z, shift, lo, hi, pressed_s, r, R[1 - ir], Z[1 - iz], it.restart, gap, level, margin
        )
        if it.restart:
            rz = rd = dom.sum(rz)
        else:
            rz, r_old_z, r_d = dom.sums(rz, r_old_z, r_d)
            # r.z = 0 (z = K^-1 r, K^-1 positive definite: r = 0 on the free nodes) ends
            # the conjugacy: steepest descent
            beta = max(0.0, (rz - r_old_z) / it.rz_old) if it.rz_old > 0.0 else 0.0
            rd = beta * r_d + rz
            if rd <= 0.0 or beta == 0.0:  # not a descent direction any more: steepest
                rd = rz
                entry = kernels.entry_bound(z, gap, lo, hi, level, margin)
            else:
                entry = kernels.axpy_entry(z, Z[1 - iz], beta, gap, lo, hi, level, margin)
        it.iz = 1 - it.iz
        pushing = self._active.pushing(z, lo, hi, on_s)
        pushing, minus_entry = dom.maxes(1.0 if pushing else 0.0, -entry)
        if pushing > 0.0:
            rd = self._active.hold(r, it.mu, z, lo, hi, pressed_s, on_s)
            minus_entry = -dom.min(kernels.entry_bound(z, gap, lo, hi, level, margin))
        return z, rd, rz, -minus_entry

    def step(self, it, u, wall, r, d, rd, entry, ops, linear, wall_scale):
        """Collective: move u along d to the trial point, on by the line search, or to the wall.

        The trial point u + alpha d (alpha = r.d / d.K d, the quadratic bound's minimiser)
        is evaluated; with adhesion phi'(alpha) = -((t(u + alpha d) - t(u)).d + r.d - alpha
        d.K d) needs two dots on the spans of the tractions. Off the wall the line search
        goes on from it and the point reached becomes the current one; a trial point
        beyond the wall hands the step to :class:`WallSteps` (CG restarts). ``entry`` is
        the entry length of d (:meth:`direction`).
        """
        dom, k_d, cur, trial = self.domain, self._k_d, it.cur, it.trial
        adhesive = self.law.sigma_a > 0.0
        self.fft.apply_diagonal(d, ops.stiffness, k_d)
        lo, hi = cur.near
        d_kd = dom.sum(kernels.dot(d, k_d))
        alpha = rd / d_kd
        # Points along d are formed on a window around the near span while no node from
        # outside can enter the zone (length < entry), and only their gaps: u follows if
        # one is taken.
        margin = self._evaluator.grid_law.window_margin
        window = (max(lo - margin, 0), min(hi + margin, self._n), entry)
        smallest, t_trial_d = self._evaluator.evaluate_shifted(trial, cur.gap, d, alpha, window)
        below = smallest < 0.0
        if adhesive:
            p, q = cur.traction_span
            t_trial_d, t_cur_d, reaching = dom.sums(
                t_trial_d, kernels.span_dot(cur.traction, d, p, q), 1.0 if below else 0.0
            )
        else:
            reaching = dom.max(1.0 if below else 0.0)
        if reaching == 0.0:
            length, best, spare = alpha, trial, it.probe
            if adhesive:  # the trial point becomes the line search's point
                length, best, spare, taken = line_search.extend(
                    self._evaluator,
                    cur,
                    trial,
                    it.probe,
                    d,
                    alpha,
                    rd,
                    d_kd,
                    rd - t_cur_d,
                    t_trial_d,
                    window,
                )
                self.extensions += taken
            PointEvaluator.take(cur, best)
            it.trial, it.probe = best, spare
            it.pending = kernels.update_and_residual(
                u,
                d,
                self._load,
                k_d,
                cur.gap,
                length,
                cur.traction,
                *cur.traction_span,
                *cur.near,
                self._residuals[1 - it.ir],
            )
            it.restart = False
        else:
            self._walls.take(
                u, cur, wall, wall_scale, self._load, linear, r, it.mu, d, k_d, alpha, ops
            )
            it.restart = True
