"""One serial retraction through the Python API: steps, iterations, CPU seconds, pull-off.

    taskset -c 0 python scripts/retraction_cost.py maugis=7 modulus_ratio=0.1 velocity=4.5 \
        depth=0.1 cell=10 adhesion=5e-5 --numerics accuracy=5e-3

A value with commas is a list (``relaxation_moduli=3,6``). Settings for measurements of
the step itself, after the numerics: ``--linear-step`` (adaptive steps with the paper's
linear SLS step instead of the quadratic one), ``--lag-per-load X`` (the tip-lag bound's
constant, ``stepping.LAG_PER_LOAD`` for one relaxation time and ``LAG_PER_LOAD_SPECTRUM``
for several, set to X) and ``--planner FFTW_ESTIMATE`` (plans that do not depend on the
machine's timing, so that two codes or two runs compare step for step; FFTW_MEASURE by
default, as a run).

The iterations are split as the issue's count takes them: all of them over the accepted
steps, and of those the preload's, the rejected and abandoned attempts' and the last
step's (the snap-off's solve).
"""
import os
import sys
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
START = time.process_time()

from mpi4py import MPI  # noqa: E402

import hpcgfmd  # noqa: E402
from hpcgfmd.runs.protocol import Retraction  # noqa: E402
from hpcgfmd.solvers import stepping  # noqa: E402


def run_script(main, doc, argv):
    """A hand-parsed script's entry: ``--help`` prints ``doc``; a case or a value the script
    or hpcgfmd rejects ends in one line on stderr with status 2 (else 0)."""
    if {"-h", "--help"} & set(argv):
        print(doc)
        return 0
    try:
        main(argv)
    except ValueError as err:  # hpcgfmd's CaseError included
        print(f"{os.path.basename(sys.argv[0])}: error: {err}", file=sys.stderr)
        return 2
    return 0


def _pairs(items):
    out = {}
    for item in items:
        key, _, value = item.partition("=")
        if "," in value:
            out[key] = [float(v) for v in value.split(",")]
            continue
        try:
            out[key] = int(value)
        except ValueError:
            try:
                out[key] = float(value)
            except ValueError:
                out[key] = value
    return out


def main(argv):
    argv = list(argv)
    linear = "--linear-step" in argv
    if linear:
        argv.remove("--linear-step")
    if "--lag-per-load" in argv:
        at = argv.index("--lag-per-load")
        stepping.LAG_PER_LOAD = stepping.LAG_PER_LOAD_SPECTRUM = float(argv[at + 1])
        del argv[at:at + 2]
    planner = "FFTW_MEASURE"
    if "--planner" in argv:
        at = argv.index("--planner")
        planner = argv[at + 1]
        del argv[at:at + 2]
    cut = argv.index("--numerics") if "--numerics" in argv else len(argv)
    groups, numerics = _pairs(argv[:cut]), _pairs(argv[cut + 1:])
    if "relaxation_moduli" in groups:  # a Prony series: k follows from its moduli
        groups.setdefault("modulus_ratio", None)
    case = hpcgfmd.Case(**groups, numerics=numerics)
    sim = Retraction(case, MPI.COMM_SELF, planner_effort=planner)
    if linear:
        sim.quadratic_history = False
    loads = [sim.preload().load]
    accepted = last = 0  # iterations of the accepted solves, and of the last one
    while not sim.detached():
        record = sim.step()
        loads.append(record.load)
        accepted, last = accepted + record.iterations, record.iterations
    steps = sim.step_index
    rejected = sim.total_iterations - sim.preload_iterations - accepted
    print(f"nx {case.numerics.nx} steps {steps} rejected {sim.rejected_steps} iterations"
          f" {sim.total_iterations} ({sim.total_iterations / max(steps, 1):.2f} per step;"
          f" preload {sim.preload_iterations}, rejected attempts {rejected}, last step {last})"
          f" fft_pairs {sim.fft.pairs} cpu {time.process_time() - START:.1f} s"
          f" pull-off {min(loads) / case.load_scale:.5f}")
    sim.close()


if __name__ == "__main__":
    sys.exit(run_script(main, __doc__, sys.argv[1:]))
