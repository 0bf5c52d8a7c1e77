"""Studies built on :mod:`hpcgfmd.runs`: the speed-against-error benchmark."""
