"""Write the intersphinx inventories of numpy, scipy, pydrake and python-control used by
``make docs`` (docs/conf.py reads them; the build never goes online).

Provenance: these are NOT copies of the projects' published ``objects.inv`` files (the machine
that made them had no route to those sites).  They are generated from the installed packages
(the versions pinned in constraints.txt): every public class and function of the modules listed
below, each pointed at the page where that project's own Sphinx build documents it, following
the layout of its published reference:

* numpy  ``reference/generated/numpy.NAME.html#numpy.NAME``
* scipy  ``reference/generated/scipy.SUB.NAME.html#scipy.SUB.NAME``
* pydrake  one page per module: ``pydrake.MODULE.html#pydrake.MODULE.NAME``
* python-control  ``generated/control.NAME.html#control.NAME``

Regenerate after moving a pin (``.venv/bin/python docs/api/_intersphinx/make_inventories.py``),
or replace a file with the project's published ``objects.inv`` where the network allows (same
file names; docs/conf.py needs no change).
"""

from __future__ import annotations

import importlib
import inspect
import zlib
from pathlib import Path

HERE = Path(__file__).resolve().parent

PYDRAKE_MODULES = ("systems.framework", "systems.primitives", "systems.analysis",
                   "systems.controllers", "systems.scalar_conversion", "multibody.plant",
                   "multibody.parsing", "multibody.tree", "geometry", "math", "trajectories",
                   "symbolic", "autodiffutils", "common", "examples", "visualization")
SCIPY_MODULES = ("linalg", "optimize", "integrate", "stats", "signal", "interpolate")


def _public(module):
    """(name, role) of the public classes and functions defined or re-exported by module."""
    names = getattr(module, "__all__", None) or [n for n in dir(module) if not n.startswith("_")]
    for name in sorted(set(names)):
        obj = getattr(module, name, None)
        # pydrake's templates (Context, LeafSystem, ...) are TemplateClass objects
        if inspect.isclass(obj) or type(obj).__name__ == "TemplateClass":
            yield name, "class"
        elif callable(obj):
            yield name, "function"


def _write(path: Path, project: str, version: str, entries):
    """A Sphinx inventory (format version 2) of entries (name, role, uri)."""
    lines = [f"{name} py:{role} 1 {uri} -" for name, role, uri in sorted(set(entries))]
    header = (f"# Sphinx inventory version 2\n# Project: {project}\n# Version: {version}\n"
              "# The remainder of this file is compressed using zlib.\n").encode()
    path.write_bytes(header + zlib.compress("\n".join(lines).encode() + b"\n", 9))
    print(f"{path.name}: {len(lines)} entries")


def numpy_inventory():
    import numpy
    entries = [(f"numpy.{n}", r, f"reference/generated/numpy.{n}.html#$")
               for n, r in _public(numpy)]
    _write(HERE / "numpy.inv", "NumPy", numpy.__version__, entries)


def scipy_inventory():
    import scipy
    entries = []
    for sub in SCIPY_MODULES:
        module = importlib.import_module(f"scipy.{sub}")
        entries.append((f"scipy.{sub}", "module", f"reference/{sub}.html#module-$"))
        entries += [(f"scipy.{sub}.{n}", r, f"reference/generated/scipy.{sub}.{n}.html#$")
                    for n, r in _public(module)]
    _write(HERE / "scipy.inv", "SciPy", scipy.__version__, entries)


def pydrake_inventory():
    from importlib.metadata import version
    entries = []
    for sub in PYDRAKE_MODULES:
        name = f"pydrake.{sub}"
        module = importlib.import_module(name)
        entries.append((name, "module", f"{name}.html#module-$"))
        entries += [(f"{name}.{n}", r, f"{name}.html#$") for n, r in _public(module)
                    if getattr(getattr(module, n), "__module__", name).startswith("pydrake")]
    _write(HERE / "pydrake.inv", "Drake", version("drake"), entries)


def control_inventory():
    import control
    entries = [(f"control.{n}", r, f"generated/control.{n}.html#$") for n, r in _public(control)]
    _write(HERE / "control.inv", "Python Control Systems Library", control.__version__, entries)


if __name__ == "__main__":
    numpy_inventory()
    scipy_inventory()
    pydrake_inventory()
    control_inventory()
