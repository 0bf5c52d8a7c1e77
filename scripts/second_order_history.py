"""The time error of SLS steps of first and second order in time, on one grid.

    taskset -c 0 python scripts/second_order_history.py maugis=7 modulus_ratio=0.1 \
        velocity=0.045 depth=0.1 cell=4 adhesion=5e-5 --nx 16384 --reference-dt 0.125 \
        --dt 2 1 0.5 --adaptive linear:accuracy=5e-3 implicit:accuracy=5e-3

The SLS step of the paper (docs/model.md, (M8)) is exact for u linear in time within a step;
near a moving contact edge u is curved in time and the step's traction lags. Three schemes:

- ``linear``: the paper's step (M8), which fixed steps take. With adaptive steps, the history
  estimate's correction after each step (``HistoryError.correct``) makes the history second
  order, the step's own equilibrium stays first order (the package's adaptive steps before
  the quadratic step; the step control is today's);
- ``corrected`` (fixed steps only): the linear step, and after each step the traction missed
  by u quadratic through u_{n-1}, u_n, u_{n+1} added to the history, as the adaptive steps'
  correction does (here on every node, without its crossing rules);
- ``implicit``: the quadratic step (M46), the step's equilibrium itself with u quadratic
  through u_{n-1}, u_n and the unknown u_{n+1}, which adaptive steps take.

``--dt``: fixed steps of these lengths (time units of tau); ``--adaptive``: adaptive runs, each
``scheme:key=value,...`` with [numerics] keys (``time_tolerance`` scales the history and
tip-lag criteria). Every run goes to the pull-off and is compared with the ``implicit`` scheme
at fixed ``--reference-dt`` on the same grid (the grid's error cancels): the pull-off's
relative error, and for fixed steps also the largest load difference at equal times up to the
reference's pull-off, over the pull-off load (the curve error at equal times). One line per
run.
"""
import argparse
import math
import os
import sys
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402

import hpcgfmd  # noqa: E402
from hpcgfmd.model.material import ViscoelasticHalfSpace  # noqa: E402
from hpcgfmd.runs.protocol import Retraction  # noqa: E402

SCHEMES = ("linear", "corrected", "implicit")


class CorrectedSLS(ViscoelasticHalfSpace):
    """The linear SLS step and, after each step, the traction (Einf - E0) F(dt) c that u
    quadratic through G_{n-1}, G_n, G_{n+1} adds, added to p (the ``corrected`` scheme).

    ``sim``: the Retraction, whose last accepted step length is h (None after the preload).
    """

    def __init__(self, sim):
        base = sim.substrate
        super().__init__(base.material, base.half_q, base.n, base.relaxed_traction.size)
        self.sim = sim

    def update(self, elastic_traction, history, dt, substrate_traction, step_before=None):
        older = self.relaxed_before.copy()  # G_{n-1}
        super().update(elastic_traction, history, dt, substrate_traction, step_before)
        h = self.sim.dt_previous
        if h is not None and math.isfinite(dt):  # G_n is now relaxed_before
            before = self.relaxed_before
            curvature = ((self.relaxed_traction - before) / dt - (before - older) / h) / (dt + h)
            substrate_traction += self.material.curvature_response(dt) * curvature


def retraction(case_keys, nx, numerics, scheme):
    """A retraction to the pull-off: (times, loads in load scales, CPU s, steps, rejected)."""
    start = time.process_time()
    case = hpcgfmd.Case(**case_keys, numerics={"nx": nx, **numerics})
    sim = Retraction(case, MPI.COMM_SELF)
    sim.quadratic_history = scheme == "implicit"  # (fixed steps take the linear one)
    if scheme == "corrected":
        sim.substrate = CorrectedSLS(sim)
    record = sim.preload()
    times, loads = [record.time], [record.load / case.load_scale]
    while not sim.detached():
        record = sim.step()
        times.append(record.time)
        loads.append(record.load / case.load_scale)
    sim.close()
    return (np.array(times), np.array(loads), time.process_time() - start, sim.step_index,
            sim.rejected_steps)


def _numerics(text):
    """``key=value,...`` as a dict of numbers."""
    return {key: float(value) for key, _, value in
            (item.partition("=") for item in text.split(",") if item)}


def main(argv):
    parser = argparse.ArgumentParser(prog="scripts/second_order_history.py",
                                     description=__doc__.split("\n")[0])
    parser.add_argument("case", nargs="+", help="[case] keys, key=value")
    parser.add_argument("--nx", type=int, required=True)
    parser.add_argument("--reference-dt", type=float, required=True)
    parser.add_argument("--dt", type=float, nargs="+", default=[])
    parser.add_argument("--schemes", nargs="+", default=list(SCHEMES), choices=SCHEMES,
                        help="the schemes of the fixed steps")
    parser.add_argument("--adaptive", nargs="+", default=[], metavar="SCHEME:KEYS")
    args = parser.parse_args(argv)
    for item in args.adaptive:
        if item.partition(":")[0] not in ("linear", "implicit"):
            parser.error(f"--adaptive {item}: expected linear:... or implicit:...")
    keys = _numerics(",".join(args.case))
    ref_t, ref_l, ref_cpu, ref_steps, _ = retraction(
        keys, args.nx, {"step_control": "fixed", "dt": args.reference_dt}, "implicit")
    pull_off = ref_l.min()
    print(f"reference implicit dt {args.reference_dt:g}: {ref_steps} steps, pull-off"
          f" {pull_off:.6f}, {ref_cpu:.1f} CPU s", flush=True)
    for scheme in args.schemes if args.dt else ():
        for dt in args.dt:
            t, loads, cpu, steps, _ = retraction(
                keys, args.nx, {"step_control": "fixed", "dt": dt}, scheme)
            # equal times before the reference's pull-off (after it, a pull-off a little
            # earlier or later differs by the whole load)
            common = np.searchsorted(ref_t, t[t <= ref_t[np.argmin(ref_l)]])
            matched = np.isclose(ref_t[np.minimum(common, ref_t.size - 1)], t[:common.size],
                                 rtol=0, atol=1e-9 * max(1.0, t[-1]))
            curve = np.max(np.abs(loads[:common.size][matched] - ref_l[common[matched]]))
            print(f"{scheme:9s} dt {dt:g}: {steps} steps, pull-off {loads.min():.6f}"
                  f" error {abs(loads.min() / pull_off - 1):.2e}, curve at equal times"
                  f" {curve / abs(pull_off):.2e}, {cpu:.1f} CPU s", flush=True)
    for item in args.adaptive:
        scheme, _, text = item.partition(":")
        _, loads, cpu, steps, rejected = retraction(keys, args.nx, _numerics(text), scheme)
        print(f"{scheme:9s} adaptive {text}: {steps} steps ({rejected} rejected), pull-off"
              f" {loads.min():.6f} error {abs(loads.min() / pull_off - 1):.2e},"
              f" {cpu:.1f} CPU s", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
