"""Sphinx configuration of the documentation site (``make docs``; offline, warnings are errors).

The site is docs/: the guides and pages in Markdown (myst-parser), the API reference from the
docstrings (docs/api/), the gallery built by running a fast subset of diagrams/ (sphinx-gallery)
and the Meshcat tutorial notebook, executed by nbclient during the build (docs/tutorial/).
Nothing is fetched: intersphinx reads the inventories committed in docs/api/_intersphinx/.
"""

import re
import sys
from pathlib import Path

import sobolev_drake

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent

project = "sobolev_drake"
author = "the sobolev_drake developers"
release = version = sobolev_drake.__version__
extensions = ["sphinx.ext.autodoc", "sphinx.ext.napoleon", "sphinx.ext.mathjax",
              "sphinx.ext.intersphinx", "myst_parser", "sphinx_gallery.gen_gallery"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_rtype = False
napoleon_use_ivar = True          # Attributes sections as fields (no second index entry)
# module pages document what each module defines (its __all__ also re-exports names documented
# where they are defined); the sd page lists the curated names without indexing them twice
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": True,
                           "ignore-module-all": True}
autodoc_member_order = "bysource"
autodoc_typehints = "none"          # the numpydoc sections carry the types
# mathjax is loaded from a CDN by the browser only when a page has maths; the build is offline
html_theme = "alabaster"
html_static_path = []
exclude_patterns = ["_build", "api/_intersphinx", "gallery/*.ipynb", "gallery/*.py",
                    "gallery/*.zip", "gallery/*.json", "tutorial/*.ipynb", "**/.ipynb_checkpoints",
                    # the last full run, links into out/ (not part of the site)
                    "experiments/REPRODUCTION.md"]
nitpicky = False
# a module that fails to import is an error (autodoc's import_object warning, -W), never hidden


def _literal_bars(app, what, name, obj, options, lines):
    """Our docstrings write |x| for absolute values and norms, plain text for help(); reST
    would read them as substitutions.  Escape every bar outside a table row."""
    for i, line in enumerate(lines):
        text = line.strip()
        grid_row = text.startswith(("+-", "+=")) or (text.startswith("| ") and text.endswith(" |"))
        if "|" in line and not grid_row:
            lines[i] = line.replace("|", "\\|")


_FIELD = re.compile(r"^\s*\*{0,2}\w+(?:, \*{0,2}\w+)* : ")
_LITERAL = re.compile(r"``.*?``")


def _literal_types(app, what, name, obj, options, lines):
    """Inline literals in a numpydoc type (a callable's signature) stay literals: napoleon's
    type parser (napoleon_preprocess_types) would read the primes of ``α'`` as string quotes,
    so inside them they are written as primes (runs before napoleon)."""
    for i, line in enumerate(lines):
        if _FIELD.match(line) and "``" in line:
            lines[i] = _LITERAL.sub(lambda m: m.group(0).replace("''", "\u2033")
                                    .replace("'", "\u2032"), line)


def _pydrake_system_block(lines):
    """(name, input ports, output ports) of a ``.. pydrake_system::`` block: ``name: X`` and
    ``input_ports:`` / ``output_ports:`` lists of ``- port`` items (pydrake's format)."""
    name, ports, current = "", {"input_ports": [], "output_ports": []}, None
    for raw in lines:
        text = raw.strip()
        if not text:
            continue
        if text.startswith("- ") and current is not None:
            ports[current].append(text[2:].strip())
        elif text.startswith("name:"):
            name, current = text[5:].strip(), None
        elif text.rstrip(":") in ports:
            current = text.rstrip(":")
        else:
            raise ValueError(f"pydrake_system: unexpected line {text!r}")
    return name, ports["input_ports"], ports["output_ports"]


def _pydrake_system_directive():
    """The ``.. pydrake_system::`` block (pydrake's docstring convention for a system's ports)
    drawn as a block with its input ports on the left and output ports on the right."""
    import html

    from docutils import nodes
    from docutils.parsers.rst import Directive

    class PydrakeSystem(Directive):
        has_content = True

        def run(self):
            name, inputs, outputs = _pydrake_system_block(self.content)
            rows = max(len(inputs), len(outputs), 1)
            cells = []
            for i in range(rows):
                left = f"{html.escape(inputs[i])} &rarr;" if i < len(inputs) else ""
                right = f"&rarr; {html.escape(outputs[i])}" if i < len(outputs) else ""
                middle = (f'<td rowspan="{rows}" style="border:1px solid #444;padding:0.4em 1em;'
                          f'text-align:center"><b>{html.escape(name)}</b></td>') if i == 0 else ""
                cells.append(f'<tr><td style="text-align:right">{left}</td>{middle}'
                             f'<td>{right}</td></tr>')
            table = ('<table class="pydrake-system" style="border-collapse:collapse;margin:0.5em 0">'
                     + "".join(cells) + "</table>")
            text = f"{name}: inputs {', '.join(inputs) or '-'}; outputs {', '.join(outputs) or '-'}"
            return [nodes.raw("", table, format="html"), nodes.raw("", text, format="latex")]

    return PydrakeSystem


def setup(app):
    app.connect("builder-inited", _build_tutorials)
    app.connect("autodoc-process-docstring", _literal_types, priority=400)
    app.connect("autodoc-process-docstring", _literal_bars)
    app.add_directive("pydrake_system", _pydrake_system_directive())


# ---- intersphinx: committed inventories only (docs/api/_intersphinx/make_inventories.py says
# how they were made); a reference to numpy, scipy, pydrake or python-control links there
_INV = DOCS / "api" / "_intersphinx"
intersphinx_mapping = {
    "numpy": ("https://numpy.org/doc/stable/", str(_INV / "numpy.inv")),
    "scipy": ("https://docs.scipy.org/doc/scipy/", str(_INV / "scipy.inv")),
    "pydrake": ("https://drake.mit.edu/pydrake/", str(_INV / "pydrake.inv")),
    "control": ("https://python-control.readthedocs.io/en/0.10.2/", str(_INV / "control.inv")),
}
intersphinx_timeout = 1
# numpydoc type fields become references, so `ndarray` or `MultibodyPlant` link to their docs
napoleon_preprocess_types = True
napoleon_type_aliases = {
    "ndarray": "numpy.ndarray",
    "MultibodyPlant": "pydrake.multibody.plant.MultibodyPlant",
    "SceneGraph": "pydrake.geometry.SceneGraph", "Meshcat": "pydrake.geometry.Meshcat",
    "DiagramBuilder": "pydrake.systems.framework.DiagramBuilder",
    "Diagram": "pydrake.systems.framework.Diagram", "Context": "pydrake.systems.framework.Context",
    "LeafSystem": "pydrake.systems.framework.LeafSystem",
    "Simulator": "pydrake.systems.analysis.Simulator",
    "LinearSystem": "pydrake.systems.primitives.LinearSystem",
    "AffineSystem": "pydrake.systems.primitives.AffineSystem",
    "Trajectory": "pydrake.trajectories.Trajectory",
    "PiecewisePolynomial": "pydrake.trajectories.PiecewisePolynomial",
    "RigidTransform": "pydrake.math.RigidTransform",
    "StateSpace": "control.StateSpace",
}

# ---- Markdown pages (docs/*.md, docs/experiments/*.md, the guides) through myst-parser
myst_heading_anchors = 4
myst_enable_extensions = ["dollarmath"]

# ---- the gallery: diagrams/ run by sphinx-gallery.  Only the fast scripts are executed (their
# figures shown); the others are rendered as code (filename_pattern); docs/_gallery.py passes
# each a short duration and picks up the PNG files it writes.
sys.path.insert(0, str(DOCS))
sphinx_gallery_conf = {
    "examples_dirs": [str(ROOT / "diagrams")],
    "gallery_dirs": ["gallery"],
    "filename_pattern": r"(pendulum_tracking|acrobot_partition|acrobot_upright|quadrotor_push)\.py$",
    "ignore_pattern": r"__init__\.py|/_",
    "image_scrapers": ("_gallery.png_scraper",),
    "reset_argv": "_gallery.reset_argv",
    "abort_on_example_error": True,
    "only_warn_on_example_error": False,
    "download_all_examples": False,
    "remove_config_comments": True,
    "show_memory": False,
    "show_signature": False,
    "write_computation_times": True,
}

# ---- the tutorial notebook, executed at every build and rendered as a page (docs/_notebook.py)
TUTORIALS = [DOCS / "tutorial" / "meshcat_tutorial.ipynb"]


def _build_tutorials(app):
    import _notebook
    for notebook in TUTORIALS:
        _notebook.build(notebook, ROOT / "build" / "tutorial-run")
