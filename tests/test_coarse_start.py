"""The preload's coarse-to-fine start (hpcgfmd/runs/coarse_start.py)."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from cases import case_text
from hpcgfmd.case import parse_case
from hpcgfmd.runs import coarse_start
from hpcgfmd.runs.protocol import Retraction


def test_prolong_is_linear_interpolation_on_any_block():
    coarse = np.random.default_rng(3).standard_normal(8)
    fine = coarse_start.prolong(coarse, 0, 16)
    np.testing.assert_array_equal(fine[0::2], coarse)  # coarse node j = fine node 2j
    np.testing.assert_allclose(fine[1::2], 0.5 * (coarse + np.roll(coarse, -1)), rtol=1e-15)
    # blocks of any split give the same values as the whole
    pieces = [coarse_start.prolong(coarse, a, b) for a, b in ((0, 3), (3, 10), (10, 16))]
    np.testing.assert_array_equal(np.concatenate(pieces), fine)


def test_prolong_is_exact_for_a_linear_field_away_from_the_wrap():
    coarse = 0.5 * np.arange(16.0)  # coarse spacing 2 dx, slope 1/4 per fine node
    fine = coarse_start.prolong(coarse, 0, 30)  # the last interval wraps: left out
    np.testing.assert_allclose(fine, 0.25 * np.arange(30.0), rtol=0, atol=1e-15)


def test_levels_stop_at_the_zone_resolution_and_the_smallest_grid():
    # the shared case: w = pi alpha^(1/3) / (4 lambda0^2) = 2.98e-3 on a cell of 2
    case = parse_case(case_text("nx = 16384"))
    assert coarse_start.coarser_nx(case) == 8192
    assert coarse_start.coarser_nx(parse_case(case_text("nx = 8192"))) == 4096
    assert coarse_start.coarser_nx(parse_case(case_text("nx = 4096"))) is None  # smallest
    assert coarse_start.coarser_nx(parse_case(case_text("nx = 12000"))) == 6000
    assert coarse_start.coarser_nx(parse_case(case_text("nx = 12002"))) is None  # 6001: odd
    assert coarse_start.coarser_nx(parse_case(case_text("nx = 6000"))) is None
    # lambda0 = 14: w = 1.9e-4, 1.5 nodes at 2^14 on L = 2: that level's lambda is coarsened
    # to 14 sqrt(1.5 / 2) = 12.2, its zone two nodes wide (w lambda0^2 / lambda_c^2)
    sharp = parse_case(case_text("nx = 32768", maugis=14.0))
    points = sharp.zone_width / (sharp.cell / 16384)
    assert points < coarse_start.MIN_ZONE_NODES
    assert coarse_start.coarser_nx(sharp) == 16384
    level = coarse_start.coarse_case(sharp, 16384)
    assert level.maugis == pytest.approx(14.0 * np.sqrt(points / 2.0), rel=1e-12)
    assert level.zone_width / level.dx == pytest.approx(2.0, rel=1e-12)
    assert level.adhesion == sharp.adhesion and level.depth == sharp.depth
    assert level.numerics.tolerance == max(sharp.numerics.tolerance, coarse_start.COARSE_TOLERANCE)
    # down to the smallest grid, 2^12 (lambda_c = 6.1); no lambda_c below MIN_COARSE_MAUGIS
    assert coarse_start.preload_grids(sharp) == [4096, 8192, 16384, 32768]
    # lambda_c = sqrt(pi beta / (8 dx)) whatever lambda0: on a cell of 4, 4.3 at 2^12
    blunt = parse_case(case_text("nx = 131072", maugis=28.0, cell=4.0))
    assert coarse_start.coarse_maugis(blunt, 4096) < coarse_start.MIN_COARSE_MAUGIS
    assert coarse_start.preload_grids(blunt)[0] == 8192


def preload(nx, coarse, **groups):
    """(load, contact half-width, fine iterations, levels) of the shared case's preload."""
    case = parse_case(case_text(f"nx = {nx}", **groups))
    sim = Retraction(case, MPI.COMM_SELF, planner_effort="FFTW_ESTIMATE")
    if not coarse:
        previous, coarse_start.MIN_LEVEL_NODES = coarse_start.MIN_LEVEL_NODES, 1 << 40
    try:
        record = sim.preload()
    finally:
        if not coarse:
            coarse_start.MIN_LEVEL_NODES = previous
        sim.close()
    return record.load, record.contact_half_width, record.iterations, sim.preload_levels


def test_coarse_start_reaches_the_flat_starts_equilibrium_in_fewer_iterations():
    load, half_width, iterations, levels = preload(16384, coarse=True)
    flat_load, flat_half_width, flat_iterations, flat_levels = preload(16384, coarse=False)
    half_grid_load = preload(8192, coarse=False)[0]
    assert [nx for nx, _ in levels] == [4096, 8192] and flat_levels == []
    # The discrete contact edge can rest on neighbouring positions (lattice trapping of the
    # adhesive edge): the two starts may end in minima of the same branch that differ by
    # less than the grid's own error, bounded here by a tenth of the change from halving it
    # (measured: 2.3e-3 of it).
    assert abs(load - flat_load) < 0.1 * abs(flat_load - half_grid_load)
    assert abs(half_width - flat_half_width) < 2.0 / 16384  # less than a node (L/R = 2)
    assert iterations < flat_iterations / 2  # measured 14 against 62


def test_a_large_lambda0_preload_starts_from_coarsened_levels():
    # lambda0 = 60 (w/dx = 1.03 on 2^16 nodes, a contact of 2 x 12,700 nodes): solved from
    # flat the active set grows a few nodes per iteration (3159 iterations); from levels
    # down to 2^12 with lambda coarsened to 10.8 there, the fine level takes a few. At this
    # zone resolution the discrete contact edge is trapped (lattice trapping): the flat
    # start's advancing edge stops early, the coarse start's sits near the converged edge
    # (measured: coarse starts at 2^16 and 2^17 within 1.7e-4 of each other, the flat
    # starts 1.3 % and 0.36 % off them, moving toward them as the grid is refined).
    groups = dict(maugis=60.0, modulus_ratio=1.0, depth=0.005, cell=0.64)
    load, half_width, iterations, levels = preload(65536, True, **groups)
    flat_load, _, flat_iterations, _ = preload(65536, False, **groups)
    fine_load = preload(131072, True, **groups)[0]
    assert [nx for nx, _ in levels] == [4096, 8192, 16384, 32768]
    assert iterations < flat_iterations / 100  # measured 7 against 3159
    assert abs(load - fine_load) < 1e-3 * abs(fine_load)
    assert abs(flat_load - fine_load) > 3 * abs(load - fine_load)


def preload_on(ranks):
    """The printed preload of tests/mpi/check_preload.py on ``ranks`` ranks."""
    script = Path(__file__).parent / "mpi" / "check_preload.py"
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    done = subprocess.run(
        [shutil.which("mpirun"), "--oversubscribe", "-n", str(ranks), sys.executable, str(script)],
        capture_output=True,
        text=True,
        env=env,
        timeout=240,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    return dict(line.split(" ", 1) for line in done.stdout.splitlines() if " " in line)


@pytest.mark.mpi
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="OpenMPI's mpirun is not installed")
def test_coarse_levels_give_the_same_preload_on_any_rank_count():
    one, three = preload_on(1), preload_on(3)
    for printed in (one, three):
        assert [level.split(":")[0] for level in printed["levels"].split()] == ["4096", "8192"]
    # P ranks round their transforms differently: the same equilibrium to the tolerance 1e-12
    assert float(three["load"]) == pytest.approx(float(one["load"]), rel=1e-10)
    u1 = np.array(one["u"].split(), dtype=float)
    u3 = np.array(three["u"].split(), dtype=float)
    assert np.max(np.abs(u3 - u1)) <= 1e-10 * np.max(np.abs(u1))
