"""The distributed grid: node blocks, the collectives of the real-space step, and the real FFT.

Imports nothing else of hpcgfmd. Every function or method that communicates says "Collective"
in its first docstring line and takes (or holds) its communicator explicitly.
"""
