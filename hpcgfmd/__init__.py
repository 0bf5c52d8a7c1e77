"""hpcgfmd: Green's function molecular dynamics for the retraction of an adhesive cylinder from a
viscoelastic half-space.

The Python API (docs/api.md): :class:`Case`, :func:`run`, :func:`open` and the :class:`Result`
they return; the exceptions are in :mod:`hpcgfmd.errors`. They are imported on first use, so
``python -m hpcgfmd`` can set the process up (BLAS threads, signals) before numpy loads.
"""

__version__ = "0.1.0"

_API = {
    "Case": ("case", "Case"),
    "run": ("api", "run"),
    "open": ("api", "open_result"),
    "Result": ("storage.reader", "Result"),
}
__all__ = ["Case", "run", "open", "Result", "__version__"]


def __getattr__(name):
    if name not in _API:
        raise AttributeError(f"module 'hpcgfmd' has no attribute {name!r}")
    from importlib import import_module

    module, attribute = _API[name]
    value = getattr(import_module(f"{__name__}.{module}"), attribute)
    globals()[name] = value
    return value
