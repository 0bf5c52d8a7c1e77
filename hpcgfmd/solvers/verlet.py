"""The paper's method as a baseline: damped GFMD with unit mass per mode (fixed step count).

Van Dokkum et al. (paper Sec. 4 and Appendix A) relax each time step's equilibrium by
damped dynamics of the Fourier modes of the surface displacement, each with unit mass,
integrated by position (Stormer-)Verlet with a pseudo time step h, for a fixed number of
pseudo steps (the "equilibration time"); the hard wall is applied in real space after every
step ("the hardwall condition returns the coordinates of the surface nodes to the rigid
body"). :class:`DampedVerletGFMD` does exactly that for one time step, with the interface of
:class:`~hpcgfmd.solvers.base.EquilibriumSolver`, so that the run can use either.

Equations of motion (docs/model.md, "Substrate"; the paper's 8|q| is |q|/2)
    Mode q, unit mass, stiffness k_q = (|q|/2) Eeff, history traction H_q (known for the time
    step), interface traction T_q (cohesive + hard-wall reaction), damping c_q:

        u_q'' = -k_q u_q - H_q + T_q - c_q u_q'

    Position Verlet with damping on the backward difference (Appendix A):

        u_q^{new} = 2 u_q^{now} - u_q^{old}
                    + h^2 [-k_q u_q^{now} - H_q + T_q - c_q (u_q^{now} - u_q^{old}) / h]
                  = a1_q u_q^{now} - a0_q u_q^{old} + h^2 (T_q - H_q),
        a1_q = 2 - k_q h^2 - c_q h,   a0_q = 1 - c_q h.

    The homogeneous recurrence has the characteristic polynomial
    z^2 - a1_q z + a0_q = 0.

Damping (paper Eq. 15, garbled in the extracted text): "relaxed critical damping"
    With k0_q = (|q|/2) E0 (relaxed stiffness) and s_q = sqrt(k0_q) h,

        c_q = 2 sqrt(k0_q) - k0_q h,   so   c_q h = 2 s_q - s_q^2,   a0_q = (1 - s_q)^2.

    For Eeff = E0 this makes the recurrence exactly critically damped: a1_q = 2 (1 - s_q),
    double root z = 1 - s_q (a double root needs a1^2 = 4 a0, i.e. with x = c h
    x^2 + 2 k0 h^2 x - k0 h^2 (4 - k0 h^2) = 0, whose positive root is x = 2 s - s^2). It
    is the discrete analogue of c = 2 sqrt(k0) (exact in the limit h -> 0) and is
    non-monotone in q, as the paper says: it rises like 2 sqrt(k0) and peaks at s_q = 1.
    For Eeff = e E0 with e >= 1 the discriminant is
    a1^2 - 4 a0 = s^2 (1 - e) ((2 - s)^2 - e s^2): modes with s_q < 2 / (1 + sqrt e) are
    underdamped with |z| = |1 - s_q|, i.e. they decay exactly as fast as the critically
    damped relaxed modes, whatever Eeff; only the few highest modes beyond that (when
    e > 1) have two real roots, one negative (a discrete, sign-alternating overdamping).
    The longest mode, q_min = 2 pi / L, decays like k (1 - sqrt(k0_min) h)^k after k
    pseudo steps; the Nyquist mode's rate depends on h too (below).

Pseudo time step h: stability limit and the fastest step below it
    Jury conditions for z^2 - a1 z + a0: |a0| < 1, 1 - a1 + a0 > 0 (= k h^2 > 0, always)
    and 1 + a1 + a0 > 0, i.e.  0 < c h < 2  and  k h^2 + 2 c h < 4.  With the c above:
    c h = 2 s - s^2 lies in (0, 2) for 0 < s < 2, and the second condition reads
    (2 - e) s^2 - 4 s + 4 > 0, whose smallest positive root is

        s* = 2 / (1 + sqrt(e - 1))          (s* = 2 for e = 1; any e <= 1 gives 2).

    s_q grows with |q| at fixed e, so the Nyquist mode |q| = pi/dx sets the limit:

        h_limit = 2 / [(1 + sqrt(Eeff/E0 - 1)) sqrt(k0_max)],   k0_max = (pi / (2 dx)) E0.

    The largest stable step is not the fastest: the contraction factor per pseudo step of a
    mode, rho(s, e) (the larger root magnitude: |1 - s| while underdamped, else
    (|a1| + sqrt(a1^2 - 4 a0)) / 2), falls with s up to s ~ 1 and rises again to 1 at s*.
    At h = 0.99 h_limit and e = 1 the Nyquist mode contracts only by 2 * 0.99 - 1 = 0.98
    per step, slower than the slowest mode at every n below ~2^14 (at n = 1024 the rate
    would be 0.98 against 0.915 possible). rho(s, e) is unimodal in s, so the slowest modes
    are the two ends of the grid, q_min = 2 pi / L and the Nyquist mode, and the best step
    balances them: h minimises max(rho(s_min, e), rho(s_max, e)), found by golden-section
    search in (0, h_limit]. For e = 1 it is the heavy-ball optimum

        h = 2 / (sqrt(k0_min) + sqrt(k0_max)) = h_limit kappa / (1 + kappa),
        kappa = sqrt(k0_max / k0_min) = sqrt(n / 2),   rate (kappa - 1) / (kappa + 1),

    i.e. 0.958 h_limit at n = 2^10 and 0.996 h_limit at n = 2^17 (this is the "safety
    factor close to 1", derived rather than chosen); for e = 10 it is 0.997-0.9998 h_limit.
    The number of pseudo steps for a given accuracy is ~ (1 + sqrt(e - 1)) kappa / 2 log(1 /
    error): it grows like sqrt(n), the paper's reason for needing long equilibration times,
    and by 1 + sqrt(e - 1) (4 at k = 0.1, dt -> 0) because the damping uses E0 (damping
    with Eeff would allow s_max = 2 at every e; the paper chose the relaxed damping
    knowingly, "albeit not in the fastest manner"). The step used is
    h = time_step_fraction * h_opt; all ranks get the same value (the extremes of sqrt(k0)
    and e are reduced over all ranks in one message, then the same scalar search runs on
    every rank).

Real-space formulation (one FFT pair per pseudo step)
    The state is u^{now} in real space (feasible: u <= wall) and, in Fourier space, the
    previous step's V = a0 U^{old} / n. With the constant load of the time step
    P = rfft(h^2 (H - applied)) / n (one forward transform per solve), one pseudo step is

        U = rfft(u)                                          (forward half of the pair)
        G = (a1 / n) U - V - P,  V <- (a0 / n) U,  G_0 -= s   (q = 0: a1 = a0 = 0)
        g = irfft(G)       (unnormalised; the 1/n is folded into a1, a0 and P)
        t = h^2 * cohesive traction of the gap wall - u      (the law with sigma_a h^2)
        u <- min(g + t, wall)                                (the hard wall)

    which is the Verlet update of every mode followed by the real-space wall, as in
    Appendix A; the first step starts at rest (U^{old} = U). The first and the last pseudo
    step project exactly instead (G_0 unshifted, u = min(g + t - s, wall) with s iterated
    to zero mean; below).

    The q = 0 mode is held at zero (docs/model.md): it has no stiffness or damping, its
    multipliers are zero, and the uniform shift s (entering as the q = 0 entry of G, for
    free) keeps the mean of u at zero: the shift of the projection min(v - s, wall) with
    zero mean. Newton's method on f(s) = sum min(v - s, wall) (concave, decreasing,
    f' = -number of free nodes) is warm-started from the last solve's multiplier; the first
    pseudo step iterates it to convergence (exact zero mean), later steps take ONE Newton
    step each, the sum and the count in one reduction, and the updated s serves the next
    pseudo step. The mean of u is thus lagged by one Newton update: its error,
    (s_{k+1} - s_k) (free nodes) / n, vanishes at the fixed point (s constant) and does not
    propagate (the mean has zero multipliers). At the fixed point the free nodes satisfy
    h^2 (t - H + applied - K u) - s = 0, so the uniform traction (the Lagrange multiplier of
    zero mean, ``mean_traction``) is mu = s / h^2; nodes on the wall carry the reaction.

    The LAST pseudo step iterates s to convergence again, so that the result is
    min(v - s, wall) with exact zero mean and the contact nodes exactly on the wall. Before
    the relaxation has settled the lagged mean error is not round-off, and an exact
    projection of a lagged state afterwards would lower EVERY node, the contact included, by
    that error; beyond the on-wall tolerance of :class:`ConstrainedCG` the whole contact
    would count as open (no wall reaction, a load of the wrong sign). With the exact last
    step, the error of the fixed pseudo-step count is a plain lag behind the equilibrium
    that decreases with the count (measured in docs/results.md, "The paper's method").

    Work per pseudo step besides the two FFTs: the serial transform's copy in and copy out
    (the spectrum stays in the transform's own buffer), one compiled pass over the modes (a0
    U and a1 U - V - P on interleaved floats, :func:`.verlet_kernels.modes`) and one over the
    nodes (the wall minimum, the free count and, with adhesion, the next step's gaps with
    their scan for the interaction span: :mod:`.verlet_kernels`), numpy's sum of u; with
    adhesion the cohesive law on the span of nodes within the zone (:mod:`.points`, as the
    CG evaluates it) and the addition of the traction. Nothing is allocated per pseudo step.

Per solve (not per pseudo step): an exact zero-mean projection of the start, the global
stability limit (one reduction), and the step problem's measure of the result
(:meth:`~hpcgfmd.solvers.step_problem.StepProblem.measure`): its exact projection leaves u as
it is (the last pseudo step's is exact); it computes K u (``elastic_traction``) and the
residual as the active-set CG defines it (max |projected residual| / traction_scale over
free nodes), reported for information only: the paper's method runs a fixed number of
pseudo steps, so ``converged`` is always True.

Parallel: every real-space vector is this rank's block, every spectrum this rank's modes in
the transform's layout; the only communication is the transform pair, one ghost exchange
(adhesion) and one reduction of two numbers per pseudo step, so all ranks take the same
branches.
"""

from __future__ import annotations

import math

import numpy as np

from ..model.interface import DugdaleMaugis
from . import kernels, verlet_kernels
from .base import NO_WATCH, EquilibriumSolver, SolveResult, SolverKey, register
from .cg import ConstrainedCG
from .points import Point, PointEvaluator
from .projection import project_feasible
from .step_problem import StepProblem

_GOLDEN = (np.sqrt(5.0) - 1.0) / 2.0
EQUILIBRATION_PER_ROOT_N = 1024  # the paper authors' code: 256 * 4 * sqrt(nx) pseudo steps


def contraction(s, e):
    """Spectral radius of z^2 - a1 z + a0 for one mode (module docstring).

    Parameters
    ----------
    s : float
        sqrt(k0) h of the mode (k0 = (|q|/2) E0).
    e : float
        Eeff / E0 of the mode.

    Returns
    -------
    float
        Factor by which the slowest component of the mode shrinks per pseudo step (> 1:
        unstable).
    """
    a0 = (1.0 - s) ** 2
    a1 = 1.0 + a0 - e * s * s
    # a1^2 - 4 a0 in factored form: no cancellation near the double root (e = 1), where
    # the square root would turn round-off into errors of ~1e-8.
    disc = (1.0 - e) * s * s * ((2.0 - s) ** 2 - e * s * s)
    if disc <= 0.0:
        return float(np.sqrt(a0))
    return float((abs(a1) + np.sqrt(disc)) / 2.0)


def pseudo_step(sqrt_k0_min, sqrt_k0_max, e):
    """Fastest pseudo step and stability limit of the grid (module docstring).

    Parameters
    ----------
    sqrt_k0_min, sqrt_k0_max : float
        Extremes of sqrt(k0_q) over the moving modes q != 0 of the whole grid.
    e : float
        Eeff / E0 (the largest over the modes).

    Returns
    -------
    h_opt, h_limit : float
        The step minimising max(contraction(sqrt_k0_min h), contraction(sqrt_k0_max h))
        (golden-section search; deterministic, so every rank gets the same bits) and the
        stability limit 2 / ((1 + sqrt(max(e - 1, 0))) sqrt_k0_max).
    """
    h_limit = 2.0 / ((1.0 + np.sqrt(max(e - 1.0, 0.0))) * sqrt_k0_max)

    def worst(h):
        return max(contraction(sqrt_k0_min * h, e), contraction(sqrt_k0_max * h, e))

    a, b = 0.0, h_limit
    c, d = b - _GOLDEN * (b - a), a + _GOLDEN * (b - a)
    fc, fd = worst(c), worst(d)
    for _ in range(100):  # 0.618^100 ~ 1e-21: to the last bit
        if fc <= fd:
            b, d, fd = d, c, fc
            c = b - _GOLDEN * (b - a)
            fc = worst(c)
        else:
            a, c, fc = c, d, fd
            d = a + _GOLDEN * (b - a)
            fd = worst(d)
    return float(0.5 * (a + b)), float(h_limit)


@register("paper")
class DampedVerletGFMD(EquilibriumSolver):
    """Damped per-mode position Verlet, the paper's GFMD (see the module docstring).

    Parameters
    ----------
    domain : hpcgfmd.parallel.domain.Domain
        This rank's block of nodes and the collectives.
    fft : SerialRealFFT, HalvedRealFFT or TransposedRealFFT
        Planned transforms (same block layout as ``domain``).
    law : DugdaleMaugis
        Cohesive law.
    half_q : ndarray, shape fft.spectrum_shape
        |q|/2 of each local mode (1/length).
    relaxed_modulus : float
        E0, for the relaxed critical damping (stress units; 1 in internal units).
    equilibration_steps : int
        Pseudo steps per solve (the paper's fixed equilibration time).
    traction_scale : float
        Traction that makes the reported residual dimensionless (stress units).
    time_step_fraction : float
        Pseudo step as a fraction of the fastest one, h_opt (module docstring); h_opt is
        0.958-0.9998 of the stability limit, so 1.05 may already be unstable.

    Attributes
    ----------
    step_length, step_optimal, step_limit : float
        h, h_opt and the stability limit h_limit of the last solve (units of
        (length/stress)^(1/2): unit mass per mode).
    modulus_ratio : float
        Eeff / E0 of the last solve.
    """

    def __init__(
        self,
        domain,
        fft,
        law: DugdaleMaugis,
        half_q,
        relaxed_modulus,
        equilibration_steps: int,
        traction_scale: float,
        time_step_fraction=1.0,
        preload=None,
    ):
        if equilibration_steps < 0:
            raise ValueError(f"equilibration_steps must be >= 0, got {equilibration_steps}")
        if not time_step_fraction > 0.0:
            raise ValueError(f"time_step_fraction must be positive, got {time_step_fraction}")
        self.domain = domain
        self.fft = fft
        self.law = law
        self.half_q = np.ascontiguousarray(half_q, dtype=np.float64)
        if self.half_q.shape != tuple(fft.spectrum_shape):
            raise ValueError(
                f"half_q has shape {self.half_q.shape}, the transform's modes {fft.spectrum_shape}"
            )
        self.relaxed_modulus = float(relaxed_modulus)
        self.equilibration_steps = int(equilibration_steps)
        self.traction_scale = traction_scale
        self.time_step_fraction = float(time_step_fraction)
        # the final projection, K u, residual and mu: the step problem's measure
        self.problem = StepProblem(domain, fft, law, traction_scale)
        self._k_u = None
        n = domain.local_n
        self._point = Point(n, domain.halo)  # the gaps and the cohesive traction of u
        self._linear = np.zeros(n)  # g = irfft(G)
        self._load = np.zeros(n)  # h^2 (H - applied) / n
        shape = fft.spectrum_shape
        # The transform's own spectrum buffer (saves the copies in the serial transform).
        self._spectrum = fft.spectrum
        self._v_old = np.zeros(shape, dtype=np.complex128).view(np.float64)  # a0 U / n
        self._v_new = np.zeros(shape, dtype=np.complex128).view(np.float64)
        self._load_hat = np.zeros(shape, dtype=np.complex128)
        self._a1 = np.zeros(shape)  # a1 / n
        self._a0 = np.zeros(shape)  # a0 / n
        self._scratch = np.zeros(shape)
        # The complex spectra are multiplied as float arrays (real, imaginary interleaved) by
        # the multipliers stored twice each: a complex-times-real multiply would make numpy
        # cast through a temporary buffer (128 kB per call) and runs ~1.5x slower.
        pairs = tuple(shape[:-1]) + (2 * shape[-1],)
        self._a1_pairs = np.zeros(pairs)
        self._a0_pairs = np.zeros(pairs)
        self._sqrt_k0 = np.sqrt(self.half_q * self.relaxed_modulus)
        self._moving = self.half_q > 0.0
        zero = np.flatnonzero(self.half_q.ravel() == 0.0)  # the q = 0 mode, if held here
        self._zero_mode = np.unravel_index(int(zero[0]), shape) if zero.size else None
        self._mean_traction = 0.0  # warm start of the shift: s = h^2 mu
        self.step_length = self.step_optimal = self.step_limit = np.nan
        self.modulus_ratio = np.nan
        self.shift_traction = np.nan  # s / h^2 of the last solve (= mean_traction at rest)
        self._preload = preload

    KEYS = (
        SolverKey(
            "equilibration_steps",
            1,
            lambda nx: round(EQUILIBRATION_PER_ROOT_N * math.sqrt(nx)),
            "pseudo steps per time step, the paper's fixed equilibration time;"
            " default 1024 sqrt(nx)",
        ),
    )

    @classmethod
    def from_case(cls, case, domain, fft, law, half_q):
        """The paper's method with the case's equilibration_steps; relaxed damping with
        E0 = 1 (internal units). Its preload is solved by CG to the case's tolerance."""
        return cls(
            domain,
            fft,
            law,
            half_q,
            1.0,
            case.numerics.setting("equilibration_steps"),
            case.sigma_a,
            preload=ConstrainedCG.from_case(case, domain, fft, law, half_q),
        )

    @classmethod
    def describe(cls, numerics):
        return (
            f"the paper's damped Verlet GFMD,"
            f" {numerics.setting('equilibration_steps')} pseudo steps per step"
        )

    @classmethod
    def iterations_per_step(cls, numerics) -> float:
        """The fixed pseudo steps of every time step."""
        return float(numerics.setting("equilibration_steps"))

    def preload_solver(self):
        """CG: the loading-branch equilibrium to the tolerance (the paper's method would need a
        loading phase of its own)."""
        if self._preload is None:
            raise ValueError("built without a preload solver (use from_case)")
        return self._preload

    # --- set-up of a solve --------------------------------------------------------------
    def prepare(self, ops):
        """Collective: pseudo step and Verlet multipliers for the step's stiffness.

        Returns the pseudo step h = time_step_fraction * h_opt (module docstring). One
        reduction (the extremes of sqrt(k0) and Eeff/E0 over all ranks' modes).
        """
        n = self.domain.n
        moving = self._moving
        if moving.any():
            sqrt_k0 = self._sqrt_k0[moving]
            ratio = ops.stiffness[moving] * n / (sqrt_k0 * sqrt_k0)  # e_q = k_q / k0_q
            local = (-float(sqrt_k0.min()), float(sqrt_k0.max()), float(ratio.max()))
        else:  # this rank holds no moving mode
            local = (-np.inf, -np.inf, -np.inf)
        low, high, e = self.domain.maxes(*local)
        if not high > 0.0:
            raise ValueError("no moving mode: the pseudo step is undefined")
        h_opt, h_limit = pseudo_step(-low, high, e)
        h = self.time_step_fraction * h_opt
        a1, a0, s = self._a1, self._a0, self._scratch
        np.multiply(self._sqrt_k0, h, out=s)  # s_q = sqrt(k0_q) h
        # a0 = 1 - c h = (1 - s)^2 with c h = 2 s - s^2
        np.subtract(1.0, s, out=a0)
        np.square(a0, out=a0)
        # a1 = 2 - k h^2 - c h = 1 + a0 - k h^2
        np.multiply(ops.stiffness, -n * h * h, out=a1)
        a1 += a0
        a1 += 1.0
        a1 *= 1.0 / n
        a0 *= 1.0 / n
        a1[~moving] = 0.0  # q = 0: held at zero mean by the shift instead
        a0[~moving] = 0.0
        self._a1_pairs.reshape(a1.shape + (2,))[...] = a1[..., None]
        self._a0_pairs.reshape(a0.shape + (2,))[...] = a0[..., None]
        self.step_limit, self.step_optimal, self.step_length = h_limit, h_opt, h
        self.modulus_ratio = e
        return h

    # --- the relaxation -----------------------------------------------------------------
    def relax(self, u, wall, ops, history, steps, applied=None, monitor=None, watch=NO_WATCH):
        """Collective: ``steps`` damped Verlet pseudo steps from ``u`` (at rest), in place.

        ``u`` is first projected exactly (zero mean, u <= wall), and so is the last pseudo
        step's result (module docstring: the contact stays on the wall). ``monitor(k, u)``,
        if given, is called after every pseudo step k = 1..steps (diagnostics and tests; u
        must not be modified). Returns the shift s of the last step (mu ~ s / h^2), or None
        when the ``watch``'s stop flag (reduced with each pseudo step's sums) stopped it.
        """
        dom, fft = self.domain, self.fft
        h = self.prepare(ops)
        h2 = h * h
        project_feasible(dom, u, wall, self._linear)
        u[:] = self._linear
        # The step's constant load h^2 (H - applied) enters in Fourier space, where it
        # costs one complex pass over n/2 modes instead of a real pass over n.
        load = self._load
        np.multiply(history, h2 / dom.n, out=load)
        if applied is not None:
            load -= (h2 / dom.n) * applied
        load_hat = fft.forward(load, self._load_hat)
        adhesive = self.law.sigma_a > 0.0
        # the cohesive traction times h^2, on the span of nodes within the zone (g < dmax)
        evaluator = PointEvaluator(dom, DugdaleMaugis(self.law.sigma_a * h2, self.law.dmax))
        level = evaluator.level = self.law.dmax
        spectrum, a1, a0 = self._spectrum, self._a1_pairs.ravel(), self._a0_pairs.ravel()
        v_old, v_new = self._v_old.ravel(), self._v_new.ravel()  # (views: contiguous)
        pairs = np.float64  # the spectra as interleaved floats (see __init__)
        spectrum_f, load_hat_f = spectrum.view(pairs).ravel(), load_hat.view(pairs).ravel()
        g, point = self._linear, self._point
        zero = self._zero_mode
        s = self._mean_traction * h2  # warm start: the last solve's multiplier
        wall_scale = dom.max_abs(wall)  # the shift's tolerance is 1e-15 of it
        scan = None  # the gaps of u and their scan, when the last step's pass formed them
        for k in range(steps):
            first = k == 0
            # The first and the last step project exactly (see the module docstring: the
            # last one so that the result has zero mean with the contact ON the wall).
            exact = first or k == steps - 1
            fft.forward(u, spectrum)  # U = rfft(u)
            # a0 U / n, the next step's "old" term, and G = (a1 U - a0 U_old) / n
            # - h^2 (H - applied)^ / n; at rest (the first step) U_old = U
            verlet_kernels.modes(spectrum_f, a1, a0, v_new if first else v_old, load_hat_f, v_new)
            if zero is not None and not exact:
                spectrum[zero] -= s  # the uniform shift, through the q = 0 mode
            v_old, v_new = v_new, v_old
            if adhesive:  # the cohesive traction of the current u, before it is replaced
                if scan is None:
                    scan = kernels.shifted_gaps(wall, u, 1.0, point.gap, level)  # wall - u
                evaluator.evaluate_scanned(point, scan)
            # The first and the last step keep the unshifted update v = g (+ t) and project
            # it exactly (Newton from the current s); the others write it into u, meet the
            # wall (and form the next step's gaps) and take one Newton step on the shift.
            v = g if exact else u
            fft.inverse(spectrum, v)
            if exact:
                if adhesive:
                    v += point.traction
                s = project_feasible(dom, v, wall, u, wall_scale=wall_scale, shift=s)
                scan = None
            else:
                if adhesive:
                    count, scan = verlet_kernels.hard_wall_adhesive(
                        u, point.traction, wall, point.gap, level
                    )
                else:
                    count = verlet_kernels.hard_wall(u, wall)
                total, count, stop = dom.sums(u.sum(), count, watch.flag())
                if stop:
                    return None
                if count == 0:
                    raise FloatingPointError(
                        "the wall leaves no free node for zero mean displacement"
                    )
                s += total / count  # Newton on the mean, used by the next step
            if monitor is not None:
                monitor(k + 1, u)
            watch.beat(k + 1)
        self._v_old, self._v_new = v_old, v_new
        return s

    def solve(
        self, u, wall, ops, history, applied=None, edge_watch=None, watch=None
    ) -> SolveResult:
        """Collective: relax ``u`` in place by ``equilibration_steps`` pseudo steps.

        Same arguments and result type as :meth:`ConstrainedCG.solve`; ``iterations`` is
        the number of pseudo steps, ``converged`` is always True (fixed equilibration time,
        the paper's method) and ``residual`` is ConstrainedCG's measure of the result.
        ``edge_watch`` is ignored: the paper's method runs with fixed steps, which never
        abandon a solve. A stop flag of the ``watch`` ends it early (``interrupted``).
        """
        s = self.relax(
            u,
            wall,
            ops,
            history,
            self.equilibration_steps,
            applied,
            watch=NO_WATCH if watch is None else watch,
        )
        if s is None:
            return SolveResult(self.equilibration_steps, np.nan, False, 0.0, True, True)
        # exact projection, K u, residual and multiplier (StepProblem.measure)
        check, self._k_u = self.problem.measure(u, wall, ops, history, applied)
        self.shift_traction = s / self.step_length**2
        self._mean_traction = check.mean_traction
        return SolveResult(
            iterations=self.equilibration_steps,
            residual=check.residual,
            converged=True,
            mean_traction=check.mean_traction,
        )

    def elastic_traction(self):
        """K u of the last solve's displacement (stress units; valid until the next solve).
        (No counters beyond the pseudo steps, which the run counts as iterations.)"""
        return self._k_u
