"""Optional compiled kernels of the tilt-rotor hot paths (plain C, built at install time).

Each C file ``native/<name>.c`` is the extension module ``sobolev_drake.native._<name>``; each
kernel reproduces a Python implementation of the library operation for operation
(``tests/native/test_native_*.py`` compare them), except ``rnea`` (inverse dynamics of a tree of
revolute and prismatic joints), whose reference is Drake's CalcInverseDynamics, matched to
rounding.  ``forces`` mirrors the scalar force tier of ``tiltrotor.propulsion``,
``tiltrotor.aerodynamics`` and ``tiltrotor.input_affine``, ``bls`` the Python tier of
``systems.bounded_ls``, ``reference`` the float path of ``systems.references`` (const, sine and
poly pieces); ``fused`` composes rnea, forces and bls into the tilt-rotor controller's
whole sample (``tiltrotor.compiled_sample``) through their C interfaces (``_C_API`` capsules,
``capi.h``), its reference being the Python path of the same sample.
``benchmarks/speed_tiers.py`` times the force, allocation and inverse-dynamics kernels against
their Python paths.  :func:`kernel` returns the module or None, so callers fall back to the reference when
it was not built (no C compiler at install time) or is switched off: ``SOBOLEV_DRAKE_NATIVE=0``
in the environment (read at import) or :func:`set_enabled` / :func:`disabled` at run time (A/B
comparisons, debugging).  Systems built while the kernels were on keep using them.
"""

from __future__ import annotations

import contextlib
import importlib
import os
from types import ModuleType
from typing import Iterator

__all__ = ["kernel", "enabled", "set_enabled", "disabled"]

_CACHE: dict = {}
_ENABLED = os.environ.get("SOBOLEV_DRAKE_NATIVE", "1").strip().lower() not in ("0", "false", "no", "off")


def enabled() -> bool:
    """Whether :func:`kernel` hands out compiled kernels."""
    return _ENABLED


def set_enabled(flag: bool) -> bool:
    """Switch the kernels on or off for the code that looks them up from now on; returns the
    previous setting."""
    global _ENABLED
    previous, _ENABLED = _ENABLED, bool(flag)
    return previous


@contextlib.contextmanager
def disabled() -> Iterator[None]:
    """Context manager: the pure-Python paths inside the block."""
    previous = set_enabled(False)
    try:
        yield
    finally:
        set_enabled(previous)


def kernel(name: str) -> ModuleType | None:
    """The compiled module ``sobolev_drake.native._<name>``, or None if it is not built or the
    kernels are switched off (cheap: called per controller sample)."""
    if not _ENABLED:
        return None
    try:
        return _CACHE[name]
    except KeyError:
        try:
            module = importlib.import_module(f"sobolev_drake.native._{name}")
        except ImportError:
            module = None
        _CACHE[name] = module
        return module
