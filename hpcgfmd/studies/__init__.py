"""Studies built on :mod:`hpcgfmd.runs`: the measurements of docs/results.md, one
``python -m hpcgfmd bench`` mode per table (:mod:`hpcgfmd.studies.bench`), and what they print
around their tables (:mod:`hpcgfmd.studies.report`)."""
