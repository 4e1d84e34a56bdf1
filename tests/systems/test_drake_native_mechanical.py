"""Issue #31 for the mechanical controller and the force adapter: scalar conversion (AutoDiffXd,
Expression) with outputs equal to double, Drake's Linearize of the arm closed loop at the
design's poles, the law as a context parameter, Drake's port names (one-line swap for
InverseDynamicsController), and the sampled controller (period, initialization, delay)."""

import re

import numpy as np
import pytest
from pydrake.autodiffutils import AutoDiffXd, ExtractGradient, InitializeAutoDiff
from pydrake.common import FindResourceOrThrow
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.symbolic import Expression, Variable
from pydrake.systems.analysis import Simulator
from pydrake.systems.controllers import InverseDynamicsController
from pydrake.systems.framework import (DiagramBuilder, InputPortSelection,
                                       OutputPortSelection)
from pydrake.systems.primitives import ConstantVectorSource, Linearize, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from sobolev_drake.models._adapter import ThesisForceAdapter
from sobolev_drake.models.arm import add_arm, make_arm_model
from sobolev_drake.rigs.seven_link import fly_seven_link_arm
from sobolev_drake.models.base import MechanicalModel
from sobolev_drake.models.quadrotor import make_quadrotor_model
from sobolev_drake.models.scalar_terms import ScalarTerms
from sobolev_drake.models.serial_chain import SEVEN_LINK_EFFORT_LIMITS, seven_link_arm
from sobolev_drake.synthesis.mechanical import (controlled_closed_form, controlled_gains,
                                                hinf_mechanical_gains, regulated_gains,
                                                stabilized_gains)
from sobolev_drake.systems.mechanical_controller import (HinfLaw, MechanicalController,
                                                         MechanicalLaw, Partition, SobolevLaw)

W_ARM = ([100, 200], [500, 400], [40, 40], [0.0720, 0.0126])   # thesis manipulator tuning
X_ARM = np.array([0.3, -0.4, 0.5, 0.7])                         # [q; q̇]
REF_ARM = np.array([1.0, 0.5, 0.1, 0.2, 0.3, -0.1])             # [q_r; q̇_r; q̈_r]
# Tolerance of "equal to double": the converted systems evaluate the same formulas as the
# double ones, with the operations in another order (matrix products with the coordinate map
# instead of index permutations, an explicit inverse instead of LAPACK's solve), from the same
# Drake kernels (M, C q̇, g of the converted plant).  Each output is a sum of a few dozen
# products of terms bounded by |u|, so the two differ by a few dozen ulps of |u|: 1e-12 |u|.
REL = 1e-12


def acrobot_model():
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModels(FindResourceOrThrow("drake/examples/acrobot/Acrobot.urdf"))
    plant.Finalize()
    return MechanicalModel.from_plant(plant)          # joint damping 0.1: friction D q̇


def arm_controllers():
    model = make_arm_model()
    gc1 = controlled_gains([100], [500], [40], [0.072])
    hg = hinf_mechanical_gains(1.0, 4.0, 4.0, 0.3, 0.6)
    acro = acrobot_model()
    return {
        "W2 fully actuated": MechanicalController(model, Partition(controlled=[0, 1]),
                                                  SobolevLaw(controlled_gains(*W_ARM))),
        "W2 printed inertia": MechanicalController(make_arm_model(inertia="thesis-printed"),
                                                   Partition(controlled=[0, 1]),
                                                   SobolevLaw(controlled_gains(*W_ARM))),
        "W2 regulated": MechanicalController(model, Partition(controlled=[0], regulated=[1]),
                                             SobolevLaw(gc1, regulated=regulated_gains(30, 5, .02))),
        "W2 stabilized": MechanicalController(model, Partition(controlled=[0], stabilized=[1]),
                                              SobolevLaw(gc1, stabilized=stabilized_gains(3, .05))),
        "W2 bounds inactive": MechanicalController(model, Partition(controlled=[0, 1]),
                                                   SobolevLaw(controlled_gains(*W_ARM)),
                                                   lower=[-1e4, -1e4], upper=[1e4, 1e4]),
        "Hinf": MechanicalController(model, Partition(controlled=[0, 1]), HinfLaw(hg)),
        "W2 reduced acrobot": MechanicalController(acro, Partition(controlled=[1], uncontrolled=[0]),
                                                   SobolevLaw(gc1)),
        "Hinf reduced acrobot": MechanicalController(acro, Partition(controlled=[1], uncontrolled=[0]),
                                                     HinfLaw(hg)),
    }


def values(y):
    """Numbers of an output of any scalar type."""
    y = np.asarray(y)
    if y.dtype != object:
        return y.astype(float)
    return np.array([x.value() if isinstance(x, AutoDiffXd) else x.Evaluate() for x in y])


def evaluate(system, x, ref, e_int):
    context = system.CreateDefaultContext()
    system.get_input_port_estimated_state().FixValue(context, x)
    n_ref = system.law.n_ref
    system.get_input_port_desired_state().FixValue(context, ref[:2 * n_ref])
    system.get_input_port_desired_acceleration().FixValue(context, ref[2 * n_ref:])
    context.SetContinuousState(e_int)
    out = {name: values(system.GetOutputPort(name).Eval(context))
           for name in ("control", "generalized_force", "error_integral")}
    out["derivative"] = values(system.EvalTimeDerivatives(context).CopyToVector())
    return out


@pytest.mark.parametrize("name", list(arm_controllers()))
def test_converted_controller_outputs_equal_double(name):
    ctrl = arm_controllers()[name]
    m = ctrl.law.n_ref
    rng = np.random.default_rng(3)
    x = X_ARM                                   # both plants have 2 DOF
    ref = np.concatenate([REF_ARM[k:k + m] for k in (0, 2, 4)])
    e_int = rng.normal(scale=0.05, size=ctrl.law.nc)
    double = evaluate(ctrl, x, ref, e_int)
    for converted in (ctrl.ToAutoDiffXd(), ctrl.ToSymbolic()):
        out = evaluate(converted, x, ref, e_int)
        for key, y in double.items():
            scale = max(1.0, np.abs(y).max())
            np.testing.assert_allclose(out[key], y, rtol=0, atol=REL * scale, err_msg=key)


def test_converted_adapter_outputs_equal_double():
    for inertia in ("physical", "thesis-printed"):
        builder = DiagramBuilder()
        adapter = add_arm(builder, inertia=inertia).adapter
        results = []
        for system in (adapter, adapter.ToAutoDiffXd(), adapter.ToSymbolic()):
            context = system.CreateDefaultContext()
            system.GetInputPort("u").FixValue(context, [1.0, -2.0])
            system.GetInputPort("disturbance").FixValue(context, [0.3, 0.1])
            system.GetInputPort("plant_state").FixValue(context, X_ARM)
            results.append([values(system.GetOutputPort(p).Eval(context))
                            for p in ("applied_generalized_force", "x")])
        for force, x in results[1:]:
            np.testing.assert_allclose(force, results[0][0], rtol=0,
                                       atol=REL * np.abs(results[0][0]).max())
            np.testing.assert_array_equal(x, results[0][1])       # a permutation: exact
        if inertia == "physical":         # B = I, no friction: τ = u + w exactly
            np.testing.assert_allclose(results[0][0], [1.3, -1.9], rtol=0, atol=1e-15)


def test_generic_law_equals_double_specialization_and_differentiates():
    law = MechanicalLaw(make_arm_model(), Partition(controlled=[0, 1]),
                        SobolevLaw(controlled_gains(*W_ARM)))
    q, qd, ei = X_ARM[:2], X_ARM[2:], np.array([0.02, -0.01])
    u = law.actuation(q, qd, ei, REF_ARM)
    x_ad = InitializeAutoDiff(X_ARM).ravel()
    u_ad = law.actuation(x_ad[:2], x_ad[2:], ei.astype(object), REF_ARM.astype(object))
    np.testing.assert_allclose(values(u_ad), u, rtol=0, atol=REL * np.abs(u).max())
    # the gradient against central differences: truncation O(h²|u'''|) ≈ 1e-10, rounding
    # eps|u|/h ≈ 2e-16 · 500 / 1e-5 ≈ 1e-8, so 1e-6 of the gradient's size separates a wrong
    # derivative from rounding
    h, J = 1e-5, ExtractGradient(u_ad)
    for k in range(4):
        dx = np.zeros(4)
        dx[k] = h
        up = law.actuation((X_ARM + dx)[:2], (X_ARM + dx)[2:], ei, REF_ARM)
        um = law.actuation((X_ARM - dx)[:2], (X_ARM - dx)[2:], ei, REF_ARM)
        np.testing.assert_allclose(J[:, k], (up - um) / (2 * h), rtol=0,
                                   atol=1e-6 * np.abs(J).max())
    # the compiled Newton–Euler kernel (double specialization) equals the generic M q̈ + h
    chain = MechanicalModel.from_plant(seven_link_arm())
    chain_law = MechanicalLaw(chain, Partition(controlled=range(7)),
                              SobolevLaw(controlled_gains(*[[1.0] * 7] * 4)))
    rng = np.random.default_rng(0)
    q7, v7, a7 = rng.normal(size=(3, 7))
    tau = chain_law.dynamics.recursive_inverse_dynamics(q7, v7, a7)
    M, hb = ScalarTerms(chain).mass_and_bias(q7, v7)
    np.testing.assert_allclose(tau, M @ a7 + hb, rtol=0, atol=REL * np.abs(tau).max())


def test_not_differentiable_parts_refuse_by_name():
    model = make_arm_model()
    bounded = MechanicalController(model, Partition(controlled=[0, 1]),
                                   SobolevLaw(controlled_gains(*W_ARM)), lower=[-1, -1],
                                   upper=[1, 1])
    with pytest.raises(ValueError, match=r"actuator bound active.*lower/upper"):
        evaluate(bounded.ToAutoDiffXd(), X_ARM, REF_ARM, np.zeros(2))
    symbolic = bounded.ToSymbolic()
    context = symbolic.CreateDefaultContext()
    symbolic.get_input_port_estimated_state().FixValue(
        context, [Expression(Variable(f"x{i}")) for i in range(4)])
    symbolic.get_input_port_reference().FixValue(context, REF_ARM)
    with pytest.raises(TypeError, match="no symbolic form"):
        symbolic.get_output_port_control().Eval(context)
    law = MechanicalLaw(model, Partition(controlled=[0, 1]), SobolevLaw(controlled_gains(*W_ARM)),
                        allocation=lambda u, q, qd: np.clip(np.asarray(u, dtype=float), -5, 5))
    x_ad = InitializeAutoDiff(X_ARM).ravel()
    with pytest.raises(TypeError, match="allocation .* failed on AutoDiffXd"):
        law.actuation(x_ad[:2], x_ad[2:], np.zeros(2, dtype=object), REF_ARM.astype(object))
    with pytest.raises(TypeError, match=r"QuadrotorModel\.B cannot evaluate AutoDiffXd"):
        ScalarTerms(make_quadrotor_model(), AutoDiffXd).input_matrix(
            InitializeAutoDiff(np.zeros(6)).ravel())


def test_linearize_arm_closed_loop_gives_the_design_poles():
    """Exact model, fully actuated: ë = −K[ė; e; ∫e] exactly (5.27), so the closed loop is
    linear in (ė, e, ∫e) and its poles are, per joint, the roots of
    s³ + (Q/y3) s² + (K/y3) s + T/y3 with the closed-form Riccati blocks (5.19)–(5.24)."""
    gains = controlled_gains(*W_ARM)
    design = np.concatenate([np.roots([1.0, f["Q"] / y[3], f["K"] / y[3], f["T"] / y[3]])
                             for y in zip(*W_ARM) for f in [controlled_closed_form(*y)]])
    for inertia in ("physical", "thesis-printed"):
        builder = DiagramBuilder()
        arm = add_arm(builder, inertia=inertia)
        qr = np.array([0.7, -0.3])
        source = builder.AddSystem(ConstantVectorSource(np.concatenate([qr, np.zeros(4)])))
        ctrl = builder.AddSystem(MechanicalController(arm.model, Partition(controlled=[0, 1]),
                                                      SobolevLaw(gains)))
        builder.Connect(arm.x, ctrl.get_input_port_estimated_state())
        builder.Connect(source.get_output_port(), ctrl.get_input_port_reference())
        builder.Connect(ctrl.get_output_port_control(), arm.u)
        diagram = builder.Build()
        context = diagram.CreateDefaultContext()
        arm.set_state(context, diagram, qr, [0.0, 0.0])
        linear = Linearize(diagram, context, InputPortSelection.kNoInput,
                           OutputPortSelection.kNoOutput, equilibrium_check_tolerance=1e-9)
        A = linear.A()
        assert A.shape == (6, 6)
        poles = np.linalg.eigvals(A)
        # The Jacobian is exact to rounding (AutoDiffXd): entries ≤ ‖A‖ ≈ 1e3 carry ~1e3·eps
        # ≈ 2e-13 errors; the eigenvalues' condition numbers (from the eigenvectors) scale
        # that, and np.roots is accurate to ~1e-13 relative: the bound below is ≥ 100× both.
        w, vl, vr = _eig_condition(A)
        bound = max(1e-8, 100 * w.max() * np.linalg.norm(A) * np.finfo(float).eps)
        assert bound < 1e-7
        for p in design:
            assert np.min(np.abs(poles - p)) <= bound, (p, poles)


def _eig_condition(A):
    import scipy.linalg as sla
    lam, vl, vr = sla.eig(A, left=True, right=True)
    kappa = np.array([1.0 / abs(vl[:, i].conj() @ vr[:, i]) * np.linalg.norm(vl[:, i])
                      * np.linalg.norm(vr[:, i]) for i in range(len(lam))])
    return kappa, vl, vr


def test_law_is_a_parameter_of_the_context():
    model = make_arm_model()
    first = SobolevLaw(controlled_gains(*W_ARM))
    second = SobolevLaw(controlled_gains(*[[1.0, 2.0]] * 4))
    ctrl = MechanicalController(model, Partition(controlled=[0, 1]), first)
    fresh = MechanicalController(model, Partition(controlled=[0, 1]), second)
    contexts = []
    for system in (ctrl, ctrl, fresh):
        context = system.CreateDefaultContext()
        system.GetInputPort("x").FixValue(context, X_ARM)
        system.GetInputPort("reference").FixValue(context, REF_ARM)
        contexts.append(context)
    c1, c2, c_fresh = contexts
    port = ctrl.get_output_port_control()
    u_first = port.Eval(c1).copy()
    assert np.array_equal(port.Eval(c2), u_first)
    ctrl.set_inner(second, c2)                    # the cached u of c2 must not survive
    u_second = port.Eval(c2)
    assert not np.allclose(u_second, u_first)
    assert np.array_equal(u_second, fresh.get_output_port_control().Eval(c_fresh))
    assert np.array_equal(port.Eval(c1), u_first)                  # c1 untouched
    assert ctrl.law_of(c2).law is second and ctrl.law_of(c1).law is first
    assert ctrl.law_of(ctrl.CreateDefaultContext()).law is first   # defaults unchanged
    with pytest.raises(TypeError, match="set_inner.*context"):
        ctrl.set_inner(second)
    with pytest.raises(ValueError, match="controlled gains are for 1 DOF"):
        ctrl.set_inner(SobolevLaw(controlled_gains([1], [1], [1], [1])), c1)


def test_drake_port_names_and_aliases():
    ctrl = arm_controllers()["W2 fully actuated"]
    assert {ctrl.get_input_port(i).get_name() for i in range(ctrl.num_input_ports())} == {
        "estimated_state", "desired_state", "desired_acceleration", "reference", "x"}
    forms = []
    for state_port, stacked in (("estimated_state", False), ("x", True)):
        context = ctrl.CreateDefaultContext()
        ctrl.GetInputPort(state_port).FixValue(context, X_ARM)
        if stacked:
            ctrl.get_input_port_reference().FixValue(context, REF_ARM)
        else:
            ctrl.get_input_port_desired_state().FixValue(context, REF_ARM[:4])
            ctrl.get_input_port_desired_acceleration().FixValue(context, REF_ARM[4:])
        forms.append([ctrl.GetOutputPort(p).Eval(context).copy()
                      for p in ("control", "actuation", "u")])
    assert all(np.array_equal(u, forms[0][0]) for form in forms for u in form)
    context = ctrl.CreateDefaultContext()
    ctrl.get_input_port_estimated_state().FixValue(context, X_ARM)
    with pytest.raises(RuntimeError, match="no reference: connect 'desired_state'"):
        ctrl.get_output_port_control().Eval(context)
    ctrl.GetInputPort("x").FixValue(context, X_ARM)
    ctrl.get_input_port_reference().FixValue(context, REF_ARM)
    with pytest.raises(RuntimeError, match="exactly one of .*'estimated_state' and 'x'.*both"):
        ctrl.get_output_port_control().Eval(context)


@pytest.mark.parametrize("system", [MechanicalController, ThesisForceAdapter])
def test_pydrake_system_block_lists_the_ports(system):
    doc = system.__doc__
    block = re.search(r"\.\. pydrake_system::\n\n(.*?)\n\n", doc, re.S).group(1)
    listed = re.findall(r"- (\w+)", block)
    if system is MechanicalController:
        instance = arm_controllers()["W2 fully actuated"]
    else:
        instance = add_arm(DiagramBuilder()).adapter
    ports = [instance.get_input_port(i).get_name() for i in range(instance.num_input_ports())]
    ports += [instance.get_output_port(i).get_name() for i in range(instance.num_output_ports())]
    assert listed == ports


# --- Drake's InverseDynamicsController example, one line swapped; the sampled controller ------
N7 = 7
GAINS7 = controlled_gains(Y0=[100.0] * N7, Y1=[50.0] * N7, Y2=[1.0] * N7, Y3=[0.01] * N7)
KD, KP, KI = (np.diag(GAINS7.K[:, k * N7:(k + 1) * N7]) for k in range(3))
TIMES = np.linspace(0.0, 3.0, 301)
DESIRED = PiecewisePolynomial.CubicWithContinuousSecondDerivatives(
    TIMES, 0.2 + np.array([0.4, 0.3, 0.5, -0.4, 0.6, 0.5, 0.7])[:, None]
    * np.sin(np.outer(0.3 * np.arange(1, 8) + 1.0, TIMES)), np.zeros(N7), np.zeros(N7))
Q0 = DESIRED.value(0.0).ravel() + 0.1


def idc_example(make_controller, duration, zoh=None, time_step=0.0):
    """Drake's InverseDynamicsController tracking a desired state on a 7-joint arm; the
    controller is made by ``make_controller(controller_plant)``, the one line a user swaps."""
    run = fly_seven_link_arm(make_controller, DESIRED, Q0, duration, time_step=time_step, zoh=zoh)
    return run["t"], run["x"], run["u"]


@pytest.fixture(scope="module")
def continuous_run():
    return idc_example(lambda plant: MechanicalController.from_plant(plant, SobolevLaw(GAINS7)), 1.0)


def test_inverse_dynamics_controller_swapped_in_one_line(continuous_run):
    # with diagonal weights the W2 gains are the PID gains of Drake's controller
    assert np.array_equal(GAINS7.K, np.hstack([np.diag(KD), np.diag(KP), np.diag(KI)]))
    t, x, u = idc_example(lambda plant: InverseDynamicsController(plant, KP, KI, KD, False), 1.0)
    t2, x2, u2 = continuous_run
    assert np.array_equal(t, t2)
    # Same law, same integrator steps: the trajectories differ by rounding (CalcInverseDynamics
    # vs M q̈ + h, ~1e-13 N·m) carried through 1 s of a stable loop: far below 1e-9
    assert np.abs(x - x2).max() < 1e-9
    assert np.abs(x[:N7, -1] - DESIRED.value(t[-1]).ravel()).max() < 0.05    # it tracks


def test_sampled_controller_tracks_like_continuous_without_startup_spike(continuous_run):
    t, x, u = continuous_run
    ts, xs, us = idc_example(
        lambda plant: MechanicalController.from_plant(plant, SobolevLaw(GAINS7), period=1e-3), 1.0)
    assert np.array_equal(t, ts)

    def ise(t, x):
        e = x[:N7] - DESIRED.vector_values(t)
        return np.trapezoid(np.sum(e ** 2, axis=0), t)

    assert ise(t, x) > 1e-3                             # the initial offset makes it sizeable
    assert abs(ise(ts, xs) / ise(t, x) - 1.0) < 0.05
    # the first command is the law at the initial state (initialization event), not zero
    np.testing.assert_allclose(us[:, 0], u[:, 0], rtol=0, atol=REL * np.abs(u[:, 0]).max())
    def peak(t, u):                       # largest |τ| / effort limit in the first 2 ms
        return np.max(np.abs(u[:, t <= 2e-3]).T / SEVEN_LINK_EFFORT_LIMITS)

    assert peak(ts, us) <= 1.01 * peak(t, u)
    # On Drake's 1 ms discrete plant the first step applies the command present at t = 0 (the
    # logged one): the sampled controller's initialization command, while a ZeroOrderHold in
    # front of the continuous controller holds x = 0 until its first sample
    sampled = lambda plant: MechanicalController.from_plant(  # noqa: E731
        plant, SobolevLaw(GAINS7), period=1e-3)
    continuous = lambda plant: MechanicalController.from_plant(plant, SobolevLaw(GAINS7))  # noqa: E731
    _, _, ud = idc_example(sampled, 2e-3, time_step=1e-3)
    _, _, uz = idc_example(continuous, 2e-3, zoh=1e-3, time_step=1e-3)
    np.testing.assert_allclose(ud[:, 0], u[:, 0], rtol=0, atol=REL * np.abs(u[:, 0]).max())
    assert np.max(np.abs(uz[:, 0] - u[:, 0]) / SEVEN_LINK_EFFORT_LIMITS) > 0.1


def test_sampled_events_hold_integrate_and_delay():
    h = 0.01
    law = MechanicalLaw(make_arm_model(), Partition(controlled=[0, 1]),
                        SobolevLaw(controlled_gains(*W_ARM)))
    ramp = PiecewisePolynomial.FirstOrderHold([0.0, 1.0], np.array([[0.0, 0.5], [0.0, -0.5],
                                                                    [0.5, 0.5], [-0.5, -0.5],
                                                                    [0.0, 0.0], [0.0, 0.0]]))
    results = {}
    for delay in (False, True):
        builder = DiagramBuilder()
        ctrl = builder.AddSystem(MechanicalController(law=law, period=h, computation_delay=delay))
        reference = builder.AddSystem(TrajectorySource(ramp))
        state = builder.AddSystem(ConstantVectorSource(X_ARM))
        builder.Connect(state.get_output_port(), ctrl.get_input_port_estimated_state())
        builder.Connect(reference.get_output_port(), ctrl.get_input_port_reference())
        diagram = builder.Build()
        assert not ctrl.HasDirectFeedthrough(0, 0)           # sampled: no feedthrough
        simulator = Simulator(diagram)
        context = simulator.get_mutable_context()
        own = ctrl.GetMyContextFromRoot(context)
        simulator.Initialize()
        results[delay, 0] = ctrl.get_output_port_control().Eval(own).copy()
        simulator.AdvanceTo(2.5 * h)
        results[delay] = (ctrl.get_output_port_control().Eval(own).copy(),
                          ctrl.get_output_port_error_integral().Eval(own).copy())
    q = X_ARM[:2]
    r = [ramp.value(k * h).ravel() for k in range(3)]
    e = [q - rk[:2] for rk in r]
    ei = [np.zeros(2), h * e[0], h * (e[0] + e[1]), h * (e[0] + e[1] + e[2])]
    u = [law.actuation(q, X_ARM[2:], ei[k], r[k]) for k in range(3)]
    for delay in (False, True):
        np.testing.assert_allclose(results[delay, 0], u[0], rtol=1e-13)    # initialization
        np.testing.assert_allclose(results[delay][1], ei[3], rtol=1e-13)   # 3 samples: 0, h, 2h
    np.testing.assert_allclose(results[False][0], u[2], rtol=1e-13)        # sampled at 2h
    np.testing.assert_allclose(results[True][0], u[1], rtol=1e-13)         # one sample late
    continuous = MechanicalController(law=law)
    assert continuous.HasDirectFeedthrough(0, 0)
    for kwargs, error, message in (({"period": 0.0}, ValueError, "period must be > 0, got 0.0"),
                                   ({"period": h, "computation_delay": "yes"}, TypeError,
                                    "computation_delay must be a bool, got 'yes'"),
                                   ({"computation_delay": True}, ValueError, "needs a period")):
        with pytest.raises(error, match=message):
            MechanicalController(law=law, **kwargs)
    # the sampled form converts too: initialization command and one Euler step of ∫e
    sampled = MechanicalController(law=law, period=h, computation_delay=True)
    for system in (sampled, sampled.ToAutoDiffXd(), sampled.ToSymbolic()):
        context = system.CreateDefaultContext()
        system.get_input_port_estimated_state().FixValue(context, X_ARM)
        system.get_input_port_reference().FixValue(context, r[0])
        system.ExecuteInitializationEvents(context)
        np.testing.assert_allclose(values(system.get_output_port_control().Eval(context)), u[0],
                                   rtol=0, atol=REL * np.abs(u[0]).max())
        context.SetDiscreteState(system.EvalUniquePeriodicDiscreteUpdate(context))
        np.testing.assert_allclose(values(system.get_output_port_error_integral().Eval(context)),
                                   ei[1], rtol=0, atol=1e-15)
