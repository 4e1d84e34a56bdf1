"""Closed loops of a Drake LinearSystem plant with the linear controller LeafSystems."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LinearSystem

from sobolev_drake.systems.linear_controllers import LinearDynamicOutputFeedback, LinearStateFeedback

A = np.array([[0.0, 1], [2, -1]])
B = np.array([[0.0], [1]])
C = np.array([[1.0, 0]])




def test_state_feedback_closed_loop_matrix():
    K = np.array([[-6.0, -3.0]])
    b = DiagramBuilder()
    plant = b.AddSystem(LinearSystem(A, B, np.eye(2), np.zeros((2, 1))))
    ctrl = b.AddSystem(LinearStateFeedback(K))
    b.Connect(plant.get_output_port(), ctrl.get_input_port(0))
    b.Connect(ctrl.get_output_port(0), plant.get_input_port())
    b.ExportOutput(plant.get_output_port())
    d = b.Build()
    ctx = d.CreateDefaultContext()
    x0 = np.array([1.0, -0.5])
    d.GetMutableSubsystemContext(plant, ctx).SetContinuousState(x0)
    sim = Simulator(d, ctx)
    sim.get_mutable_integrator().set_target_accuracy(1e-10)
    sim.AdvanceTo(1.0)
    from scipy.linalg import expm
    expected = expm((A + B @ K) * 1.0) @ x0
    assert np.allclose(d.GetSubsystemContext(plant, ctx).get_continuous_state_vector().CopyToVector(),
                       expected, atol=1e-6)


def test_state_feedback_reference_port_and_operating_point():
    K = np.array([[-2.0, -1.0]])
    sys = LinearStateFeedback(K, u_r=[0.5], reference_port=True)
    ctx = sys.CreateDefaultContext()
    sys.get_input_port(0).FixValue(ctx, [1.0, 2.0])
    sys.GetInputPort("x_r").FixValue(ctx, [0.5, 1.0])
    assert np.allclose(sys.GetOutputPort("u").Eval(ctx), 0.5 + K @ np.array([0.5, 1.0]))


@pytest.mark.parametrize("DK", [np.zeros((1, 1)), np.array([[-1.5]])])
def test_dynamic_output_feedback_closed_loop_matrix(DK):
    AK = np.array([[-5.0, 1], [-20, -6]])
    BK = np.array([[4.0], [18]])
    CK = np.array([[-8.0, -2.0]])
    b = DiagramBuilder()
    plant = b.AddSystem(LinearSystem(A, B, C, np.zeros((1, 1))))
    ctrl = b.AddSystem(LinearDynamicOutputFeedback(AK, BK, CK, DK))
    b.Connect(plant.get_output_port(), ctrl.GetInputPort("y"))
    b.Connect(ctrl.GetOutputPort("u"), plant.get_input_port())
    d = b.Build()
    ctx = d.CreateDefaultContext()
    x = np.array([1.0, -0.5, 0.2, 0.1])
    # the diagram state is [plant; controller]; compare derivatives with the analytic matrix
    ctx.SetContinuousState(x)
    xdot = d.EvalTimeDerivatives(ctx).CopyToVector()
    Acl = np.block([[A + B @ DK @ C, B @ CK], [BK @ C, AK]])
    assert np.allclose(xdot, Acl @ x)


def test_strictly_proper_controller_has_no_feedthrough():
    sys = LinearDynamicOutputFeedback(-np.eye(2), np.ones((2, 1)), np.ones((1, 2)))
    assert not sys.HasDirectFeedthrough(0, 0)
    sys2 = LinearDynamicOutputFeedback(-np.eye(2), np.ones((2, 1)), np.ones((1, 2)), [[1.0]])
    assert sys2.HasDirectFeedthrough(0, 0)


def test_bad_shapes():
    with pytest.raises(ValueError, match="BK must have shape"):
        LinearDynamicOutputFeedback(-np.eye(2), np.ones((3, 1)), np.ones((1, 2)))
    with pytest.raises(ValueError, match="x_r must have shape"):
        LinearStateFeedback(np.ones((1, 2)), x_r=[1.0, 2.0, 3.0])


def test_state_feedback_gains_are_a_context_parameter_and_clip():
    K = np.array([[2.0, 3.0]])
    sys = LinearStateFeedback(K, u_r=[0.5], reference_port=True, u_min=-1.0, u_max=1.0)
    ctx = sys.CreateDefaultContext()
    x, r = np.array([0.2, -0.1]), np.array([0.1, 0.0])
    sys.GetInputPort("x").FixValue(ctx, x)
    sys.GetInputPort("x_r").FixValue(ctx, r)
    raw = 0.5 + K @ (x - r)  # = 0.4: inside the bounds
    assert sys.GetOutputPort("u").Eval(ctx) == pytest.approx(raw)
    sys.set_gains(ctx, np.array([[20.0, 0.0]]))  # same context, new gains: 0.5 + 2 = 2.5
    assert sys.GetOutputPort("u_raw").Eval(ctx) == pytest.approx([2.5])
    assert sys.GetOutputPort("u").Eval(ctx) == pytest.approx([1.0])
    np.testing.assert_array_equal(sys.gains(ctx), [[20.0, 0.0]])
    # a fresh context still holds the construction gains
    np.testing.assert_array_equal(sys.gains(sys.CreateDefaultContext()), K)
    with pytest.raises(ValueError, match="K must have shape"):
        sys.set_gains(ctx, np.ones((2, 2)))
    with pytest.raises(ValueError, match="u_min"):
        LinearStateFeedback(K, u_min=1.0, u_max=0.0)
    assert LinearStateFeedback(K).num_output_ports() == 1  # no u_raw without bounds


# ----------------------------------------------------------------- per-context gains, selection
def _placeholder(nk=2, ny=1, nu=1, **kw):
    return LinearDynamicOutputFeedback(np.zeros((nk, nk)), np.zeros((nk, ny)), np.zeros((nu, nk)),
                                       np.zeros((nu, ny)), **kw)


@pytest.mark.parametrize("DK", [np.zeros((1, 1)), np.array([[-1.5]])])
def test_dynamic_gains_set_per_context_drive_the_closed_loop(DK):
    """A controller built with zero placeholder gains; the gains written into the context (not
    the constructor's) drive the closed loop: derivatives equal the analytic closed-loop matrix
    and a simulation matches expm(Acl t). The plant outputs its full state; S = C selects y."""
    from scipy.linalg import expm
    from pydrake.systems.analysis import Simulator
    AK = np.array([[-5.0, 1], [-20, -6]])
    BK = np.array([[4.0], [18]])
    CK = np.array([[-8.0, -2.0]])
    b = DiagramBuilder()
    plant = b.AddSystem(LinearSystem(A, B, np.eye(2), np.zeros((2, 1))))
    ctrl = b.AddSystem(_placeholder(S=C, feedthrough=True))
    b.Connect(plant.get_output_port(), ctrl.GetInputPort("y"))
    b.Connect(ctrl.GetOutputPort("u"), plant.get_input_port())
    d = b.Build()
    ctx = d.CreateDefaultContext()
    cctx = ctrl.GetMyMutableContextFromRoot(ctx)
    x = np.array([1.0, -0.5, 0.2, 0.1])
    ctx.SetContinuousState(x)
    Azero = np.block([[A, np.zeros((2, 2))], [np.zeros((2, 4))]])
    np.testing.assert_allclose(d.EvalTimeDerivatives(ctx).CopyToVector(), Azero @ x)  # placeholder
    ctrl.set_gains(cctx, (AK, BK, CK, DK))
    Acl = np.block([[A + B @ DK @ C, B @ CK], [BK @ C, AK]])
    np.testing.assert_allclose(d.EvalTimeDerivatives(ctx).CopyToVector(), Acl @ x)
    for got, want in zip(ctrl.gains(cctx), (AK, BK, CK, DK)):
        np.testing.assert_array_equal(got, want)
    sim = Simulator(d, ctx)
    sim.get_mutable_integrator().set_target_accuracy(1e-10)
    sim.AdvanceTo(0.5)
    np.testing.assert_allclose(ctx.get_continuous_state_vector().CopyToVector(), expm(Acl * 0.5) @ x,
                               atol=1e-6)
    # a fresh context still holds the constructor's (zero) gains
    assert all(np.all(m == 0) for m in ctrl.gains(ctrl.CreateDefaultContext()))


def test_dynamic_gains_two_contexts_are_independent():
    AK, BK, CK, DK = -np.eye(2), np.array([[1.0], [2.0]]), np.array([[0.5, -1.0]]), np.array([[3.0]])
    sys = LinearDynamicOutputFeedback(AK, BK, CK, DK, y_op=[0.25], u_op=[1.0])
    c1, c2 = sys.CreateDefaultContext(), sys.CreateDefaultContext()
    xk, y = np.array([0.3, -0.7]), np.array([2.0])
    for c in (c1, c2):
        c.SetContinuousState(xk)
        sys.GetInputPort("y").FixValue(c, y)
    sys.set_gains(c2, (2 * AK, -BK, 3 * CK, None))  # DK None -> 0
    dy = y - 0.25
    assert sys.GetOutputPort("u").Eval(c1) == pytest.approx(1.0 + CK @ xk + DK @ dy)
    assert sys.GetOutputPort("u").Eval(c2) == pytest.approx(1.0 + 3 * CK @ xk)
    np.testing.assert_allclose(sys.EvalTimeDerivatives(c1).CopyToVector(), AK @ xk + BK @ dy)
    np.testing.assert_allclose(sys.EvalTimeDerivatives(c2).CopyToVector(), 2 * AK @ xk - BK @ dy)


def test_dynamic_feedthrough_flag_and_clipping():
    # inferred: DK = 0 at construction -> no feedthrough, and then DK != 0 is refused
    sys = _placeholder()
    assert not sys.HasDirectFeedthrough(0, 0)
    ctx = sys.CreateDefaultContext()
    with pytest.raises(ValueError, match="feedthrough"):
        sys.set_gains(ctx, (-np.eye(2), np.ones((2, 1)), np.ones((1, 2)), [[1.0]]))
    with pytest.raises(ValueError, match="feedthrough"):
        LinearDynamicOutputFeedback(-np.eye(2), np.ones((2, 1)), np.ones((1, 2)), [[1.0]], feedthrough=False)
    # explicit feedthrough with zero placeholder gains; output clipped, u_raw unclipped
    sys = _placeholder(feedthrough=True, u_min=-1.0, u_max=2.0)
    assert sys.HasDirectFeedthrough(0, 0)
    ctx = sys.CreateDefaultContext()
    sys.GetInputPort("y").FixValue(ctx, [4.0])
    sys.set_gains(ctx, (-np.eye(2), np.ones((2, 1)), np.zeros((1, 2)), [[1.0]]))
    assert sys.GetOutputPort("u_raw").Eval(ctx) == pytest.approx([4.0])
    assert sys.GetOutputPort("u").Eval(ctx) == pytest.approx([2.0])
    assert _placeholder().num_output_ports() == 1  # no u_raw without bounds


def test_dynamic_gains_bad_shapes():
    sys = _placeholder(feedthrough=True)
    ctx = sys.CreateDefaultContext()
    with pytest.raises(ValueError, match=r"AK must have shape \(2, 2\)"):
        sys.set_gains(ctx, (-np.eye(3), np.ones((2, 1)), np.ones((1, 2)), [[0.0]]))
    with pytest.raises(ValueError, match=r"BK must have shape \(2, 1\)"):
        sys.set_gains(ctx, (-np.eye(2), np.ones((2, 2)), np.ones((1, 2)), [[0.0]]))
    with pytest.raises(ValueError, match=r"CK must have shape \(1, 2\)"):
        sys.set_gains(ctx, (-np.eye(2), np.ones((2, 1)), np.ones((2, 2)), [[0.0]]))
    with pytest.raises(ValueError, match=r"DK must have shape \(1, 1\)"):
        sys.set_gains(ctx, (-np.eye(2), np.ones((2, 1)), np.ones((1, 2)), np.ones((1, 2))))
    with pytest.raises(ValueError, match="non-finite"):
        sys.set_gains(ctx, (np.full((2, 2), np.nan), np.ones((2, 1)), np.ones((1, 2)), [[0.0]]))
    with pytest.raises(ValueError, match="AK, BK, CK, DK"):
        sys.set_gains(ctx, (-np.eye(2), np.ones((2, 1))))
    with pytest.raises(ValueError, match=r"S must have shape \(1, any\)"):
        _placeholder(S=np.eye(2))
    with pytest.raises(ValueError, match="u_min must be a scalar or a vector of 1 entries"):
        _placeholder(u_min=[0.0, 1.0])
    # the failed writes left the context untouched
    assert all(np.all(m == 0) for m in sys.gains(ctx))


def test_state_feedback_selection_matrix_reference_and_clip():
    S = np.array([[0, 1.0, 0], [0, 0, 1.0]])
    K = np.array([[2.0, 3.0]])
    sys = LinearStateFeedback(K, u_r=[0.5], S=S, reference_port=True, u_min=-1.0, u_max=1.0)
    ctx = sys.CreateDefaultContext()
    x, r = np.array([9.0, 0.2, -0.1]), np.array([0.1, 0.0])
    assert sys.GetInputPort("x").size() == 3 and sys.GetInputPort("x_r").size() == 2
    sys.GetInputPort("x").FixValue(ctx, x)
    sys.GetInputPort("x_r").FixValue(ctx, r)
    raw = 0.5 + K @ (S @ x - r)
    assert sys.GetOutputPort("u_raw").Eval(ctx) == pytest.approx(raw)
    assert sys.GetOutputPort("u").Eval(ctx) == pytest.approx(np.clip(raw, -1, 1))
    with pytest.raises(ValueError, match=r"S must have shape \(2, any\)"):
        LinearStateFeedback(K, S=np.eye(3))
