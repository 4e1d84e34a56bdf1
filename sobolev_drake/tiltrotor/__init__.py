"""The convertible tilt-rotor UAV of thesis chapter 7, in one place.

Modules, from the plant up to the controller:

params        TiltrotorParams (Table B.1) and the rigid-body kinematics of section 7.2
urdf          the URDF written from TiltrotorParams (section 7.2)
plant         URDF, MultibodyPlant and TiltrotorModel (section 7.2), add_tiltrotor
propeller     the propeller's Ct(J, φ), Cq(J, φ), advance ratio and inflow (7.25)–(7.30)
body_frame    body kinematics and body-wrench map of the scalar force tier
propulsion    propellers and servomotors, (7.19)–(7.33)
aero_tables   the wind-tunnel tables of Appendix B, per surface
aerodynamics  fuselage, wings, V-tail and interference loads, (7.34)–(7.56)
input_affine  the input-affine form (7.62) of the generalized forces
trim          hover and level-flight trims (7.3.1)
tilt_schedule the tilt schedule α(V) from level-flight trims
linearization (A, B, D) about a trim (7.57)
allocation    control allocation (7.84)–(7.89) and the thrust → propeller-speed inversion (7.90)
references    the tilt reference α(U) over forward air speed and the regulated references
law           the W∞ law composed with the model, allocation and propeller data (7.3.2)
compiled_sample  the controller's whole per-sample update in one compiled call (native/fused.c)
controller    the nonlinear W∞ controller LeafSystem of the missions (7.3.2)
gain_schedule the envelope's scheduled W∞ weights (beyond 7.3.2: targets per regime, C² blend)
envelope_analysis  frozen-point closed-loop poles of a design at level-flight trims

The experiments' pieces, from the linear hover designs (7.3.1) to the missions (7.3.2):

linear_design      the linear W∞ hover designs of Table 7.2, their channel norms and margins
linear_controller  the linear hover controller LeafSystem (u = u_trim + K Δx or dynamic)
hover_flight       flights of the linear designs on the nonlinear plant and their indices
mission            mission phases, disturbance profiles, the mission diagram and its flight
mission_metrics    per-phase tracking, effort and bounds of a mission flight
tables             result tables (ours beside Table 7.2, mission phases, effort, tilt schedule)
plots              figures of the missions and of the linear hover flights

Nothing outside this package depends on it except the experiments, benchmarks and tests.
"""

from sobolev_drake.tiltrotor.controller import TiltrotorWInfController
from sobolev_drake.tiltrotor.envelope_analysis import frozen_point
from sobolev_drake.tiltrotor.gain_schedule import EnvelopeSchedule
from sobolev_drake.tiltrotor.linear_controller import LinearHoverController
from sobolev_drake.tiltrotor.linear_design import HoverDesign
from sobolev_drake.tiltrotor.mission import build_mission, simulate_mission
from sobolev_drake.tiltrotor.mission_metrics import score_mission
from sobolev_drake.tiltrotor.params import TiltrotorParams
from sobolev_drake.tiltrotor.plant import TiltrotorHandles, TiltrotorModel, add_tiltrotor, tiltrotor_urdf
from sobolev_drake.tiltrotor.linearization import linearize
from sobolev_drake.tiltrotor.trim import Trim, trim_hover, trim_level_flight

__all__ = [
    "TiltrotorParams", "TiltrotorModel", "TiltrotorHandles", "add_tiltrotor", "tiltrotor_urdf",
    "TiltrotorWInfController", "Trim", "trim_hover", "trim_level_flight", "linearize",
    "HoverDesign", "LinearHoverController", "build_mission", "simulate_mission", "score_mission",
    "EnvelopeSchedule", "frozen_point",
]
