"""Any multirotor described as drone packages describe one — a floating body (quaternion
floating base) and Drake ``Propeller``s — flown by the nonlinear W2/W∞ law with allocation or by
a linear state feedback designed at hover (e.g. Drake's LQR), one diagram per flight.

* :func:`add_multirotor` parses the description, adds the ``Propeller`` system, the Euler-angle
  model (``MechanicalModel.from_plant(plant, propellers=...)``) and the state conversion
  (:class:`~sobolev_drake.systems.floating_state.FloatingBaseState`);
* :func:`linearize_hover` linearizes plant + propellers at hover with Drake's ``Linearize``
  and moves the result to the minimal Euler chart (12 states, no quaternion redundancy);
* :func:`add_w_controller` / :func:`add_state_feedback` close the loop;
  :func:`add_hover_winf` is the linear path in one call (linearize, ``winf_state_feedback``,
  state feedback on the plant's ports);
* :func:`fly_multirotor` builds, flies and logs one closed loop.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from pydrake.autodiffutils import ExtractGradient, InitializeAutoDiff
from pydrake.multibody.parsing import Parser
from pydrake.geometry import Meshcat
from pydrake.multibody.plant import (AddMultibodyPlantSceneGraph, MultibodyPlant, Propeller,
                                     PropellerInfo)
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import (DiagramBuilder, InputPort, LeafSystem, OutputPort,
                                       System)
from pydrake.systems.primitives import (AffineSystem, ConstantVectorSource, LogVectorOutput,
                                        Multiplexer, Saturation, Linearize)

from sobolev_drake.models.base import MechanicalModel
from sobolev_drake.models.euler_chart import euler_to_quaternion
from sobolev_drake.synthesis import winf_state_feedback
from sobolev_drake.synthesis.problem import SynthesisResult
from sobolev_drake.systems.inner_laws import SobolevLaw
from sobolev_drake.systems.floating_state import FloatingBaseState
from sobolev_drake.systems.multirotor_control import MultirotorController

__all__ = ["MultirotorHandles", "HoverLinearization", "add_multirotor", "linearize_hover",
           "add_w_controller", "add_state_feedback", "add_hover_winf", "reference_state_selector",
           "fly_multirotor"]


@dataclass
class MultirotorHandles:
    """What :func:`add_multirotor` added.

    Attributes
    ----------
    plant, scene_graph, propeller, state
        The MultibodyPlant, its SceneGraph, Drake's ``Propeller`` system and the
        ``FloatingBaseState`` conversion.
    model : FloatingBaseModel
        The Euler-angle model (inputs = propeller commands).
    infos : list of PropellerInfo
        The propellers.
    """

    plant: object
    scene_graph: object
    propeller: object
    state: object
    model: object
    infos: list

    @property
    def command(self) -> InputPort:
        """The propeller command input port."""
        return self.propeller.get_command_input_port()

    @property
    def x(self) -> OutputPort:
        """The model state output [ϕ θ ψ x y z, rates]."""
        return self.state.get_output_port(0)

    @property
    def disturbance(self) -> InputPort:
        """The plant's generalized-force input (Drake's velocity order: [torque; world force]
        of the floating body's joint)."""
        return self.plant.get_applied_generalized_force_input_port()


def add_multirotor(builder: DiagramBuilder, description: str,
                   propellers: Callable[[MultibodyPlant], Iterable[PropellerInfo]], *,
                   file_type: str = "sdf",
                   command_upper: float | ArrayLike | None = None,
                   max_pitch: float | None = None) -> MultirotorHandles:
    """Add a multirotor (plant + SceneGraph + Propeller + state conversion) to ``builder``.

    Parameters
    ----------
    builder : DiagramBuilder
        The builder.
    description : str
        SDFormat or URDF text of the vehicle: one floating body (Drake gives it a quaternion
        floating joint).
    propellers : callable
        ``propellers(plant) -> list of PropellerInfo`` (called after parsing, so body indices
        are known).
    file_type : {"sdf", "urdf"}, default "sdf"
        Format of ``description``.
    command_upper : float or array_like, optional
        Largest propeller command (default unbounded); the lower bound is 0.
    max_pitch : float, optional
        The model's ``max_pitch`` (default 80°).

    Returns
    -------
    MultirotorHandles
    """
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    Parser(plant).AddModelsFromString(description, file_type)
    plant.Finalize()
    infos = list(propellers(plant))
    prop = builder.AddSystem(Propeller(infos))
    builder.Connect(plant.get_body_poses_output_port(), prop.get_body_poses_input_port())
    builder.Connect(prop.get_spatial_forces_output_port(), plant.get_applied_spatial_force_input_port())
    extra = {} if max_pitch is None else {"max_pitch": max_pitch}
    model = MechanicalModel.from_plant(plant, propellers=infos, command_upper=command_upper, **extra)
    state = builder.AddSystem(FloatingBaseState(model))
    builder.Connect(plant.get_state_output_port(), state.get_input_port(0))
    return MultirotorHandles(plant, scene_graph, prop, state, model, infos)


@dataclass
class HoverLinearization:
    """ẋ_e ≈ A (x_e − x0) + B (u − u0) at hover, x_e = [ϕ θ ψ x y z, rates] (12 states).

    Attributes
    ----------
    A, B : ndarray
        12 × 12 and 12 × m.
    x0, u0 : ndarray
        Hover state (model coordinates) and propeller commands.
    """

    A: np.ndarray
    B: np.ndarray
    x0: np.ndarray
    u0: np.ndarray


def linearize_hover(handles: MultirotorHandles, position: ArrayLike = (0.0, 0.0, 0.0),
                    yaw: float = 0.0) -> HoverLinearization:
    """Linearize plant + propellers at hover by Drake's ``Linearize`` and express it in the
    minimal Euler chart.

    Drake's state [quaternion, position; ω, v] has 13 entries for 12 degrees of freedom (the
    quaternion's norm is not a state direction), so its linearization is not stabilizable in
    the norm direction.  With P = ∂x_e/∂x_d (AutoDiffXd of ``FloatingBaseState``) and
    Q = ∂x_d/∂x_e (AutoDiffXd of the chart's inverse at rest: [∂quat/∂η, I; J(q)]),
    ẋ_e = P f(x_d, u) gives A = P A_d Q, B = P B_d exactly at the equilibrium (f = 0 there).

    Parameters
    ----------
    handles : MultirotorHandles
        From :func:`add_multirotor` (its plant is cloned, not modified).
    position : array_like, shape (3,), default origin
        Hover position.
    yaw : float, default 0
        Hover yaw (rad).

    Returns
    -------
    HoverLinearization
    """
    model = handles.model
    q0 = np.r_[0.0, 0.0, float(yaw), np.asarray(position, float)]
    u0 = model.hover_input(q0)
    b = DiagramBuilder()
    plant = b.AddSystem(handles.plant.Clone())
    prop = b.AddSystem(Propeller(handles.infos))
    b.Connect(plant.get_body_poses_output_port(), prop.get_body_poses_input_port())
    b.Connect(prop.get_spatial_forces_output_port(), plant.get_applied_spatial_force_input_port())
    b.ExportInput(prop.get_command_input_port(), "command")
    b.ExportOutput(plant.get_state_output_port(), "state")
    diagram = b.Build()
    ctx = diagram.CreateDefaultContext()
    qd, vd = model.to_drake_state(q0)
    plant.SetPositionsAndVelocities(plant.GetMyMutableContextFromRoot(ctx), np.r_[qd, vd])
    diagram.get_input_port(0).FixValue(ctx, u0)
    lin = Linearize(diagram, ctx)
    # P: derivative of the chart at the hover state (Drake's AutoDiffXd of the system)
    conv = handles.state.ToAutoDiffXd()
    cctx = conv.CreateDefaultContext()
    conv.get_input_port(0).FixValue(cctx, InitializeAutoDiff(np.r_[qd, vd]))
    P = ExtractGradient(conv.get_output_port(0).Eval(cctx))
    # Q: derivative of the chart's inverse at rest (quaternion of η; v = J q̇)
    nq = plant.num_positions()
    Q = np.zeros((nq + model.n, 2 * model.n))
    fq = model.joint.position_start()
    if model.kind == "quaternion_floating":
        Q[fq:fq + 4, :3] = ExtractGradient(euler_to_quaternion(InitializeAutoDiff(q0[:3]).ravel()))
        Q[fq + 4:fq + 7, 3:6] = np.eye(3)
    else:
        Q[fq:fq + 6, :6] = np.eye(6)
    Q[nq:, model.n:] = model.velocity_jacobian(q0)
    x0 = np.r_[q0, np.zeros(6)]
    return HoverLinearization(P @ lin.A() @ Q, P @ lin.B(), x0, u0)


def reference_state_selector() -> np.ndarray:
    """S (12 × 12) with x_ref = S [q_r; q̇_r; q̈_r] of [ψ x y z] (roll, pitch and rates zero).

    Returns
    -------
    ndarray, shape (12, 12)
    """
    S = np.zeros((12, 12))
    for j, i in enumerate((2, 3, 4, 5)):
        S[i, j] = 1.0            # positions
        S[6 + i, 4 + j] = 1.0    # rates
    return S


def add_state_feedback(builder: DiagramBuilder, handles: MultirotorHandles, K: ArrayLike,
                       u0: ArrayLike, reference_port: OutputPort | None = None, *,
                       lower: ArrayLike | None = None, upper: ArrayLike | None = None) -> System:
    """u = sat(u0 − K (x_e − x_ref)) on the propeller commands (Drake primitives only).

    Parameters
    ----------
    builder : DiagramBuilder
        The builder holding ``handles``.
    handles : MultirotorHandles
        The vehicle.
    K : array_like, shape (m, 12)
        State-feedback gain in the Euler chart (e.g. Drake's ``LinearQuadraticRegulator`` of
        :func:`linearize_hover`'s A, B).
    u0 : array_like, shape (m,)
        Hover commands.
    reference_port : OutputPort, optional
        [q_r; q̇_r; q̈_r] of [ψ x y z] (12); without it x_ref is the hover state at the origin.
    lower, upper : array_like, optional
        Command saturation (default the model's bounds).

    Returns
    -------
    System
        The system whose output 0 is the (saturated) command.
    """
    K = np.asarray(K, dtype=float)
    m = K.shape[0]
    if reference_port is None:
        reference_port = builder.AddSystem(ConstantVectorSource(np.zeros(12))).get_output_port(0)
    mux = builder.AddSystem(Multiplexer([12, 12]))
    D = np.hstack([-K, K @ reference_state_selector()])
    law = builder.AddSystem(AffineSystem(np.zeros((0, 0)), np.zeros((0, 24)), np.zeros(0),
                                         np.zeros((m, 0)), D, np.asarray(u0, float)))
    model = handles.model
    lo = model.input_lower if lower is None else np.asarray(lower, float) * np.ones(m)
    hi = model.input_upper if upper is None else np.asarray(upper, float) * np.ones(m)
    sat = builder.AddSystem(Saturation(lo, np.where(np.isfinite(hi), hi, 1e12)))
    builder.Connect(handles.x, mux.get_input_port(0))
    builder.Connect(reference_port, mux.get_input_port(1))
    builder.Connect(mux.get_output_port(0), law.get_input_port(0))
    builder.Connect(law.get_output_port(0), sat.get_input_port(0))
    builder.Connect(sat.get_output_port(0), handles.command)
    return sat


def add_hover_winf(builder: DiagramBuilder, handles: MultirotorHandles,
                   reference_port: OutputPort | None, Gamma0: ArrayLike, Gamma1: ArrayLike, *,
                   disturbance: ArrayLike | None = None,
                   **options: Any) -> tuple[System, SynthesisResult]:
    """The linear path in one call: :func:`linearize_hover` (minimal Euler chart),
    ``sd.winf_state_feedback`` on it, and the gain acting on the plant's ports through
    :func:`add_state_feedback` (u = sat(u0 + K (x_e − x_ref)), the synthesis' u = +K x).

    Parameters
    ----------
    builder : DiagramBuilder
        The builder holding ``handles``.
    handles : MultirotorHandles
        The vehicle.
    reference_port : OutputPort or None
        [q_r; q̇_r; q̈_r] of [ψ x y z] (None: hover at the origin).
    Gamma0, Gamma1 : array_like
        Sobolev weights of the 12 chart states and of their rates (6.7).
    disturbance : array_like, shape (12, k), optional
        D of ẋ = A x + B u + D w (default: a generalized force on each of the 6 DOF,
        [0; M⁻¹] at hover).
    **options
        Passed to ``winf_state_feedback`` (``gamma``, ``method``, ...).

    Returns
    -------
    (System, SynthesisResult)
        The saturated command system and the certified design.
    """
    lin = linearize_hover(handles)
    D = disturbance
    if D is None:
        D = np.vstack([np.zeros((6, 6)), np.linalg.inv(handles.model.M(lin.x0[:6]))])
    result = winf_state_feedback(lin.A, lin.B, D, Gamma0=Gamma0, Gamma1=Gamma1, **options)
    return add_state_feedback(builder, handles, -result.K, lin.u0, reference_port), result


def add_w_controller(builder: DiagramBuilder, handles: MultirotorHandles, inner: SobolevLaw,
                     reference_port: OutputPort, **kwargs: Any) -> MultirotorController:
    """The nonlinear W2/W∞ position law with bounded allocation (:class:`MultirotorController`)
    between the state conversion and the propellers.

    Parameters
    ----------
    builder : DiagramBuilder
        The builder holding ``handles``.
    handles : MultirotorHandles
        The vehicle.
    inner : SobolevLaw
        Controlled gains of [ψ x y z], regulated gains of [ϕ θ].
    reference_port : OutputPort
        [q_r; q̇_r; q̈_r] of [ψ x y z].
    **kwargs
        ``lower``, ``upper``, ``max_tilt`` of :class:`MultirotorController`.

    Returns
    -------
    MultirotorController
    """
    ctrl = builder.AddSystem(MultirotorController(handles.model, inner, **kwargs))
    builder.Connect(handles.x, ctrl.get_input_port(0))
    builder.Connect(reference_port, ctrl.get_input_port(1))
    builder.Connect(ctrl.get_output_port(0), handles.command)
    return ctrl


def fly_multirotor(description: str,
                   propellers: Callable[[MultibodyPlant], Iterable[PropellerInfo]],
                   reference: LeafSystem, disturbance: LeafSystem, duration: float, *,
                   controller: Callable[[DiagramBuilder, MultirotorHandles, OutputPort], System],
                   file_type: str = "sdf", command_upper: float | ArrayLike | None = None,
                   x0: ArrayLike | None = None, accuracy: float = 1e-5, max_step: float = 0.01,
                   meshcat: Meshcat | None = None) -> dict[str, Any]:
    """Build one closed loop, fly it from ``x0`` (default the reference at t = 0), return logs.

    Parameters
    ----------
    description, propellers, file_type, command_upper
        As for :func:`add_multirotor`.
    reference : LeafSystem
        Output port "reference" = [q_r; q̇_r; q̈_r] of [ψ x y z].
    disturbance : LeafSystem
        Output 0: generalized force in Drake's velocity order ([torque; world force]).
    duration : float
        Seconds.
    controller : callable
        ``controller(builder, handles, reference_port) -> system`` closing the loop (e.g. a
        ``functools.partial`` of :func:`add_w_controller`, or a function using
        :func:`linearize_hover` and :func:`add_state_feedback`).
    x0 : array_like, shape (12,), optional
        Initial model state.
    accuracy, max_step : float
        Integrator settings (error-controlled RK3).
    meshcat : Meshcat, optional
        Record the flight to it (``sobolev_drake.viz``).

    Returns
    -------
    dict
        "t", "x" (samples × 12 model state), "u" (commands), "ref" (reference), "handles".
    """
    from sobolev_drake import viz

    b = DiagramBuilder()
    h = add_multirotor(b, description, propellers, file_type=file_type, command_upper=command_upper)
    ref = b.AddSystem(reference)
    dist = b.AddSystem(disturbance)
    b.Connect(dist.get_output_port(0), h.disturbance)
    ctrl = controller(b, h, ref.GetOutputPort("reference"))
    logs = {"x": LogVectorOutput(h.x, b), "u": LogVectorOutput(ctrl.get_output_port(0), b),
            "ref": LogVectorOutput(ref.GetOutputPort("reference"), b)}
    recorder = viz.add_meshcat_recorder(b, h.scene_graph, meshcat) if meshcat is not None else None
    diagram = b.Build()
    sim = Simulator(diagram)
    ctx = sim.get_mutable_context()
    if x0 is None:
        r = ref.GetOutputPort("reference").Eval(ref.GetMyContextFromRoot(ctx))
        x0 = reference_state_selector() @ r
    qd, vd = h.model.to_drake_state(x0[:6], x0[6:])
    h.plant.SetPositionsAndVelocities(h.plant.GetMyMutableContextFromRoot(ctx), np.r_[qd, vd])
    integ = sim.get_mutable_integrator()
    integ.set_target_accuracy(accuracy)
    integ.set_maximum_step_size(max_step)
    sim.AdvanceTo(float(duration))
    out = {k: sink.FindLog(ctx).data().T.copy() for k, sink in logs.items()}
    out["t"] = logs["x"].FindLog(ctx).sample_times().copy()
    out["handles"], out["recorder"] = h, recorder
    return out

