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
    app.connect("autodoc-process-docstring", _literal_bars)
    app.add_directive("pydrake_system", _pydrake_system_directive())
