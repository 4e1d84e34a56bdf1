"""Every docstring example of the package runs and prints what it shows.

The numpydoc ``Examples`` sections of every module of ``sobolev_drake`` (walked with pkgutil;
``sobolev_drake.__main__``, which runs the command line, is not imported) are collected with the
standard :class:`doctest.DocTestFinder` and each docstring with examples runs as one test, with
``ELLIPSIS | NORMALIZE_WHITESPACE``.  A :class:`SynthesisWarning` raised by an example is an
error: examples show well-posed problems, or catch the warning where it is the point.  The
examples print rounded numbers only, so they pass under every OpenBLAS kernel family CI uses.
"""

from __future__ import annotations

import doctest
import importlib
import pkgutil
import re
import warnings

import pytest

import sobolev_drake
from sobolev_drake.synthesis import SynthesisWarning

OPTIONS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
#: issue #35: the main public API has examples; fewer docstrings with examples means some were lost
MIN_DOCSTRINGS_WITH_EXAMPLES = 25
SKIPPED_MODULES = {"sobolev_drake.__main__"}


def _raise(name):
    raise ImportError(f"cannot import {name} while collecting the docstring examples")


def package_modules():
    """The package and every module under it (imported), ``__main__`` excepted."""
    modules = [sobolev_drake]
    for info in pkgutil.walk_packages(sobolev_drake.__path__, "sobolev_drake.", onerror=_raise):
        if info.name not in SKIPPED_MODULES:
            modules.append(importlib.import_module(info.name))
    return modules


def display_name(name):
    """The name of a found docstring, Drake template instantiations by their template's alias.

    pydrake publishes each instantiation of a scalar-type template (``TemplateSystem``) in its
    module as ``X_𝓣float𝓤``, ``X_𝓣AutoDiffXd𝓤``, ... (the same docstring; which exist depends
    on what ran before) and the package names the double one ``X = X_[None]``: one test
    named ``X``, whatever instantiations exist.
    """
    return INSTANTIATION.sub("", name)


INSTANTIATION = re.compile("_\U0001d4e3[^\U0001d4e4]*\U0001d4e4")


def collect():
    """{name: DocTest} of every docstring with examples, defined in the module it is found in."""
    finder = doctest.DocTestFinder(exclude_empty=True)
    found = {}
    for module in package_modules():
        for test in finder.find(module):
            if test.examples:
                found.setdefault(display_name(test.name), test)
    return dict(sorted(found.items()))


DOCTESTS = collect()


def test_the_public_api_has_examples():
    assert len(DOCTESTS) >= MIN_DOCSTRINGS_WITH_EXAMPLES, sorted(DOCTESTS)


@pytest.mark.parametrize("name", list(DOCTESTS))
def test_docstring_example(name):
    found = DOCTESTS[name]
    # a fresh copy of the module globals per run (the runner clears the globals it was given)
    test = doctest.DocTest(found.examples, dict(found.globs), found.name, found.filename,
                           found.lineno, found.docstring)
    runner = doctest.DocTestRunner(optionflags=OPTIONS)
    report = []
    with warnings.catch_warnings():
        warnings.simplefilter("error", SynthesisWarning)
        runner.run(test, out=report.append)
    assert runner.failures == 0, "".join(report)
