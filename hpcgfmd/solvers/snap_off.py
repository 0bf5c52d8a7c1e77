"""Where a retraction's snap-off is placed in time: to its share of the work of separation.

Under displacement control a retracted contact, past its pull-off (the most tensile load),
shrinks along its attached branch to the branch's fold and jumps off. A step that passes
the fold has no attached equilibrium left: its solve descends to the detached state. The
step control places that jump by repeating such a step shorter (docs/numerics.md, "Time
steps"); the shortest step it accepts a vanishing contact at bounds how far after the fold
the jump is recorded. Near the fold the solves are slow (the attached branch's stiffness
vanishes there: 100-300 CG iterations each on a sphere), and halving the bracket down to
dt_min costs a retraction's last steps up to half of its iterations (docs/results.md).

What the bracket moves. Up to the pull-off nothing: the accuracy's pull-off and load-area or
load-depth curves end at the pull-off sample, taken before. After it, the work of separation
(docs/model.md, (M45)): with the fold anywhere in a last step of length dt from an attached
state of load L, the trapezoid from L to the detached 0 differs from the curve held near L
up to the fold by at most |L| v dt / 2, v the drive's rate. So once the load has risen from
its most tensile sample by more than the load allowance (the pull-off is behind), a step of
length up to

    dt_jump = 2 share W / (|L| v)                                          (snap-off bound)

may end detached, W the tensile work of the segment so far (sum of -(L_n + L_{n-1})/2
(D_n - D_{n-1}) over its rising steps of tensile load): the jump moves W by at most the
fraction ``share``. Before the pull-off, on a falling drive, without tensile work, or
with ``share`` = 0 (a compliant drive or load control, whose jumps are the spring's), it is
dt_min, as for any jump of the contact.
"""

from __future__ import annotations

import math


class SnapOff:
    """The longest step in which a retraction's contact may vanish (module docstring).

    Parameters
    ----------
    share : float
        Largest relative change of the work of separation the jump's placement may make
        (0: none; every jump is placed to dt_min).
    load_allowance : float
        The step control's load allowance (load per length): how far the load must have
        risen from its most tensile sample for the pull-off to be behind.

    Attributes
    ----------
    bound : float
        dt_jump of the last accepted step (tau; 0: none, the step control's dt_min applies).
    """

    def __init__(self, share, load_allowance):
        self.share = share
        self.load_allowance = load_allowance
        self.new_segment()

    def new_segment(self):
        """A protocol segment began: its pull-off and work start afresh (no bound until it
        has its own)."""
        self.bound = 0.0
        self.most_tensile = math.inf
        self.work = 0.0
        self.last = None  # (time, load, drive) of the last accepted step

    def accept(self, time, load, drive):
        """An accepted step (or the start) ended at ``time`` (tau) with ``load`` (load per
        length) and the drive at ``drive`` (length; NaN: unknown, no bound)."""
        self.bound = 0.0
        last, self.last = self.last, (time, load, drive)
        self.most_tensile = min(self.most_tensile, load)
        if last is None or not (time > last[0]) or not math.isfinite(drive + last[2]):
            return
        rise = drive - last[2]
        if rise > 0.0:
            self.work += max(0.0, -0.5 * (load + last[1])) * rise
        rate = rise / (time - last[0])
        past_pull_off = load < 0.0 and load > self.most_tensile + self.load_allowance
        if self.share > 0.0 and past_pull_off and rate > 0.0 and self.work > 0.0:
            self.bound = 2.0 * self.share * self.work / (-load * rate)

    def state(self) -> list:
        """The scalars a checkpoint keeps (NaN for no last step)."""
        last = self.last if self.last is not None else (math.nan,) * 3
        return [self.bound, self.most_tensile, self.work, *last]

    def restore(self, values):
        """Continue from :meth:`state`'s list."""
        self.bound, self.most_tensile, self.work = (float(v) for v in values[:3])
        last = tuple(float(v) for v in values[3:6])
        self.last = None if math.isnan(last[0]) else last
