"""Packaging metadata (issue #35): extras named by install hints exist, the lock fits the ranges,
LICENSE / CITATION.cff, ``--version``.  Fast checks only; building and installing the sdist and
the wheel is ``.ci/wheel-check`` (``make wheel-check``)."""

import importlib.metadata as md
import re
from pathlib import Path

import pytest

import sobolev_drake
from sobolev_drake import cli

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "sobolev_drake"

try:
    import tomllib
except ImportError:                     # Python 3.10
    tomllib = pytest.importorskip("tomli")

Requirement = pytest.importorskip("packaging.requirements").Requirement
canonicalize_name = pytest.importorskip("packaging.utils").canonicalize_name


@pytest.fixture(scope="module")
def project():
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]


def _extras(project):
    return {name: [Requirement(r) for r in reqs]
            for name, reqs in project.get("optional-dependencies", {}).items()}


def _install_hints():
    """(file:line, extra) of every ``sobolev_drake[extra,...]`` in the package, docs and README."""
    files = [*PACKAGE.rglob("*.py"), *(ROOT / "docs").rglob("*.md"), ROOT / "README.md"]
    hints = []
    for path in files:
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for match in re.finditer(r"sobolev_drake\[([^\]]*)\]", line):
                for extra in match.group(1).split(","):
                    hints.append((f"{path.relative_to(ROOT)}:{number}", extra.strip()))
    return hints


def test_install_hints_name_existing_extras(project):
    hints = _install_hints()
    assert hints, "expected install hints such as pip install 'sobolev_drake[campaign]'"
    extras = _extras(project)
    missing = [f"{where}: [{extra}]" for where, extra in hints if extra not in extras]
    assert not missing, f"install hints name extras pyproject.toml lacks ({sorted(extras)}): {missing}"


def test_extras_provide_the_optional_imports(project):
    """The modules the code imports on demand come with the extra its hint names, and the
    ``test`` extra brings them all (the tests of those paths skip without them)."""
    extras = _extras(project)
    provides = {name: {canonicalize_name(r.name) for r in reqs} for name, reqs in extras.items()}
    assert {"control", "slycot"} <= provides["control"]
    dask = [r for r in extras["campaign"] if canonicalize_name(r.name) == "dask"]
    assert dask and "distributed" in dask[0].extras          # executors import `distributed`
    self_extras = set().union(*(r.extras for r in extras["test"]
                                if canonicalize_name(r.name) == canonicalize_name(project["name"])))
    assert {"control", "campaign"} <= self_extras
    assert "sphinx" in provides["docs"]


def test_lock_satisfies_the_ranges(project):
    """constraints.txt (what `make` installs) lies inside pyproject's ranges, and every direct
    dependency is a range, not an exact pin."""
    locked = {}
    for line in (ROOT / "constraints.txt").read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            name, version = line.split("==")
            locked[canonicalize_name(name)] = version.strip()
    requirements = [Requirement(r) for r in project["dependencies"]]
    requirements += [r for reqs in _extras(project).values() for r in reqs]
    for req in requirements:
        name = canonicalize_name(req.name)
        if name == canonicalize_name(project["name"]):
            continue
        assert name in locked, f"{req} is not pinned in constraints.txt"
        assert req.specifier.contains(locked[name], prereleases=True), \
            f"constraints.txt pins {name}=={locked[name]} outside pyproject's {req}"
    for req in map(Requirement, project["dependencies"]):
        assert not any(spec.operator in ("==", "===") for spec in req.specifier), \
            f"{req}: a library dependency should be a compatible range"


def test_license_and_citation(project):
    license_text = (ROOT / "LICENSE").read_text()
    assert license_text.startswith("MIT License")
    assert "Copyright (c) 2026 the sobolev_drake developers" in license_text
    assert project["license"] == "MIT" and project["license-files"] == ["LICENSE"]
    text = (ROOT / "CITATION.cff").read_text()
    try:
        import yaml
    except ImportError:
        for key in ("cff-version: 1.2.0", "title:", "authors:", "license: MIT", "references:",
                    "type: thesis", f"version: {project['version']}"):
            assert key in text, key
        return
    cff = yaml.safe_load(text)
    assert cff["cff-version"] == "1.2.0"
    for key in ("message", "title", "authors"):               # required by the schema
        assert cff[key], key
    assert cff["license"] == "MIT"
    assert str(cff["version"]) == project["version"]
    thesis = [r for r in cff["references"] if r["type"] == "thesis"]
    assert len(thesis) == 1
    assert thesis[0]["authors"][0]["family-names"] == "Cardoso"
    assert thesis[0]["title"] and "UFMG" in thesis[0]["institution"]["name"]


def test_version_option_prints_the_metadata_version(project, capsys):
    installed = md.version("sobolev_drake")
    assert installed == project["version"] == sobolev_drake.__version__
    assert cli.main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"sobolev-drake {installed}"


def test_import_leaves_the_matplotlib_backend_alone(tmp_path):
    """``import sobolev_drake`` and saving a figure choose no backend for the user (figures are
    drawn on matplotlib.figure.Figure, which needs none); MPLBACKEND unset as a user has it."""
    import os
    import subprocess
    import sys
    code = ("import matplotlib, numpy as np, sobolev_drake as sd\n"
            "before = matplotlib.rcParams._get_backend_or_none()\n"
            "sd.plots.plot_time_series(np.linspace(0, 1, 5), {'y': np.arange(5.0)}, 'y.png')\n"
            "print(before, matplotlib.rcParams._get_backend_or_none())\n")
    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, check=True,
                         capture_output=True, text=True).stdout.split()
    assert out == ["None", "None"]
    assert (tmp_path / "y.png").stat().st_size > 0


#: modules whose public functions and methods carry complete type hints (PEP 561: py.typed)
TYPED_MODULES = ("sobolev_drake.errors", "sobolev_drake.native", "sobolev_drake.native.forces",
                 "sobolev_drake.native.rnea",
                 "sobolev_drake.campaign.case", "sobolev_drake.campaign.errors",
                 "sobolev_drake.campaign.executors", "sobolev_drake.campaign.registry",
                 "sobolev_drake.campaign.runner", "sobolev_drake.campaign.stats",
                 "sobolev_drake.campaign.store", "sobolev_drake.datafile", "sobolev_drake.cli",
                 "sobolev_drake.norms", "sobolev_drake.report", "sobolev_drake.validation",
                 *(f"sobolev_drake.models.{m}" for m in (
                     "arm", "base", "euler_chart", "euler_zyx", "floating_base",
                     "generic_quadrotor", "handles", "linearization", "plant_checks", "quadrotor",
                     "quadrotor_linear", "quadrotor_params", "scalar_terms", "serial_chain",
                     "simple_linear", "two_wheeled", "two_wheeled_design", "two_wheeled_linear")),
                 *(f"sobolev_drake.rigs.{m}" for m in (
                     "balance_galerkin", "balance_linear", "linear_simple", "mechanical",
                     "multirotor", "quadrotor_hover", "quadrotor_hover_plots", "seven_link")),
                 *(f"sobolev_drake.tiltrotor.{m}" for m in (
                     "aero_tables", "aerodynamics", "allocation", "body_frame", "campaigns",
                     "compiled_sample", "controller", "envelope_analysis", "gain_schedule", "generic_forces",
                     "hover_flight", "input_affine", "law", "law_checks", "linear_controller",
                     "linear_design", "linearization", "mission", "mission_metrics", "params",
                     "plant", "plots", "propeller", "propulsion", "references", "scalars", "tables",
                     "tilt_schedule", "trim", "urdf")),
                 "sobolev_drake.simulation", "sobolev_drake.harness", "sobolev_drake.plots",
                 "sobolev_drake.viz", "sobolev_drake.recording_html", "sobolev_drake.analysis_plots",
                 *(f"sobolev_drake.synthesis.{m}" for m in (
                     "loop_analysis", "weights", "discrete", "design_file", "certificates",
                     "closed_loop_bounds", "designs", "galerkin", "galerkin_balance",
                     "galerkin_basis", "galerkin_problem", "hinf", "hinf_common", "hinf_riccati",
                     "hinf_surface", "interop", "lmi", "margins", "mechanical", "options",
                     "output_feedback", "polytopic", "problem", "random_plants", "regions",
                     "riccati", "scaling", "sdp_ipm", "sobolev", "strategy", "thesis_lmi", "controller")),
                 *(f"sobolev_drake.systems.{m}" for m in (
                     "bounded_ls", "control_output", "discrete_controller", "disturbances",
                     "floating_state", "galerkin_controller", "hinf_baseline", "inner_laws",
                     "linear_controllers", "mechanical_controller", "mechanical_sample",
                     "multirotor_control", "partition", "plant_dynamics", "reference_catalogue",
                     "rotor_allocation", "scalar_law", "scalar_time", "controller_ports",
                     "mechanical_law", "mechanical_hinf", "reference_coordinates", "reference_smoothing", "references",
                     "wind", "von_karman")),
                 "sobolev_drake.optional", "sobolev_drake.simulation_errors", "sobolev_drake.tuning",
                 "sobolev_drake.experiments",
                 *(f"sobolev_drake.experiments.{m}" for m in (
                     "_balance_linear_designs", "_balance_linear_posedness", "_balance_linear_report",
                     "_balance_linear_variants", "balance_coupled", "balance_linear", "balance_sgaa",
                     "linear_simple", "manipulator", "models_tour", "quadrotor_attitude",
                     "quadrotor_figure8", "quadrotor_polytopic", "tiltrotor_hover_linear",
                     "tiltrotor_missions")))


def _type_checking_names(module):
    """The names ``module`` imports only for type checkers (``if TYPE_CHECKING:``, e.g. to
    break an import cycle), imported here so that its hints resolve."""
    import ast
    import inspect
    names = {}
    for node in ast.parse(inspect.getsource(module)).body:
        if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING":
            exec(compile(ast.Module(body=node.body, type_ignores=[]), module.__file__, "exec"),
                 names)
    return names


def test_the_package_is_typed_and_its_typed_modules_are_complete():
    """py.typed ships with the package (package data), and in the modules listed every public
    function and method annotates each argument and its return (the hints resolve).  Methods
    pydrake adds to a TemplateSystem class (ToAutoDiffXd, ...) are Drake's, not checked."""
    import importlib
    import inspect
    import typing
    assert (PACKAGE / "py.typed").is_file()
    assert "py.typed" in tomllib.loads((ROOT / "pyproject.toml").read_text())[
        "tool"]["setuptools"]["package-data"]["sobolev_drake"]
    from pydrake.systems.scalar_conversion import TemplateSystem
    missing = []
    for name in TYPED_MODULES:
        module = importlib.import_module(name)
        localns = _type_checking_names(module)
        # every scalar instantiation of the module's TemplateSystems, whatever ran before (the
        # classes appear in the module as X_𝓣AutoDiffXd𝓤 ... when first requested)
        for template in [t for t in vars(module).values() if isinstance(t, TemplateSystem)]:
            for param in template.param_list:
                template[param]
        functions = [(f"{name}.{n}", f) for n, f in vars(module).items()
                     if inspect.isfunction(f) and f.__module__ == name and not n.startswith("_")]
        for cname, cls in vars(module).items():
            if inspect.isclass(cls) and cls.__module__ == name and not cname.startswith("_"):
                functions += [(f"{name}.{cname}.{n}", inspect.unwrap(f)) for n, f in vars(cls).items()
                              if inspect.isfunction(f) and not n.startswith("_")
                              and f.__module__ == name]
        for qual, func in functions:
            hints = typing.get_type_hints(func, localns=localns)
            params = [p for p in inspect.signature(func).parameters if p not in ("self", "cls")]
            lacking = [p for p in params if p not in hints] + \
                ([] if "return" in hints else ["return"])
            if lacking:
                missing.append(f"{qual}: {', '.join(lacking)}")
    assert not missing, "\n".join(missing)


def test_the_core_works_without_python_control(tmp_path):
    """python-control is the ``control`` extra: without it ``import sobolev_drake`` and the
    README's first synthesis still work, and the features that need it say which extra to
    install (the wheel-check installs no extras and failed on a module-level import once)."""
    import os
    import subprocess
    import sys
    code = ("import sys\n"
            "sys.modules['control'] = None\n"
            "sys.modules['slycot'] = None\n"
            "import numpy as np, sobolev_drake as sd\n"
            "A, B = np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[0.0], [1.0]])\n"
            "res = sd.winf_state_feedback(A, B, np.eye(2), "
            "Gamma0=np.eye(2), Gamma1=0.1 * np.eye(2))\n"
            "print(res.certified)\n"
            "for call in (lambda: sd.hinf_discrete(None, 1, 1), lambda: sd.to_statespace([[1.0]]),\n"
            "             lambda: sd.loop_analysis(res, (A, B))):\n"
            "    try:\n"
            "        call()\n"
            "    except ImportError as exc:\n"
            "        print('sobolev_drake[control]' in str(exc))\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=dict(os.environ),
                         check=True, capture_output=True, text=True).stdout.split()
    assert out == ["True"] * 4


def test_no_library_code_chooses_a_matplotlib_backend():
    """Figures are drawn on matplotlib.figure.Figure: no ``matplotlib.use`` and no pyplot import
    anywhere in the package (the user's backend — an interactive one in a notebook — stays)."""
    import re
    pattern = re.compile(r"matplotlib\.use\(|import matplotlib\.pyplot|from matplotlib import pyplot")
    offenders = [f"{p.relative_to(ROOT)}:{n}" for p in sorted((ROOT / "sobolev_drake").rglob("*.py"))
                 for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
                 if pattern.search(line.split("#")[0])]
    assert not offenders, offenders


def test_every_public_module_with_functions_is_in_the_typed_list():
    """A new module joins TYPED_MODULES (and so gets complete hints) as soon as it defines a
    public function or class method; private modules (``_x``) and ``__main__`` are exempt."""
    import importlib
    import inspect
    import pkgutil
    import sobolev_drake
    unlisted = []
    for info in pkgutil.walk_packages(sobolev_drake.__path__, "sobolev_drake."):
        name = info.name
        if name in TYPED_MODULES or any(part.startswith("_") for part in name.split(".")):
            continue
        module = importlib.import_module(name)
        own = [v for k, v in vars(module).items() if not k.startswith("_")
               and (inspect.isfunction(v) or inspect.isclass(v)) and v.__module__ == name]
        if own:
            unlisted.append(name)
    assert not unlisted, unlisted
