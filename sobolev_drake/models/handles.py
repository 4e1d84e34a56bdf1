"""Plant handles and the shared URDF → MultibodyPlant plumbing of the models.

Every ``add_<name>(builder, ...)`` returns a :class:`PlantHandles`: the MultibodyPlant, its
SceneGraph, the :class:`~sobolev_drake.models.base.MechanicalModel` wrapping that plant, and the
ports of the :class:`~sobolev_drake.models._adapter.ThesisForceAdapter` that speak the thesis'
language (actuator commands ``u`` in thesis units, generalized disturbance ``disturbance`` and
state ``x = [q; q̇]`` in thesis order).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from collections.abc import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike
from pydrake.geometry import SceneGraph
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.systems.framework import Context, Diagram, DiagramBuilder, InputPort, OutputPort

from sobolev_drake.models._adapter import ThesisForceAdapter
from sobolev_drake.models.base import MechanicalModel, check_vector
from sobolev_drake.validation import index_tuple

__all__ = [
    "PlantHandles", "add_state_selector", "urdf_text", "UrdfEditor", "build_plant",
    "coordinate_map", "verify_against_closed_forms", "attach_adapter",
]


@dataclass
class PlantHandles:
    """What ``add_<name>`` hands back (the contract every plant builder keeps, docs/design.md §5).

    ``u`` and ``disturbance`` read as zero when left unconnected.

    Attributes
    ----------
    plant : MultibodyPlant
        The plant added to the builder.
    scene_graph : SceneGraph or None
        Its SceneGraph (None for a bare plant).
    model : MechanicalModel
        Model wrapping ``plant`` (thesis-ordered M, C q̇, g, B).
    u : InputPort
        Actuator commands in thesis units (size ``model.num_inputs``).
    disturbance : InputPort
        Thesis-ordered generalized disturbance force w (size n).
    x : OutputPort
        Thesis-ordered state [q; q̇] (size 2n).
    adapter : ThesisForceAdapter or None
        The adapter system (for extra wiring or inspection).
    """

    plant: MultibodyPlant
    scene_graph: SceneGraph | None
    model: MechanicalModel
    u: InputPort
    disturbance: InputPort
    x: OutputPort
    adapter: ThesisForceAdapter | None = None

    def set_state(self, context: Context, diagram: Diagram | None, q: ArrayLike,
                  qdot: ArrayLike) -> None:
        """Write thesis-ordered (q, q̇) into the plant's part of ``context``.

        Parameters
        ----------
        context : Context
            The root diagram context (e.g. ``simulator.get_mutable_context()``).
        diagram : Diagram or None
            Accepted for the shared contract but not needed: the plant's sub-context is found
            from the root context.
        q, qdot : array_like, shape (n,)
            Thesis-ordered generalized coordinates and velocities.
        """
        n = self.model.n
        q = check_vector("q", q, n)
        qdot = check_vector("qdot", qdot, n)
        plant_context = self.plant.GetMyMutableContextFromRoot(context)
        self.plant.SetPositions(plant_context, self.model.to_drake(q))
        self.plant.SetVelocities(plant_context, self.model.to_drake(qdot))

    def get_state(self, context: Context) -> tuple[np.ndarray, np.ndarray]:
        """Thesis-ordered (q, q̇) read from the plant's part of the root ``context``.

        Parameters
        ----------
        context : Context
            The root diagram context.

        Returns
        -------
        q, qdot : ndarray, shape (n,)
            Thesis-ordered generalized coordinates and velocities.
        """
        plant_context = self.plant.GetMyContextFromRoot(context)
        q = self.model.to_thesis(self.plant.GetPositions(plant_context))
        v = self.model.to_thesis(self.plant.GetVelocities(plant_context))
        return q, v


def add_state_selector(builder: DiagramBuilder, state: OutputPort, index: Sequence[int],
                       name: str) -> OutputPort:
    """Output port ``x`` with ``x[j] = state[index[j]]``, computed by Drake's C++ ``Selector``.

    Used for the thesis-ordered state of a plant whose Drake order is a permutation of it: the
    copy is exact (no arithmetic) and costs no Python call per evaluation, which matters for
    ports read by a sampled controller and log sinks at every sample.
    """
    from pydrake.systems.primitives import Selector, SelectorParams

    n = state.size()
    index = list(index_tuple(f"index (a permutation of range({n}))", index, n))
    if sorted(index) != list(range(n)):
        raise ValueError(f"index must be a permutation of range({n}) (the size of {state.get_name()!r}), "
                         f"got {index}")
    params = SelectorParams()
    port_in = SelectorParams.InputPortParams()
    port_in.name, port_in.size = "state", n
    port_out = SelectorParams.OutputPortParams()
    port_out.name = "x"
    selections = []
    for i in index:
        sel = SelectorParams.OutputSelection()
        sel.input_port_index, sel.input_offset = 0, i
        selections.append(sel)
    port_out.selections = selections
    params.inputs, params.outputs = [port_in], [port_out]
    selector = builder.AddSystem(Selector(params))
    selector.set_name(name)
    builder.Connect(state, selector.get_input_port())
    return selector.get_output_port()


# --- URDF helpers -------------------------------------------------------------------------------
URDF_DIR = Path(__file__).resolve().parent.parent / "urdf"


def urdf_text(name: str) -> str:
    """Text of ``sobolev_drake/urdf/<name>.urdf`` (shipped with the package).

    Located relative to this file rather than with ``importlib.resources``: the top-level package
    of an editable install can resolve as a namespace package, which ``resources.files`` rejects.
    """
    path = URDF_DIR / f"{name}.urdf"
    if not path.is_file():
        raise FileNotFoundError(f"no URDF named {name!r} in sobolev_drake/urdf")
    return path.read_text()


def _fmt(values) -> str:
    return " ".join(repr(float(v)) for v in np.atleast_1d(values))


class UrdfEditor:
    """Small ElementTree wrapper used to rewrite the parameters of a shipped URDF.

    The URDF files hold the thesis' table values; other parameter sets are written into the XML
    before parsing, so Drake always sees a plain URDF (no context-dependent parameters to keep in
    sync between the standalone model and the diagram plant).
    """

    def __init__(self, text: str):
        self.root = ET.fromstring(text)

    def _find(self, tag: str, name: str) -> ET.Element:
        el = self.root.find(f"{tag}[@name='{name}']")
        if el is None:
            raise KeyError(f"URDF has no {tag} named {name!r}")
        return el

    def set_inertial(self, link: str, mass: float, com: ArrayLike, inertia_diag: ArrayLike) -> None:
        inertial = self._find("link", link).find("inertial")
        inertial.find("origin").set("xyz", _fmt(com))
        inertial.find("mass").set("value", repr(float(mass)))
        ixx, iyy, izz = (float(v) for v in inertia_diag)
        inertial.find("inertia").attrib.update(
            ixx=repr(ixx), iyy=repr(iyy), izz=repr(izz), ixy="0", ixz="0", iyz="0")

    def set_joint_origin(self, joint: str, xyz: ArrayLike) -> None:
        self._find("joint", joint).find("origin").set("xyz", _fmt(xyz))

    def set_visual(self, link: str, index: int, *, xyz: ArrayLike | None = None,
                   rpy: ArrayLike | None = None, **geometry: Mapping[str, ArrayLike]) -> None:
        """Update the ``index``-th visual of ``link``: origin and/or geometry attributes
        (e.g. ``box={"size": ...}``, ``cylinder={"radius": ..., "length": ...}``)."""
        visual = self._find("link", link).findall("visual")[index]
        origin = visual.find("origin")
        if xyz is not None:
            origin.set("xyz", _fmt(xyz))
        if rpy is not None:
            origin.set("rpy", _fmt(rpy))
        for shape, attrs in geometry.items():
            el = visual.find("geometry").find(shape)
            for key, val in attrs.items():
                el.set(key, _fmt(val))

    def text(self) -> str:
        return ET.tostring(self.root, encoding="unicode")


def build_plant(text: str, gravity: float, builder: DiagramBuilder | None = None,
                before_finalize: Callable[[MultibodyPlant], None] | None = None
                ) -> tuple[MultibodyPlant, SceneGraph | None]:
    """Parse URDF ``text`` into a continuous (time_step = 0) MultibodyPlant and finalize it.

    With ``builder`` the plant comes with a SceneGraph (visual geometry for Meshcat); without it
    a bare plant is returned (``scene_graph`` is None) for standalone model queries.
    ``before_finalize(plant)`` may add frames or geometry (e.g. the quadrotor's rotor frames).
    """
    if builder is None:
        plant, scene_graph = MultibodyPlant(time_step=0.0), None
    else:
        plant, scene_graph = AddMultibodyPlantSceneGraph(builder, time_step=0.0)
    Parser(plant).AddModelsFromString(text, "urdf")
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, -float(gravity)])
    if before_finalize is not None:
        before_finalize(plant)
    plant.Finalize()
    return plant, scene_graph


def coordinate_map(plant: MultibodyPlant,
                   joints_and_scales: Sequence[tuple[str, float]]) -> np.ndarray:
    """T with ``q_drake = T q_thesis`` from thesis-ordered (joint name, scale) pairs.

    ``scale`` is the factor from the thesis coordinate to the joint coordinate (e.g. the wheel
    radius r for a prismatic axle x = r ϕ).  Every joint must be single-DOF.
    """
    n = plant.num_positions()
    if len(joints_and_scales) != n:
        raise ValueError(f"need {n} thesis coordinates, got {len(joints_and_scales)}")
    T = np.zeros((n, n))
    for j, (name, scale) in enumerate(joints_and_scales):
        joint = plant.GetJointByName(name)
        if joint.num_positions() != 1:
            raise ValueError(f"joint {name!r} is not single-DOF")
        T[joint.position_start(), j] = scale
    return T


def verify_against_closed_forms(model: MechanicalModel, q: ArrayLike, tol: float = 1e-8) -> None:
    """Raise ValueError if the plant's M(q), g(q) (and B(q)) disagree with the model's closed
    forms at ``q`` — catches a plant built with parameters other than ``model.params``.  M, g and
    B are the plant's own (the base class' Drake evaluations, ``model.B_plant`` where a model
    defines it), also for a model that replaces them by another reading
    (``ThesisPrintedArmModel``, ``ThesisPrintedQuadrotorModel``)."""
    pairs = [("M", MechanicalModel.M(model, q), model.M_closed_form(q)),
             ("g", MechanicalModel.g(model, q), model.g_closed_form(q))]
    if hasattr(model, "B_closed_form"):
        plant_B = model.B_plant if hasattr(model, "B_plant") else model.B
        pairs.append(("B", plant_B(q), model.B_closed_form(q)))
    for what, drake_value, closed in pairs:
        err = np.linalg.norm(drake_value - closed) / max(np.linalg.norm(closed), 1e-300)
        if err > tol:
            raise ValueError(f"{model.name}: the plant's {what}(q) differs from the closed form of "
                             f"model.params (relative error {err:.2e}); build the plant with the "
                             "same parameters")


def attach_adapter(builder: DiagramBuilder, plant: MultibodyPlant, scene_graph: SceneGraph | None,
                   model: MechanicalModel,
                   name: str) -> PlantHandles:
    """Add the generic ThesisForceAdapter for ``model`` and wire it to ``plant``."""
    adapter = builder.AddSystem(ThesisForceAdapter(model))
    adapter.set_name(f"{name}_adapter")
    builder.Connect(plant.get_state_output_port(), adapter.GetInputPort("plant_state"))
    builder.Connect(adapter.GetOutputPort("applied_generalized_force"),
                    plant.get_applied_generalized_force_input_port())
    return PlantHandles(plant=plant, scene_graph=scene_graph, model=model,
                        u=adapter.GetInputPort("u"), disturbance=adapter.GetInputPort("disturbance"),
                        x=adapter.GetOutputPort("x"), adapter=adapter)
