"""The paper reproduced: its studies as sweep files, one command that runs them through the
farm, draws every figure and checks each of the paper's claims in numbers (docs/paper.md).

Modules: :mod:`.study` (the figures' cases, merged into one farm), :mod:`.curves` (what the
checks measure on a retraction: scaled curves, peeling velocity, effective work, distances
between curves), :mod:`.checks` (each claim against our numbers), :mod:`.figures` (PNG and
CSV of each figure) and :mod:`.command` (``python -m hpcgfmd paper``).
"""
