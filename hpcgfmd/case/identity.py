"""The identity of a case: a hash of everything that determines its series.

A checkpoint and an output file store it; a restart, and the farm's skipping of finished
cases, compare it. The ``[output]`` settings are left out (they change what is written, not
the solution), and so is ``max_iterations``: the cap only ends a solve that has not
converged, which stops the run, so every step written is the same under any cap, and a run
stopped by its cap continues with a higher one.
"""

from __future__ import annotations

import hashlib
import json


def case_identity(case) -> str:
    """The 16 hex digits of the SHA-256 of ``case``'s groups, units, numerics (but the
    iteration cap), grid, solid, drive and protocol."""
    n = case.numerics
    content = {
        "groups": [
            case.maugis,
            case.modulus_ratio,
            case.velocity,
            case.depth,
            case.cell,
            case.adhesion,
        ],
        "units": [case.units.length, case.units.stress, case.units.time],
        "numerics": [
            n.nx,
            n.dt,
            n.tolerance,
            n.solver,
            n.step_control,
            n.dt_min,
            n.dt_max,
            n.edge_fraction,
            n.load_tolerance,
            n.time_tolerance,
            n.accuracy,
            [list(pair) for pair in n.solver_settings],
        ],
        "geometry": type(case.indenter()).__name__,
        "prony": [list(case.relaxation_moduli), list(case.relaxation_times)],
        "drive_stiffness": case.drive_stiffness if case.compliant else None,
        "protocol": [[s.kind, s.target, s.rate] for s in case.protocol],
    }
    if len(n.shape) > 1:  # a surface (a line's identity is the one it always had)
        content["grid"] = list(n.shape)
    return hashlib.sha256(json.dumps(content).encode()).hexdigest()[:16]
