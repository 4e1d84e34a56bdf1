"""Sphinx configuration of the API reference (``make docs``; offline, warnings are errors)."""

project = "sobolev_drake"
author = "the sobolev_drake developers"
extensions = ["sphinx.ext.autodoc", "sphinx.ext.napoleon", "sphinx.ext.mathjax"]
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
exclude_patterns = ["_build"]
nitpicky = False
suppress_warnings = ["autodoc.import_object"]


def _literal_bars(app, what, name, obj, options, lines):
    """Our docstrings write |x| for absolute values and norms, plain text for help(); reST
    would read them as substitutions.  Escape every bar outside a table row."""
    for i, line in enumerate(lines):
        text = line.strip()
        grid_row = text.startswith(("+-", "+=")) or (text.startswith("| ") and text.endswith(" |"))
        if "|" in line and not grid_row:
            lines[i] = line.replace("|", "\\|")


def setup(app):
    app.connect("autodoc-process-docstring", _literal_bars)
