"""The physics: the case and its dimensionless groups, the substrate, the interface law and the
closed-form theories. Pure numpy and scipy on whatever block of nodes or modes the caller owns;
imports nothing of hpcgfmd but :mod:`hpcgfmd.errors`. The equations are in docs/model.md.
"""
