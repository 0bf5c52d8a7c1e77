"""The time error of SLS steps of first and second order in time, on one grid (a measurement of
a scheme the package does not use).

    taskset -c 0 python scripts/second_order_history.py maugis=7 modulus_ratio=0.1 \
        velocity=0.045 depth=0.1 cell=4 adhesion=5e-5 --nx 16384 --reference-dt 0.125 \
        --dt 2 1 0.5 --adaptive linear:accuracy=5e-3 implicit:accuracy=5e-3

The package's SLS step (docs/model.md, (M8)) is exact for u linear in time within a step;
near a moving contact edge u is curved in time and the step's traction lags. Three schemes:

- ``linear``: the package's step. With fixed steps nothing more (no history estimate); with
  adaptive steps the package as it is: the history estimate's correction after each step
  (``HistoryError.correct``) makes the history second order, the step's own equilibrium stays
  first order;
- ``corrected`` (fixed steps only): the linear step, and after each step the traction missed
  by u quadratic through u_{n-1}, u_n, u_{n+1} added to the history, as the adaptive steps'
  correction does (here on every node, without its crossing rules);
- ``implicit``: the step's equilibrium itself with u quadratic through u_{n-1}, u_n and the
  unknown u_{n+1}. The missed traction (|q|/2) (Einf - E0) F(dt) c, with
  c = ((u_{n+1} - u_n) / dt - (u_n - u_{n-1}) / h) / (dt + h) (h the step before), is linear
  in u_{n+1}: the step stays an elastic problem, of modulus Eeff + R / (dt (dt + h)),
  R = (Einf - E0) F(dt), with the history term -R (G_n / (dt (dt + h)) + (G_n - G_{n-1}) /
  (h (dt + h))), G = (|q|/2) u kept in real space as the package keeps G_n. With adaptive
  steps the history estimate's correction is not added (the step holds it) and the step
  control is the package's, unchanged (its history estimate then overstates the step's
  error, and its tip-lag criterion is the linear step's).

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
from hpcgfmd.model.material import (StepOperators, ViscoelasticHalfSpace,  # noqa: E402
                                    curvature_integral)
from hpcgfmd.runs.protocol import Retraction  # noqa: E402

SCHEMES = ("linear", "corrected", "implicit")


class CurvedHistorySLS(ViscoelasticHalfSpace):
    """The SLS half-space with the ``corrected`` or ``implicit`` quadratic-in-time step
    (module docstring); the first step after the preload is the linear one.

    ``sim``: the Retraction, whose last accepted step length is h; G_{n-1} is then one more
    state field, undone with a rejected step.
    """

    def __init__(self, sim, scheme):
        base = sim.substrate
        super().__init__(base.material, base.half_q, base.n, base.relaxed_traction.size)
        self.sim, self.scheme = sim, scheme
        self.previous = np.zeros_like(self.relaxed_traction)  # G_{n-1}
        m = self.material
        self._missed = lambda dt: (m.e_instantaneous - m.e_relaxed) * curvature_integral(
            dt, m.relaxation_time)
        self._implicit_ops = {}

    @property
    def h(self):
        """Length of the last accepted step (None after the preload: no G_{n-1})."""
        return self.sim.dt_previous

    def _implicit(self, dt):
        return self.scheme == "implicit" and self.h is not None and math.isfinite(dt)

    def _extra(self, dt):
        return self._missed(dt) / (dt * (dt + self.h))

    def operators(self, dt):
        ops = super().operators(dt)
        if not self._implicit(dt):
            return ops
        key = (dt, self.h)
        if key not in self._implicit_ops:
            modulus = self._e_eff + self._extra(dt)
            self._implicit_ops[key] = StepOperators.from_modulus(self.half_q, modulus, self.n)
        return self._implicit_ops[key]

    def history(self, fft, u, substrate_traction, dt, out):
        super().history(fft, u, substrate_traction, dt, out)
        if self._implicit(dt):
            r, h = self._missed(dt), self.h
            out -= (r / (dt * (dt + h))) * self.relaxed_traction
            out -= (r / (h * (dt + h))) * (self.relaxed_traction - self.previous)
        return out

    def state_elastic_traction(self, dt, out):
        super().state_elastic_traction(dt, out)
        if self._implicit(dt):
            out += self._extra(dt) * self.relaxed_traction
        return out

    def update(self, elastic_traction, history, dt, substrate_traction):
        implicit = self._implicit(dt)
        modulus = (self._e_eff + self._extra(dt)) if implicit else None
        before = self.relaxed_traction.copy()
        super().update(elastic_traction, history, dt, substrate_traction)
        if implicit:  # G_{n+1} = K' u_{n+1} / Eeff'
            np.multiply(elastic_traction, 1.0 / modulus, out=self.relaxed_traction)
        elif self.scheme == "corrected" and self.h is not None and math.isfinite(dt):
            h = self.h
            curvature = ((self.relaxed_traction - before) / dt
                         - (before - self.previous) / h) / (dt + h)
            substrate_traction += self._missed(dt) * curvature
        self.previous[:] = before

    def correct(self, missed, dt, substrate_traction):
        """The history estimate's correction (adaptive steps): held by the implicit step."""
        if self.scheme != "implicit":
            substrate_traction += missed

    def field_names(self):
        return ("relaxed_traction", "relaxed_previous")

    def fields(self):
        return {"relaxed_traction": self.relaxed_traction, "relaxed_previous": self.previous}

    def restore(self, fields, fft=None, u=None):
        super().restore(fields, fft, u)
        self.previous[:] = fields["relaxed_previous"]


def retraction(case_keys, nx, numerics, scheme):
    """A retraction to the pull-off: (times, loads in load scales, CPU s, steps, rejected)."""
    start = time.process_time()
    case = hpcgfmd.Case(**case_keys, numerics={"nx": nx, **numerics})
    sim = Retraction(case, MPI.COMM_SELF)
    sim.substrate = CurvedHistorySLS(sim, scheme)
    if sim.history_window is not None:
        sim.history_window.error.substrate = sim.substrate
    sim._reverted += ("relaxed_previous",)  # undone with a rejected step, as G_n
    sim._saved["relaxed_previous"] = np.empty(sim.domain.local_n)
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
