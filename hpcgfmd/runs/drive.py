"""The compliant drive: the indenter on a spring whose far end follows the protocol.

docs/model.md, "Protocol", (M43): the drive Z(t) follows the protocol (:mod:`.schedule`)
from Z0 = u_z0 - L_0 / k_s (the spring holds the start's load L_0), and each step's indenter
position u_z balances the spring, f(u_z) = L(u_z) - k_s (u_z - Z) = 0, L the load
(compressive positive) of the equilibrium at u_z. Under load control (k_s = 0) the drive is
the applied load F(t) itself, from F0 = L_0, and f(u_z) = L(u_z) - F. :meth:`CompliantDrive.balance`
searches u_z around the step's equilibrium solve (docs/numerics.md, "The compliant drive").
"""

from __future__ import annotations

import math

from ..errors import NonConvergenceError
from ..state import State

SPRING_TOLERANCE = 0.1  # spring imbalance accepted, in load allowances
MAX_SPRING_SOLVES = 40  # the solves one step's search may take
SPRING_TRUST = 0.5  # its Newton moves of the indenter at most, in dmax
SPRING_TRAVEL = 1e-3  # the indenter's uncertainty accepted with a stiff spring, in dmax


class CompliantDrive:
    """State and search of the spring between the drive and the indenter (module docstring).

    Parameters
    ----------
    case : Case
        A case with a finite ``drive_stiffness`` (internal units).

    Attributes
    ----------
    rate : float
        du_z/dt of the last accepted step, for the next step's first guess (length/time).
    slope : float
        The secant dL/du_z between the last accepted steps where it is below k_s (NaN
        before one is known; it includes the history's relaxation over the step): the
        search's first Newton slope (stress).
    solves : int
        Equilibrium solves beyond one per step.
    accepted_load : float
        The load of the last accepted step (load per length).
    """

    def __init__(self, case):
        self.stiffness = case.drive_stiffness
        self.load_control = case.load_control
        self.tolerance = SPRING_TOLERANCE * case.numerics.load_tolerance * case.load_scale
        self.reach = SPRING_TRUST * case.dmax
        self.travel = SPRING_TRAVEL * case.dmax
        self.dmax = case.dmax
        self.rate = case.indenter_speed
        self.slope = math.nan
        self.solves = 0
        self.accepted_load = math.nan

    def hold(self, indenter: float, load: float) -> float:
        """After the start: the drive's value that holds ``load`` at ``indenter``, Z0 =
        u_z0 - L_0 / k_s (length), or under load control F0 = L_0 (load per length)."""
        self.accepted_load = load
        return load if self.load_control else indenter - load / self.stiffness

    def force(self, indenter: float, drive: float) -> float:
        """The drive's push on the indenter, k_s (u_z - Z), or the applied load F = ``drive``
        under load control (load per length, compressive positive)."""
        return drive if self.load_control else self.stiffness * (indenter - drive)

    def guess(self, indenter: float, dt: float) -> float:
        """The indenter's first position for a step of length dt: its last rate."""
        return indenter + self.rate * dt

    def accept(self, indenter_before: float, indenter: float, load: float, dt: float):
        """After an accepted step: the indenter's rate, and the slope dL/du_z of the steps
        when it is below the spring's stiffness (a Newton slope of a stable balance)."""
        moved = indenter - indenter_before
        self.rate = moved / dt
        if moved != 0.0:
            secant = (load - self.accepted_load) / moved
            if secant < self.stiffness:
                self.slope = secant
        self.accepted_load = load

    def balance(self, equilibrium, drive: float, indenter: float):
        """Collective: the step's equilibrium where the spring balances the load.

        ``equilibrium`` (:class:`~.equilibrium.Equilibrium`, the step begun) solves the
        step at an indenter position, from the last solve below the root with the nodes
        within range carried along by the indenter (the search follows the attached branch
        while it lasts); ``drive`` is the drive's value at the step's end, ``indenter`` the
        first position tried. The search on f(u_z) = L(u_z) - k_s (u_z - Z): outside a
        bracket, secant steps on f, or Newton steps with f' = S - k_s (S: :attr:`slope`),
        at most SPRING_TRUST dmax per solve; where no slope is negative (past the spring's
        jump, or across a jump of the discrete L(u_z) where the grid's contact edge passes a
        node) the spring alone, f' = -k_s, which marches u_z to the next balance. Inside a
        bracket (f > 0 below, f < 0 above): regula falsi alternating with bisection;
        detached (no node within range): the drive's position. Converged when |f| is below
        SPRING_TOLERANCE load allowances; or when the next Newton step would move the load by
        less than that and u_z by less than SPRING_TRAVEL dmax (a stiff spring: its
        imbalance is k_s times the solves' own position error); or when the bracket is
        narrower than that load's travel (the balance falls in a jump of the discrete L).
        Every decision uses reduced values (loads, widths), so all ranks take the same.

        Returns
        -------
        StepRecord or None
            The balanced step (its indenter the balanced position, its iterations those of
            all the solves); None when a solve was abandoned (its edges strayed beyond what
            the step control accepts) or no balance was found within MAX_SPRING_SOLVES
            solves of a step the step control can still shorten (else NonConvergenceError).
        """
        stiffness, tolerance = self.stiffness, self.tolerance
        slope = self.slope if math.isfinite(self.slope) else -1.0
        iterations = 0
        previous = below = above = None  # (u_z, f); f > 0 below the root, < 0 above
        bisect = False
        for solves in range(MAX_SPRING_SOLVES):
            record = equilibrium.solve(indenter)
            if record is None:
                return None
            iterations += record.iterations
            self.solves += solves > 0
            record.iterations = iterations
            imbalance = record.load - self.force(indenter, drive)
            point = (indenter, imbalance)
            detached = record.load == 0.0 and record.cohesive_half_width == 0.0
            if self.load_control and detached:
                return record  # the load let go: the indenter flew off
            if imbalance > 0.0:
                below = point
                equilibrium.anchor()
            else:
                above = point
            bracket = below is not None and above is not None and below[0] < above[0]
            if (
                abs(imbalance) <= tolerance
                or (
                    abs(imbalance) <= (stiffness - slope) * self.travel
                    and abs(imbalance * slope) <= tolerance * (stiffness - slope)
                )
                or (bracket and (above[0] - below[0]) * max(stiffness, abs(slope)) <= tolerance)
            ):
                return record
            target = (
                drive
                if detached  # the spring alone, balanced at the drive (k_s > 0)
                else self._next(point, previous, below, above, bracket, bisect, slope)
            )
            bisect = bracket and not bisect
            previous, indenter = point, target
        if equilibrium.can_shorten:  # the step control may shorten the step: abandoned
            return None
        raise NonConvergenceError(
            f"{equilibrium.where()}: no position of the indenter balances the drive's"
            f" spring (drive_stiffness = {stiffness:g}) within {MAX_SPRING_SOLVES} solves;"
            " reduce dt or raise [numerics] tolerance"
        )

    def _next(self, point, previous, below, above, bracket, bisect, slope):
        """The search's next indenter position (:meth:`balance`)."""
        if bracket:
            if bisect:
                return 0.5 * (below[0] + above[0])
            return below[0] - below[1] * (above[0] - below[0]) / (above[1] - below[1])
        derivative = slope - self.stiffness
        if previous is not None and point[0] != previous[0]:
            secant = (point[1] - previous[1]) / (point[0] - previous[0])
            if secant < 0.0:  # (not across a jump of the discrete L)
                derivative = secant
        if derivative < 0.0:  # Newton, within reach of the last solve
            step = -point[1] / derivative
            return point[0] + max(-self.reach, min(self.reach, step))
        if self.load_control:  # no stable slope: away from the imbalance by the reach
            return point[0] + math.copysign(self.reach, point[1])
        return point[0] + point[1] / self.stiffness  # no stable slope: the spring alone

    def state(self) -> State:
        """The indenter's rate, the search's slope and the last load (:mod:`hpcgfmd.state`)."""
        return State(
            scalars={"rate": self.rate, "slope": self.slope, "accepted_load": self.accepted_load}
        )

    def restore(self, state: State):
        s = state.scalars
        self.rate, self.slope = float(s["rate"]), float(s["slope"])
        self.accepted_load = float(s["accepted_load"])

    def counters(self) -> dict:
        """Equilibrium solves beyond one per step."""
        return {"spring_solves": self.solves}

    def restore_counters(self, counters: dict):
        self.solves = int(counters["spring_solves"])
