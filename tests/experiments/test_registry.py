"""The experiment registry: every shipped module imports, and a broken one is contained."""

import sys
import types

import pytest

from sobolev_drake import experiments


def test_every_experiment_module_imports_and_registers():
    reg = experiments.discover()
    assert experiments.IMPORT_ERRORS == {}
    for name in ("models-tour", "linear-simple", "balance-linear", "quadrotor-polytopic",
                 "manipulator", "quadrotor-attitude", "balance-coupled", "quadrotor-figure8",
                 "balance-sgaa", "tiltrotor-hover-linear", "tiltrotor-hover", "tiltrotor-envelope"):
        assert name in reg, name
    assert experiments.flagship().name == "tiltrotor-envelope"


def test_broken_module_is_reported_not_fatal(monkeypatch):
    experiments.discover()
    fake = types.SimpleNamespace(name="zz_broken")
    real_iter = experiments.pkgutil.iter_modules

    def iter_with_broken(path):
        yield from real_iter(path)
        yield fake

    def import_module(name, _real=experiments.importlib.import_module):
        if name.endswith(".zz_broken"):
            raise ImportError("simulated failure")
        return _real(name)

    monkeypatch.setattr(experiments.pkgutil, "iter_modules", iter_with_broken)
    monkeypatch.setattr(experiments.importlib, "import_module", import_module)
    monkeypatch.setattr(experiments, "IMPORT_ERRORS", {})
    with pytest.warns(RuntimeWarning, match="zz_broken"):
        reg = experiments.discover()
    assert "models-tour" in reg  # the healthy experiments are still there
    with pytest.raises(experiments.UnknownExperimentError, match="zz_broken.*simulated failure"):
        experiments.get("zz-broken")
    assert "sobolev_drake.experiments.zz_broken" not in sys.modules
