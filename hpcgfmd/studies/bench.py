"""``python -m hpcgfmd bench [MODE] ...``: the measurements of docs/results.md.

Each mode makes one table of docs/results.md and prints, before it, the date, the machine and
the commit (:func:`hpcgfmd.studies.report.header`), and after it which targets are met or
missed (:func:`hpcgfmd.studies.report.verdict`). ``bench MODE --help`` says what a mode runs.
Without a mode (``bench --cases ...``) it is ``bench speed``. Every mode is collective over
the communicator it is given (``mpirun -n 2 python -m hpcgfmd bench fft``).
"""

from __future__ import annotations

import sys

from ..errors import CaseError


def _speed(comm, argv):
    from .benchmark import main

    return main(comm, argv, modes_help())


def _cases(comm, argv):
    from .cases import main

    return main(comm, argv)


def _accuracy(comm, argv):
    from .accuracy_study import main

    return main(comm, argv)


def _fft(comm, argv):
    from .transforms import main

    return main(comm, argv)


def _fft2d(comm, argv):
    from .transforms2d import main

    return main(comm, argv)


def _collectives(comm, argv):
    from .counts import collectives

    return collectives(comm, argv)


def _lag(comm, argv):
    from .counts import paper_lag

    return paper_lag(comm, argv)


def _convergence(comm, argv):
    from .convergence import convergence

    return convergence(comm, argv)


def _grid(comm, argv):
    from .convergence import grid_error

    return grid_error(comm, argv)


def _time_error(comm, argv):
    from .convergence import time_error

    return time_error(comm, argv)


def _farm(comm, argv):
    from .farm_throughput import main

    return main(comm, argv)


# mode: (its function, what its table holds)
MODES = {
    "speed": (
        _speed,
        ("speed against error: the fast solver and the paper's method (the default mode)"),
    ),
    "cases": (
        _cases,
        (
            "the paper's four cases at the default accuracy, each in its own"
            " process, and the default case on 2 ranks"
        ),
    ),
    "accuracy": (_accuracy, "the accuracy knob's validation: errors against converged runs"),
    "fft": (_fft, "one FFT pair: serial, four-step and halved transforms on the ranks given"),
    "fft2d": (_fft2d, "one 2-D FFT pair of an n x n grid: the slab transform on 1 and P ranks"),
    "collectives": (_collectives, "collective calls and FFT pairs per CG iteration"),
    "lag": (_lag, ("the paper's method: its lag behind the equilibrium against its pseudo steps")),
    "convergence": (_convergence, ("the paper's cases' pull-off on refined grids and fixed steps")),
    "grid": (_grid, "grid error of the pull-off on 1 to 16 points across the zone"),
    "time-error": (_time_error, "the time steps' error alone, on one fixed grid"),
    "farm": (_farm, "a farm of equal cases on 1 and on 2 ranks"),
}


def modes_help() -> str:
    """The modes and their tables, for ``--help``."""
    width = max(map(len, MODES))
    return "modes (bench MODE --help):\n" + "\n".join(
        f"  {name:<{width}}  {text}" for name, (_, text) in MODES.items()
    )


def main(comm, argv=None):
    """Collective: ``python -m hpcgfmd bench [MODE] ...``; the exit status (2, with one line,
    for a case that a run refuses, e.g. a cell too small for its contact: every rank raises
    it alike)."""
    argv = list(argv or [])
    mode = "bench"
    if argv and argv[0] in MODES:
        mode = f"bench {argv[0]}"
        function = MODES[argv[0]][0]
        argv = argv[1:]
    else:
        function = _speed
    try:
        return function(comm, argv)
    except CaseError as err:
        if comm.Get_rank() == 0:
            print(f"{mode}: {err}", file=sys.stderr)
        return 2
