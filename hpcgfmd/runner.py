"""One case from a validated :class:`~hpcgfmd.config.Case` to a finished HDF5 file."""
from __future__ import annotations

import time

from .config import TARGET_ZONE_POINTS, Case, CaseError
from .driver import Progress, Retraction
from .output import CaseFile

# The indenter must have left the surface long before it is one radius above it.
MAX_INDENTER_HEIGHT = 1.0
# After the preload the cohesive zone must stay within a quarter of the cell: beyond that the
# periodic images change the load by more than about 10 % (physics.md numerical notes).
MAX_ZONE_PER_CELL = 0.25


class SnapshotSchedule:
    """Decides at which steps full profiles are written (``[output]`` of the case)."""

    def __init__(self, output):
        self.times = list(output.snapshot_times)
        self.widths = list(output.snapshot_contact_widths)  # descending
        self.zero_load = output.snapshot_zero_load

    def due(self, record) -> bool:
        """True (once per trigger) when a requested time, width or zero load is reached."""
        hit = False
        while self.times and record.time >= self.times[0]:
            self.times.pop(0)
            hit = True
        while self.widths and record.contact_half_width <= self.widths[0]:
            self.widths.pop(0)
            hit = True
        if self.zero_load and record.time > 0 and record.load <= 0.0:
            self.zero_load = False
            hit = True
        return hit


def describe(case: Case) -> str:
    """The derived groups and numerics, printed at start."""
    g = case.groups()
    u = case.units
    auto = (f" (chosen automatically: the smallest power of two with w/dx >= {TARGET_ZONE_POINTS:g})"
            if case.numerics.nx_automatic else "")
    lines = [f"lambda0 = {g['lambda0']:.6g}   lambda_inf = {g['lambda_inf']:.6g}   k = {g['k']:.6g}"
             f"   V_z = {g['Vz']:.6g}   chi_ve = {g['chi_ve']:.6g}   alpha = {g['alpha']:.6g}",
             f"h0/R = {g['depth']:.6g}   L/R = {g['cell']:.6g}   beta = {case.beta * u.length:.6g}"
             f"   load scale = {case.load_scale * u.load:.6g}   w/dx = {g['zone_points']:.3g}",
             f"nx = {case.numerics.nx}{auto}"
             f"   dt = {case.numerics.dt * u.time:.6g}   tolerance = {case.numerics.tolerance:g}"]
    return "\n".join(lines)


def run_case(case: Case, path, printer=print, overwrite=False) -> dict:
    """Run the whole retraction of ``case`` into a new HDF5 file at ``path``.

    The preload is solved before the file is created: a contact too large for the cell is
    reported as a :class:`CaseError` with no file touched. ``overwrite`` replaces an existing
    file (only once the preload succeeded). Returns the summary stored in the file.
    """
    start = time.monotonic()
    sim = Retraction(case)
    record = sim.preload()
    if record.cohesive_half_width > MAX_ZONE_PER_CELL * case.cell:
        need = record.cohesive_half_width / MAX_ZONE_PER_CELL
        raise CaseError(f"{case.cell_key()} = {case.cell * case.units.length:g}: too small for"
                        f" the contact; after the preload the cohesive zone reaches a_a ="
                        f" {record.cohesive_half_width * case.units.length:.4g}, more than"
                        f" {MAX_ZONE_PER_CELL:g} L; need L >= {need * case.units.length:.4g}")
    out = CaseFile(path, case, sim.x, overwrite=overwrite)
    try:
        schedule = SnapshotSchedule(case.output)
        progress = Progress(case.output.progress_interval, printer)
        out.append_step(record.as_dict())
        out.add_snapshot(record.time, sim.u, sim.traction, sim.gap())
        schedule.due(record)
        while not sim.detached():
            record = sim.step()
            out.append_step(record.as_dict())
            if schedule.due(record):
                out.add_snapshot(record.time, sim.u, sim.traction, sim.gap())
            progress.update(sim.step_index, record, case.units)
            if sim.indenter > MAX_INDENTER_HEIGHT:
                raise RuntimeError(f"no complete detachment by u_z = {MAX_INDENTER_HEIGHT} R")
        out.add_snapshot(record.time, sim.u, sim.traction, sim.gap())
        summary = {"steps": sim.step_index, "iterations": sim.total_iterations,
                   "fft_pairs": sim.fft.pairs, "wall_time": time.monotonic() - start,
                   "projections": sim.solver.projections,
                   "residual_steps": sim.solver.residual_steps,
                   "cut_steps": sim.solver.cut_steps,
                   "rejected_predictions": sim.rejected_predictions,
                   "moving_edge_predictions": sim.predictor_choice[1],
                   "detachment_indenter": sim.indenter * case.units.length,
                   "detachment_time": sim.time * case.units.time}
        out.finish(summary)
    finally:
        out.close()
    return summary
