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
documented there and skipped.  numpydoc parses the docstrings (``numpydoc.docscrape``) and its
validator (``numpydoc.validate.Validator``) says whether a function returns something; the
rules above that numpydoc's error codes do not express (a constructor documented in the class,
dataclass fields and properties under ``Attributes``, a starred entry of another name) are
applied here.  A failure lists every offending name with what is missing, so an argument added
without documentation breaks CI.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import pkgutil
import types
import warnings

from numpydoc.docscrape import NumpyDocString, get_doc_object
from numpydoc.validate import Validator

PACKAGE = "sobolev_drake"
API_MODULES = ("sobolev_drake", "sobolev_drake.synthesis", "sobolev_drake.systems",
               "sobolev_drake.models")
# library modules outside those namespaces whose ``__all__`` is public too: the tilt-rotor
# package, the rigs and the experiment toolkit
LIBRARY_PACKAGES = ("sobolev_drake.tiltrotor", "sobolev_drake.rigs", "sobolev_drake.campaign")
LIBRARY_MODULES = ("sobolev_drake.harness", "sobolev_drake.tuning", "sobolev_drake.norms",
                   "sobolev_drake.report", "sobolev_drake.viz", "sobolev_drake.plots",
                   "sobolev_drake.recording_html", "sobolev_drake.simulation")


# --------------------------------------------------------------------------- docstring parsing

def parse(doc: str) -> NumpyDocString:
    """numpydoc's parse of a docstring (its warnings, e.g. an unknown section title, ignored:
    this test checks arguments and returns, not the section vocabulary)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return NumpyDocString(inspect.cleandoc(doc or ""))


def documented_names(doc: NumpyDocString, *sections: str) -> set[str]:
    """Names of the entries of Parameters-like ``sections``: ``a, b : type`` documents both;
    stars (``*args``, ``**kwargs``, also written escaped) are kept."""
    return {name.strip().replace("\\", "") for section in sections for entry in doc[section]
            for name in entry.name.split(",") if name.strip()}


def is_documented(param: inspect.Parameter, names: set[str]) -> bool:
    """True if ``names`` (entries of a Parameters section) documents ``param``."""
    if param.kind is param.VAR_KEYWORD:
        return any(n.startswith("**") for n in names) or param.name in names
    if param.kind is param.VAR_POSITIONAL:
        return (any(n.startswith("*") and not n.startswith("**") for n in names)
                or param.name in names)
    return param.name in names


# --------------------------------------------------------------------------- source inspection

def return_kind(func, doc: str | None = None) -> str | None:
    """"Yields" for a generator, "Returns" if numpydoc's validator finds a ``return <value>``
    in the source (not in nested functions), else None."""
    func = inspect.unwrap(func)
    if inspect.isgeneratorfunction(func):
        return "Yields"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            returns = Validator(get_doc_object(func, what="function", doc=doc or "")
                                ).method_returns_something
    except (OSError, TypeError, SyntaxError):
        return None                                   # no Python source (a builtin, a lambda)
    return "Returns" if returns else None


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
    parsed = parse(doc)
    params = signature_parameters(func, bound=method) or []
    if params:
        if not parsed["Parameters"] and not parsed["Other Parameters"]:
            problems.append(f"{name}: no 'Parameters' section (arguments: "
                            f"{', '.join(p.name for p in params)})")
        else:
            names = documented_names(parsed, "Parameters", "Other Parameters")
            for p in params:
                if not is_documented(p, names):
                    problems.append(f"{name}: argument '{p.name}' not documented")
    kind = return_kind(func, doc)
    if kind is not None and not parsed[kind]:
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
        parsed = parse(doc)
        names = documented_names(parsed, "Parameters")
        if dataclasses.is_dataclass(cls):
            names |= documented_names(parsed, "Attributes")
        if inspect.isfunction(init) and init.__doc__:
            names |= documented_names(parse(init.__doc__), "Parameters")
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
        attributes = documented_names(parse(_own_doc(owner)), "Attributes")
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

