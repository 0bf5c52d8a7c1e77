"""Fuzz the case parser and the sweep parser on demand (the properties of tests/test_fuzz.py).

    python scripts/fuzz.py --examples 10000            # both parsers, 10,000 inputs each
    python scripts/fuzz.py --examples 50000 --parser sweep

Runs the same hypothesis properties as the test suite (fixed seed: derandomized) with another
budget and prints, per parser, the number of inputs tried and how many were valid and
invalid. Exits 1 with hypothesis's shrunk counterexample when an input is neither parsed nor
rejected with a one-line CaseError / SweepError. Needs hypothesis (pip install 'hpcgfmd[test]').
"""

import argparse
import os
import sys
import tempfile
import time
import traceback

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--examples", type=int, default=10_000, help="inputs per parser (default 10000)"
    )
    parser.add_argument("--parser", choices=("case", "sweep", "both"), default="both")
    args = parser.parse_args(argv)
    os.environ["HPCGFMD_FUZZ_EXAMPLES"] = str(args.examples)  # read when test_fuzz is imported
    sys.path[:0] = [ROOT, os.path.join(ROOT, "tests")]
    import test_fuzz

    status = 0
    for name in ("case", "sweep") if args.parser == "both" else (args.parser,):
        start = time.perf_counter()
        try:
            if name == "case":
                test_fuzz.test_case_parser_fuzz()
            else:
                with tempfile.TemporaryDirectory(prefix="hpcgfmd-fuzz-") as directory:
                    test_fuzz.make_sweep_directory(directory)
                    test_fuzz.test_sweep_parser_fuzz(directory)
            verdict = "ok"
        except Exception:  # hypothesis's report of the shrunk failing input
            traceback.print_exc()
            verdict, status = "FAILED", 1
        counts = test_fuzz.OUTCOMES[name]
        print(
            f"{name} parser: {sum(counts.values())} inputs tried, {counts['valid']} valid,"
            f" {counts['invalid']} invalid (rejected with one line); {verdict}"
            f" ({time.perf_counter() - start:.0f} s)",
            flush=True,
        )
    return status


if __name__ == "__main__":
    sys.exit(main())
