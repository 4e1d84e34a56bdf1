"""Every public name has a numpydoc docstring that documents every argument.

The public names are ``sobolev_drake.__all__``, the ``__all__`` of ``synthesis``, ``systems``
and ``models``, and that of every public module of ``tiltrotor`` and ``rigs`` and of the
toolkit modules (``harness``, ``tuning``, ``norms``, ``report``, ``viz``, ``simulation``); a
module among them adds its own ``__all__`` (or, lacking one, the functions and classes it
defines).  For each name:

* functions, classes, their public methods and properties have a docstring (a property may
  instead be listed in the class's ``Attributes`` section);
* a function or method with arguments (besides self/cls) has a ``Parameters`` section naming
  each of them (``a, b : type`` names both; ``*args``/``**kwargs`` are documented by an entry
  with the same stars, e.g. ``**options``); a class's constructor arguments may be documented
  in the class docstring or in ``__init__``'s (a dataclass's fields also as ``Attributes``);
* a function or method whose source has a ``return <value>`` has a ``Returns`` section
  (``Yields`` for a generator).

Methods that override a hook of a third-party base class (Drake's ``DoCalc...``) are
documented there and skipped.  The docstrings are parsed here (no numpydoc dependency).  A
failure lists every offending name with what is missing, so an argument added without
documentation breaks CI.
"""

from __future__ import annotations

import ast
import dataclasses
import importlib
import inspect
import pkgutil
import re
import textwrap
import types

PACKAGE = "sobolev_drake"
API_MODULES = ("sobolev_drake", "sobolev_drake.synthesis", "sobolev_drake.systems",
               "sobolev_drake.models")
# library modules outside those namespaces whose ``__all__`` is public too: the tilt-rotor
# package, the rigs and the experiment toolkit
LIBRARY_PACKAGES = ("sobolev_drake.tiltrotor", "sobolev_drake.rigs", "sobolev_drake.campaign")
LIBRARY_MODULES = ("sobolev_drake.harness", "sobolev_drake.tuning", "sobolev_drake.norms",
                   "sobolev_drake.report", "sobolev_drake.viz", "sobolev_drake.plots",
                   "sobolev_drake.recording_html", "sobolev_drake.simulation")

_UNDERLINE = re.compile(r"^\s*-{3,}\s*$")


# --------------------------------------------------------------------------- docstring parsing

def parse_sections(doc: str) -> dict[str, list[str]]:
    """Sections of a numpydoc docstring: title -> its lines (header and dashes excluded).

    A section starts at a line followed by a line of at least three dashes; the text before
    the first section is stored under ``""``.
    """
    lines = inspect.cleandoc(doc).splitlines()
    sections: dict[str, list[str]] = {"": []}
    current = ""
    i = 0
    while i < len(lines):
        line = lines[i]
        if (line.strip() and i + 1 < len(lines) and _UNDERLINE.match(lines[i + 1])
                and not _UNDERLINE.match(line)):
            current = line.strip().rstrip(":").title()
            sections.setdefault(current, [])
            i += 2
            continue
        sections[current].append(line)
        i += 1
    return sections


def documented_names(section: list[str]) -> set[str]:
    """Names of the entries of a Parameters-like section.

    An entry is a line at the section's smallest indentation, ``name : type`` or ``name``;
    ``a, b : type`` documents both; stars (``*args``, ``**kwargs``) are kept.
    """
    entries = [line for line in section if line.strip()]
    if not entries:
        return set()
    indent = min(len(line) - len(line.lstrip()) for line in entries)
    names = set()
    for line in entries:
        if len(line) - len(line.lstrip()) != indent:
            continue                                     # description or type continuation
        head = line.strip().split(" : ", 1)[0].rstrip(":").strip()
        for name in head.split(","):
            name = name.strip()
            if re.fullmatch(r"\*{0,2}[A-Za-z_][A-Za-z0-9_]*", name):
                names.add(name)
    return names


def is_documented(param: inspect.Parameter, names: set[str]) -> bool:
    """True if ``names`` (entries of a Parameters section) documents ``param``."""
    if param.kind is param.VAR_KEYWORD:
        return any(n.startswith("**") for n in names) or param.name in names
    if param.kind is param.VAR_POSITIONAL:
        return (any(n.startswith("*") and not n.startswith("**") for n in names)
                or param.name in names)
    return param.name in names


# --------------------------------------------------------------------------- source inspection

def _own_nodes(func_node):
    """Nodes of a function body, not descending into nested functions, lambdas or classes."""
    stack = list(func_node.body)
    while stack:
        node = stack.pop()
        yield node
        for child in ast.iter_child_nodes(node):
            if not isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda,
                                      ast.ClassDef)):
                stack.append(child)


def return_kind(func) -> str | None:
    """"Yields" for a generator, "Returns" if the source has ``return <value>``, else None."""
    func = inspect.unwrap(func)
    if inspect.isgeneratorfunction(func):
        return "Yields"
    try:
        source = textwrap.dedent(inspect.getsource(func))
    except (OSError, TypeError):
        return None
    tree = ast.parse(source)
    node = next(n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef,
                                                            ast.AsyncFunctionDef)))
    for child in _own_nodes(node):
        if isinstance(child, ast.Return) and child.value is not None and not (
                isinstance(child.value, ast.Constant) and child.value.value is None):
            return "Returns"
    return None


def signature_parameters(obj, *, bound: bool) -> list[inspect.Parameter] | None:
    """Parameters of ``obj`` without self/cls (``bound``: the first is dropped); None if
    the signature is unavailable."""
    try:
        params = list(inspect.signature(obj).parameters.values())
    except (TypeError, ValueError):
        return None
    if bound and params and params[0].name in ("self", "cls"):
        params = params[1:]
    return params


# --------------------------------------------------------------------------- public names

def _ours(obj) -> bool:
    return (getattr(obj, "__module__", None) or "").split(".")[0] == PACKAGE


def _module_members(module):
    names = getattr(module, "__all__", None)
    if names is None:
        names = [n for n, v in vars(module).items() if not n.startswith("_")
                 and (inspect.isfunction(v) or inspect.isclass(v)) and v.__module__ ==
                 module.__name__]
    return [(f"{module.__name__}.{n}", getattr(module, n)) for n in names]


def public_objects():
    """(public name, object) for every public function, class and module, each object once."""
    seen, out = set(), []

    def add(name, obj):
        if id(obj) in seen:
            return
        if isinstance(obj, types.ModuleType):
            if not obj.__name__.startswith(PACKAGE):
                return
            seen.add(id(obj))
            out.append((name, obj))
            for member in _module_members(obj):
                add(*member)
        elif (inspect.isclass(obj) or inspect.isfunction(obj)) and _ours(obj):
            seen.add(id(obj))
            out.append((name, obj))

    for module_name in API_MODULES:
        module = importlib.import_module(module_name)
        for name in module.__all__:
            add(f"{module_name}.{name}", getattr(module, name))
    library = list(LIBRARY_MODULES)
    for package in LIBRARY_PACKAGES:
        path = importlib.import_module(package).__path__
        library += [f"{package}.{m.name}" for m in pkgutil.iter_modules(path)
                    if not m.name.startswith("_")]
    for module_name in library:
        module = importlib.import_module(module_name)
        for name, obj in _module_members(module):
            add(name, obj)
    return out


def _third_party_attribute(cls, name) -> bool:
    return any(not _ours(k) and name in vars(k) for k in cls.__mro__)


def class_members(cls):
    """{name: raw class attribute} of the public methods and properties of ``cls`` defined in
    sobolev_drake classes of its MRO (overrides of third-party hooks left out)."""
    members = {}
    for klass in cls.__mro__:
        if not _ours(klass):
            continue
        for name, value in vars(klass).items():
            if name.startswith("_") or name in members:
                continue
            if isinstance(value, (staticmethod, classmethod, property)) or inspect.isfunction(
                    value):
                if not _third_party_attribute(cls, name):
                    members[name] = value
    return members


def _own_doc(cls) -> str | None:
    doc = vars(cls).get("__doc__")
    if doc and dataclasses.is_dataclass(cls) and doc.startswith(f"{cls.__name__}("):
        return None                                        # dataclass's generated signature
    return doc


def _constructor_owner(cls):
    """The class of ``cls``'s MRO defining the constructor used (``__init__``, or
    ``__new__`` for a namedtuple)."""
    for klass in cls.__mro__:
        if "__init__" in vars(klass):
            return klass
        if "__new__" in vars(klass) and issubclass(klass, tuple):
            return klass
    return object


# --------------------------------------------------------------------------- the checks

def check_function(name, func, *, method=False, doc=None) -> list[str]:
    """Problems of one function or method (an empty list when it is documented)."""
    doc = inspect.getdoc(func) if doc is None else doc
    if not doc:
        return [f"{name}: no docstring"]
    problems = []
    sections = parse_sections(doc)
    params = signature_parameters(func, bound=method) or []
    if params:
        if "Parameters" not in sections:
            problems.append(f"{name}: no 'Parameters' section (arguments: "
                            f"{', '.join(p.name for p in params)})")
        else:
            names = documented_names(sections["Parameters"])
            names |= documented_names(sections.get("Other Parameters", []))
            for p in params:
                if not is_documented(p, names):
                    problems.append(f"{name}: argument '{p.name}' not documented")
    kind = return_kind(func)
    if kind is not None and kind not in sections:
        problems.append(f"{name}: no '{kind}' section")
    return problems


def check_class(name, cls) -> list[str]:
    """Problems of a class's docstring and constructor arguments (not of its methods)."""
    problems = []
    doc = _own_doc(cls)
    if not doc:
        problems.append(f"{name}: no class docstring")
    owner = _constructor_owner(cls)
    if _ours(owner):
        params = signature_parameters(cls, bound=False) or []
        init = vars(cls).get("__init__") if owner is cls else None
        sections = parse_sections(doc or "")
        names = documented_names(sections.get("Parameters", []))
        if dataclasses.is_dataclass(cls):
            names |= documented_names(sections.get("Attributes", []))
        if inspect.isfunction(init) and init.__doc__:
            names |= documented_names(parse_sections(init.__doc__).get("Parameters", []))
        missing = [p.name for p in params if not is_documented(p, names)]
        if missing:
            problems.append(f"{name}: constructor argument(s) {', '.join(missing)} not "
                            "documented (class or __init__ docstring, 'Parameters')")
    return problems


def check_member(name, cls, member, value) -> list[str]:
    """Problems of one public method or property of ``cls``.

    A property needs a docstring of its own or an entry in the ``Attributes`` section of the
    class docstring (numpydoc's place for them; a ``property(lambda ...)`` has no docstring).
    """
    if isinstance(value, property):
        if value.fget and value.fget.__doc__:
            return []
        owner = next(k for k in cls.__mro__ if member in vars(k))
        attributes = documented_names(parse_sections(_own_doc(owner) or "").get("Attributes", []))
        return [] if member in attributes else [f"{name}: no docstring (property) and not in "
                                                 "the class's 'Attributes' section"]
    func = value.__func__ if isinstance(value, (staticmethod, classmethod)) else value
    return check_function(name, func, method=not isinstance(value, staticmethod),
                          doc=inspect.getdoc(getattr(cls, member)))


def public_checks():
    """(public name, check) for every public object and every public method or property of
    a public class; a method inherited unchanged is checked once, under its first class."""
    items, seen = [], set()
    for name, obj in PUBLIC:
        if isinstance(obj, types.ModuleType):
            items.append((name, lambda n=name, o=obj: [] if o.__doc__ else
                          [f"{n}: no module docstring"]))
        elif inspect.isclass(obj):
            items.append((name, lambda n=name, o=obj: check_class(n, o)))
            for member, value in class_members(obj).items():
                key = (id(value), inspect.getdoc(getattr(obj, member)))
                if key in seen:
                    continue
                seen.add(key)
                items.append((f"{name}.{member}", lambda n=f"{name}.{member}", c=obj, m=member,
                              v=value: check_member(n, c, m, v)))
        else:
            items.append((name, lambda n=name, o=obj: check_function(n, o)))
    return items


PUBLIC = public_objects()
CHECKS = public_checks()


def test_public_api_is_not_empty():
    assert len(PUBLIC) > 50 and len(CHECKS) > len(PUBLIC)


def test_every_public_name_is_documented():
    problems = [p for _, run in CHECKS for p in run()]
    assert not problems, (f"{len(problems)} docstring problem(s) in the {len(CHECKS)} public "
                          "names:\n  " + "\n  ".join(problems))


# --------------------------------------------------------------------------- the parser itself

def _sample(a, b, *rest, c=None, **options):
    """Summary.

    Parameters
    ----------
    a, b : float
        Two numbers.
    *rest
        More.
    options : dict
        Not starred, so does not document ``**options`` by the star rule, but by name.

    Returns
    -------
    float
    """
    return a


def _undocumented(x, y, **kw):
    """Summary.

    Parameters
    ----------
    x : int
        Only x; y and the keywords are missing, and so is Returns.
        y : this indented line is a description, not an entry
    """
    return x


def _generator(n):
    """Count.

    Parameters
    ----------
    n : int
    """
    yield from range(n)


def test_parser_accepts_grouped_and_starred_entries_and_rejects_missing_ones():
    assert check_function("sample", _sample) == ["sample: argument 'c' not documented"]
    assert check_function("undoc", _undocumented) == [
        "undoc: argument 'y' not documented", "undoc: argument 'kw' not documented",
        "undoc: no 'Returns' section"]
    assert check_function("gen", _generator) == ["gen: no 'Yields' section"]
    assert check_function("nodoc", lambda: None) == ["nodoc: no docstring"]

