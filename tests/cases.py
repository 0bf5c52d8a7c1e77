"""The small fast case the parallel, farm and SLURM tests share.

lambda0 = 3.5, k = 0.1, V_z = 1 on a cell of L/R = 2 at h0/R = 0.03 (alpha = 1e-4): about
217 steps, 1-6 s on one core for nx = 2048-8192 (measured), with a real viscoelastic
retraction (pull-off, jumps) to compare between runs.
"""

GROUPS = {"maugis": 3.5, "modulus_ratio": 0.1, "velocity": 1.0, "depth": 0.03, "cell": 2.0,
          "adhesion": 1e-4}


def case_text(numerics="nx = 2048", output="", prefix=""):
    """A case file of :data:`GROUPS`; ``prefix = "base."`` gives a sweep file's base."""
    groups = "".join(f"{key} = {value!r}\n" for key, value in GROUPS.items())
    text = f"[{prefix}case]\n{groups}[{prefix}numerics]\n{numerics}\n"
    return text + (f"[{prefix}output]\n{output}\n" if output else "")


def pull_off_run(text):
    """A whole serial retraction of the case file ``text``: (pull-off Lbar, the finished run).

    The pull-off is the most tensile load over the run (preload included) in load scales.
    """
    from mpi4py import MPI

    from hpcgfmd.config import parse_case
    from hpcgfmd.driver import Retraction

    case = parse_case(text)
    sim = Retraction(case, MPI.COMM_SELF, planner_effort="FFTW_ESTIMATE")
    loads = [sim.preload().load]
    while not sim.detached():
        loads.append(sim.step().load)
    sim.close()
    return min(loads) / case.load_scale, sim
