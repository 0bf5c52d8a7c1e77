"""hpcgfmd: GFMD for adhesive viscoelastic retraction."""
__version__ = "0.1.0"
