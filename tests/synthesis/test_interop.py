"""Linear systems in (Drake, python-control, scipy), controllers out, python-control's hinfsyn."""

import numpy as np
import pytest
from pydrake.examples import AcrobotPlant
from pydrake.systems.primitives import LinearSystem, Linearize

import sobolev_drake as sd
from sobolev_drake.synthesis.certificates import hinf_norm
from sobolev_drake.synthesis.random_plants import plant_family

control = pytest.importorskip("control")

# the certificate's own relative tolerance (rtol of the synthesis) bounds every comparison of a
# closed-loop norm with a certified gamma below
RTOL = 1e-4


def as_control(p, D22=None):
    D22 = np.zeros((p.ny, p.nu)) if D22 is None else D22
    return control.ss(p.A, np.hstack([p.B1, p.B2]), np.vstack([p.C1, p.C2]),
                      np.block([[p.D11, p.D12], [p.D21, D22]]))


@pytest.mark.parametrize("case", plant_family(4, (3, 6), seed=5, families=("stable", "unstable")),
                         ids=str)
def test_hinfsyn_matches_python_control_signature_and_certifies(case):
    p = case.plant
    P = as_control(p)
    out = sd.hinfsyn(P, p.ny, p.nu)
    K, CL, gamma, rcond = out                       # the same four values as control.hinfsyn
    K_pc, CL_pc, gamma_pc, rcond_pc = control.hinfsyn(P, p.ny, p.nu)
    assert isinstance(K, control.StateSpace) and isinstance(CL, control.StateSpace)
    assert (K.ninputs, K.noutputs) == (K_pc.ninputs, K_pc.noutputs) == (p.ny, p.nu)
    assert (CL.ninputs, CL.noutputs) == (CL_pc.ninputs, CL_pc.noutputs) == (p.nw, p.nz)
    assert isinstance(gamma, float) and np.shape(rcond) == np.shape(rcond_pc) == (4,)
    assert out.result.certificate.ok and out.gamma == gamma
    # python-control's own loop closure (positive feedback lft) of our controller
    closed = P.lft(K)
    norm = hinf_norm(closed.A, closed.B, closed.C, closed.D)[0]
    assert np.linalg.eigvals(closed.A).real.max() < 0 and norm <= gamma * (1 + RTOL)
    assert hinf_norm(CL.A, CL.B, CL.C, CL.D)[0] == pytest.approx(norm, rel=RTOL)
    # where python-control's controller is stabilizing and honest, ours is no worse
    theirs_cl = P.lft(K_pc)
    if np.linalg.eigvals(theirs_cl.A).real.max() < 0:
        theirs = hinf_norm(theirs_cl.A, theirs_cl.B, theirs_cl.C, theirs_cl.D)[0]
        if theirs <= gamma_pc * (1 + 1e-6):
            assert gamma <= theirs * (1 + RTOL)


def test_hinfsyn_with_measurement_feedthrough_d22():
    case = plant_family(1, (4, 4), seed=3, families=("stable",))[0]
    p = case.plant
    D22 = np.full((p.ny, p.nu), 0.3)
    P = as_control(p, D22)
    K, _, gamma, _ = sd.hinfsyn(P, p.ny, p.nu)
    closed = P.lft(K)                     # the real loop, with D22 in it
    assert np.linalg.eigvals(closed.A).real.max() < 0
    assert hinf_norm(closed.A, closed.B, closed.C, closed.D)[0] <= gamma * (1 + RTOL)


def acrobot_upright():
    acrobot = AcrobotPlant()
    context = acrobot.CreateDefaultContext()
    context.SetContinuousState([np.pi, 0.0, 0.0, 0.0])
    acrobot.get_input_port(0).FixValue(context, [0.0])
    return Linearize(acrobot, context)


def test_drake_and_python_control_systems_are_accepted_like_matrices():
    lin = acrobot_upright()
    A, B = lin.A(), lin.B()
    G0, G1 = np.eye(4), 0.1 * np.eye(4)
    ref = sd.winf_state_feedback(A, B, B, G0, G1)
    for system in (lin, control.ss(A, B, np.eye(4), 0)):
        res = sd.winf_state_feedback(system, Gamma0=G0, Gamma1=G1)      # D defaults to B
        np.testing.assert_array_equal(res.K, ref.K)
    C = np.eye(4)[:2]
    measured = LinearSystem(A, B, C, np.zeros((2, 1)))
    res = sd.winf_output_feedback(measured, Gamma0=G0, Gamma1=G1)
    assert res.certificate.ok and res.controller.BK.shape[1] == 2
    with pytest.raises(TypeError, match="B comes from the linear system"):
        sd.winf_state_feedback(lin, B, B, G0, G1)
    with pytest.raises(TypeError, match="Gamma1 is required"):
        sd.winf_state_feedback(lin, Gamma0=G0)
    with pytest.raises(ValueError, match="continuous-time"):
        sd.winf_state_feedback(control.ss(A, B, np.eye(4), 0, 0.01), Gamma0=G0, Gamma1=G1)
    with pytest.raises(TypeError, match="linear system"):
        sd.winf_state_feedback("A", Gamma0=G0, Gamma1=G1)


def test_generalized_plant_partition_and_bad_counts():
    case = plant_family(1, (3, 3), seed=1, families=("stable",))[0]
    p = case.plant
    P = as_control(p)
    q, D22 = sd.generalized_plant(P, p.ny, p.nu)
    for a, b in zip(q.as_tuple(), p.as_tuple()):
        np.testing.assert_array_equal(a, b)
    assert not np.any(D22)
    res = sd.hinf_output_feedback(P, nmeas=p.ny, ncon=p.nu)
    assert res.certificate.ok
    with pytest.raises(ValueError, match="nmeas must be between 1 and"):
        sd.hinfsyn(P, P.noutputs, p.nu)
    with pytest.raises(TypeError, match="ncon must be an integer"):
        sd.hinfsyn(P, p.ny, 1.5)
    with pytest.raises(TypeError, match="nmeas .* is required"):
        sd.hinf_output_feedback(P, ncon=p.nu)


def test_controllers_convert_to_python_control_and_to_drake_around_an_operating_point():
    lin = acrobot_upright()
    res = sd.winf_state_feedback(lin, Gamma0=np.eye(4), Gamma1=0.1 * np.eye(4))
    ss = sd.to_statespace(res)
    assert ss.nstates == 0 and np.array_equal(ss.D, res.K)
    x_op, u_op = np.array([np.pi, 0.0, 0.0, 0.0]), np.array([0.5])
    system = sd.controller_system(res, x_op=x_op, u_op=u_op)
    context = system.CreateDefaultContext()
    dx = np.array([0.01, -0.02, 0.03, 0.0])
    system.get_input_port(0).FixValue(context, x_op + dx)
    # u = u_op + K (x − x_op): the sign convention u = +K x in deviation coordinates
    np.testing.assert_allclose(system.get_output_port(0).Eval(context), u_op + res.K @ dx,
                               rtol=1e-14, atol=1e-14)
    C = np.eye(4)[:2]
    of = sd.winf_output_feedback(lin.A(), lin.B(), C, lin.B(), np.eye(4), 0.1 * np.eye(4))
    ss = sd.to_statespace(of)
    np.testing.assert_array_equal(ss.A, of.controller.AK)
    system = sd.controller_system(of, x_op=x_op, u_op=u_op, S=C)   # full state in, angles used
    np.testing.assert_array_equal(system.y_op, C @ x_op)
    with pytest.raises(ValueError, match="give y_op, or S"):
        sd.controller_system(of, x_op=x_op)
    with pytest.raises(TypeError, match="y_op is for output feedback"):
        sd.controller_system(res, y_op=[0.0])
