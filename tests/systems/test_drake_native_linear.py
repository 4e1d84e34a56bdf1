"""Drake-native linear controllers, Galerkin controller and linearizations (issue #31).

* every LeafSystem of ``linear_controllers`` / ``galerkin_controller`` converts to AutoDiffXd
  and Expression with outputs equal to the double system's, a GalerkinController of a
  GalerkinResult too when the design's functions accept object arrays (else it refuses,
  naming the function), and Drake's ``Linearize`` of it gives the law's ``feedback_gain()``;
* Drake's ``Linearize`` of a closed loop with ``controller_system(K)`` gives eig(A − B K);
* a sampled controller's first command at t = 0 is the law's at the initial state (no zero);
* Drake's linearization of the models equals the former central differences at their accuracy.

Tolerances.  Double, AutoDiffXd and Expression evaluate the same products in possibly another
summation order: |difference| ≤ n ε Σ|terms| (n ≤ 4 terms of size O(1) here), so rtol = 1e-13.
Central differences with step h have the error h²/6 |f'''| (truncation) + ε F/h per
evaluation pair (rounding, F the size of the terms summed in f near the point); with the
scale S = F + max|J| bounding |f'''| (trigonometric dependence on angles: third derivatives
are of the size of the terms themselves) this is S (h²/6 + ε/h), times 10 for the O(10)
rounded operations of an evaluation (mass matrix, bias term, solve).
"""

import numpy as np
import pytest
import scipy.linalg
import scipy.signal
from pydrake.autodiffutils import AutoDiffXd, ExtractGradient, ExtractValue, InitializeAutoDiff
from pydrake.symbolic import Evaluate, Expression, Variable
from pydrake.systems.analysis import Simulator
from pydrake.systems.controllers import PidController
from pydrake.systems.framework import DiagramBuilder, InputPortSelection, OutputPortSelection
from pydrake.systems.primitives import LinearSystem, Linearize

from sobolev_drake.models import quadrotor_linear as ql
from sobolev_drake.models import two_wheeled_linear as twl
from sobolev_drake.models.linearization import linearize_mechanical
from sobolev_drake.systems.galerkin_controller import GalerkinController
from sobolev_drake.systems.linear_controllers import (LinearDynamicOutputFeedback,
                                                      LinearStateFeedback, controller_system)

EPS = np.finfo(float).eps
RTOL_SAME_ARITHMETIC = 1e-13   # n ε Σ|terms| with n ≤ 4, |terms| = O(1): see the module docstring

# plant of the closed loops: unstable, controllable; K places the poles at -1, -2, -3
A3 = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [2.0, -1.0, 0.5]])
B3 = np.array([[0.0], [0.0], [1.0]])
K3 = scipy.signal.place_poles(A3, B3, [-1.0, -2.0, -3.0]).gain_matrix   # u = −K3 x


def _symbols(n, name="x"):
    v = [Variable(f"{name}{i}") for i in range(n)]
    return v, np.array([Expression(x) for x in v])


def _evaluate(expressions, variables, values):
    env = dict(zip(variables, values))
    return np.array([e.Evaluate(env) for e in expressions])


# ------------------------------------------------------------------------- scalar conversion
def test_state_feedback_converts_with_outputs_and_gradient_equal_to_double():
    K = np.array([[2.0, -1.0, 0.5], [0.3, 4.0, -2.0]])
    S = np.array([[0, 1.0, 0, 0], [0, 0, 1.0, 0], [0, 0, 0, 1.0]])   # drops entry 0
    sys = LinearStateFeedback(K, u_r=[0.2, -0.2], S=S, reference_port=True, u_min=-1.0, u_max=1.0)
    x, r = np.array([7.0, 0.1, -0.2, 0.3]), np.array([0.05, 0.0, -0.1])
    ctx = sys.CreateDefaultContext()
    sys.GetInputPort("x").FixValue(ctx, x)
    sys.GetInputPort("x_r").FixValue(ctx, r)
    u, raw = sys.GetOutputPort("u").Eval(ctx), sys.GetOutputPort("u_raw").Eval(ctx)
    assert abs(raw[0]) < 1 < abs(raw[1])            # one channel inside, one clipped

    ad = sys.ToAutoDiffXd()
    c = ad.CreateDefaultContext()
    ad.GetInputPort("x").FixValue(c, InitializeAutoDiff(x).ravel())   # d/dx
    ad.GetInputPort("x_r").FixValue(c, np.array([AutoDiffXd(v) for v in r]))
    u_ad = ad.GetOutputPort("u").Eval(c)
    np.testing.assert_allclose(ExtractValue(u_ad).ravel(), u, rtol=RTOL_SAME_ARITHMETIC)
    # ∂u/∂x = K S where unclipped, 0 where the bound holds
    np.testing.assert_allclose(ExtractGradient(u_ad), [(K @ S)[0], np.zeros(4)],
                               rtol=RTOL_SAME_ARITHMETIC, atol=0)
    np.testing.assert_allclose(ExtractValue(ad.GetOutputPort("u_raw").Eval(c)).ravel(), raw,
                               rtol=RTOL_SAME_ARITHMETIC)

    sym = sys.ToSymbolic()
    c = sym.CreateDefaultContext()
    xv, xe = _symbols(4)
    sym.GetInputPort("x").FixValue(c, xe)
    sym.GetInputPort("x_r").FixValue(c, np.array([Expression(v) for v in r]))
    u_sym = sym.GetOutputPort("u").Eval(c)
    assert not u_sym[0].GetVariables().include(xv[0])   # S drops x0: u does not depend on it
    np.testing.assert_allclose(_evaluate(u_sym, xv, x), u, rtol=RTOL_SAME_ARITHMETIC)


@pytest.mark.parametrize("period", [None, 0.1])
def test_output_feedback_converts_with_outputs_and_dynamics_equal_to_double(period):
    AK = np.array([[-5.0, 1.0], [-20.0, -6.0]])
    BK = np.array([[4.0, 0.0], [18.0, 1.0]])
    CK, DK = np.array([[-8.0, -2.0]]), np.array([[-1.5, 0.25]])
    S = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    sys = LinearDynamicOutputFeedback(AK, BK, CK, DK, y_op=[0.1, -0.1], u_op=[0.3], S=S,
                                      x0=[0.2, -0.4], u_min=-5.0, u_max=5.0, period=period)
    y = np.array([0.3, 9.0, -0.2])
    ctx = sys.CreateDefaultContext()
    sys.GetInputPort("y").FixValue(ctx, y)
    if period is not None:
        sys.ExecuteInitializationEvents(ctx)
    u = sys.GetOutputPort("u").Eval(ctx)
    dy = S @ y - [0.1, -0.1]
    np.testing.assert_allclose(u, 0.3 + CK @ [0.2, -0.4] + DK @ dy, rtol=RTOL_SAME_ARITHMETIC)
    for converted, T in ((sys.ToAutoDiffXd(), AutoDiffXd), (sys.ToSymbolic(), Expression)):
        c = converted.CreateDefaultContext()
        converted.GetInputPort("y").FixValue(c, np.array([T(v) for v in y]))
        if period is not None:
            converted.ExecuteInitializationEvents(c)
        got = converted.GetOutputPort("u").Eval(c)
        value = (ExtractValue(got).ravel() if T is AutoDiffXd
                 else np.array([e.Evaluate() for e in got]))
        np.testing.assert_allclose(value, u, rtol=RTOL_SAME_ARITHMETIC)
        if period is None:
            xdot = converted.EvalTimeDerivatives(c).CopyToVector()
            xdot = ExtractValue(xdot).ravel() if T is AutoDiffXd else [e.Evaluate() for e in xdot]
            np.testing.assert_allclose(xdot, sys.EvalTimeDerivatives(ctx).CopyToVector(),
                                       rtol=RTOL_SAME_ARITHMETIC)


class _CubicLaw:
    """A vectorized law written for any scalar type: u = K x − ½ x₀³ (rows of X)."""

    K = np.array([[-2.0, -1.0, 0.5]])

    def control(self, X):
        return X @ self.K.T - 0.5 * X[:, :1] ** 3


def test_galerkin_controller_converts_for_a_generic_law():
    law = _CubicLaw()
    sys = GalerkinController(law, n=3, nu=1, plant_state_size=4, selection=[1, 2, 3],
                             offset=[0.1, 0.0, 0.0])
    assert sys.conversion_refusal is None
    x = np.array([5.0, 0.2, -0.3, 0.4])
    ctx = sys.CreateDefaultContext()
    sys.get_input_port_estimated_state().FixValue(ctx, x)
    u = sys.get_output_port_control().Eval(ctx)
    xd = x[1:] + [0.1, 0.0, 0.0]
    np.testing.assert_allclose(u, law.K @ xd - 0.5 * xd[0] ** 3, rtol=RTOL_SAME_ARITHMETIC)

    ad = sys.ToAutoDiffXd()
    c = ad.CreateDefaultContext()
    ad.get_input_port(0).FixValue(c, InitializeAutoDiff(x).ravel())
    u_ad = ad.get_output_port(0).Eval(c)
    np.testing.assert_allclose(ExtractValue(u_ad).ravel(), u, rtol=RTOL_SAME_ARITHMETIC)
    grad = np.r_[0.0, law.K[0] - [1.5 * xd[0] ** 2, 0.0, 0.0]]    # ∂u/∂x by hand
    np.testing.assert_allclose(ExtractGradient(u_ad)[0], grad, rtol=RTOL_SAME_ARITHMETIC)

    sym = sys.ToSymbolic()
    c = sym.CreateDefaultContext()
    xv, xe = _symbols(4)
    sym.get_input_port(0).FixValue(c, xe)
    np.testing.assert_allclose(_evaluate(sym.get_output_port(0).Eval(c), xv, x), u,
                               rtol=RTOL_SAME_ARITHMETIC)


def test_galerkin_controller_of_a_double_only_galerkin_result_refuses_conversion_by_name():
    def f_double_only(X):              # fills a float array: no AutoDiffXd / Expression
        out = np.empty((X.shape[0], 3))
        out[:] = X @ A3.T
        return out

    law = _galerkin_law(f_double_only, _g_nl)
    sys = GalerkinController(law, plant_state_size=4, selection=[1, 2, 3])
    for scalar in ("AutoDiffXd", "Expression"):
        assert (f"GalerkinResult.control(X) fails on {scalar} (ObjectEvaluationError: the model "
                f"function f(X) does not evaluate on an object array of {scalar}"
                in sys.conversion_refusal)
    for convert in (sys.ToAutoDiffXd, sys.ToSymbolic):
        with pytest.raises(RuntimeError, match="GalerkinController.*does not support scalar"):
            convert()
    # the documented alternative: the law's gain at the origin in a LinearStateFeedback converts
    # (the gain by central differences, the design being double only)
    np.testing.assert_array_equal(law.feedback_gain(), law.feedback_gain("central"))
    alt = LinearStateFeedback(law.feedback_gain(), S=np.eye(4)[1:])
    assert alt.ToAutoDiffXd() is not None and alt.ToSymbolic() is not None


# ------------------------------------------------------------------ Drake's Linearize of loops
def _loop(controller, plant=None):
    b = DiagramBuilder()
    plant = b.AddSystem(plant or LinearSystem(A3, B3, np.eye(3), np.zeros((3, 1))))
    ctrl = b.AddSystem(controller)
    b.Connect(plant.get_output_port(), ctrl.get_input_port_estimated_state())
    b.Connect(ctrl.get_output_port_control(), plant.get_input_port())
    return b.Build(), plant, ctrl


def _linearize(diagram, context):
    return Linearize(diagram, context, input_port_index=InputPortSelection.kNoInput,
                     output_port_index=OutputPortSelection.kNoOutput)


def _assert_same_spectrum(M, expected):
    # Linearize is exact to rounding (AutoDiffXd): M = A − B K to ~ε‖A‖, and the distinct
    # eigenvalues (condition number of the eigenvectors < 1e3 here) move by < 1e3 ε ‖A‖ ≪ 1e-8
    got, want = np.sort_complex(np.linalg.eigvals(M)), np.sort_complex(expected)
    np.testing.assert_allclose(got, want, rtol=1e-8)


def test_linearized_closed_loop_with_controller_system_has_eigenvalues_of_A_minus_BK():
    diagram, _, _ = _loop(controller_system(-K3, u_min=-100.0, u_max=100.0))
    lin = _linearize(diagram, diagram.CreateDefaultContext())
    np.testing.assert_allclose(lin.A(), A3 - B3 @ K3, rtol=0, atol=10 * EPS * np.abs(K3).max())
    _assert_same_spectrum(lin.A(), [-1.0, -2.0, -3.0])
    # the gains of the context are the ones linearized (zero placeholder, K set per context)
    diagram, _, ctrl = _loop(controller_system(np.zeros((1, 3))))
    context = diagram.CreateDefaultContext()
    ctrl.set_gains(ctrl.GetMyMutableContextFromRoot(context), -K3)
    _assert_same_spectrum(_linearize(diagram, context).A(), np.linalg.eigvals(A3 - B3 @ K3))


def test_linearized_closed_loop_with_output_feedback_matches_the_block_matrix():
    C = np.array([[1.0, 0.0, 0.0]])
    AK = np.array([[-4.0, 1.0, 0.0], [-5.0, 0.0, 1.0], [-6.0, -1.0, -2.0]])
    BK, CK, DK = np.array([[1.0], [0.5], [0.2]]), np.array([[-1.0, -2.0, -1.5]]), np.array([[-0.5]])
    diagram, _, _ = _loop(controller_system((AK, BK, CK, DK), S=C))
    lin = _linearize(diagram, diagram.CreateDefaultContext())
    Acl = np.block([[A3 + B3 @ DK @ C, B3 @ CK], [BK @ C, AK]])
    _assert_same_spectrum(lin.A(), np.linalg.eigvals(Acl))


# ----------------------------------------------------------------------- sampled controllers
def _command(ctrl, context):
    return ctrl.get_output_port_control().Eval(ctrl.GetMyContextFromRoot(context))


@pytest.mark.parametrize("delay", [False, True])
def test_sampled_state_feedback_first_output_is_the_law_at_the_initial_state(delay):
    T, u_r, x_r = 0.1, np.array([0.5]), np.array([0.1, 0.0, 0.0])
    diagram, plant, ctrl = _loop(controller_system(-K3, x_op=x_r, u_op=u_r, period=T,
                                                   computation_delay=delay))
    context = diagram.CreateDefaultContext()
    x0 = np.array([1.0, -0.5, 0.2])
    plant.GetMyMutableContextFromRoot(context).SetContinuousState(x0)
    law = lambda x: u_r - K3 @ (x - x_r)   # noqa: E731
    np.testing.assert_array_equal(_command(ctrl, context), u_r)   # before initialization
    sim = Simulator(diagram, context)
    sim.Initialize()
    assert abs(law(x0)[0]) > 1.0                                 # far from the zero of a ZOH
    np.testing.assert_allclose(_command(ctrl, context), law(x0), rtol=RTOL_SAME_ARITHMETIC)
    sim.AdvanceTo(T)                       # the sample at T is taken at the start of the next step
    xT = plant.GetMyContextFromRoot(context).get_continuous_state_vector().CopyToVector()
    sim.AdvanceTo(1.5 * T)
    np.testing.assert_allclose(_command(ctrl, context), law(x0) if delay else law(xT),
                               rtol=RTOL_SAME_ARITHMETIC)
    sim.AdvanceTo(2.5 * T)
    if delay:
        np.testing.assert_allclose(_command(ctrl, context), law(xT), rtol=RTOL_SAME_ARITHMETIC)


def test_sampled_output_feedback_is_the_exact_hold_equivalent():
    """With a constant measurement the sampled controller's state at t = kT equals the
    continuous controller's x_K(kT) (the ZOH discretization is exact for a held input); the
    continuous one is integrated to accuracy 1e-12, so 1e-9 is the test's margin."""
    AK, BK = np.array([[-1.0, 2.0], [-2.0, -0.5]]), np.array([[1.0], [0.5]])
    CK, DK, T = np.array([[1.0, -1.0]]), np.array([[0.7]]), 0.2
    y, x0 = np.array([0.8]), np.array([0.3, -0.1])
    states = []
    for period in (None, T):
        sys = LinearDynamicOutputFeedback(AK, BK, CK, DK, x0=x0, period=period)
        ctx = sys.CreateDefaultContext()
        sys.get_input_port_estimated_state().FixValue(ctx, y)
        sim = Simulator(sys, ctx)
        sim.get_mutable_integrator().set_target_accuracy(1e-12)
        sim.Initialize()
        if period is not None:   # first command at initialization: u_op + CK x0 + DK y
            np.testing.assert_allclose(sys.get_output_port_control().Eval(ctx), CK @ x0 + DK @ y,
                                       rtol=RTOL_SAME_ARITHMETIC)
        if period is None:
            sim.AdvanceTo(4 * T)
            states.append(ctx.get_continuous_state_vector().CopyToVector())
        else:   # after the sample at 3T the discrete state is x_K[4], the state at 4T
            sim.AdvanceTo(3.5 * T)
            states.append(ctx.get_discrete_state(0).CopyToVector())   # group 0: x_K
    np.testing.assert_allclose(states[1], states[0], rtol=0, atol=1e-9)


def test_sampled_galerkin_controller_starts_with_the_law_at_the_initial_state():
    law = _CubicLaw()
    sys = GalerkinController(law, n=3, nu=1, period=0.05, computation_delay=True)
    ctx = sys.CreateDefaultContext()
    x0 = np.array([0.4, -0.2, 0.1])
    sys.GetInputPort("estimated_state").FixValue(ctx, x0)
    assert sys.GetOutputPort("control").Eval(ctx)[0] == 0.0      # before initialization
    sys.ExecuteInitializationEvents(ctx)
    np.testing.assert_allclose(sys.GetOutputPort("u").Eval(ctx), law.control(x0[None])[0],
                               rtol=RTOL_SAME_ARITHMETIC)
    with pytest.raises(ValueError, match="period must be > 0"):
        GalerkinController(law, n=3, nu=1, period=0.0)
    with pytest.raises(ValueError, match="computation_delay=True needs a sample period"):
        GalerkinController(law, n=3, nu=1, computation_delay=True)


# --------------------------------------------------------------------------- Drake port names
def test_drake_port_names_make_swapping_for_a_pid_controller_one_line():
    """The same wiring code runs Drake's PidController and the library's state feedback; with
    K = [−kp, −kd] the closed loops have the same plant derivative."""
    kp, kd = 4.0, 1.5
    A, B = np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[0.0], [1.0]])

    def wire(controller):
        b = DiagramBuilder()
        plant = b.AddSystem(LinearSystem(A, B, np.eye(2), np.zeros((2, 1))))
        ctrl = b.AddSystem(controller)
        b.Connect(plant.get_output_port(), ctrl.get_input_port_estimated_state())
        b.Connect(ctrl.get_output_port_control(), plant.get_input_port())
        d = b.Build()
        context = d.CreateDefaultContext()
        ctrl.get_input_port_desired_state().FixValue(ctrl.GetMyMutableContextFromRoot(context),
                                                     [0.2, 0.0])
        plant.GetMyMutableContextFromRoot(context).SetContinuousState([1.0, -0.5])
        return plant.EvalTimeDerivatives(plant.GetMyContextFromRoot(context)).CopyToVector()

    drake = wire(PidController([kp], [0.0], [kd]))
    ours = wire(LinearStateFeedback([[-kp, -kd]], reference_port=True))   # the one changed line
    np.testing.assert_allclose(ours, drake, rtol=RTOL_SAME_ARITHMETIC)
    sys = LinearStateFeedback([[1.0, 2.0]])
    assert sys.GetInputPort("estimated_state").get_index() == sys.GetInputPort("x").get_index()
    assert sys.HasOutputPort("control") and not sys.HasInputPort("desired_state")
    of = LinearDynamicOutputFeedback(-np.eye(1), [[1.0]], [[1.0]])
    assert of.get_input_port_estimated_state().get_name() == "y"


# ------------------------------------------------------------------- Drake vs former FD
def _fd_tolerance(model, q0, qdot0, u0, w0, J, h):
    """10 S (h²/6 + ε/h) with S = F + max|J| (module docstring)."""
    Minv = np.linalg.inv(model.M(q0))
    terms = [model.B(q0) @ u0, w0, model.Cqdot(q0, qdot0), model.g(q0), model.friction(qdot0)]
    F = max([np.abs(qdot0).max()] + [np.abs(Minv @ t).max() for t in terms])
    return 10 * (F + np.abs(J).max()) * (h ** 2 / 6 + EPS / h)


def _assert_fd_agrees(model, q0, qdot0, u0, drake, fd, steps, w0=None):
    w0 = np.zeros(model.n) if w0 is None else w0
    for name, J, J_fd, h in zip("ABD", drake, fd, steps):
        tol = _fd_tolerance(model, q0, qdot0, u0, w0, J, h)
        err = np.abs(J - J_fd).max()
        assert err <= tol, (name, err, tol)


def test_two_wheeled_drake_linearization_equals_central_differences():
    from sobolev_drake.models.two_wheeled import make_two_wheeled_model
    model = make_two_wheeled_model()
    z = np.zeros(2)
    full = linearize_mechanical(model, z, z, [0.0])
    fd = linearize_mechanical(model, z, z, [0.0], h=1e-6)
    _assert_fd_agrees(model, z, z, np.zeros(1), full, fd, (1e-6,) * 3)
    for reduced, reduced_fd in zip(twl.linearize(), twl.linearize(h=1e-6)):
        assert np.abs(reduced - reduced_fd).max() <= _fd_tolerance(
            model, z, z, np.zeros(1), z, full[0], 1e-6)
    # and Drake's is the exact derivative: the hand Jacobian to rounding (10 ε relative)
    for got, want in zip(twl.linearize(), twl.closed_form_linearization()):
        np.testing.assert_allclose(got, want, rtol=0, atol=10 * EPS * np.abs(want).max())


@pytest.mark.parametrize("point", ["hover", "moving"])
def test_quadrotor_drake_linearization_equals_central_differences(point):
    from sobolev_drake.models.quadrotor import QuadrotorParams, make_quadrotor_model
    p = QuadrotorParams.chapter6_nominal()
    model = make_quadrotor_model(p)
    u0 = np.full(4, p.hover_input())
    q0, qdot0, w0 = np.zeros(6), np.zeros(6), np.zeros(6)
    if point == "moving":
        q0, qdot0 = np.array([0.3, -0.2, 0.5, 1.0, 2.0, 3.0]), np.array([0.1, -0.3, 0.2, 0.5, -0.4, 0.3])
        u0, w0 = 1.1 * u0, 0.1 * np.arange(6)
    drake = linearize_mechanical(model, q0, qdot0, u0, w0,
                                 body_wrench=("body", model.body_wrench_matrix()))
    steps = (1e-6, 1.0, 1e-3)   # the former steps of quadrotor_linear.linearize
    fd = linearize_mechanical(model, q0, qdot0, u0, w0, h=steps[0], h_u=steps[1], h_w=steps[2])
    _assert_fd_agrees(model, q0, qdot0, u0, drake, fd, steps, w0)
    if point == "hover":
        for got, want in zip(ql.linearize(p), drake):
            np.testing.assert_array_equal(got, want)
        A = drake[0]
        assert A[9, 1] == pytest.approx(p.g, rel=10 * EPS) and A[10, 0] == pytest.approx(-p.g, rel=10 * EPS)


def test_plant_model_with_joint_damping_drake_equals_central_differences():
    """A from_plant model keeps the damping out of its plant context (it is K(q̇) = D q̇): the
    linearized plant uses that context, so the damping is counted once."""
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import RevoluteJoint, SpatialInertia, UnitInertia
    from sobolev_drake.models.base import MechanicalModel
    plant = MultibodyPlant(0.0)
    l1 = plant.AddRigidBody("l1", SpatialInertia(1.0, [0, 0, -0.5], UnitInertia(0.4, 0.4, 0.02)))
    l2 = plant.AddRigidBody("l2", SpatialInertia(0.7, [0, 0, -0.4], UnitInertia(0.3, 0.3, 0.01)))
    plant.AddJoint(RevoluteJoint("j1", plant.world_frame(), l1.body_frame(), [0, 1, 0], damping=0.3))
    j2 = plant.AddJoint(RevoluteJoint("j2", l1.body_frame(), l2.body_frame(), [0, 1, 0], damping=0.1))
    plant.AddJointActuator("a2", j2)
    plant.Finalize()
    model = MechanicalModel.from_plant(plant)
    q0, qdot0, u0 = np.array([0.4, -0.7]), np.array([0.5, -1.2]), np.array([0.3])
    drake = linearize_mechanical(model, q0, qdot0, u0)
    fd = linearize_mechanical(model, q0, qdot0, u0, h=1e-6, h_u=1.0, h_w=1.0)
    _assert_fd_agrees(model, q0, qdot0, u0, drake, fd, (1e-6, 1.0, 1.0))
    # ∂q̈/∂q̇ at q̇ = 0 is −M⁻¹ D: the damping once (twice would double it)
    A0 = linearize_mechanical(model, q0, np.zeros(2), u0)[0]
    # (exact to the rounding of M⁻¹: ε κ(M) < 1e-13 for this M)
    np.testing.assert_allclose(A0[2:, 2:], -np.linalg.solve(model.M(q0), np.diag([0.3, 0.1])),
                               rtol=1e-12)


def test_drake_linearization_refuses_what_it_cannot_represent():
    from sobolev_drake.models.quadrotor import make_quadrotor_model
    from sobolev_drake.models.two_wheeled import TwoWheeledModel
    model = make_quadrotor_model()
    u0, z = np.full(4, model.params.hover_input()), np.zeros(6)
    with pytest.raises(ValueError, match="B\\(q\\) depends on q.*body_wrench"):
        linearize_mechanical(model, z, z, u0)
    W = model.body_wrench_matrix()
    with pytest.raises(ValueError, match="does not reproduce model.B"):
        linearize_mechanical(model, z, z, u0, body_wrench=("body", np.vstack([W[3:], W[:3]])))
    printed = make_quadrotor_model(euler_matrix="thesis-printed")
    with pytest.raises(ValueError, match="replaces its plant's equations.*h="):
        linearize_mechanical(printed, z, z, u0, body_wrench=("body", W))

    class CubicFriction(TwoWheeledModel):
        def friction(self, qdot):
            return 0.1 * np.asarray(qdot) ** 3

    with pytest.raises(ValueError, match="friction K\\(q̇\\) is not linear"):
        linearize_mechanical(CubicFriction(), np.zeros(2), np.zeros(2), [0.0])


# ------------------------------------------- GalerkinController of a scalar-generic design
# A W∞ SGAA design on a nonlinear plant whose linearization is (A3, B3), written with
# dtype-preserving NumPy code so that it evaluates on AutoDiffXd and Expression.  f is odd and
# g, k even, so V is even and u*(0) = 0 (the origin is an equilibrium of the closed loop).
def _f_nl(X):
    x0, x1, x2 = X[:, 0], X[:, 1], X[:, 2]
    return np.stack([x1, x2 - 0.5 * np.sin(x0) * x1 ** 2, 2.0 * np.sin(x0) - x1 + 0.5 * x2],
                    axis=1)


def _g_nl(X):
    out = np.zeros((X.shape[0], 3, 1), dtype=X.dtype)
    out[:, 2, 0] = 1.0 / (1.0 + 0.2 * np.sin(X[:, 0]) ** 2)
    return out


def _k_nl(X):
    out = np.zeros((X.shape[0], 3, 1), dtype=X.dtype)
    out[:, 1, 0] = 0.3
    out[:, 2, 0] = 0.2 * np.cos(X[:, 0])
    return out


def _galerkin_law(f, g):
    """W∞ SGAA law (degree-4 basis, 5³ nodes on ±0.5; ~0.1 s) from u0 = −K3 x."""
    from sobolev_drake.synthesis.galerkin import GalerkinProblem, InputAffineModel, WinfCost
    from sobolev_drake.synthesis.galerkin_basis import Box, PolynomialBasis
    cost = WinfCost(lambda X: X, lambda X: np.broadcast_to(np.eye(3), (X.shape[0], 3, 3)),
                    np.eye(3), np.diag([0.5, 0.2, 0.3]), 3.0)
    prob = GalerkinProblem(InputAffineModel(f, g, _k_nl, n=3), cost, PolynomialBasis(3, 4),
                           Box.symmetric([0.5, 0.5, 0.5]), quadrature=5)
    return prob.solve(lambda X: -X @ K3.T, tol=1e-10)


@pytest.fixture(scope="module")
def generic_law():
    return _galerkin_law(_f_nl, _g_nl)


def test_galerkin_controller_of_a_galerkin_result_converts_with_outputs_equal_to_double(
        generic_law):
    law = generic_law
    S, o = np.eye(4)[1:], np.array([0.1, 0.0, 0.0])
    sys = GalerkinController(law, plant_state_size=4, selection=[1, 2, 3], offset=o)
    assert sys.conversion_refusal is None
    x = np.array([5.0, 0.2, -0.3, 0.4])
    ctx = sys.CreateDefaultContext()
    sys.get_input_port_estimated_state().FixValue(ctx, x)
    u = sys.get_output_port_control().Eval(ctx)
    np.testing.assert_array_equal(u, law.control((S @ x + o)[None])[0])

    # AutoDiffXd: exactly the law's scalar-generic evaluation at the AutoDiffXd design state
    # (the selection multiplies by exact 0 and 1); that path equals the double one to a few
    # ulps, bound derived in tests/synthesis/test_galerkin_autodiff.py: 2(N + d + 3m + 8)ε T
    # with N = 34, d = 4, m = 2 and the term scale T = 3.5|u| at this point, 8e-14|u| < 1e-12
    ad = sys.ToAutoDiffXd()
    c = ad.CreateDefaultContext()
    x_ad = InitializeAutoDiff(x).ravel()
    ad.get_input_port(0).FixValue(c, x_ad)
    u_ad = ad.get_output_port(0).Eval(c)
    ref = law.control((S @ x_ad + o)[None])[0]
    np.testing.assert_array_equal(ExtractValue(u_ad), ExtractValue(ref))
    np.testing.assert_array_equal(ExtractGradient(u_ad), ExtractGradient(ref))
    np.testing.assert_allclose(ExtractValue(u_ad).ravel(), u, rtol=1e-12)
    assert ExtractGradient(u_ad)[0, 0] == 0.0            # ϕ is not selected

    sym = sys.ToSymbolic()
    c = sym.CreateDefaultContext()
    xv, xe = _symbols(4)
    sym.get_input_port(0).FixValue(c, xe)
    np.testing.assert_allclose(_evaluate(sym.get_output_port(0).Eval(c), xv, x), u, rtol=1e-12)


def test_drake_linearize_of_a_galerkin_controller_gives_the_feedback_gain(generic_law):
    law = generic_law
    sys = GalerkinController(law, plant_state_size=4, selection=[1, 2, 3])
    ctx = sys.CreateDefaultContext()
    sys.get_input_port(0).FixValue(ctx, np.zeros(4))
    lin = Linearize(sys, ctx)
    assert lin.A().shape == (0, 0) and lin.D().shape == (1, 4)
    # the same AutoDiffXd evaluation at the origin, chained through exact 0/1 selections
    np.testing.assert_array_equal(lin.D(), law.feedback_gain("autodiff") @ np.eye(4)[1:])
    # and the closed loop on the linear plant (A3, B3) has eig(A3 + B3 K) in the left half plane
    diagram, _, _ = _loop(GalerkinController(law))
    dl = _linearize(diagram, diagram.CreateDefaultContext())
    _assert_same_spectrum(dl.A(), np.linalg.eigvals(A3 + B3 @ law.feedback_gain()))
    assert np.linalg.eigvals(dl.A()).real.max() < 0
