"""The time steps' error alone: one case on one fixed grid, several step settings against a
reference setting on the same grid (pull-off and curve errors as in docs/results.md).

    taskset -c 0 python scripts/time_error.py maugis=7 modulus_ratio=0.1 velocity=0.045 \
        depth=0.1 cell=10 adhesion=5e-5 --nx 32768 \
        --reference accuracy=1e-3 dt_max=0.25 --runs accuracy=5e-3 accuracy=1e-2

Each ``--runs`` item is one run, its numerics keys joined by commas (``accuracy=5e-3,dt_max=1``);
the grid is ``--nx`` for all, so that the grid's error cancels. Prints one line per run:
steps, CPU seconds, pull-off Lbar, its relative error, and the curve error.
"""
import argparse
import os
import sys

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from mpi4py import MPI  # noqa: E402

from hpcgfmd.studies import benchmark  # noqa: E402


def _value(text):
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def _keys(items):
    return {key: _value(value) for key, _, value in (item.partition("=") for item in items)}


def main(argv):
    parser = argparse.ArgumentParser(prog="scripts/time_error.py",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("case", nargs="+", help="[case] keys, key=value")
    parser.add_argument("--nx", type=int, required=True)
    parser.add_argument("--reference", nargs="+", required=True, help="numerics key=value")
    parser.add_argument("--runs", nargs="+", required=True,
                        help="one run each: numerics key=value joined by commas")
    args = parser.parse_args(argv)
    case = _keys(args.case)
    maugis, velocity = case.pop("maugis"), case.pop("velocity")

    def run(numerics):
        text = benchmark.case_text(maugis, velocity, {"nx": args.nx, **numerics}, case)
        return benchmark.run(text, MPI.COMM_SELF)

    reference = run(_keys(args.reference))
    converged = reference["lbar"].min()
    print(f"reference {' '.join(args.reference)}: {reference['steps']} steps,"
          f" {reference['cpu_s']:.1f} CPU s, pull-off {converged:.5f}")
    for item in args.runs:
        result = run(_keys(item.split(",")))
        pull_off = result["lbar"].min()
        print(f"{item}: {result['steps']} steps, {result['cpu_s']:.1f} CPU s,"
              f" pull-off {pull_off:.5f}, error {abs(pull_off / converged - 1):.1e},"
              f" curve error {benchmark.curve_error(reference, result):.1e}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
