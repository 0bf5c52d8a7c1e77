"""Which criterion sets each step of a retraction: the step control's verdicts, per tenth of
the retraction time.

    taskset -c 0 python scripts/step_binding.py maugis=14 modulus_ratio=0.1 velocity=0.9 \
        depth=0.1 cell=10 adhesion=5e-5 --numerics accuracy=5e-3

Runs the case serially through the Python API (as scripts/retraction_cost.py) and records
every verdict of :meth:`hpcgfmd.solvers.stepping.AdaptiveSteps.judge` with the ratio that set
the next step: the edge motion, the load's deviation (its square root), the history's (its
square root: own error or the kept errors' signed sum against what is left of their
allowance) or the tip's lag (the module docstring of :mod:`hpcgfmd.solvers.stepping`).
Prints, for the accepted steps of each tenth of the retraction's time, their number, mean
length and the count set by each criterion, and the rejected steps by criterion. Last, the
load criterion against node crossings: the median load-deviation ratio (deviation over
``load_tolerance``) of the accepted steps in which the number of nodes on the wall changed
and of the others (a crossing moves the load by a jump of the discrete solution, which no
shorter step removes).
"""
import collections
import math
import os
import statistics
import sys

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from mpi4py import MPI  # noqa: E402

import hpcgfmd  # noqa: E402
from hpcgfmd.runs.protocol import Retraction  # noqa: E402
from retraction_cost import _pairs, run_script  # noqa: E402


def binding(decision):
    """The criterion whose ratio set the next step (as AdaptiveSteps.judge sizes it)."""
    ratios = {"edge": decision.edge_error, "load": math.sqrt(decision.load_error),
              "history": math.sqrt(max(decision.history_error, 0.0)),
              "lag": decision.lag_error}
    return max(ratios, key=ratios.get)


def main(argv):
    cut = argv.index("--numerics") if "--numerics" in argv else len(argv)
    case = hpcgfmd.Case(**_pairs(argv[:cut]), numerics=_pairs(argv[cut + 1:]))
    sim = Retraction(case, MPI.COMM_SELF)
    if not sim.steps.adaptive:
        sys.exit("step_binding: the case has fixed steps")
    verdicts = []
    judge = sim.steps.judge

    def recorded(dt, time, *args, **kwargs):
        decision = judge(dt, time, *args, **kwargs)
        verdicts.append((time, dt, decision.accepted, binding(decision), decision.load_error))
        return decision

    def on_wall():
        return sim.domain.sum(float((sim.wall - sim.u <= 0.0).sum()))

    sim.steps.judge = recorded
    sim.preload()
    crossing, smooth = [], []
    nodes = on_wall()
    while not sim.detached():
        sim.step()
        now = on_wall()
        (crossing if now != nodes else smooth).append(verdicts[-1][4])
        nodes = now
    sim.close()
    accepted = [v for v in verdicts if v[2]]
    end = accepted[-1][0]
    print(f"nx {case.numerics.nx} steps {sim.step_index} rejected {sim.rejected_steps}")
    for tenth in range(10):
        low, high = tenth * end / 10, (tenth + 1) * end / 10
        chosen = [v for v in accepted if low <= v[0] < high or (tenth == 9 and v[0] == end)]
        if chosen:
            counts = dict(collections.Counter(v[3] for v in chosen))
            mean = sum(v[1] for v in chosen) / len(chosen)
            print(f"t in [{low:.4g}, {high:.4g}): {len(chosen)} steps, mean dt {mean:.3g},"
                  f" set by {counts}")
    rejected = collections.Counter(v[3] for v in verdicts if not v[2])
    print(f"rejected, by the criterion that shortened them: {dict(rejected)}")
    for label, ratios in (("with", crossing), ("without", smooth)):
        if ratios:
            print(f"{len(ratios)} steps {label} a node crossing onto or off the wall: median load"
                  f" deviation {statistics.median(ratios):.3g} of load_tolerance")


if __name__ == "__main__":
    sys.exit(run_script(main, __doc__, sys.argv[1:]))
