"""Grid error of the pull-off on grids of 1, 2, 4, 8 and 16 points across the relaxed zone.

    taskset -c 0 python scripts/grid_error.py 1:0.1:0.1:0.1 3.5:0.1:0.01:0.1

Each case LAMBDA0:K:VZ:H0 (L/R = 8 sqrt(2 h0/R), alpha = 5e-5, or a fifth field for L/R) is run
serially with its steps at accuracy 1e-3 (nx given) on the smallest powers of two with at least
1, 2, 4, 8, 16 points across w (up to 2^17); the error of each grid is its pull-off's distance
to the finest one's, relative. One line per case: w/dx:error(steps, CPU s, zone at the
pull-off in units of w). The finest grid's own error is not in the figures: they are lower
bounds on the coarse grids' errors where convergence is slow.
"""
import math
import os
import sys
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from mpi4py import MPI  # noqa: E402

import hpcgfmd  # noqa: E402
from hpcgfmd.runs.protocol import Retraction  # noqa: E402

POINTS = (1, 2, 4, 8, 16)
LARGEST = 2 ** 17


def pull_off(groups, nx):
    """(pull-off Lbar, steps, CPU s, cohesive-zone width at the pull-off / w) on nx nodes."""
    case = hpcgfmd.Case(**groups, numerics={"accuracy": 1e-3, "nx": nx})
    start = time.process_time()
    sim = Retraction(case, MPI.COMM_SELF)
    records = [sim.preload()]
    while not sim.detached():
        records.append(sim.step())
    sim.close()
    low = min(records, key=lambda r: r.load)
    zone = (low.cohesive_half_width - low.contact_half_width) / case.zone_width
    return low.load / case.load_scale, sim.step_index, time.process_time() - start, zone


def main(argv):
    for spec in argv:
        fields = [float(v) for v in spec.split(":")]
        lambda0, k, vz, depth = fields[:4]
        cell = fields[4] if len(fields) > 4 else round(8.0 * math.sqrt(2.0 * depth), 3)
        groups = dict(maugis=lambda0, modulus_ratio=k, velocity=vz, depth=depth, cell=cell,
                      adhesion=5e-5)
        width = hpcgfmd.Case(**groups).zone_width
        grids = sorted({2 ** max(6, math.ceil(math.log2(p * cell / width))) for p in POINTS})
        runs = [(nx, *pull_off(groups, nx)) for nx in grids if nx <= LARGEST]
        finest = runs[-1][1]
        chi = hpcgfmd.Case(**groups).chi_ve
        print(f"{spec} (chi_ve/k = {chi / k:.3g}): " + "  ".join(
            f"{width / (cell / nx):.2f}:{abs(load / finest - 1):.1e}({steps},{cpu:.0f}s,"
            f"z{zone:.1f})" for nx, load, steps, cpu, zone in runs), flush=True)


if __name__ == "__main__":
    from retraction_cost import run_script

    sys.exit(run_script(main, __doc__, sys.argv[1:]))
