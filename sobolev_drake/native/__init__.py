"""Optional compiled kernels of the tilt-rotor hot paths (plain C, built at install time).

Each C file ``native/<name>.c`` is the extension module ``sobolev_drake.native._<name>``; each
kernel reproduces a pure-Python reference implementation of the library operation for operation
(tests compare them).  :func:`kernel` returns the module or None, so callers fall back to Python
when it was not built (no C compiler at install time).  ``SOBOLEV_DRAKE_NATIVE=0`` in the
environment disables every kernel (A/B comparisons, debugging).
"""

from __future__ import annotations

import importlib
import os

__all__ = ["kernel", "enabled"]

_CACHE: dict = {}


def enabled() -> bool:
    """False when ``SOBOLEV_DRAKE_NATIVE`` is set to 0/false/no/off."""
    return os.environ.get("SOBOLEV_DRAKE_NATIVE", "1").strip().lower() not in ("0", "false", "no", "off")


def kernel(name: str):
    """The compiled module ``sobolev_drake.native._<name>``, or None if it is not built or the
    kernels are disabled."""
    if not enabled():
        return None
    if name not in _CACHE:
        try:
            _CACHE[name] = importlib.import_module(f"sobolev_drake.native._{name}")
        except ImportError:
            _CACHE[name] = None
    return _CACHE[name]
