"""The float per-sample path of the mechanical law (systems.mechanical_sample.FloatSample)
equals the generic law it specializes, for each partition, allocation and dynamics path it
covers, and hands non-finite samples back to the generic law's named errors."""

import sys

import numpy as np
import pytest
from pydrake.all import FindResourceOrThrow, MultibodyPlant, Parser

from sobolev_drake import native
from sobolev_drake.models.arm import make_arm_model
from sobolev_drake.models.base import MechanicalModel
from sobolev_drake.models.serial_chain import seven_link_arm
from sobolev_drake.synthesis.mechanical import (controlled_gains, hinf_mechanical_gains,
                                                regulated_gains, stabilized_gains)
from sobolev_drake.systems.mechanical_controller import (HinfLaw, MechanicalController,
                                                         MechanicalLaw, Partition, SobolevLaw)
from sobolev_drake.systems.mechanical_sample import FloatSample, compiled_desired_acceleration

W_ARM = ([100, 200], [500, 400], [40, 40], [0.0720, 0.0126])
# The fast path computes u* by one Newton–Euler pass instead of M q̈ + h and the desired
# acceleration with the gain columns rearranged: the same sums of a few dozen products in
# another order, so the two differ by a few dozen ulps of the largest term.  That term is
# bounded by |M||q̈| + |h| ≲ 10 |u*| at these states (|q̈| from gains ≤ 500 on errors ≤ 1),
# so 1e-12 · (1 + |u*|) separates an error in a formula (≥ 1e-6 relative) from rounding.
REL = 1e-12


def damped_seven():
    plant = seven_link_arm()
    context = plant.CreateDefaultContext()
    for k, index in enumerate(plant.GetJointIndices()):
        joint = plant.get_joint(index)
        if joint.num_velocities():
            joint.SetDampingVector(context, [0.2 + 0.1 * k])
    model = MechanicalModel.from_plant(plant, context=context)
    assert not model.frictionless
    return model


def acrobot_model():
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModels(FindResourceOrThrow("drake/examples/acrobot/Acrobot.urdf"))
    plant.Finalize()
    return MechanicalModel.from_plant(plant)          # joint damping: friction D q̇


def seven():
    return MechanicalModel.from_plant(seven_link_arm())


def laws():
    arm = make_arm_model()
    gc1 = controlled_gains([100], [500], [40], [0.072])
    g7 = controlled_gains(*[[100.0] * 7, [50.0] * 7, [1.0] * 7, [0.01] * 7])
    return {
        "arm fully actuated": MechanicalLaw(arm, Partition(controlled=[0, 1]),
                                           SobolevLaw(controlled_gains(*W_ARM))),
        "arm reversed order": MechanicalLaw(arm, Partition(controlled=[1, 0]),
                                            SobolevLaw(controlled_gains(*W_ARM))),
        "arm regulated": MechanicalLaw(arm, Partition(controlled=[1], regulated=[0]),
                                       SobolevLaw(gc1, regulated=regulated_gains(30, 5, .02))),
        "arm stabilized": MechanicalLaw(arm, Partition(controlled=[0], stabilized=[1]),
                                        SobolevLaw(gc1, stabilized=stabilized_gains(3, .05))),
        "arm bounds": MechanicalLaw(arm, Partition(controlled=[0, 1]),
                                    SobolevLaw(controlled_gains(*W_ARM)),
                                    lower=[-50.0, -50.0], upper=[50.0, 50.0]),
        "seven-link": MechanicalLaw(seven(), Partition(controlled=range(7)), SobolevLaw(g7)),
        "seven-link damped, regulated, stabilized": MechanicalLaw(
            damped_seven(), Partition(controlled=[6, 0, 2], regulated=[1, 3], stabilized=[4, 5]),
            SobolevLaw(controlled_gains(*[[100.0] * 3, [50.0] * 3, [1.0] * 3, [0.01] * 3]),
                       regulated=regulated_gains([30.0] * 2, [5.0] * 2, [0.02] * 2),
                       stabilized=stabilized_gains([3.0] * 2, [0.05] * 2))),
    }


def generic(law, x, desired, qddot_r, e_int):
    n = law.n
    ref = np.concatenate([desired, np.zeros(law.n_ref) if qddot_r is None else qddot_r])
    u_star = law.generalized_input(x[:n], x[n:], e_int, ref)
    return u_star, law.allocate(u_star, x[:n], x[n:]), law.integral_derivative(x[:n], ref)


@pytest.mark.parametrize("path", ["compiled law", "compiled RNEA", "Drake RNEA"])
@pytest.mark.parametrize("name", list(laws()))
def test_float_sample_equals_generic_law(name, path):
    rng = np.random.default_rng(7)
    kernel = path != "Drake RNEA"
    with (native.disabled() if not kernel else _nothing()):
        law = laws()[name]
        fast = FloatSample.of(law)
        assert fast is not None
        assert (fast._compiled is not None) == (fast._rnea is not None)
        if path == "compiled RNEA":              # the numpy form around the kernel's pass
            fast._compiled = None
        # the seven-link arm is in the compiled kernel's scope; the two-link arm is not
        assert (fast._rnea is not None) == (kernel and name.startswith("seven")
                                            and native.kernel("rnea") is not None)
        for _ in range(20):
            x = rng.normal(scale=0.7, size=2 * law.n)
            desired = x[np.r_[list(law.partition.tracked), [law.n + i for i in law.partition.tracked]]] \
                + rng.normal(scale=0.3, size=2 * law.n_ref)
            qddot_r = None if rng.random() < 0.3 else rng.normal(size=law.n_ref)
            e_int = rng.normal(scale=0.1, size=law.nc)
            got = fast(x, desired, qddot_r, e_int)
            want = generic(law, x, desired, qddot_r, e_int)
            for a, b, what in zip(got, want, ("u*", "tau", "integral rate")):
                np.testing.assert_allclose(a, b, rtol=0, atol=REL * (1 + np.abs(b).max()),
                                           err_msg=f"{name}: {what}")


def test_bounds_active_go_to_bounded_least_squares():
    law = laws()["arm bounds"]
    x = np.array([0.3, -0.4, 0.5, 0.7])
    desired = np.array([1.5, -1.0, 0.0, 0.0])          # large errors: |τ| > 50
    u_star, tau, _ = FloatSample.of(law)(x, desired, None, np.zeros(2))
    assert np.abs(np.linalg.solve(law.dynamics.input_matrix(x[:2]), u_star)).max() > 50.0
    assert np.all(np.abs(tau) <= 50.0 + 1e-12)
    np.testing.assert_allclose(tau, generic(law, x, desired, None, np.zeros(2))[1], rtol=0,
                               atol=1e-12 * 50.0)


def test_not_covered_laws_keep_the_generic_path():
    arm = make_arm_model()
    hinf = MechanicalLaw(arm, Partition(controlled=[0, 1]),
                         HinfLaw(hinf_mechanical_gains(1.0, 4.0, 4.0, 0.3, 0.6)))
    reduced = MechanicalLaw(acrobot_model(), Partition(controlled=[1], uncontrolled=[0]),
                            SobolevLaw(controlled_gains([100], [500], [40], [0.072])))
    allocated = MechanicalLaw(arm, Partition(controlled=[0, 1]),
                              SobolevLaw(controlled_gains(*W_ARM)),
                              allocation=lambda u, q, qd: u)
    assert FloatSample.of(hinf) is None
    assert FloatSample.of(reduced) is None
    assert FloatSample.of(allocated) is None


def test_controller_uses_the_float_path_and_names_non_finite_inputs():
    ctrl = MechanicalController.from_plant(seven_link_arm(),
                                           SobolevLaw(controlled_gains(*[[10.0] * 7] * 4)))
    context = ctrl.CreateDefaultContext()
    rng = np.random.default_rng(1)
    x, desired, acc = rng.normal(size=14), rng.normal(size=14), rng.normal(size=7)
    ctrl.get_input_port_estimated_state().FixValue(context, x)
    ctrl.get_input_port_desired_state().FixValue(context, desired)
    ctrl.get_input_port_desired_acceleration().FixValue(context, acc)
    u_star, tau, rate = generic(ctrl.law, x, desired, acc, np.zeros(7))
    np.testing.assert_allclose(ctrl.get_output_port_control().Eval(context), tau, rtol=0,
                               atol=REL * (1 + np.abs(tau).max()))
    np.testing.assert_array_equal(ctrl.EvalTimeDerivatives(context).CopyToVector(), rate)
    x[3] = np.nan
    ctrl.get_input_port_estimated_state().FixValue(context, x)
    with pytest.raises(ValueError, match="q must be finite"):
        ctrl.get_output_port_control().Eval(context)


class _nothing:
    def __enter__(self):
        return None

    def __exit__(self, *exc):
        return False


def test_compiled_sample_refuses_wrong_sizes_by_name():
    fast = FloatSample.of(laws()["seven-link"])
    if fast._compiled is None:
        pytest.skip("the rnea kernel is not built")
    module, capsule = fast._rnea
    args = [np.zeros(14), np.zeros(14), None, np.zeros(7), np.empty(7), np.empty(7)]
    with pytest.raises(ValueError, match="x must have 14 entries"):
        module.tracking_sample(capsule, fast._compiled, np.zeros(13), *args[1:])
    with pytest.raises(ValueError, match="u_out must be a float64 array of 7"):
        module.tracking_sample(capsule, fast._compiled, *args[:4], np.empty(6), args[5])
    with pytest.raises(ValueError, match="incorrect name"):      # not a law capsule
        module.tracking_sample(capsule, capsule, *args)


@pytest.mark.parametrize("name", ["arm regulated", "arm stabilized", "seven-link",
                                  "seven-link damped, regulated, stabilized"])
def test_compiled_desired_acceleration_equals_the_python_floats(name):
    law = laws()[name]
    with native.disabled():
        python = laws()[name]
        python.desired_acceleration_scalar([0.0] * law.n, [0.0] * law.n, [0.0] * law.nc,
                                           [0.0] * (3 * law.n_ref))     # caches "no kernel"
    compiled = compiled_desired_acceleration(law)
    if compiled is None:
        pytest.skip("the rnea kernel is not built")
    rng = np.random.default_rng(11)
    for _ in range(50):
        q, qd = rng.normal(size=(2, law.n)).tolist()
        e_int = rng.normal(scale=0.1, size=law.nc).tolist()
        ref = rng.normal(size=3 * law.n_ref).tolist()
        got = law.desired_acceleration_scalar(q, qd, e_int, ref)
        want = python.desired_acceleration_scalar(q, qd, e_int, ref)
        if sys.version_info < (3, 12):     # same operations in the same order: the same bits
            assert got == want
        else:                              # sum() compensates from 3.12: rounding of the sums
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * (1 + np.abs(want).max()))
        np.testing.assert_allclose(got, law.desired_acceleration(
            np.array(q), np.array(qd), np.array(e_int), np.array(ref)), rtol=0,
            atol=REL * (1 + np.abs(want).max()))


@pytest.mark.parametrize("delay", [False, True])
def test_sampled_controller_holds_tau_and_u_star_in_state_output_ports(delay):
    law = laws()["seven-link"]
    ctrl = MechanicalController(law=law, period=1e-3, computation_delay=delay)
    context = ctrl.CreateDefaultContext()
    rng = np.random.default_rng(5)
    x, ref = rng.normal(size=14), rng.normal(size=21)
    ctrl.get_input_port_estimated_state().FixValue(context, x)
    ctrl.get_input_port_reference().FixValue(context, ref)
    ctrl.ExecuteInitializationEvents(context)
    u_star, tau, rate = generic(law, x, ref[:14], ref[14:], np.zeros(7))
    for port, want in (("control", tau), ("actuation", tau), ("u", tau),
                       ("generalized_force", u_star)):
        np.testing.assert_allclose(ctrl.GetOutputPort(port).Eval(context), want, rtol=0,
                                   atol=REL * (1 + np.abs(want).max()), err_msg=port)
    context.SetDiscreteState(ctrl.EvalUniquePeriodicDiscreteUpdate(context))
    np.testing.assert_array_equal(ctrl.get_output_port_error_integral().Eval(context), 1e-3 * rate)
    np.testing.assert_allclose(ctrl.get_output_port_control().Eval(context), tau, rtol=0,
                               atol=REL * (1 + np.abs(tau).max()))   # same inputs, same command
