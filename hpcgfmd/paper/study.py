"""The paper's studies: its figures' cases, shipped as sweep files, merged into one farm.

Each figure that needs runs has a sweep file in ``hpcgfmd/paper/sweeps/`` (Figs. 4, 5, 8, 9
and B1; Figs. 6 and 7 draw the snapshots of the Fig. 5 cases, Fig. 2 is Eq. 8 alone). A
case that several figures share (lambda0 = 7, V_z = 0.9 at both depths is in Figs. 8 and 9)
runs once: the cases are merged by their identity and named from their groups, so every
figure finds its runs under the same names in one output directory, and the farm's
resumption, locking and summary apply unchanged.
"""

from __future__ import annotations

import tomllib
from dataclasses import replace
from importlib import resources

from ..errors import SweepError
from ..runs.sweep import Sweep, parse_sweep, to_toml

#: Every figure of the paper the command draws, in the paper's order.
FIGURES = ("2", "4", "5", "6", "7", "8", "9", "B1")
#: The sweep file of each figure's runs (the others draw runs of these).
SWEEP_FILES = {
    "4": "fig4.toml",
    "5": "fig5.toml",
    "8": "fig8.toml",
    "9": "fig9.toml",
    "B1": "figB1.toml",
}
#: Figures drawn from another figure's runs.
RUNS_OF = {"6": "5", "7": "5"}
#: ``[numerics] accuracy`` of the shipped sweep files (the command's ``--accuracy`` replaces it).
DEFAULT_ACCURACY = 1e-2


def sweep_text(figure: str) -> str:
    """The shipped sweep file of ``figure`` (a key of :data:`SWEEP_FILES`)."""
    return resources.files(__package__).joinpath("sweeps").joinpath(SWEEP_FILES[figure]).read_text()


def figure_sweep(figure: str, accuracy: float | None = None, text: str | None = None) -> Sweep:
    """The sweep of one figure; ``accuracy`` replaces its ``[base.numerics] accuracy``.

    ``text`` replaces the shipped sweep file (the tests' tiny studies).
    """
    try:
        doc = tomllib.loads(sweep_text(figure) if text is None else text)
    except tomllib.TOMLDecodeError as err:
        raise SweepError(f"paper Fig. {figure}: not valid TOML: {err}") from None
    if not isinstance(doc.get("base"), dict):
        raise SweepError(f"paper Fig. {figure}: needs an inline [base.case] section")
    if accuracy is not None:
        doc["base"].setdefault("numerics", {})["accuracy"] = accuracy
    return parse_sweep(to_toml(doc), path=f"paper Fig. {figure}")


def case_name(case) -> str:
    """The run's file stem from its groups: ``lambda0_7-k_0.1-Vz_4.5-h0_0.1`` plus the grid
    and the fixed step when the case gives them."""
    name = (
        f"lambda0_{case.maugis:g}-k_{case.modulus_ratio:g}-Vz_{case.velocity:g}-h0_{case.depth:g}"
    )
    if not case.numerics.nx_automatic:
        name += f"-nx_{case.numerics.nx}"
    if case.numerics.step_control == "fixed":
        name += f"-dt_{case.numerics.dt:g}"
    return name


def runs_of(figure: str) -> str:
    """The figure whose runs ``figure`` draws (itself, or e.g. 5 for Figs. 6 and 7)."""
    return RUNS_OF.get(figure, figure)


def paper_study(figures, accuracy=None, texts=None):
    """The merged farm of ``figures`` and, per figure, the names of its runs in order.

    Parameters
    ----------
    figures : iterable of str
        Figure labels of :data:`FIGURES`.
    accuracy : float, optional
        Replaces every case's ``[numerics] accuracy``.
    texts : dict, optional
        Sweep file text per figure in place of the shipped ones (tests).

    Returns
    -------
    sweep : Sweep
        One case per distinct run, named by :func:`case_name`.
    members : dict
        Figure label -> list of run names (the figure's sweep order).

    Raises
    ------
    SweepError
        A shipped (or given) sweep file that does not validate, or one of its cases.
    """
    texts = texts or {}
    merged, members, by_run = [], {}, {}
    swept = []
    for figure in dict.fromkeys(runs_of(f) for f in figures):
        if figure not in SWEEP_FILES:
            members[figure] = []
            continue
        sweep = figure_sweep(figure, accuracy, texts.get(figure))
        names = []
        for item in sweep.cases:
            if item.case is None:
                raise SweepError(f"paper Fig. {figure}, case {item.name}: {item.error}")
            # (the cap too: cases that differ in it alone are different settings of the study)
            run = (item.case.identity(), item.case.numerics.max_iterations)
            if run not in by_run:
                by_run[run] = replace(item, index=len(merged), name=case_name(item.case))
                merged.append(by_run[run])
            elif _snapshots(item.case) > _snapshots(by_run[run].case):
                # the same run ([output] is not part of the identity): keep the snapshots
                kept = by_run[run]
                by_run[run] = replace(item, index=kept.index, name=kept.name)
                merged[kept.index] = by_run[run]
            names.append(by_run[run].name)
        swept += [key for key in sweep.swept if key not in swept]
        members[figure] = names
    for figure in figures:
        members[figure] = members[runs_of(figure)]
    seen = {}
    for item in merged:  # different runs, one name: a study that varies more than the name
        if item.name in seen:
            raise SweepError(
                f"paper: runs {seen[item.name]} and {item.index} would both be"
                f" named {item.name} (they differ in a key the name leaves out:"
                " cell, adhesion, units or numerics); vary lambda0, k, V_z, h0,"
                " nx or dt only"
            )
        seen[item.name] = item.index
    return Sweep(cases=merged, swept=swept, path="paper"), members


def _snapshots(case) -> int:
    """How many snapshot triggers a case's [output] sets."""
    out = case.output
    return len(out.snapshot_times) + len(out.snapshot_contact_widths) + int(out.snapshot_zero_load)
