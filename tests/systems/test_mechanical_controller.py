"""MechanicalLaw / MechanicalController: exact-model closed loops, integral action, W∞ and H∞
dissipation bounds on simulated runs, reduced and regulated partitions, bad input."""

import numpy as np
import pytest
from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.primitives import VectorLogSink
from scipy.integrate import solve_ivp

from sobolev_drake.models.arm import add_arm, make_arm_model
from sobolev_drake.models.quadrotor import make_quadrotor_model
from sobolev_drake.synthesis.mechanical import (controlled_gains, hinf_mechanical_gains,
                                                regulated_gains, stabilized_gains, winf_gamma)
from sobolev_drake.systems.mechanical_controller import (HinfLaw, MechanicalController,
                                                         MechanicalLaw, Partition, SobolevLaw)

W_ARM = ([100, 200], [500, 400], [40, 40], [0.0720, 0.0126])  # thesis manipulator tuning
OMEGA = 2 * np.pi / 10


def ref_arm(t):
    """Table 5.2: q1r = π/2, q2r = (π/2) sin(2πt/10), with derivatives."""
    s, c = np.sin(OMEGA * t), np.cos(OMEGA * t)
    return (np.array([np.pi / 2, np.pi / 2 * s]), np.array([0.0, np.pi / 2 * OMEGA * c]),
            np.array([0.0, -np.pi / 2 * OMEGA ** 2 * s]))


class FnSource(LeafSystem):
    """Time-only vector source from a python function (test helper)."""

    def __init__(self, size, fn, name):
        super().__init__()
        self.fn = fn
        self.DeclareVectorOutputPort(name, size, self._calc, prerequisites_of_calc={self.time_ticket()})

    def _calc(self, context, out):
        out.SetFromVector(self.fn(context.get_time()))


def ref_const(t):
    return np.array([np.pi / 2, 0.5]), np.zeros(2), np.zeros(2)


def run_arm(inner, partition, w_fn, duration, q0, *, accuracy=1e-4, integrator="runge_kutta3",
            ref_fn=ref_arm):
    b = DiagramBuilder()
    h = add_arm(b)
    m = len(ref_fn(0.0)[0])
    ref = b.AddSystem(FnSource(3 * m, lambda t: np.concatenate(ref_fn(t)), "reference"))
    dist = b.AddSystem(FnSource(2, w_fn, "w"))
    ctrl = b.AddSystem(MechanicalController(make_arm_model(), partition, inner))
    b.Connect(h.x, ctrl.GetInputPort("x"))
    b.Connect(ref.get_output_port(), ctrl.GetInputPort("reference"))
    b.Connect(ctrl.GetOutputPort("u"), h.u)
    b.Connect(dist.get_output_port(), h.disturbance)
    logs = {}
    for name, port, size in (("x", h.x, 4), ("u", ctrl.GetOutputPort("u"), 2),
                             ("ei", ctrl.GetOutputPort("error_integral"), ctrl.law.nc)):
        sink = b.AddSystem(VectorLogSink(size))
        b.Connect(port, sink.get_input_port())
        logs[name] = sink
    d = b.Build()
    sim = Simulator(d)
    ctx = sim.get_mutable_context()
    h.set_state(ctx, d, q0, [0.0, 0.0])
    ResetIntegratorFromFlags(sim, integrator, 0.05)
    sim.get_mutable_integrator().set_target_accuracy(accuracy)
    sim.AdvanceTo(duration)
    t = logs["x"].FindLog(ctx).sample_times()
    out = {k: v.FindLog(ctx).data() for k, v in logs.items()}
    out["t"] = t
    out["w"] = np.array([w_fn(ti) for ti in t]).T
    out["ref_fn"] = ref_fn
    return out


def chain_errors(run):
    t = run["t"]
    refs = [run["ref_fn"](ti) for ti in t]
    qr = np.array([r[0] for r in refs]).T
    qdr = np.array([r[1] for r in refs]).T
    qddr = np.array([r[2] for r in refs]).T
    return run["x"][:2] - qr, run["x"][2:] - qdr, qddr


def test_exact_model_error_follows_linear_closed_loop():
    """(5.27): with an exact model and w = 0 the error obeys ẋ = A_cl x (and (7.81) for a
    regulated DOF)."""
    g = controlled_gains(*W_ARM)
    q0 = np.array([np.pi / 4, 0.2])
    run = run_arm(SobolevLaw(g), Partition(controlled=[0, 1]), lambda t: np.zeros(2), 3.0, q0,
                  accuracy=1e-8, integrator="runge_kutta5")
    e, ed, _ = chain_errors(run)
    x0 = np.concatenate([ed[:, 0], e[:, 0], [0, 0]])
    sol = solve_ivp(lambda _, x: g.closed_loop @ x, (0, 3.0), x0, t_eval=run["t"], rtol=1e-11,
                    atol=1e-12, method="DOP853")
    assert np.max(np.abs(sol.y[2:4] - e)) < 1e-6
    assert np.max(np.abs(sol.y[4:6] - run["ei"])) < 1e-6
    # controlled q1 with integral action + regulated q2 (W^{2,2}), B = I square → exact too
    gc = controlled_gains([100], [500], [40], [0.072])
    gr = regulated_gains([30.0], [5.0], [0.02])
    law = SobolevLaw(controlled=gc, regulated=gr)
    run = run_arm(law, Partition(controlled=[0], regulated=[1]), lambda t: np.zeros(2), 2.0, q0,
                  accuracy=1e-8, integrator="runge_kutta5")
    e, ed, _ = chain_errors(run)
    sol = solve_ivp(lambda _, x: gr.closed_loop @ x, (0, 2.0), [ed[1, 0], e[1, 0]],
                    t_eval=run["t"], rtol=1e-11, atol=1e-12, method="DOP853")
    assert np.max(np.abs(sol.y[1] - e[1])) < 1e-6


def test_integral_action_rejects_constant_disturbance():
    """Constant w, constant reference: the acceleration-channel disturbance M⁻¹w is constant at
    the equilibrium, so ∫e absorbs it and e → 0 (with a moving reference M(q)⁻¹w varies and a
    small residual error remains — not a failure of the integral action)."""
    g = controlled_gains(*W_ARM)
    w = np.array([15.0, -8.0])
    run = run_arm(SobolevLaw(g), Partition(controlled=[0, 1]), lambda t: w, 30.0,
                  np.array([np.pi / 4, 0.0]), ref_fn=ref_const)
    e, ed, _ = chain_errors(run)
    assert np.max(np.abs(e[:, -1])) < 1e-4
    assert np.max(np.abs(ed[:, -1])) < 1e-3
    assert np.max(np.abs(e[:, len(e[0]) // 3])) > 1e-3  # the disturbance did act


def _pulse(t):
    return np.array([30 * np.exp(-(t - 2.0) ** 2 / 0.1),
                     -20 * np.sin(2 * np.pi * t) * np.exp(-(t - 4.0) ** 2 / 0.5)])


def test_winf_dissipation_bound_on_simulation():
    """Theorem 3: ‖z‖²_W ≤ γ²‖w‖²_L2 + 2V(x0); with an exact model the storage identity
    V(T) − V(0) + ½‖z‖²_W = ½∫wᵀΠw (Π = M⁻¹Y3M⁻¹) holds, hence the bound."""
    g = controlled_gains(*W_ARM)
    model = make_arm_model()
    run = run_arm(SobolevLaw(g), Partition(controlled=[0, 1]), _pulse, 10.0,
                  np.array([np.pi / 2 + 0.3, 0.1]), accuracy=1e-7, integrator="runge_kutta5")
    e, ed, qddr = chain_errors(run)
    t, X, U, W = run["t"], run["x"], run["u"], run["w"]
    Y0, Y1, Y2, Y3 = (np.diag(w) for w in W_ARM)
    cost, wpw, gam2, V = [], [], [], []
    for k in range(len(t)):
        q, qd = X[:2, k], X[2:, k]
        M = model.M(q)
        qdd = np.linalg.solve(M, U[:, k] + W[:, k] - model.Cqdot(q, qd) - model.g(q))
        edd = qdd - qddr[:, k]
        xc = np.concatenate([ed[:, k], e[:, k], run["ei"][:, k]])
        cost.append(xc[4:] @ Y0 @ xc[4:] + xc[2:4] @ Y1 @ xc[2:4] + xc[:2] @ Y2 @ xc[:2]
                    + edd @ Y3 @ edd)
        Mi = np.linalg.inv(M)
        wpw.append(W[:, k] @ Mi @ Y3 @ Mi @ W[:, k])
        gam2.append(winf_gamma(M, Y3) ** 2)
        V.append(g.value(xc))
    z2 = np.trapezoid(cost, t)
    w2 = np.trapezoid(np.sum(W ** 2, axis=0), t)
    identity_rhs = np.trapezoid(wpw, t)
    lhs = 2 * (V[-1] - V[0]) + z2
    assert lhs == pytest.approx(identity_rhs, rel=2e-3, abs=1e-3)
    gamma2 = max(gam2)
    assert z2 <= gamma2 * w2 + 2 * V[0]
    assert identity_rhs > 0.05 * gamma2 * w2  # the disturbance term is not negligible


def test_hinf_dissipation_bound_on_simulation():
    """Classic H∞ (docs/design.md §4.3): V(T) − V(0) + ½∫(x̃ᵀQx̃ + uᵀRu) ≤ ½γ²∫|T11 w|² and V decays
    without disturbance."""
    hg = hinf_mechanical_gains(1.0, 4.0, 4.0, 0.3, 0.6)
    model = make_arm_model()
    for w_fn, T in ((_pulse, 8.0), (lambda t: np.zeros(2), 4.0)):
        run = run_arm(HinfLaw(hg), Partition(controlled=[0, 1]), w_fn, T,
                      np.array([np.pi / 2 + 0.3, 0.1]), accuracy=1e-7, integrator="runge_kutta5")
        e, ed, _ = chain_errors(run)
        t, X, W, ei = run["t"], run["x"], run["w"], run["ei"]
        V, stage = [], []
        for k in range(len(t)):
            sig = hg.sigma(ed[:, k], e[:, k], ei[:, k])
            V.append(hg.storage(model.M(X[:2, k]), sig, e[:, k], ei[:, k]))
            stage.append(2 * hg.stage_cost(ed[:, k], e[:, k], ei[:, k], -hg.R_inv * sig))
        lhs = V[-1] - V[0] + 0.5 * np.trapezoid(stage, t)
        rhs = 0.5 * hg.gamma ** 2 * np.trapezoid(np.sum((hg.T11 * W) ** 2, axis=0), t)
        assert lhs <= rhs + 1e-4 * max(V[0], 1.0)
        if T == 4.0:
            assert np.all(np.diff(V) <= 1e-6 * V[0])
            assert lhs <= 1e-4 * V[0]


def test_reduced_model_law_produces_desired_acceleration():
    """(5.5)/(5.26): τ = B̄⁻¹(M̄ q̈c_des + h̄) applied to the full model gives q̈c = q̈c_des
    (and the same for the H∞ law's σ dynamics), quadrotor qc = [z φ θ ψ], qu = [x y]."""
    model = make_quadrotor_model()
    part = Partition(controlled=[5, 0, 1, 2], uncontrolled=[3, 4])
    g = controlled_gains([1, 1, 1, 1], [1, 1, 1, 1], [0.61, 0.6, 0.6, 0.6], [2e-3, 1e-3, 1e-3, 1e-3])
    law = MechanicalLaw(model, part, SobolevLaw(g))
    rng = np.random.default_rng(0)
    for _ in range(3):
        q = rng.normal(scale=0.3, size=6)
        qd = rng.normal(scale=0.5, size=6)
        ei = rng.normal(scale=0.1, size=4)
        ref = rng.normal(scale=0.3, size=12)
        tau = law.actuation(q, qd, ei, ref)
        qdd = np.linalg.solve(model.M(q), model.B(q) @ tau - model.Cqdot(q, qd) - model.g(q))
        acc = law.desired_acceleration(q, qd, ei, ref)
        assert np.allclose(qdd[[5, 0, 1, 2]], acc[[5, 0, 1, 2]], rtol=1e-8, atol=1e-8)
        assert np.all(np.isnan(acc[[3, 4]]))
    # input coupling with the tilted quadrotor: u* = M q̈_des + h exactly (5.84)
    part = Partition(controlled=[3, 4, 5, 2], stabilized=[0, 1])
    law = MechanicalLaw(model, part, SobolevLaw(controlled_gains(*[np.ones(4)] * 4),
                                                stabilized=stabilized_gains([2, 2], [0.01, 0.01])))
    u = law.generalized_input(q, qd, ei, ref)
    acc = law.desired_acceleration(q, qd, ei, ref)
    assert np.allclose(u, model.M(q) @ acc + model.Cqdot(q, qd) + model.g(q))
    assert np.allclose(acc[[0, 1]], -np.sqrt(2 / 0.01) * qd[[0, 1]])  # −Υ1⁻¹U q̇s, U = √(υ0υ1)
    tau = law.actuation(q, qd, ei, ref)
    assert np.allclose(tau, np.linalg.pinv(model.B(q)) @ u)  # (5.118)


def test_bad_input_raises_clear_errors():
    model = make_arm_model()
    g = controlled_gains(*W_ARM)
    with pytest.raises(ValueError, match="exactly one group"):
        MechanicalLaw(model, Partition(controlled=[0]), SobolevLaw(controlled_gains(1, 1, 1, 1)))
    with pytest.raises(ValueError, match="controlled gains are for 2 DOF"):
        MechanicalLaw(model, Partition(controlled=[0], regulated=[1]),
                      SobolevLaw(g, regulated=regulated_gains(1, 1, 1)))
    with pytest.raises(ValueError, match="no regulated gains"):
        MechanicalLaw(model, Partition(controlled=[0], regulated=[1]),
                      SobolevLaw(controlled_gains(1, 1, 1, 1)))
    with pytest.raises(ValueError, match="SobolevLaw.regulated must be regulated"):
        SobolevLaw(g, regulated=stabilized_gains(1, 1))
    with pytest.raises(ValueError, match="controlled must name"):
        Partition(controlled=[])
    law = MechanicalLaw(model, Partition(controlled=[0, 1]), SobolevLaw(g))
    with pytest.raises(ValueError, match="reference must be a vector of length 6"):
        law.actuation([0, 0], [0, 0], [0, 0], np.zeros(5))
    with pytest.raises(ValueError, match="e_int must be a vector of length 2"):
        law.actuation([0, 0], [0, 0], [0], np.zeros(6))
    with pytest.raises(ValueError, match="lower must be a vector of length 2"):
        MechanicalLaw(model, Partition(controlled=[0, 1]), SobolevLaw(g), lower=[0])
    with pytest.raises(TypeError, match="SobolevLaw or an HinfLaw"):
        MechanicalLaw(model, Partition(controlled=[0, 1]), g)
    quad = make_quadrotor_model()
    with pytest.raises(ValueError, match="square and invertible"):
        MechanicalLaw(quad, Partition(controlled=list(range(6))),
                      SobolevLaw(controlled_gains(*[np.ones(6)] * 4)))


def test_input_coupling_theorem6_bound_with_exact_allocation():
    """Theorem 6 / (5.115): with qc = q1 (W^{3,2}), qs = q2 (W^{1,2}) and B = I (u* realized
    exactly) the storage identity V(T) − V(0) + ½(‖zc‖² + ‖zs‖²) = ½∫wᵀΠw, Π = M⁻¹EM⁻¹,
    E = blkdiag(Υ1, Γ3) in DOF order, holds, hence ‖zc‖² + ‖zs‖² ≤ γ²‖w‖² + 2V(x0)."""
    gc = controlled_gains([100], [500], [40], [0.072])
    gs = stabilized_gains([3.0], [0.05])
    model = make_arm_model()
    run = run_arm(SobolevLaw(gc, stabilized=gs), Partition(controlled=[0], stabilized=[1]), _pulse,
                  8.0, np.array([np.pi / 2 + 0.3, 0.1]), accuracy=1e-7, integrator="runge_kutta5",
                  ref_fn=lambda t: tuple(v[:1] for v in ref_arm(t)))
    t, X, U, W, ei = run["t"], run["x"], run["u"], run["w"], run["ei"]
    E = np.diag([0.072, 0.05])  # DOF order [q1 (controlled), q2 (stabilized)]
    cost, wpw, gam2, V = [], [], [], []
    for k in range(len(t)):
        q, qd = X[:2, k], X[2:, k]
        qr, qdr, qddr = ref_arm(t[k])
        M = model.M(q)
        qdd = np.linalg.solve(M, U[:, k] + W[:, k] - model.Cqdot(q, qd) - model.g(q))
        xc = np.array([qd[0] - qdr[0], q[0] - qr[0], ei[0, k]])
        acc = np.array([qdd[0] - qddr[0], qdd[1]])
        cost.append(100 * xc[2] ** 2 + 500 * xc[1] ** 2 + 40 * xc[0] ** 2 + 3.0 * qd[1] ** 2
                    + acc @ E @ acc)
        Mi = np.linalg.inv(M)
        wpw.append(W[:, k] @ Mi @ E @ Mi @ W[:, k])
        gam2.append(winf_gamma(M, E) ** 2)
        V.append(gc.value(xc) + gs.value([qd[1]]))
    z2 = np.trapezoid(cost, t)
    lhs = 2 * (V[-1] - V[0]) + z2
    assert lhs == pytest.approx(np.trapezoid(wpw, t), rel=2e-3, abs=1e-3)
    assert z2 <= max(gam2) * np.trapezoid(np.sum(W ** 2, axis=0), t) + 2 * V[0]
