"""The package's import graph: no module imports another module's private names, and no
import cycle between modules (function-level imports included; an import only type checkers
run, under ``if TYPE_CHECKING:``, is no edge: it never executes)."""

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "sobolev_drake"

KNOWN_CYCLES = []


def modules():
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = path
    return out


def imports(mods):
    """{module: set of package modules it imports}, [(module, imported module, private name)]."""
    edges, private = {m: set() for m in mods}, []
    for name, path in mods.items():
        package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
        tree = ast.parse(path.read_text(encoding="utf-8"))
        typing_only = {id(n) for block in ast.walk(tree) if isinstance(block, ast.If)
                       and getattr(block.test, "id", getattr(block.test, "attr", None))
                       == "TYPE_CHECKING" for stmt in block.body for n in ast.walk(stmt)}
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    parts = package.split(".")
                    parts = parts[:len(parts) - node.level + 1]
                    base = ".".join(parts + ([node.module] if node.module else []))
                if not base.startswith("sobolev_drake"):
                    continue
                for alias in node.names:
                    full = f"{base}.{alias.name}"
                    target = full if full in mods else base
                    if target in mods and target != name and id(node) not in typing_only:
                        edges[name].add(target)
                    if alias.name.startswith("_") and not alias.name.startswith("__") \
                            and full not in mods:
                        private.append((name, base, alias.name))
            elif isinstance(node, ast.Import) and id(node) not in typing_only:
                edges[name].update(a.name for a in node.names if a.name in mods and a.name != name)
    return edges, private


def cycles(edges):
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.add(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(component)

    for v in edges:
        if v not in index:
            visit(v)
    return found


def test_no_module_imports_another_modules_private_names():
    _, private = imports(modules())
    assert private == [], "\n".join(f"{m} imports {n} from {b}" for m, b, n in private)


def test_no_import_cycle_between_modules():
    edges, _ = imports(modules())
    new = [sorted(c) for c in cycles(edges) if c not in KNOWN_CYCLES]
    assert new == [], f"import cycles: {new}"


def test_the_checks_see_a_cycle_and_a_private_import():
    # the analysis itself, on a made-up graph: a -> b -> a is found, a -> c is not a cycle
    assert cycles({"a": {"b", "c"}, "b": {"a"}, "c": set()}) == [{"a", "b"}]


def package_of(module):
    parts = module.split(".")
    return ".".join(parts[:2])


def test_no_import_cycle_between_subpackages():
    # e.g. models -> systems -> models would make either unusable without the other
    edges, _ = imports(modules())
    packages = {package_of(m): set() for m in edges}
    for m, targets in edges.items():
        for t in targets:
            if package_of(t) != package_of(m) and package_of(t) != "sobolev_drake":
                packages[package_of(m)].add(package_of(t))
    packages.pop("sobolev_drake", None)     # the curated namespace re-exports everything
    for deps in packages.values():
        deps.discard("sobolev_drake")
    assert cycles(packages) == [], {p: sorted(d) for p, d in packages.items()}


def test_the_chapter_7_vehicle_stays_in_its_package():
    edges, _ = imports(modules())
    outside = {m: sorted(t for t in ts if t.startswith("sobolev_drake.tiltrotor"))
               for m, ts in edges.items()
               if package_of(m) in ("sobolev_drake.models", "sobolev_drake.systems",
                                    "sobolev_drake.synthesis")}
    assert not any(outside.values()), outside


def test_no_module_imports_an_experiment():
    # an experiment (a module that registers one) is a composition, not a library: what two
    # experiments share lives in the library or in a private helper module
    mods = modules()
    registered = {m for m, p in mods.items() if "@register(" in p.read_text(encoding="utf-8")}
    assert len(registered) >= 10
    edges, _ = imports(mods)
    offenders = {m: sorted(ts & registered) for m, ts in edges.items() if ts & registered}
    assert offenders == {}, offenders


def test_experiment_modules_are_short_compositions():
    # an experiment is configuration, design, flights, scoring and claims; anything longer has
    # library pieces in it (docs/design.md, "Experiments")
    long = {p.name: n for p in (PACKAGE / "experiments").glob("*.py")
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > 200}
    assert long == {}, long


def test_library_modules_stay_readable():
    # one concern per module: past ~500 lines a module usually holds two
    long = {str(p.relative_to(PACKAGE)): n for p in PACKAGE.rglob("*.py")
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > 520}
    assert long == {}, long
