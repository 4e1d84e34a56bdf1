"""Build hook for the optional compiled kernels (``sobolev_drake/native/*.c``).

Every ``native/<name>.c`` becomes the extension module ``sobolev_drake.native._<name>``: plain C
(CPython API only, no other library), the hot scalar paths of the tilt-rotor simulation.  Each
has a reference implementation (Python, or Drake for ``rnea``) that the tests compare it with;
when a kernel is not built (no compiler) the package falls back to the reference
(``sobolev_drake.native``).  All other metadata is in pyproject.toml.
"""

from pathlib import Path

from setuptools import Extension, setup

_FLAGS = ["-O2", "-ffp-contract=off", "-fno-fast-math", "-std=c99"]   # IEEE, no FMA contraction

_NATIVE = Path("sobolev_drake/native")
_HEADERS = [str(h) for h in sorted(_NATIVE.glob("*.h"))]     # shared by the kernels

setup(ext_modules=[
    Extension(f"sobolev_drake.native._{src.stem}", [str(src)], depends=_HEADERS,
              extra_compile_args=_FLAGS, optional=True)
    for src in sorted(_NATIVE.glob("*.c"))
])
