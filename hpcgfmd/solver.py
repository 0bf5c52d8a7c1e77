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
CG direction, alpha* the bound's minimiser, lowers E. Steps that would cross the wall are
either projected (accepted only if E drops) or cut at the first contact (inside that
interval; when the CG direction presses on a node already on the wall, the step is taken
along the projected residual instead, whose first contact is at a positive length). Every
iteration lowers E: the solver goes downhill from its start, the previous step's equilibrium
or a guess of lower energy, and ends in the local minimum of that basin, the physical branch.

Cost per iteration: two FFT pairs (preconditioner and K d); one more when the direction is
projected off the wall, one per backtracking trial when a step reaches it. K u is updated
incrementally.

Parallel layout. Every real-space vector is this rank's block of nodes
(:class:`hpcgfmd.domain.Domain`); the transforms inside ``fft.apply_diagonal`` are the only
bulk communication. Each iteration adds about ten ``Allreduce`` calls of one to five doubles
(dot products, counts, the residual's maximum) and one ghost-node exchange for the
interface law; every branch is decided on those reduced values, so all ranks take it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .domain import Domain
from .interface import DugdaleMaugis
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
    """

    iterations: int
    residual: float
    converged: bool
    mean_traction: float


def project_feasible(domain, u, wall, out):
    """Collective: closest displacement with zero mean and u <= wall of the form min(u - c, wall).

    Finds the shift c with sum(min(u - c, wall)) = 0 by Newton's method on this concave,
    decreasing, piecewise-linear function of c (finite, monotone convergence).
    """
    c = 0.0
    wall_scale = domain.max_abs(wall) + 1e-300
    for _ in range(100):
        np.subtract(u, c, out=out)
        free = out < wall
        np.minimum(out, wall, out=out)
        total, count = domain.sums(out.sum(), np.count_nonzero(free))
        if count == 0:
            raise FloatingPointError("the wall leaves no free node for zero mean displacement")
        step = total / count
        if abs(step) <= 1e-15 * wall_scale:
            break
        c += step
    return out


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
        self._k_u = np.empty(n)
        self._k_d = np.empty(n)
        self._gap_ext = np.empty(n + 2)  # the block's gaps with a ghost node each side
        self._gap = self._gap_ext[1:-1]
        self._traction = np.empty(n)
        self._residual = np.empty(n)
        self._residual_old = np.zeros(n)
        self._z = np.empty(n)
        self._d = np.zeros(n)
        self._trial = np.empty(n)
        self._work = np.empty((3, n + 2), dtype=bool)
        self._free = np.empty(n, dtype=bool)
        self._free_previous = np.empty(n, dtype=bool)
        self._pressed = np.empty(n, dtype=bool)
        self._held = np.empty(n, dtype=bool)
        self._on_wall = np.empty(n, dtype=bool)
        self._free_weight = np.empty(n)
        self._scratch = np.empty(n)
        self._projected = np.empty(n)
        self._k_projected = np.empty(n)
        self._gap_energy_ext = np.empty(n + 2)
        # Statistics: projections accepted (each lowered the energy), steps cut at the first
        # wall contact.
        self.projections = 0
        self.cut_steps = 0
        self.residual_steps = 0  # cut steps along the residual (d pressed on the wall)

    def solve(self, u, wall, ops: StepOperators, history, applied=None) -> SolveResult:
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
        """
        fft, law, dom = self.fft, self.law, self.domain
        k_u, k_d, gap, traction = self._k_u, self._k_d, self._gap, self._traction
        r, r_old, z, d = self._residual, self._residual_old, self._z, self._d
        project_feasible(dom, u, wall, self._trial)
        u[:] = self._trial
        fft.apply_diagonal(u, ops.stiffness, k_u)
        restart = True
        first_pass = True
        # Gaps within round-off of the wall count as contact (left by sums of steps).
        on_wall_tolerance = 1e-14 * dom.max_abs(wall)
        rz_old = 1.0
        residual = np.inf
        mu = 0.0
        iteration = 0
        while True:
            # Residual traction on every node: cohesive + applied - elastic - history.
            np.subtract(wall, u, out=gap)
            dom.fill_halo(self._gap_ext)
            law.traction(self._gap_ext, out=traction, work=self._work)
            np.subtract(traction, k_u, out=r)
            r -= history
            if applied is not None:
                r += applied
            # Active set: nodes on the wall pushed into it once the uniform traction mu (the
            # multiplier of zero mean displacement) is removed; mu depends on the set, so
            # iterate the pair to a fixed point (2-3 passes).
            on_wall, pressed, free, weight = self._on_wall, self._pressed, self._free, self._free_weight
            np.less_equal(gap, on_wall_tolerance, out=on_wall)
            for _ in range(10):
                np.greater(r, mu, out=pressed)
                pressed &= on_wall
                np.logical_not(pressed, out=free)
                np.copyto(weight, free)
                r_free, n_free = dom.sums(r @ weight, np.count_nonzero(free))
                mu_new = r_free / n_free
                if mu_new == mu:
                    break
                mu = mu_new
            r -= mu
            r *= weight
            residual = dom.max_abs(r) / self.traction_scale
            if residual <= self.tolerance or iteration >= self.max_iterations:
                break
            # Restart CG when nodes join the active set (the search space shrinks). Nodes that
            # leave it only enlarge the space: the old direction stays admissible (zero on
            # the released nodes), so conjugacy is kept, which matters when the contact edge
            # recedes by several nodes per step.
            if first_pass or dom.any(np.logical_and(self._free_previous, pressed, out=pressed)):
                restart = True
            first_pass = False
            self._free_previous[:] = free
            # Preconditioned residual, projected on the free nodes with zero mean.
            fft.apply_diagonal(r, ops.compliance, z)
            z -= dom.dot(z, weight) / n_free
            z *= weight
            rz, r_old_z = dom.sums(r @ z, r_old @ z)
            if restart:
                d[:] = z
            else:
                beta = max(0.0, (rz - r_old_z) / rz_old)  # Polak-Ribiere+
                d *= beta
                d += z
            rd = dom.dot(r, d)
            if rd <= 0.0:  # not a descent direction any more: steepest (preconditioned) descent
                d[:] = z
                rd = rz
            # Nodes on the wall that the (smoothed) direction pushes into it cannot move: hold
            # them this iteration and keep the zero mean on the others (projected direction).
            np.greater(d, 0.0, out=pressed)
            pressed &= on_wall
            if dom.any(pressed):
                held = self._held
                held[:] = False
                while dom.any(pressed):  # removing the mean can push another node in
                    held |= pressed
                    np.logical_not(held, out=pressed)
                    pressed &= free
                    np.copyto(self._scratch, pressed)
                    d_keep, n_keep = dom.sums(d @ self._scratch, np.count_nonzero(pressed))
                    if n_keep == 0:  # every free node held: fall back to the residual below
                        d[:] = 0.0
                        break
                    d -= d_keep / n_keep
                    d *= self._scratch
                    np.greater(d, 0.0, out=pressed)
                    pressed &= on_wall
                rd = dom.dot(r, d)
                if rd <= 0.0:  # the projected residual lifts on-wall nodes off: descent
                    d[:] = r
                    rd = dom.dot(r, r)
            fft.apply_diagonal(d, ops.stiffness, k_d)
            alpha = rd / dom.dot(d, k_d)  # minimiser of the quadratic upper bound
            np.multiply(d, alpha, out=self._trial)
            self._trial += u
            if not self._reaches_wall(wall):
                if law.sigma_a > 0.0:
                    secant = self._secant_step(u, wall, d, k_d, history, applied, alpha, rd)
                    np.multiply(d, secant, out=self._trial)
                    self._trial += u
                    if self._reaches_wall(wall):  # the longer step would reach the wall
                        np.multiply(d, alpha, out=self._trial)
                        self._trial += u
                    else:
                        alpha = secant
                u[:] = self._trial
                k_d *= alpha
                k_u += k_d
                restart = False
            else:
                self._constrained_step(u, wall, d, k_d, alpha, ops, history, applied)
                restart = True
            r_old[:] = r
            rz_old = rz
            iteration += 1
        # Put the nodes counted as contact exactly on the wall, so that every later use of
        # the state (reaction, load, contact width, predictor) sees the same contact set.
        np.less_equal(gap, on_wall_tolerance, out=on_wall)
        np.copyto(u, wall, where=on_wall)
        fft.apply_diagonal(u, ops.stiffness, k_u)
        return SolveResult(iterations=iteration, residual=residual,
                           converged=residual <= self.tolerance, mean_traction=mu)

    def _reaches_wall(self, wall):
        return self.domain.any(np.greater(self._trial, wall, out=self._pressed))

    def _constrained_step(self, u, wall, d, k_d, alpha, ops, history, applied):
        """A step u + alpha d that reaches the wall, taken so that the energy decreases.

        First choice: the Euclidean projection (zero mean, gap >= 0) of u + a d, which sets
        many nodes on the wall at once, accepted for the first a in alpha, alpha/8, ...,
        alpha/8^5 that lowers the energy (projected backtracking; measured: at the first
        retraction step a = alpha/512 was needed, 2451 nodes being pushed in by the full step).
        Otherwise the step is cut
        where the first node touches the wall: that length lies inside (0, alpha], where the
        quadratic upper bound guarantees descent. All of them restart CG.
        """
        energy = self.energy_with(u, self._k_u, wall, history, applied)
        for trial in range(6):  # projected backtracking along the arc P(u + a d)
            step = alpha * 0.125**trial  # a full CG step can push thousands of nodes in
            np.multiply(d, step, out=self._trial)
            self._trial += u
            project_feasible(self.domain, self._trial, wall, self._projected)
            self.fft.apply_diagonal(self._projected, ops.stiffness, self._k_projected)
            if self.energy_with(self._projected, self._k_projected, wall, history,
                                applied) < energy:
                u[:] = self._projected
                self._k_u[:] = self._k_projected
                self.projections += 1
                return
        cut = self._first_contact(u, wall, d)
        if cut <= 0.0:
            # d presses on a node already on the wall (held nodes are excluded from d, so only
            # round-off gets here). The projected residual r moves every free node along its
            # own force, so on-wall nodes move away and its first contact is at a positive
            # length: a descent step.
            d[:] = self._residual
            self.fft.apply_diagonal(d, ops.stiffness, k_d)
            rd, dkd = self.domain.sums(self._residual @ d, d @ k_d)
            alpha = rd / dkd
            cut = min(alpha, self._first_contact(u, wall, d))
            self.residual_steps += 1
        u += cut * d
        np.minimum(u, wall, out=u)  # the touching node lands on the wall exactly
        k_d *= cut
        self._k_u += k_d
        self.cut_steps += 1

    def _first_contact(self, u, wall, d):
        """Collective: largest step length along d before a node reaches the wall."""
        rising = d > 0.0
        room = (wall[rising] - u[rising]) / d[rising]
        return self.domain.min(float(room.min()) if room.size else np.inf)

    def energy(self, u, wall, ops, history, applied=None):
        """Collective: energy of the step per unit length, divided by dx (one FFT pair).

        E/dx = 1/2 u.K u + (H - p_applied).u - sigma_a sum_e M_e (see the module docstring).
        """
        self.fft.apply_diagonal(u, ops.stiffness, self._k_projected)
        return self.energy_with(u, self._k_projected, wall, history, applied)

    def energy_with(self, u, k_u, wall, history, applied=None):
        """Collective: energy (per unit length, divided by dx) of u with K u given."""
        value = 0.5 * float(u @ k_u) + float(history @ u)
        if applied is not None:
            value -= float(applied @ u)
        gap_ext = self._gap_energy_ext
        np.subtract(wall, u, out=gap_ext[1:-1])
        self.domain.fill_halo(gap_ext)
        return self.domain.sum(value + self.law.energy(gap_ext, 1.0))

    def _secant_step(self, u, wall, d, k_d, history, applied, alpha, rd):
        """Step length along d from the slope of the true energy at the bound's minimiser.

        phi(a) = E(u + a d) has phi'(0) = -rd and, the adhesion being concave, curvature at
        most d.K d; so phi'(alpha) <= 0 at the bound's minimiser alpha and every step in
        (0, 2 alpha) lowers E. The secant through phi'(0) and phi'(alpha) accounts for the
        cohesive edge's negative stiffness; it is capped at 1.9 alpha to keep the descent.
        """
        gap, traction = self._gap, self._traction
        np.subtract(wall, self._trial, out=gap)
        self.domain.fill_halo(self._gap_ext)
        self.law.traction(self._gap_ext, out=traction, work=self._work)
        # phi'(alpha) = -(t - K(u + alpha d) - H + applied) . d; uniform parts drop (mean d = 0)
        t_d, ku_d, kd_d, h_d, a_d = self.domain.sums(
            traction @ d, self._k_u @ d, k_d @ d, history @ d,
            applied @ d if applied is not None else 0.0)
        slope = -(t_d - ku_d - alpha * kd_d - h_d + a_d)
        if slope >= -1e-300:
            return alpha
        if slope <= -rd:  # no positive curvature along d: go as far as the bound allows
            return 1.9 * alpha
        return min(alpha * rd / (rd + slope), 1.9 * alpha)

    def elastic_traction(self):
        """K u of the last solve's displacement (stress units; a view, valid until the next solve)."""
        return self._k_u

    def interface_traction(self, u, wall, history, mean_traction, out, applied=None):
        """Traction the indenter exerts on the surface at equilibrium (stress, upward positive).

        Cohesive traction on free nodes; on the wall the total reaction
        K u + H + mean_traction - applied, which balances the substrate.
        """
        np.subtract(wall, u, out=self._gap)
        self.domain.fill_halo(self._gap_ext)
        self.law.traction(self._gap_ext, out=out, work=self._work)
        contact = self._gap <= 0.0
        balance = self._k_u + history + mean_traction
        if applied is not None:
            balance -= applied
        out[contact] = balance[contact]
        return out
