"""The builders of case files for the tests (the [case] and the [physical] form), the small
fast case they share, and a stop flag that interrupts a run after a given step.

:data:`GROUPS`: lambda0 = 3.5, k = 0.1, V_z = 1 on a cell of L/R = 2 at h0/R = 0.03
(alpha = 1e-4): about 217 steps, 1-6 s on one core for nx = 2048-8192, with a real
viscoelastic retraction (pull-off, jumps) to compare between runs.
"""

GROUPS = {
    "maugis": 3.5,
    "modulus_ratio": 0.1,
    "velocity": 1.0,
    "depth": 0.03,
    "cell": 2.0,
    "adhesion": 1e-4,
}
# The [physical] form of an SLS case (lambda0 = 7.0 at these values; tau = 1 s, R = 1 mm), in SI,
# as the TOML spells them
PHYSICAL_VALUES = {
    "radius": "1e-3",
    "modulus_relaxed": "1e6",
    "modulus_instantaneous": "1e7",
    "relaxation_time": "1.0",
    "work_of_adhesion": "0.05",
    "interaction_range": "1.94e-7",
    "velocity": "1e-6",
    "depth": "1e-4",
    "cell_length": "1e-2",
}
# Numerics lines for runs compared across rank counts or a restart to round-off: adaptive steps
# follow round-off differences in the loads (another rank count picks other steps now and then),
# fixed steps do not.
FIXED_STEPS = 'step_control = "fixed"\n'


class StopAtStep:
    """A stop flag in place of the run's StopSignals, raised once the run has looked at it k
    times: it looks once after the preload and once after each step, so the run stops (with
    a checkpoint) after step k."""

    def __init__(self, k):
        self.k, self.looks = k, 0

    @property
    def received(self):
        self.looks += 1
        return 10 if self.looks > self.k else None


def case_text(numerics="nx = 2048", output="", prefix="", **groups):
    """A case file of :data:`GROUPS` changed by ``groups``.

    A value of None leaves the key out; a string is written as it is (so a test can write
    ``maugis='"seven"'``). ``numerics`` and ``output`` are the sections' lines;
    ``prefix = "base."`` gives a sweep file's base.
    """
    values = {**GROUPS, **groups}
    body = "".join(
        f"{key} = {value if isinstance(value, str) else repr(value)}\n"
        for key, value in values.items()
        if value is not None
    )
    text = f"[{prefix}case]\n{body}[{prefix}numerics]\n{numerics}\n"
    return text + (f"[{prefix}output]\n{output}\n" if output else "")


def physical_text(numerics="", output="", **values):
    """A case file in the [physical] form: :data:`PHYSICAL_VALUES` changed by ``values``.

    As :func:`case_text`: a value of None leaves the key out, a string is written as it is.
    ``numerics`` and ``output`` are the sections' lines; an empty one leaves its section out, so
    without them the text ends inside [physical] and a test may append keys to it.
    """
    values = {**PHYSICAL_VALUES, **values}
    body = "".join(
        f"{key} = {value if isinstance(value, str) else repr(value)}\n"
        for key, value in values.items()
        if value is not None
    )
    text = f"[physical]\n{body}"
    text += f"[numerics]\n{numerics}\n" if numerics else ""
    return text + (f"[output]\n{output}\n" if output else "")


PHYSICAL = physical_text()


def whole_run(text):
    """A whole serial retraction of the case file ``text``: (its step records, preload
    first, and the finished run, closed)."""
    from mpi4py import MPI

    from hpcgfmd.case import parse_case
    from hpcgfmd.runs.protocol import Retraction

    sim = Retraction(parse_case(text), MPI.COMM_SELF, planner_effort="FFTW_ESTIMATE")
    try:
        records = [sim.preload()]
        while not sim.finished():
            records.append(sim.step())
    finally:
        sim.close()
    return records, sim


def pull_off_run(text):
    """A whole serial retraction of the case file ``text``: (pull-off Lbar, the finished run).

    The pull-off is the most tensile load over the run (preload included) in load scales.
    """
    from hpcgfmd.case import parse_case

    records, sim = whole_run(text)
    return min(r.load for r in records) / parse_case(text).load_scale, sim
