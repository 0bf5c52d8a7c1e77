"""Running cases: the retraction protocol, one case to a file with checkpoints, sweep files and
the task farm. The only layer that puts model, solvers, the parallel grid and storage together.
"""
