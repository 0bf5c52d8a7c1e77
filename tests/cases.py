"""The builders of case files for the tests (the [case] and the [physical] form), the small
fast case they share, and real stop signals sent in a given phase of a run.

:data:`GROUPS`: lambda0 = 3.5, k = 0.1, V_z = 1 on a cell of L/R = 2 at h0/R = 0.03
(alpha = 1e-4): about 217 steps, 1-6 s on one core for nx = 2048-8192, with a real
viscoelastic retraction (pull-off, jumps) to compare between runs.
"""

import os
import signal

from hpcgfmd.signals import StopSignals
from hpcgfmd.storage.result_file import ResultFile

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


class StopAtStep(StopSignals):
    """The process's real stop signals, and a real signal sent to this process while the run
    writes step k's entry of the result file (the output phase): the run then stops with the
    checkpoint of step k. A context manager, as :class:`~hpcgfmd.signals.StopSignals`."""

    def __init__(self, k, signum=signal.SIGUSR1):
        self.k, self.signum = k, signum

    def __enter__(self):
        original = self._original = ResultFile.append_step
        k, signum = self.k, self.signum

        def append_step(result_file, values):
            original(result_file, values)
            if result_file.file["series"]["time"].shape[0] == k + 1:  # entry k: step k
                os.kill(os.getpid(), signum)

        ResultFile.append_step = append_step
        return super().__enter__()

    def __exit__(self, *exc):
        ResultFile.append_step = self._original
        return super().__exit__(*exc)


class SignalInPhase(StopSignals):
    """The process's real stop signals, and a real signal sent to this process once, from the
    first solver iteration of the first phase whose name starts with ``phase``
    (:class:`hpcgfmd.runs.watch.Watch`: "preload, level 1 of 2 ...", "solve of step 5"), or
    while the transforms are planned (``phase = "planning"``)."""

    def __init__(self, phase, signum=signal.SIGUSR1):
        self.phase, self.signum = phase, signum

    def __enter__(self):
        import hpcgfmd.runs.protocol as protocol
        from hpcgfmd.runs.watch import Watch

        self._restore = [
            (Watch, "beat", Watch.beat),
            (protocol, "plan_real_fft", protocol.plan_real_fft),
        ]
        phase, signum, sent = self.phase, self.signum, []

        def send():
            if not sent:
                sent.append(True)
                os.kill(os.getpid(), signum)

        beat, plan = Watch.beat, protocol.plan_real_fft

        def beat_and_signal(watch, iteration, residual=None):
            if watch.phase.startswith(phase):
                send()
            beat(watch, iteration, residual)

        def plan_and_signal(*args, **kwargs):
            fft = plan(*args, **kwargs)
            if phase == "planning":
                send()
            return fft

        Watch.beat, protocol.plan_real_fft = beat_and_signal, plan_and_signal
        self.sent = sent
        return super().__enter__()

    def __exit__(self, *exc):
        for owner, name, value in self._restore:
            setattr(owner, name, value)
        return super().__exit__(*exc)


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


def sphere_case(n, numerics=None, **groups):
    """A sphere's :class:`~hpcgfmd.case.case.Case` on n x n at accuracy 2e-2: lambda0 = 3,
    elastic, V_z = 1, h0/R = 0.01 on L/R = 0.894 (alpha = 1e-3; the knob's cell, 4.4 a0),
    changed by ``groups`` and the ``numerics`` keys."""
    from hpcgfmd.case.case import Case

    values = {
        "maugis": 3.0,
        "modulus_ratio": 1.0,
        "velocity": 1.0,
        "depth": 0.01,
        "cell": 0.894,
        "adhesion": 1e-3,
        **groups,
    }
    return Case(
        geometry="sphere", numerics={"n": n, "accuracy": 2e-2, **(numerics or {})}, **values
    )


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
