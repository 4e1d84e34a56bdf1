"""Bad input across the public API: every case raises a TypeError or ValueError whose message
names the argument and says what was expected (never a silent truncation, a NaN carried into a
solver, an IndexError/LinAlgError from deep inside, or a hang).

Each case is (id, call, exception type, regex the message must match).  The calls are cheap:
the checks fire before any solver or simulation runs.
"""

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, Integrator

from sobolev_drake import norms, report, validation
from sobolev_drake import viz
from sobolev_drake.models.arm import ArmParams
from sobolev_drake.models.base import check_vector
from sobolev_drake.models.quadrotor import QuadrotorParams
from sobolev_drake.models.two_wheeled import TwoWheeledParams
from sobolev_drake.tiltrotor.params import TiltrotorParams
from sobolev_drake.synthesis.galerkin_basis import Box, PolynomialBasis, gauss_legendre, midpoint
from sobolev_drake.synthesis.mechanical import HinfMechanicalGains, hinf_mechanical_gains
from sobolev_drake.systems.references import PiecewiseTrajectory
from sobolev_drake.simulation import SimulationTimeout, simulate
from sobolev_drake.synthesis import margins, regions
from sobolev_drake.synthesis.hinf import GeneralizedPlant, output_feedback, state_feedback
from sobolev_drake.synthesis.mechanical import controlled_gains
from sobolev_drake.synthesis.polytopic import (interval_vertices, random_interior_points,
                                               robust_hinf_state_feedback, robust_winf_state_feedback)
from sobolev_drake.synthesis.sobolev import winf_output_feedback, winf_plant, winf_state_feedback
from sobolev_drake.tiltrotor.allocation import ControlAllocator, propeller_speed_for_thrust
from sobolev_drake.systems.bounded_ls import bounded_least_squares
from sobolev_drake.systems.disturbances import TimeProfiledForce, pulses_from_mission
from sobolev_drake.systems.wind import GustProfile
from sobolev_drake.systems.linear_controllers import LinearDynamicOutputFeedback, LinearStateFeedback
from sobolev_drake.systems.mechanical_controller import HinfLaw, Partition, SobolevLaw
from sobolev_drake.systems.references import const, poly, sine

A2 = np.array([[0.0, 1.0], [-1.0, -0.5]])
B2 = np.array([[0.0], [1.0]])
D2 = np.array([[0.0], [1.0]])
G0, G1 = np.eye(2), 0.1 * np.eye(2)
T = np.linspace(0.0, 1.0, 11)


def plant():
    return GeneralizedPlant.make(A2, D2, B2, np.vstack([np.eye(2), np.zeros((1, 2))]), None,
                                 [[0.0], [0.0], [1.0]])


def diagram():
    b = DiagramBuilder()
    integ = b.AddSystem(Integrator(1))
    src = b.AddSystem(ConstantVectorSource([1.0]))
    b.Connect(src.get_output_port(), integ.get_input_port())
    d = b.Build()
    return d, d.CreateDefaultContext()


def sim(duration, **kw):
    d, ctx = diagram()
    return simulate(d, ctx, duration, progress=False, **kw)


def sim_from(t0, duration):
    d, ctx = diagram()
    ctx.SetTime(t0)
    return simulate(d, ctx, duration, progress=False)


def _force_at_arm():
    from sobolev_drake.models.arm import add_arm
    from sobolev_drake.systems.disturbances import CartesianForceAtBody
    arm = add_arm(DiagramBuilder())
    return CartesianForceAtBody(arm.model, "link2")


def _result_file(data):
    import json
    import tempfile
    from pathlib import Path
    path = Path(tempfile.mkdtemp()) / "result.json"
    path.write_text(json.dumps(data))
    return path


SF_RESULT = None


def sf_result():
    global SF_RESULT
    if SF_RESULT is None:
        SF_RESULT = winf_state_feedback(A2, B2, D2, G0, G1)
    return SF_RESULT


CASES = [
    # --- simulate
    ("simulate inf", lambda: sim(float("inf")), ValueError, "duration must be a finite number, got inf"),
    ("simulate nan", lambda: sim(float("nan")), ValueError, "duration must be a finite number, got nan"),
    ("simulate str", lambda: sim("5"), TypeError, "duration must be a real number, got '5'"),
    ("simulate negative", lambda: sim(-1.0), ValueError, "duration must be > 0, got -1.0"),
    ("simulate zero", lambda: sim(0), ValueError, "duration must be > 0, got 0.0"),
    ("simulate bool", lambda: sim(True), TypeError, "duration must be a real number, got True"),
    ("simulate None", lambda: sim(None), TypeError, "duration must be a real number, got None"),
    ("simulate list", lambda: sim([1.0]), TypeError, "duration must be a real number"),
    ("simulate rounds away", lambda: sim_from(1e9, 1e-9), ValueError, "rounds back to the start time"),
    ("simulate integrator", lambda: sim(1.0, integrator="rk4"), ValueError, "integrator must be one of"),
    ("simulate accuracy", lambda: sim(1.0, accuracy=0.0), ValueError, "accuracy must be > 0"),
    ("simulate max_step nan", lambda: sim(1.0, max_step=float("nan")), ValueError, "max_step must be a finite"),
    ("simulate context None", lambda: simulate(diagram()[0], None, 1.0), TypeError, "context must be the root Context"),
    ("simulate simulator str", lambda: simulate(diagram()[0], None, 1.0, simulator="sim"), TypeError, "simulator must be a pydrake Simulator"),
    ("simulate label", lambda: sim(1.0, label=None), TypeError, "label must be a string"),
    ("tiltrotor mass", lambda: TiltrotorParams(m1=-7.0), ValueError, "TiltrotorParams.m1 must be > 0"),
    ("tiltrotor rho nan", lambda: TiltrotorParams(rho=float("nan")), ValueError, "TiltrotorParams.rho must be a finite"),
    ("tiltrotor beta nan", lambda: TiltrotorParams(beta=float("nan")), ValueError, "TiltrotorParams.beta must be a finite"),
    ("tiltrotor vector nan", lambda: TiltrotorParams(d_B_F=np.array([np.nan, 0.0, 0.0])), ValueError, "TiltrotorParams.d_B_F must be finite"),
    ("tiltrotor crossflow", lambda: TiltrotorParams(crossflow="none"), ValueError, "crossflow must be one of"),
    ("simulate wall limit", lambda: sim(1.0, wall_time_limit=-1), ValueError, "wall_time_limit must be > 0"),
    # --- generalized plant and synthesis
    ("complex A", lambda: GeneralizedPlant.make(A2 + 1j, D2, B2, np.eye(2)), TypeError, "A must be real, got complex"),
    ("0x0 plant", lambda: GeneralizedPlant.make(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((0, 1)),
                                                np.zeros((1, 0))), ValueError, "A must be a non-empty square"),
    ("string A", lambda: GeneralizedPlant.make("A", D2, B2, np.eye(2)), TypeError, "A must be a real number or array, got the string"),
    ("ragged A", lambda: GeneralizedPlant.make([[1.0, 2.0], [3.0]], D2, B2, np.eye(2)), TypeError, "A must be a real number or array"),
    ("nan A", lambda: GeneralizedPlant.make(np.full((2, 2), np.nan), D2, B2, np.eye(2)), ValueError, "A must be finite, got non-finite"),
    ("B1 shape", lambda: GeneralizedPlant.make(A2, np.ones((3, 1)), B2, np.eye(2)), ValueError, r"B1 must have shape \(2, any\)"),
    ("no input", lambda: GeneralizedPlant.make(A2, D2, np.zeros((2, 0)), np.eye(2)), ValueError, "B2 must have at least one control input"),
    ("no disturbance", lambda: GeneralizedPlant.make(A2, np.zeros((2, 0)), B2, np.eye(2)), ValueError, "B1 must have at least one disturbance"),
    ("3-D A", lambda: GeneralizedPlant.make(np.zeros((2, 2, 2)), D2, B2, np.eye(2)), ValueError, "A must be a matrix"),
    ("Gamma0=Gamma1=0", lambda: winf_state_feedback(A2, B2, D2, 0, 0), ValueError, "depends on neither x nor u"),
    ("D=0", lambda: winf_state_feedback(A2, B2, 0 * D2, G0, G1), ValueError, "reaches neither the state nor z"),
    ("D=0 output feedback", lambda: winf_output_feedback(A2, B2, [[1.0, 0.0]], 0 * D2, G0, G1), ValueError, "D21 = 0"),
    ("complex Gamma0", lambda: winf_plant(A2, B2, D=D2, Gamma0=[1 + 1j, 1], Gamma1=G1), TypeError, "Gamma0 must be real"),
    ("Gamma0 size", lambda: winf_plant(A2, B2, D=D2, Gamma0=[1.0, 1.0, 1.0], Gamma1=G1), ValueError, "Gamma0 must have 2 entries"),
    ("Gamma0 indefinite", lambda: winf_plant(A2, B2, D=D2, Gamma0=[-1.0, 1.0], Gamma1=G1), ValueError, "Gamma0 must be positive semidefinite"),
    ("Gamma0 asymmetric", lambda: winf_plant(A2, B2, D=D2, Gamma0=[[1.0, 1.0], [0.0, 1.0]], Gamma1=G1), ValueError, "Gamma0 must be symmetric"),
    ("gamma nan", lambda: state_feedback(plant(), gamma=float("nan")), ValueError, "gamma must be a finite number, got nan"),
    ("gamma inf", lambda: state_feedback(plant(), gamma=float("inf")), ValueError, "gamma must be a finite number, got inf"),
    ("gamma str", lambda: state_feedback(plant(), gamma="1"), TypeError, "gamma must be a real number"),
    ("gamma below bound", lambda: state_feedback(GeneralizedPlant.make(A2, D2, B2, np.eye(2), [[2.0], [0.0]]), gamma=1.0),
     ValueError, "feedthrough"),
    ("rtol nan", lambda: state_feedback(plant(), rtol=float("nan")), ValueError, "rtol must be a finite number"),
    ("rtol negative", lambda: state_feedback(plant(), rtol=-1.0), ValueError, "rtol must be > 0"),
    ("delta nan", lambda: state_feedback(plant(), delta=float("nan")), ValueError, "delta must be a finite number"),
    ("delta negative", lambda: state_feedback(plant(), delta=-0.5), ValueError, "delta must be > 0"),
    ("margin nan", lambda: state_feedback(plant(), margin=float("nan")), ValueError, "margin must be a finite number"),
    ("regularize", lambda: state_feedback(plant(), regularize="yes"), ValueError, "regularize must be 'auto', True or False"),
    ("method name", lambda: state_feedback(plant(), method="ric"), ValueError, "method must be one of"),
    ("method OF", lambda: output_feedback(plant(), method=None), ValueError, "method must be one of"),
    ("riccati + region", lambda: state_feedback(plant(), method="riccati", region=regions.disk(5.0)),
     ValueError, "method='riccati' does not support region"),
    ("time_limit zero", lambda: state_feedback(plant(), time_limit=0.0), ValueError, "time_limit must be > 0"),
    ("time_limit nan", lambda: output_feedback(plant(), time_limit=float("nan")), ValueError, "time_limit must be a finite number"),
    ("time_limit str", lambda: state_feedback(plant(), time_limit="30"), TypeError, "time_limit must be a real number"),
    ("backend int", lambda: state_feedback(plant(), backend=123), TypeError, "backend must be None"),
    ("backend name", lambda: state_feedback(plant(), backend="matlab"), ValueError, "backend"),
    ("backend chain", lambda: state_feedback(plant(), backend=("ipm", 3)), ValueError, "backend chain"),
    ("solver_options", lambda: state_feedback(plant(), backend="clarabel", solver_options="fast"), TypeError, "solver_options must be a dict"),
    ("input_weight", lambda: state_feedback(plant(), input_weight=-np.eye(1)), ValueError, "input_weight must be positive semidefinite"),
    ("region str", lambda: state_feedback(plant(), region="disk"), TypeError, "region must be an LMIRegion"),
    ("plant tuple", lambda: state_feedback((A2, B2)), TypeError, "plant must be a GeneralizedPlant"),
    ("plant tuple OF", lambda: output_feedback((A2, B2)), TypeError, "plant must be a GeneralizedPlant"),
    ("vertices", lambda: state_feedback(plant(), vertices=[(A2, B2)]), TypeError, "vertices must be a list of GeneralizedPlant"),
    ("strictly_proper", lambda: output_feedback(plant(), strictly_proper="no"), TypeError, "strictly_proper must be True or False"),
    ("initial_states shape", lambda: state_feedback(plant(), initial_states=[1.0, 2.0, 3.0]), ValueError, "initial_states must have shape"),
    ("initial_states zero", lambda: state_feedback(plant(), initial_states=[0.0, 0.0]), ValueError, "not all zero"),
    ("transient weight", lambda: output_feedback(plant(), transient_gain_weight=-1.0), ValueError, "transient_gain_weight must be"),
    # --- regions
    ("half_plane nan", lambda: regions.half_plane(float("nan")), ValueError, "a must be a finite number, got nan"),
    ("half_plane inf", lambda: regions.half_plane(float("inf")), ValueError, "a must be a finite number, got inf"),
    ("disk negative", lambda: regions.disk(-1.0), ValueError, "radius must be > 0, got -1.0"),
    ("disk inf", lambda: regions.disk(float("inf")), ValueError, "radius must be a finite number"),
    ("disk center nan", lambda: regions.disk(1.0, center=float("nan")), ValueError, "center must be a finite number"),
    ("disk str", lambda: regions.disk("5"), TypeError, "radius must be a real number"),
    ("sector range", lambda: regions.sector(2.0), ValueError, "theta must be <"),
    ("damping range", lambda: regions.damping(1.5), ValueError, "zeta must be <"),
    ("strip order", lambda: regions.strip(2.0, 1.0), ValueError, "strip needs a_max > a_min"),
    ("strip inf", lambda: regions.strip(1.0, float("inf")), ValueError, "a_max must be a finite number"),
    ("intersect empty", lambda: regions.intersect(), TypeError, "intersect takes one or more LMIRegion"),
    ("region & str", lambda: regions.disk(1.0) & "x", TypeError, "unsupported operand"),
    ("LMIRegion nan", lambda: regions.LMIRegion([[np.nan]], [[1.0]]), ValueError, "L must be finite"),
    # --- polytopic
    ("robust no vertices", lambda: robust_winf_state_feedback([], G0, G1), ValueError, "vertices must contain at least one"),
    ("robust hinf no vertices", lambda: robust_hinf_state_feedback([], np.eye(2), 1.0), ValueError, "vertices must contain at least one"),
    ("robust pair", lambda: robust_winf_state_feedback([(A2, B2)], G0, G1), TypeError, r"vertices\[0\] must be an \(A, B, D\) tuple"),
    ("robust sizes", lambda: robust_winf_state_feedback([(A2, B2, D2), (np.eye(3), np.ones((3, 1)), np.ones((3, 1)))], G0, G1),
     ValueError, r"vertices\[1\] has shapes A \(3, 3\)"),
    ("robust not list", lambda: robust_winf_state_feedback(5, G0, G1), TypeError, "vertices must be a sequence"),
    ("interval nan spread", lambda: interval_vertices(lambda **k: 0, {"a": 1.0}, {"a": float("nan")}), ValueError, "spread\\['a'\\] must be a finite"),
    ("interval swapped", lambda: interval_vertices(lambda **k: 0, {"a": 1.0}, {"a": (2.0, 1.0)}), ValueError, "must not exceed"),
    ("interval too many", lambda: interval_vertices(lambda **k: 0, {f"p{i}": 1.0 for i in range(40)},
                                                    {f"p{i}": 0.1 for i in range(40)}), ValueError, "40 uncertain parameters"),
    ("interval unknown", lambda: interval_vertices(lambda **k: 0, {"a": 1.0}, {"b": 0.1}), ValueError, "absent from nominal"),
    ("interior count", lambda: random_interior_points([(A2, B2, D2)], -1), ValueError, "count must be an integer >= 0"),
    ("interior empty", lambda: random_interior_points([], 2), ValueError, "vertices must contain at least one"),
    # --- margins
    ("gain margin rtol 0", lambda: margins.input_gain_margins(A2, B2, [[-1.0, -1.0]], rtol=0.0), ValueError, "rtol must be > 0"),
    ("gain margin rtol nan", lambda: margins.input_gain_margins(A2, B2, [[-1.0, -1.0]], rtol=float("nan")), ValueError, "rtol must be a finite"),
    ("gain margin k_max", lambda: margins.input_gain_margins(A2, B2, [[-1.0, -1.0]], k_max=0.5), ValueError, "k_max must be > 1"),
    ("delay points", lambda: margins.input_delay_margin(A2, B2, [[-1.0, -1.0]], points=0), ValueError, "points must be an integer in"),
    ("delay points huge", lambda: margins.input_delay_margin(A2, B2, [[-1.0, -1.0]], points=10**7), ValueError, "points must be an integer in"),
    ("delay w order", lambda: margins.input_delay_margin(A2, B2, [[-1.0, -1.0]], w_min=10.0, w_max=1.0), ValueError, "w_max must be >"),
    # --- mechanical gains and laws
    ("complex Y0", lambda: controlled_gains(Y0=np.array([1 + 1j, 1.0]), Y1=[1, 1], Y2=[1, 1], Y3=[1, 1]), TypeError, "Y0 must be real"),
    ("Partition 0.7", lambda: Partition(controlled=[0.7]), TypeError, r"Partition.controlled must contain integer indices.*0.7"),
    ("Partition name", lambda: Partition(controlled=["elbow"]), ValueError, "'elbow' is not an index"),
    ("Partition '1'", lambda: Partition(controlled=["1"]), ValueError, "'1' is not an index"),
    ("Partition bool", lambda: Partition(controlled=[True]), TypeError, "got the boolean True"),
    ("Partition negative", lambda: Partition(controlled=[-1]), ValueError, "index -1 is negative"),
    ("Partition repeat", lambda: Partition(controlled=[0, 0]), ValueError, "must not repeat an index"),
    ("Partition two groups", lambda: Partition(controlled=[0], stabilized=[0]), ValueError, "DOF 0 is in both controlled and stabilized"),
    ("Partition empty", lambda: Partition(controlled=[]), ValueError, "at least one DOF"),
    ("Partition float scalar", lambda: Partition(controlled=1.0), TypeError, "integer indices"),
    ("SobolevLaw str", lambda: SobolevLaw(controlled="x"), TypeError, "SobolevLaw.controlled must be SobolevGains"),
    ("SobolevLaw None", lambda: SobolevLaw(controlled=None), TypeError, "SobolevLaw.controlled is required"),
    ("HinfLaw str", lambda: HinfLaw(gains="x"), TypeError, "HinfLaw.gains must be HinfMechanicalGains"),
    # --- linear controllers
    ("SF complex K", lambda: LinearStateFeedback(np.array([[1 + 1j, 0.0]])), TypeError, "K must be real"),
    ("SF empty K", lambda: LinearStateFeedback([]), ValueError, "K must not be empty"),
    ("SF bounds swapped", lambda: LinearStateFeedback([[1.0, 0.0]], u_min=1.0, u_max=0.0), ValueError, "u_min must not exceed u_max"),
    ("SF bounds nan", lambda: LinearStateFeedback([[1.0, 0.0]], u_min=float("nan")), ValueError, "u_min must not contain NaN"),
    ("OF bounds size", lambda: LinearDynamicOutputFeedback([[-1.0]], [[1.0]], [[1.0]], u_min=[0.0, 1.0]), ValueError, "u_min must be a scalar or a vector of 1"),
    ("from_controller SF", lambda: LinearDynamicOutputFeedback.from_controller(sf_result()), TypeError, "state-feedback SynthesisResult"),
    ("from_controller junk", lambda: LinearDynamicOutputFeedback.from_controller(3), TypeError, "controller must be a DynamicController"),
    # --- references
    ("const nan", lambda: const(float("nan")), ValueError, "c must be a finite number"),
    ("sine inf", lambda: sine(1.0, float("inf")), ValueError, "omega must be a finite number"),
    ("sine str", lambda: sine("1", 1.0), TypeError, "amplitude must be a real number"),
    ("poly nan", lambda: poly([1.0, float("nan")]), ValueError, "coefficients .* must be finite"),
    ("poly empty", lambda: poly([]), ValueError, "ascending powers.* must not be empty"),
    ("poly complex", lambda: poly([1j]), TypeError, "must be real"),
    # --- norms
    ("ise complex", lambda: norms.ise(T, T + 1j), TypeError, "e must be real"),
    ("ise length", lambda: norms.ise(T, T[:-1]), ValueError, "e has 10 samples but t has 11"),
    ("ise nan", lambda: norms.ise(T, np.full_like(T, np.nan)), ValueError, "e must be finite"),
    ("iadu no channel", lambda: norms.iadu(T, np.zeros((11, 0))), ValueError, "u must have at least one channel"),
    ("finite_difference bool", lambda: norms.finite_difference(T, T, order=True), ValueError, "order must be a non-negative integer"),
    ("empirical initial nan", lambda: norms.empirical_gain(T, T, T + 1, initial_term=float("nan")), ValueError, "initial_term must be a finite number"),
    ("empirical initial neg", lambda: norms.empirical_gain(T, T, T + 1, initial_term=-1.0), ValueError, "initial_term must be >= 0"),
    # --- disturbances, wind, allocation, report
    ("pulse bool index", lambda: TimeProfiledForce(2, [{"index": True, "value": 1.0}]), ValueError, r"pulses\[0\]\['index'\] must be an integer"),
    ("pulse nan", lambda: TimeProfiledForce(2, [{"index": 0, "value": float("nan")}]), ValueError, "must be finite"),
    ("mission pulse order", lambda: pulses_from_mission([{"axis": "x", "value": 1.0, "from": 5.0, "to": 1.0}], ["x"]),
     ValueError, "needs from < to"),
    ("mission pulse nan", lambda: pulses_from_mission([{"axis": "x", "value": float("nan"), "from": 0.0, "to": 1.0}], ["x"]),
     ValueError, "must be finite"),
    ("mission pulse axis", lambda: pulses_from_mission([{"axis": "w", "value": 1.0, "from": 0.0, "to": 1.0}], ["x"]),
     ValueError, "is not a coordinate"),
    ("gust nan", lambda: GustProfile([{"axis": "x", "value": float("nan"), "from": 0.0, "to": 1.0}]), ValueError, "must be a finite wind speed"),
    ("gust axis", lambda: GustProfile([{"axis": "q", "value": 1.0, "from": 0.0, "to": 1.0}]), ValueError, "must be one of 'x', 'y', 'z'"),
    ("BLS complex", lambda: bounded_least_squares(np.array([[1 + 1j, 0.0], [0.0, 1.0]]), np.ones(2), -1.0, 1.0), TypeError, "B must be real"),
    ("BLS swapped", lambda: bounded_least_squares(np.eye(2), np.ones(2), 1.0, -1.0), ValueError, "need lo <= hi"),
    ("allocator method", lambda: ControlAllocator(2, 2, bounds=([0.0, 0.0], [1.0, 1.0]), method="bogus"), ValueError, "method must be one of"),
    ("allocator regularization", lambda: ControlAllocator(2, 2, bounds=([0.0, 0.0], [1.0, 1.0]), regularization=-1.0),
     ValueError, "regularization must be >= 0"),
    ("report row length", lambda: report.markdown_table(["a"], [[1, 2]]), ValueError, "row 0 has 2 cells, expected 1"),
    ("report results", lambda: report.write_reproduction([None], "unused.md"), TypeError, r"results\[0\] must be an ExperimentResult"),
    ("report save", lambda: report.save_result(None, "unused"), TypeError, "result must be an ExperimentResult"),
    # --- more construction checks (each of these used to crash, hang or pass silently)
    ("force at body nan q", lambda: _force_at_arm().generalized_force([0.1, np.nan], [1.0, 0.0, 0.0]), ValueError, "q must be finite"),
    ("meshcat port", lambda: viz.start_meshcat(port=-5), ValueError, "port must be 0"),
    ("trajectory names str", lambda: PiecewiseTrajectory("xy", [[const(0.0), const(1.0)]]), TypeError, "names must be a sequence"),
    ("trajectory breakpoints nan", lambda: PiecewiseTrajectory(["x"], [[const(0.0)], [const(1.0)]], [np.nan]), ValueError, "breakpoints must be finite"),
    ("complex q", lambda: check_vector("q", np.array([0.1 + 1j, 0.0]), 2), TypeError, "q must be real"),
    ("feedthrough str", lambda: LinearDynamicOutputFeedback([[-1.0]], [[1.0]], [[1.0]], [[1.0]], feedthrough="no"), TypeError, "feedthrough must be None, True or False"),
    ("simulate huge", lambda: sim(1e12), ValueError, "more than 1e\\+09 integrator steps"),
    ("simulate tiny step", lambda: sim(1.0, max_step=1e-12), ValueError, "pass wall_time_limit"),
    ("Hinf gains gamma <= omega_u", lambda: HinfMechanicalGains(1.0, 1.0, 1.0, 2.0, 1.0), ValueError, "need gamma > omega_u"),
    ("Hinf gains bool", lambda: hinf_mechanical_gains(True, 1, 1, 1, 2), TypeError, "omega1 must be a real number"),
    ("basis float degree", lambda: PolynomialBasis(1, 2.7), TypeError, "degree must be an integer"),
    ("basis huge", lambda: PolynomialBasis(12, 40), ValueError, "terms, more than"),
    ("gauss float nodes", lambda: gauss_legendre(Box.symmetric([1.0]), 2.5), TypeError, "nodes_per_dim must be integers"),
    ("gauss huge", lambda: gauss_legendre(Box.symmetric([1.0] * 6), 200), ValueError, "tensor rule would have"),
    ("midpoint huge", lambda: midpoint(Box.symmetric([1.0, 1.0, 1.0]), 1e-4), ValueError, "tensor rule would have"),
    ("midpoint nan", lambda: midpoint(Box.symmetric([1.0]), float("nan")), ValueError, "width must be a finite"),
    ("trajectory float indices", lambda: viz.trajectory_from_log((T, np.zeros((4, T.size))), indices=(0.5, 1.5, 2.5)),
     TypeError, "indices must contain integer indices"),
    ("draw_path rgba", lambda: viz.draw_path(None, "p", [[0, 0, 0], [1, 1, 1]], rgba=(2, 0, 0, 1)), ValueError, r"rgba entries must be in \[0, 1\]"),
    ("draw_path width", lambda: viz.draw_path(None, "p", [[0, 0, 0], [1, 1, 1]], line_width=float("nan")), ValueError, "line_width must be a finite"),
    ("load_result held string", lambda: report.load_result(_result_file({"name": "x", "claims": [
        {"text": "t", "held": "false"}]})), ValueError, r"claims\[0\].held must be a JSON boolean, got 'false'"),
    ("propeller tol nan", lambda: propeller_speed_for_thrust(10.0, tol=float("nan")), ValueError, "tol must be a finite"),
    ("arm mass nan", lambda: ArmParams(m1=float("nan")), ValueError, "ArmParams.m1 must be a finite number"),
    ("arm gravity nan", lambda: ArmParams(g=float("nan")), ValueError, "ArmParams.g must be a finite number"),
    ("arm length str", lambda: ArmParams(l1="1"), TypeError, "ArmParams.l1 must be a real number"),
    ("two-wheeled gravity inf", lambda: TwoWheeledParams(g=float("inf")), ValueError, "TwoWheeledParams.g must be a finite"),
    ("two-wheeled friction", lambda: TwoWheeledParams(k=-1.0), ValueError, "TwoWheeledParams.k must be >= 0"),
    ("quadrotor mass inf", lambda: QuadrotorParams(m=float("inf")), ValueError, "QuadrotorParams.m must be a finite"),
    # --- the validation helpers themselves
    ("index_tuple range", lambda: validation.index_tuple("joints", [3], 2), ValueError, r"joints: index 3 is out of range\(2\)"),
    ("index_tuple names", lambda: validation.index_tuple("joints", ["wrist"], 2, names=["q1", "q2"]), ValueError, "known names"),
    ("bounds_pair lengths", lambda: validation.bounds_pair("lo", [0.0, 0.0], "hi", [1.0]), ValueError, "same length"),
    ("one_of", lambda: validation.one_of("method", "bogus", ("pdas", "osqp")), ValueError, r"method must be one of \('pdas', 'osqp'\)"),
    ("real_scalar high", lambda: validation.real_scalar("p", 2.0, high=1.0), ValueError, "p must be <= 1, got 2.0"),
]


@pytest.mark.parametrize("name, call, exc, pattern", CASES, ids=[c[0] for c in CASES])
def test_bad_input_raises_clear_error(name, call, exc, pattern):
    with pytest.raises(exc, match=pattern):
        call()


def test_enough_cases():
    assert len(CASES) >= 100


def test_index_tuple_accepts_what_it_should():
    assert validation.index_tuple("i", np.array([2, 0]), 3) == (2, 0)
    assert validation.index_tuple("i", 1, 3) == (1,)
    assert validation.index_tuple("i", ["q2"], 2, names=["q1", "q2"]) == (1,)
    assert Partition(controlled=np.int64(0), stabilized=[np.int32(1)]).stabilized == (1,)


def test_real_matrix_keeps_real_complex_dtype_with_zero_imaginary_part():
    M = validation.real_matrix("M", np.eye(2, dtype=complex))
    assert M.dtype == float and np.array_equal(M, np.eye(2))


def test_simulate_wall_time_limit_stops_and_reports():
    d, ctx = diagram()
    with pytest.raises(SimulationTimeout, match="wall_time_limit=0.2 s reached") as info:
        simulate(d, ctx, 1e9, wall_time_limit=0.2, max_step=1e-3, progress=False)
    # the context holds the state reached: x' = 1 from x = 0, so x = t
    assert 0 < info.value.simulated < 1e9
    assert ctx.get_continuous_state_vector().GetAtIndex(0) == pytest.approx(info.value.simulated, rel=1e-9)
