"""Files: the HDF5 result file (written collectively), checkpoints, reading results back, and plots.
Imports :mod:`hpcgfmd.model` (the case's units) and nothing of the solvers or the protocol.
"""
