"""The documentation site (``make docs`` builds it; CI runs that): its pages' code runs, the
tutorial notebook runs from top to bottom and records in Meshcat, every page is reachable,
the gallery and intersphinx are wired to files that exist, and an import failure is not hidden."""

from __future__ import annotations

import ast
import os
import re
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
#: pages whose ```python blocks are runnable examples (each block self-contained)
EXAMPLE_PAGES = [DOCS / "getting-started.md", *sorted((DOCS / "guides").glob("*.md"))]
BLOCKS = [(page, i, block) for page in EXAMPLE_PAGES
          for i, block in enumerate(re.findall(r"```python\n(.*?)```",
                                               page.read_text(encoding="utf-8"), flags=re.S))]


def _conf():
    """docs/conf.py's top-level assignments that are plain literals (no import of Sphinx)."""
    tree = ast.parse((DOCS / "conf.py").read_text(encoding="utf-8"))
    out = {}
    for node in tree.body:
        if isinstance(node, ast.Assign) and len(node.targets) == 1 \
                and isinstance(node.targets[0], ast.Name):
            try:
                out[node.targets[0].id] = ast.literal_eval(node.value)
            except ValueError:
                pass
    return out


def test_every_guide_has_runnable_examples():
    pages = {page.name for page, _, _ in BLOCKS}
    assert {"getting-started.md", "your-robot.md", "your-drone.md",
            "linear-design.md"} <= pages, pages


@pytest.mark.parametrize("page,index,block", BLOCKS,
                         ids=[f"{p.stem}-{i}" for p, i, _ in BLOCKS])
def test_page_block_runs(page, index, block, tmp_path):
    if "import control" in block:
        pytest.importorskip("control")
    cwd = os.getcwd()
    os.chdir(tmp_path)                 # blocks may write into out/
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            exec(compile(block, f"{page.relative_to(ROOT)} block {index}", "exec"),
                 {"__name__": "docs_example"})
    finally:
        os.chdir(cwd)


def test_tutorial_notebook_runs_and_records(tmp_path):
    """Every cell runs (nbclient, a real kernel), Meshcat serves on localhost and the recording
    is a standalone page; the tracking error printed is the design's (poles −7.7 ± 3.2j and
    −1.44: after 3 s the slowest mode is down to e^(−1.44·3) ≈ 1.3 % of 0.4 rad, 5e-3 rad)."""
    pytest.importorskip("nbclient")
    import sys
    sys.path.insert(0, str(DOCS))
    try:
        import _notebook
    finally:
        sys.path.remove(str(DOCS))
    nb = _notebook.execute(DOCS / "tutorial" / "meshcat_tutorial.ipynb", tmp_path)
    text = "\n".join(o.get("text", "") for c in nb.cells if c.cell_type == "code"
                     for o in c.outputs)
    m = re.search(r"largest after 3 s: ([0-9.e+-]+) rad", text)
    assert m, text
    assert float(m.group(1)) < 5e-3
    html = (tmp_path / "pendulum_w2.html").read_text(encoding="utf-8")
    assert "<html" in html.lower() and "meshcat" in html.lower()
    images = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs
              if "image/png" in o.get("data", {})]
    assert len(images) == 1                                   # the error plot, inline


def test_every_markdown_page_is_in_the_site():
    index = (DOCS / "index.rst").read_text(encoding="utf-8")
    entries = set(re.findall(r"^   (\S+)$", index, flags=re.M))
    assert "experiments/*" in entries
    for page in [*DOCS.glob("*.md"), *(DOCS / "guides").glob("*.md")]:
        name = page.relative_to(DOCS).with_suffix("").as_posix()
        assert name in entries, f"{page.relative_to(ROOT)} is in no toctree of docs/index.rst"


def test_import_failures_are_not_suppressed():
    conf = _conf()
    suppressed = conf.get("suppress_warnings", [])
    assert not any(w.startswith("autodoc") for w in suppressed), suppressed
    makefile = (ROOT / "Makefile").read_text(encoding="utf-8")
    assert re.search(r"sphinx -W .* docs build/docs", makefile)


def test_gallery_runs_existing_scripts_and_every_script_has_a_title():
    conf_text = (DOCS / "conf.py").read_text(encoding="utf-8")
    pattern = ast.literal_eval(re.search(r'"filename_pattern": (r".*?"),', conf_text).group(1))
    scripts = sorted((ROOT / "diagrams").glob("*.py"))
    executed = [s.name for s in scripts if re.search(pattern, str(s))]
    assert len(executed) >= 3, executed
    for script in scripts:   # sphinx-gallery takes the title from the docstring's first heading
        doc = ast.get_docstring(ast.parse(script.read_text(encoding="utf-8")), clean=False)
        lines = doc.splitlines()
        assert len(lines) > 1 and set(lines[1]) == {"="} and len(lines[1]) >= len(lines[0]), \
            f"{script.name}: the docstring must start with a title underlined with '='"
    assert (ROOT / "diagrams" / "GALLERY_HEADER.rst").is_file()


@pytest.mark.parametrize("name,entry", [
    ("numpy", "numpy.ndarray"), ("scipy", "scipy.linalg.solve_continuous_are"),
    ("pydrake", "pydrake.multibody.plant.MultibodyPlant"), ("control", "control.StateSpace")])
def test_intersphinx_inventories_are_committed_and_readable(name, entry):
    from sphinx.util.inventory import InventoryFile
    path = DOCS / "api" / "_intersphinx" / f"{name}.inv"
    with open(path, "rb") as f:
        inventory = InventoryFile.load(f, "https://example.invalid/", lambda base, uri: base + uri)
    found = [inventory[kind][entry] for kind in ("py:class", "py:function") if entry in inventory.get(kind, {})]
    assert found, f"{entry} not in {path.name}"


def test_readme_is_for_a_user_first():
    """What it is, pip install (not on PyPI), a runnable example and the two make commands come
    before any maintainer detail; that detail lives in docs/ and is linked."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    order = [readme.index(s) for s in ("weighted Sobolev", "not on PyPI", "pip install .",
                                       "```python", "make demo", "make test")]
    assert order == sorted(order), order
    for moved in ("make lock", "OPENBLAS_CORETYPE", "../shared", "Status and known gaps"):
        assert moved not in readme, f"{moved!r} belongs in docs/, not the README"
    for link in re.findall(r"\]\(((?:docs/)?[^)#:]+)\)", readme):
        assert (ROOT / link).exists(), f"README links to a missing file: {link}"
