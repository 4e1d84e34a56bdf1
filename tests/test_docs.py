"""docs/: the equation table points at code and tests that exist, and the package's references
into docs/design.md land on real headings (no reference to the old out-of-tree notes is left)."""

from __future__ import annotations

import ast
import importlib
import re
from functools import lru_cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DESIGN = ROOT / "docs" / "design.md"
EQUATIONS = ROOT / "docs" / "equations.md"
PACKAGE = ROOT / "sobolev_drake"
TEXT_SUFFIXES = {".py", ".c", ".h", ".md", ".urdf", ".toml", ".txt", ".cfg", ".sh"}
#: places outside the package whose references to the design are checked as well
OTHER_SOURCES = ("tests", "diagrams", "benchmarks", "urdf", "README.md", "Makefile",
                 "docs/experiments/REPRODUCTION.md")

REFERENCE = re.compile(r"docs/design\.md\s+§(\d+(?:\.\d+)*)")
OLD_NOTES = re.compile(r"DESIGN(?:\.md| ?§| section)")
HEADING = re.compile(r"^#{1,6}\s+(\d+(?:\.\d+)*)\.?\s")
CODE = re.compile(r"`([^`]+)`")
TEST_ID = re.compile(r"^(tests/[\w/]+\.py)::(\w+)$")


def _text_files(path: Path):
    if path.is_file():
        yield path
        return
    for p in sorted(path.rglob("*")):
        if p.is_file() and (p.suffix in TEXT_SUFFIXES or p.name == "Makefile") \
                and "__pycache__" not in p.parts:
            yield p


@lru_cache(maxsize=None)
def equation_rows() -> tuple:
    """(line number, equation, function path, test id or None) of every table row."""
    rows = []
    for k, line in enumerate(EQUATIONS.read_text(encoding="utf-8").splitlines(), 1):
        if not line.startswith("|") or set(line) <= set("|-: "):
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if cells[0] == "Equation":              # header row
            continue
        assert len(cells) == 4, f"docs/equations.md:{k}: expected 4 columns, got {len(cells)}"
        fn = CODE.fullmatch(cells[2])
        assert fn, f"docs/equations.md:{k}: the function column must be one `dotted.path`"
        if cells[3] == "—":
            test = None
        else:
            t = CODE.fullmatch(cells[3])
            assert t, f"docs/equations.md:{k}: the test column must be `tests/...::name` or —"
            test = t.group(1)
        rows.append((k, cells[0], fn.group(1), test))
    return tuple(rows)


def resolve(dotted: str):
    """Import the longest importable module prefix of ``dotted`` and follow the rest with
    getattr (classes, functions, methods, properties)."""
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ModuleNotFoundError as e:
            if e.name is not None and not ".".join(parts[:i]).startswith(e.name):
                raise                               # a real import error inside the module
            continue
        for name in parts[i:]:
            obj = getattr(obj, name)
        return obj
    raise ModuleNotFoundError(f"no importable prefix in {dotted!r}")


@lru_cache(maxsize=None)
def functions_in(path: str) -> frozenset:
    tree = ast.parse((ROOT / path).read_text(encoding="utf-8"))
    return frozenset(n.name for n in tree.body
                     if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)))


def design_headings() -> set:
    out = set()
    for line in DESIGN.read_text(encoding="utf-8").splitlines():
        m = HEADING.match(line)
        if m:
            out.add(m.group(1))
    return out


def test_equation_table_is_not_empty():
    rows = equation_rows()
    assert len(rows) >= 100
    assert len({r[2] for r in rows}) >= 80          # distinct implementing functions
    assert sum(r[3] is not None for r in rows) >= 0.9 * len(rows)


def test_every_function_path_resolves():
    bad = []
    for line, eq, dotted, _ in equation_rows():
        assert dotted.startswith("sobolev_drake."), f"line {line}: {dotted}"
        try:
            obj = resolve(dotted)
        except (ImportError, AttributeError) as e:
            bad.append(f"docs/equations.md:{line} {eq}: {dotted} ({type(e).__name__}: {e})")
            continue
        if not (callable(obj) or isinstance(obj, property)):
            bad.append(f"docs/equations.md:{line} {eq}: {dotted} is not a function or class")
    assert not bad, "\n".join(bad)


def test_every_named_test_exists():
    bad = []
    for line, eq, _, test in equation_rows():
        if test is None:
            continue
        m = TEST_ID.match(test)
        if not m:
            bad.append(f"docs/equations.md:{line} {eq}: malformed test id {test!r}")
            continue
        path, name = m.groups()
        if not (ROOT / path).is_file():
            bad.append(f"docs/equations.md:{line} {eq}: no file {path}")
        elif not name.startswith("test") or name not in functions_in(path):
            bad.append(f"docs/equations.md:{line} {eq}: no test function {name} in {path}")
    assert not bad, "\n".join(bad)


def test_resolve_follows_methods_and_rejects_missing_names():
    from sobolev_drake.systems.mechanical_controller import MechanicalLaw
    assert resolve("sobolev_drake.systems.mechanical_controller.MechanicalLaw.generalized_input") \
        is MechanicalLaw.generalized_input
    with pytest.raises(AttributeError):
        resolve("sobolev_drake.synthesis.mechanical.no_such_function")
    with pytest.raises(ModuleNotFoundError):
        resolve("no_such_package.f")


def test_design_has_the_numbered_sections():
    headings = design_headings()
    expected = {str(k) for k in range(1, 9)} | {f"4.{k}" for k in range(1, 6)}
    assert expected <= headings, sorted(expected - headings)


def test_package_no_longer_cites_the_old_notes():
    hits = []
    for base in (PACKAGE,) + tuple(ROOT / p for p in OTHER_SOURCES):
        if not base.exists():
            continue
        for path in _text_files(base):
            if path == Path(__file__).resolve():
                continue
            for k, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                if OLD_NOTES.search(line):
                    hits.append(f"{path.relative_to(ROOT)}:{k}: {line.strip()}")
    assert not hits, "\n".join(hits)


def test_design_references_point_at_existing_headings():
    headings = design_headings()
    refs, bad = 0, []
    for base in (PACKAGE,) + tuple(ROOT / p for p in OTHER_SOURCES):
        if not base.exists():
            continue
        for path in _text_files(base):
            for k, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                for m in REFERENCE.finditer(line):
                    refs += 1
                    if m.group(1) not in headings:
                        bad.append(f"{path.relative_to(ROOT)}:{k}: §{m.group(1)}")
    assert refs >= 30                               # the package does point into the design
    assert not bad, "no such heading in docs/design.md:\n" + "\n".join(bad)


EXPERIMENT_PAGE = re.compile(r"docs/experiments/([\w.-]+\.md)")
EXPERIMENT_PAGES = ROOT / "docs" / "experiments"


def test_experiment_page_references_point_at_existing_pages():
    refs, bad = 0, []
    for base in (PACKAGE, DESIGN) + tuple(ROOT / p for p in OTHER_SOURCES):
        if not base.exists():
            continue
        for path in _text_files(base):
            for k, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                for m in EXPERIMENT_PAGE.finditer(line):
                    refs += 1
                    if not (EXPERIMENT_PAGES / m.group(1)).is_file():
                        bad.append(f"{path.relative_to(ROOT)}:{k}: docs/experiments/{m.group(1)}")
    assert refs >= 12                               # every experiment module points at its page
    assert not bad, "no such page:\n" + "\n".join(bad)


def test_every_registered_experiment_has_a_page():
    # the @register("name", ...) decorators, read from the source (no Drake import)
    names = set()
    for path in sorted((PACKAGE / "experiments").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if (isinstance(node, ast.Call) and getattr(node.func, "id", None) == "register"
                    and node.args and isinstance(node.args[0], ast.Constant)):
                names.add(node.args[0].value)
    assert len(names) >= 12
    index = (EXPERIMENT_PAGES / "README.md").read_text(encoding="utf-8")
    missing = sorted(n for n in names if not (EXPERIMENT_PAGES / f"{n}.md").is_file())
    unlisted = sorted(n for n in names if f"({n}.md)" not in index)
    assert not missing and not unlisted, f"no page: {missing}; not in the index: {unlisted}"
