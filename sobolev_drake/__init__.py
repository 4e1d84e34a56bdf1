"""sobolev_drake: robust control in weighted Sobolev spaces on Drake's systems framework.

``import sobolev_drake as sd`` gives the curated API below; the subpackages hold the rest:

synthesis    controller design (pure maths: Riccati equations, LMIs, Galerkin)
systems      Drake LeafSystems (controllers, references, disturbances, propellers, wind, ...)
models       plant builders: URDF -> MultibodyPlant wrapped as :class:`MechanicalModel`
tiltrotor    the chapter-7 convertible tilt-rotor UAV (plant, forces, law, allocation, missions)
rigs         closed loops built once and flown many times (design comparisons, tuning)
experiments  the thesis experiments, composed from the above

Naming rule: ``<norm>_<structure>`` for syntheses (``winf_state_feedback``,
``hinf_output_feedback``, ...), each returning a :class:`SynthesisResult`; ``hinfsyn`` alone
follows python-control's signature and return value.  A result's ``controller`` is one type,
:class:`DynamicController` (a state-feedback gain is the static one), converting to Drake and
python-control systems.  Sign convention everywhere: u = +K x
(state feedback) and u = C_K x_K + D_K y (output feedback); Drake's
``LinearQuadraticRegulator`` returns K for u = −K x.
"""

__version__ = "0.1.0"

from sobolev_drake import norms, plots, recording_html, viz
from sobolev_drake.errors import (CampaignError, ModelError, SimulationError, SobolevDrakeError,
                                  SobolevDrakeWarning)
from sobolev_drake.models import FloatingBaseModel, MechanicalModel, PlantHandles
from sobolev_drake.models.base import PlantModel
from sobolev_drake.simulation import SimulationDiverged, SimulationStalled, SimulationTimeout, simulate
from sobolev_drake.synthesis import (DynamicController, GeneralizedPlant, InfeasibleLMIError,
                                     SynthesisError,
                                     SynthesisOptions, SynthesisResult, controlled_gains, generalized_plant,
                                     hinf_mechanical_gains, hinf_output_feedback,
                                     hinf_output_feedback_qr, hinf_plant, hinf_state_feedback,
                                     hinf_state_feedback_qr, hinfsyn, load_result, regions,
                                     regulated_gains, save_result,
                                     stabilized_gains, to_statespace, winf_output_feedback,
                                     winf_plant, winf_state_feedback)
from sobolev_drake.synthesis.loop_analysis import LoopAnalysis, loop_analysis
from sobolev_drake.synthesis.weights import winf_weights
from sobolev_drake.synthesis.discrete import hinf_discrete, sampled_data_plant
from sobolev_drake.synthesis.problem import DiscreteDesign
from sobolev_drake.analysis_plots import plot_loop_analysis
from sobolev_drake.systems.discrete_controller import discrete_controller_system
from sobolev_drake.systems import (FloatingBaseState, HinfLaw, LinearDynamicOutputFeedback,
                                   LinearStateFeedback, MechanicalController, MechanicalLaw,
                                   MultirotorController, Partition,
                                   PiecewiseTrajectory, SobolevLaw, TimeProfiledForce,
                                   TrajectoryReference, const, controller_system, poly, sine,
                                   smooth_junctions)

__all__ = [
    "__version__", "norms", "plots", "recording_html", "viz",
    # the exception hierarchy (sobolev_drake.errors)
    "SobolevDrakeError", "SobolevDrakeWarning", "ModelError", "SimulationError", "CampaignError",
    # models
    "MechanicalModel", "PlantModel", "PlantHandles", "FloatingBaseModel", "FloatingBaseState",
    # nonlinear mechanical controllers
    "Partition", "MechanicalLaw", "MechanicalController", "SobolevLaw", "HinfLaw",
    "MultirotorController",
    "controlled_gains", "regulated_gains", "stabilized_gains", "hinf_mechanical_gains",
    # references, disturbances, simulation
    "TrajectoryReference", "PiecewiseTrajectory", "sine", "poly", "const", "smooth_junctions",
    "TimeProfiledForce",
    "simulate", "SimulationTimeout", "SimulationDiverged", "SimulationStalled",
    # linear synthesis
    "winf_state_feedback", "winf_output_feedback", "hinf_state_feedback", "hinf_output_feedback",
    "hinf_state_feedback_qr", "hinf_output_feedback_qr", "winf_plant", "hinf_plant",
    "GeneralizedPlant", "generalized_plant", "SynthesisResult", "DynamicController",
    "SynthesisOptions", "SynthesisError",
    "InfeasibleLMIError", "regions", "hinfsyn", "to_statespace", "save_result", "load_result",
    # analysis of a designed loop, weights from bandwidth and damping
    "loop_analysis", "LoopAnalysis", "plot_loop_analysis", "winf_weights",
    # discrete-time and sampled-data synthesis
    "hinf_discrete", "sampled_data_plant", "DiscreteDesign", "discrete_controller_system",
    # linear controllers as Drake systems
    "controller_system", "LinearStateFeedback", "LinearDynamicOutputFeedback",
]
