"""Drake-native tilt-rotor systems (issue #31): scalar conversion of the force systems, the
linear hover controller and the allocator's refusal; Drake's linearization of the hover plant
against the former central differences; Drake's LQR on the plant through the library's systems.

Equalities and where their tolerances come from:

* AutoDiffXd and constant-Expression values against double: the generic cores do the float
  tier's IEEE operations in the same order (Drake evaluates AutoDiffXd values and constant
  Expressions with the same double operations and libm), so they are equal to the bit; the
  linear controller's K Δx is summed by numpy's object loop instead of BLAS (rounding of a
  20-term sum: 20 ε Σ|K_ij Δx_j|).
* Expressions with variables, evaluated: Drake regroups sums and products, so each output is
  the double's up to the rounding of its terms (≤ 1000 ε relative to the largest output).
* AutoDiffXd gradients against central differences of the double system with step h:
  |error| ≤ h² |f'''|/6 + k ε |f|/h; for forces |f| ≤ 100 N with h = 1e-6 the rounding term
  (k = 16) is 3.5e-7 and the truncation term (|f'''| ≲ |f| per rad³) 2e-11.
"""

import numpy as np
import pytest
from pydrake.autodiffutils import AutoDiffXd, ExtractGradient, ExtractValue, InitializeAutoDiff
from pydrake.symbolic import Expression, Variable
from pydrake.systems.controllers import LinearQuadraticRegulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import Linearize

from sobolev_drake.synthesis.controller import DynamicController
from sobolev_drake.synthesis.problem import SynthesisResult
from sobolev_drake.tiltrotor.aerodynamics import AerodynamicSurfaces
from sobolev_drake.tiltrotor.allocation import ControlAllocator
from sobolev_drake.tiltrotor.body_frame import body_kinematics_scalar
from sobolev_drake.tiltrotor.generic_forces import aero_loads_generic, propeller_force_generic
from sobolev_drake.tiltrotor.input_affine import cores
from sobolev_drake.tiltrotor.linear_controller import LinearHoverController
from sobolev_drake.tiltrotor.linearization import linearize, trim_diagram
from sobolev_drake.tiltrotor.plant import TiltrotorForces, TiltrotorModel
from sobolev_drake.tiltrotor.propulsion import PropellerForces
from sobolev_drake.tiltrotor.scalars import scalar_math
from sobolev_drake.tiltrotor.trim import trim_hover, trim_level_flight

EPS = np.finfo(float).eps
FLOAT, AUTODIFF, SYMBOLIC = (scalar_math(T) for T in (float, AutoDiffXd, Expression))


@pytest.fixture(scope="module")
def trims():
    return trim_hover(), trim_level_flight(15.0)


def _states(trims):
    """(x, wind, n, τs, δ, force at C1, w) at the hover trim (no inflow, no airspeed), at
    15 m/s with deflections, and at a tumbling state in wind (reverse and crossflow)."""
    hover, cruise = trims
    rng = np.random.default_rng(3)
    return [
        (np.r_[hover.q, hover.qdot], np.zeros(3), hover.n, hover.tau_s, np.zeros(4), np.zeros(3),
         np.zeros(8)),
        (np.r_[cruise.q, cruise.qdot], cruise.zeta, cruise.n, cruise.tau_s, [0.1, -0.05, 0.2, 0.1],
         [1.0, -2.0, 0.5], np.zeros(8)),
        (np.r_[0.3 * rng.normal(size=8), 3.0 * rng.normal(size=8)], [-4.0, 6.0, 1.0], [40.0, 60.0],
         [0.3, -0.4], 0.2 * rng.normal(size=4), [2.0, 0.0, -1.0], rng.normal(size=8)),
    ]


# ------------------------------------------------------------------ the scalar-generic cores

def test_generic_cores_on_floats_are_the_float_tier(trims):
    """On Python floats the generic cores give the float tier's numbers to the bit (same
    operations): the double systems keep the float tier, the others run these."""
    prop, aero = cores(trims[0].info["model"].params)
    for x, zeta, n, ts, delta, force, _ in _states(trims):
        q, qd, zeta = list(map(float, x[:8])), list(map(float, x[8:])), list(map(float, zeta))
        kin = body_kinematics_scalar(q, qd, zeta)
        rotors = prop.rotors_scalar(q, qd, kin)
        n, delta = list(map(float, n)), list(map(float, delta))
        assert propeller_force_generic(prop, kin, rotors, n, FLOAT) == \
            prop.propeller_force_scalar(kin, rotors, n)
        assert aero_loads_generic(aero, kin, delta, FLOAT) == aero.loads_scalar(kin, delta)[0]


def test_table_interpolation_of_each_scalar_type():
    rows = [(0.0, 1.0), (1.0, 0.0), (3.0, 0.0), (2.0, 4.0)]         # three segments
    imax = 2
    for x in (0.0, 0.25, 1.0, 1.5, 2.0, 3.0):
        ref = FLOAT.lerp_rows(rows, x, imax)
        ad = AUTODIFF.lerp_rows(rows, AutoDiffXd(x, [1.0]), imax)
        assert [a.value() for a in ad] == list(ref)
        i = min(int(x), imax)
        right = [b - a for a, b in zip(rows[i], rows[i + 1])]
        if x == int(x) and 0 < x <= imax:    # interior node: the central slope
            slope = [0.5 * (b - a) for a, b in zip(rows[i - 1], rows[i + 1])]
        else:                                # inside a segment, or an end: that segment's slope
            slope = right
        assert [a.derivatives()[0] for a in ad] == slope
        const = SYMBOLIC.lerp_rows(rows, Expression(x), imax)
        assert [e.Evaluate() if isinstance(e, Expression) else e for e in const] == list(ref)
    t = Variable("t")
    tree = SYMBOLIC.lerp_rows(rows, Expression(t), imax)   # if_then_else over the segments
    for x in (0.0, 0.25, 1.0, 1.5, 2.0, 2.75, 3.0):
        assert [e.Evaluate({t: x}) for e in tree] == list(FLOAT.lerp_rows(rows, x, imax))


# ------------------------------------------------------------------ the force systems

def _force_systems(model):
    """name -> (system, input values of a state tuple)"""
    forces = TiltrotorForces(model, native=False)
    return {
        "PropellerForces": (PropellerForces(model.params), lambda s: [s[0], s[1], s[2], s[3]]),
        "AerodynamicSurfaces": (AerodynamicSurfaces(model.params), lambda s: [s[0], s[1], s[4]]),
        "TiltrotorForces": (forces, lambda s: _tiltrotor_inputs(forces, model, s)),
    }


def _tiltrotor_inputs(forces, model, s):
    x, zeta, n, ts, delta, force, w = s
    drake_x = np.r_[model.T @ x[:8], model.T @ x[8:]]
    u = np.r_[n, ts, delta]
    values = {"plant_state": drake_x, "u": u, "propeller_speed": np.zeros(2),
              "servo_torque": np.zeros(2), "surface_deflection": np.zeros(4), "wind": zeta,
              "force_disturbance": force, "disturbance": w}
    return [values[forces.get_input_port(i).get_name()] for i in range(forces.num_input_ports())]


def _outputs(system, values, T=float):
    ctx = system.CreateDefaultContext()
    for i, v in enumerate(values):
        system.get_input_port(i).FixValue(ctx, np.asarray(v, dtype=object if T is not float else float))
    return [system.get_output_port(i).Eval(ctx) for i in range(system.num_output_ports())]


def _gradient_and_differences(system, values, k, h):
    """Output ``k`` of ``system`` as a function ``f`` of its stacked inputs ``flat``: the
    AutoDiffXd Jacobian G and the central differences (step h) of f at ``flat``.

    Returns
    -------
    G, fd : ndarray
    f : callable
    flat : ndarray
    """
    sizes = [len(v) for v in values]
    flat = np.concatenate([np.asarray(v, float) for v in values])
    seeded = np.split(InitializeAutoDiff(flat)[:, 0], np.cumsum(sizes)[:-1])
    G = ExtractGradient(_outputs(system.ToAutoDiffXd(), seeded, AutoDiffXd)[k])

    def f(z):
        return _outputs(system, np.split(z, np.cumsum(sizes)[:-1]))[k]

    fd = np.column_stack([(f(flat + h * e) - f(flat - h * e)) / (2 * h) for e in np.eye(flat.size)])
    return G, fd, f, flat


@pytest.mark.parametrize("name", ["PropellerForces", "AerodynamicSurfaces", "TiltrotorForces"])
def test_force_systems_convert_with_the_double_values(trims, name):
    model = trims[0].info["model"]
    system, inputs = _force_systems(model)[name]
    ad, sym = system.ToAutoDiffXd(), system.ToSymbolic()
    assert type(ad).__name__.endswith("AutoDiffXd𝓤") and sym.num_output_ports() == system.num_output_ports()
    for s in _states(trims):
        values = inputs(s)
        ref = _outputs(system, values)
        flat = np.concatenate([np.asarray(v, float) for v in values])
        seeded = InitializeAutoDiff(flat)[:, 0]
        split = np.split(seeded, np.cumsum([len(v) for v in values])[:-1])
        got = _outputs(ad, split, AutoDiffXd)
        for r, g in zip(ref, got):                      # same operations: equal to the bit
            np.testing.assert_array_equal(ExtractValue(g).ravel(), r)
            assert np.all(np.isfinite(ExtractGradient(g)))
        const = _outputs(sym, [[Expression(float(a)) for a in v] for v in values], Expression)
        for r, g in zip(ref, const):
            np.testing.assert_array_equal([e.Evaluate() for e in g], r)
    # variables: the symbolic forces of one state, evaluated there (regrouped rounding)
    s = _states(trims)[2]
    values = inputs(s)
    variables = [[Variable(f"{k}_{j}") for j in range(len(v))] for k, v in enumerate(values)]
    exprs = _outputs(sym, [[Expression(a) for a in v] for v in variables], Expression)
    env = {var: float(a) for vs, v in zip(variables, values) for var, a in zip(vs, v)}
    for r, g in zip(_outputs(system, values), exprs):
        np.testing.assert_allclose([e.Evaluate(env) for e in g], r, rtol=0,
                                   atol=1000 * EPS * np.abs(r).max())


def test_autodiff_gradients_are_the_derivatives(trims):
    """Away from kinks (the tumbling state: inflow, airspeed, no table node) the AutoDiffXd
    gradient of TiltrotorForces is its derivative: central differences agree to their error
    (module docstring: 3.5e-7)."""
    model = trims[0].info["model"]
    system, inputs = _force_systems(model)["TiltrotorForces"]
    h = 1e-6
    G, fd, f, flat = _gradient_and_differences(system, inputs(_states(trims)[2]), 2, h)
    scale = max(100.0, np.abs(f(flat)).max())
    assert np.abs(G - fd).max() <= 16 * EPS * scale / h + h**2 * scale / 6


def test_zero_inflow_derivative_is_the_central_one(trims):
    """At the hover trim the rotors see no air (u = w = 0), where the thrust has a kink in
    the inflow: the AutoDiffXd derivative along each input coordinate is the central
    difference's.  Their difference is then only the second-order inflow terms,
    kf n² Σ_{i≥2}|a_ij|(π/2)^j (h‖e‖/(nd))²/h (‖e‖ ≤ 1.2: rotor speed per unit input, lever
    arms ≤ 1.1 m on the generalized force), plus the rounding of the module docstring."""
    hover = trims[0]
    system = PropellerForces(hover.info["model"].params)
    values = [np.r_[hover.q, hover.qdot], np.zeros(3), hover.n, hover.tau_s]
    h = 1e-6
    G, fd, f, flat = _gradient_and_differences(system, values, 0, h)
    coef, n = system.core.coef, hover.n[0]
    c2 = sum(abs(a) * (np.pi / 2) ** j for (i, j), a in zip(coef._pw.astype(int).tolist(),
                                                          coef.ct_coef) if i >= 2)
    kf_n2 = coef.rho * coef.diameter**4 * n**2
    second_order = kf_n2 * c2 * 1.2**2 * h / (n * coef.diameter) ** 2 * 1.1 * (1 + coef.diameter)
    assert np.abs(G - fd).max() <= second_order + 16 * EPS * 100.0 / h
    # the kink is real: the one-sided slopes along the axial velocity differ (climb vs descent)
    j = 8 + 7                                    # ż: axial inflow at both (vertical) rotors
    up = (f(flat + h * np.eye(flat.size)[j]) - f(flat)) / h
    down = (f(flat) - f(flat - h * np.eye(flat.size)[j])) / h
    assert abs(up[7] - down[7]) > 100 * second_order


def test_linear_hover_controller_converts():
    rng = np.random.default_rng(5)

    class Trim:
        q, n, tau_s = np.r_[-0.137, -0.137, 0, 0.137, 0, 0, 0, 0], np.r_[51.9, 51.9], np.r_[-0.127, -0.127]

    C = np.eye(20)[[i for i in range(20) if i not in (13, 14)]]
    designs = [SynthesisResult("state_feedback", np.nan, K=rng.normal(size=(4, 20))),
               SynthesisResult("output_feedback", np.nan, controller=DynamicController(
                   -np.eye(3), rng.normal(size=(3, 18)), rng.normal(size=(4, 3)),
                   rng.normal(size=(4, 18))))]
    for result, reference in zip(designs, ("zero", "path")):
        ctrl = {"kind": result.kind, "K": result.K, **dict(zip(("AK", "BK", "CK", "DK"), result.controller))}
        c = LinearHoverController(result, Trim(), reference)
        x, ref, s = rng.normal(size=16), rng.normal(size=12), rng.normal(size=4 + c.nk)
        ctx = c.CreateDefaultContext()
        c.get_input_port(0).FixValue(ctx, x)
        c.get_input_port(1).FixValue(ctx, ref)
        ctx.SetContinuousState(s)
        outs = [c.get_output_port(i).Eval(ctx) for i in range(4)] + [c.EvalTimeDerivatives(ctx).CopyToVector()]
        dx, xk = c.delta_x(ctx)
        terms = np.abs(ctrl["K"]) @ np.abs(dx) if ctrl["kind"] == "state_feedback" else \
            np.abs(ctrl["CK"]) @ np.abs(xk) + np.abs(ctrl["DK"]) @ (C @ np.abs(dx))
        tol = 20 * EPS * max(terms.max(), 60.0)          # the 20-term sums (module docstring)
        z = InitializeAutoDiff(np.r_[x, ref, s])[:, 0]
        ad = c.ToAutoDiffXd()
        actx = ad.CreateDefaultContext()
        ad.get_input_port(0).FixValue(actx, z[:16])
        ad.get_input_port(1).FixValue(actx, z[16:28])
        actx.SetContinuousState(z[28:])
        got = [ad.get_output_port(i).Eval(actx) for i in range(4)] + [ad.EvalTimeDerivatives(actx).CopyToVector()]
        for r, g in zip(outs, got):
            np.testing.assert_allclose(ExtractValue(g).ravel(), r, rtol=0, atol=tol)
        # ∂(delta_u)/∂x of a state feedback is K on the state part of Δx
        if ctrl["kind"] == "state_feedback":
            np.testing.assert_allclose(ExtractGradient(got[3])[:, :16], ctrl["K"][:, :16], rtol=0, atol=0)
        sym = c.ToSymbolic()
        sctx = sym.CreateDefaultContext()
        sym.get_input_port(0).FixValue(sctx, [Expression(a) for a in x])
        sym.get_input_port(1).FixValue(sctx, [Expression(a) for a in ref])
        sctx.SetContinuousState([Expression(a) for a in s])
        for i in range(4):
            np.testing.assert_allclose([e.Evaluate() for e in sym.get_output_port(i).Eval(sctx)],
                                       outs[i], rtol=0, atol=tol)


def test_bad_arguments_name_the_argument(trims):
    from sobolev_drake.tiltrotor.plant import TiltrotorForces_
    hover = trims[0]
    with pytest.raises(ValueError, match="native must be .*True only for the double system.*"
                                         "got True for T = AutoDiffXd"):
        TiltrotorForces_[AutoDiffXd](hover.info["model"], native=True)
    with pytest.raises(ValueError, match=r"inputs must be distinct keys of \('propeller_speed'"):
        trim_diagram(hover, inputs=("wind", "wind"))
    with pytest.raises(ValueError, match="method must be one of .*'drake'.*got 'fd'"):
        linearize(hover, method="fd")
    with pytest.raises(ValueError, match="eps must be a finite step > 0, got 0.0"):
        linearize(hover, method="central_difference", eps=0.0)
    with pytest.raises(ValueError, match="T must be float, AutoDiffXd or Expression"):
        scalar_math(int)


def test_allocator_refuses_conversion_and_names_the_alternative():
    alloc = ControlAllocator()
    for convert, T in ((alloc.ToAutoDiffXd, "AutoDiffXd"), (alloc.ToSymbolic, "Expression")):
        with pytest.raises(RuntimeError, match=f"does not convert to {T}.*active-set.*MatrixGain"):
            convert()
    assert alloc.ToAutoDiffXdMaybe() is None
    b = DiagramBuilder()
    b.AddSystem(ControlAllocator()).set_name("allocator")
    with pytest.raises(RuntimeError, match="allocator.*ControlAllocator does not support scalar "
                                           "conversion"):
        b.Build().ToAutoDiffXd()


# ------------------------------------------------------------------ linearization and LQR

def test_drake_linearization_equals_the_central_differences(trims):
    """Drake's AutoDiffXd linearization of the hover plant against the former central
    differences, step h = 1e-6 (relative, h·max(1, |u|), on n, τs and δ).  Their error is
    c₁ s + c₀ ε/s for a step s: at hover the forces are not twice differentiable (air loads
    quadratic in a zero airspeed, the propeller's inflow kink), so the truncation is first
    order (c₁, per entry), and the rounding of the derivative evaluation is at most c₀ ε/s.
    c₁ is measured at h = 1e-4, where the rounding is ≤ 1e-9, and c₀ (the largest over all
    entries: one noise level bounds every row) at h = 1e-8, where the truncation is ≤ 1e-9;
    at h = 1e-6 the difference must be within twice that model.  A wrong Drake derivative δ
    would pass only for δ ≲ c₁ s + c₀ ε/s ≈ 1e-7 (on entries of size 1–20).  Also at 15 m/s:
    a symmetric flight (zero sideslip, a node of the β tables) and not an equilibrium."""
    for trim in trims:
        exact = linearize(trim, include_surfaces=True)
        scale = {"A": np.ones(20), "B": np.maximum(1.0, np.abs(trim.u)), "D": np.ones(3)}
        fd = {h: linearize(trim, include_surfaces=True, method="central_difference", eps=h)
              for h in (1e-4, 1e-6, 1e-8)}
        err = {(h, k): np.abs(getattr(lin, k) - getattr(exact, k)) for h, lin in fd.items()
               for k in "ABD"}
        c0 = max((err[1e-8, k] * (1e-8 * scale[k])).max() for k in "ABD") / EPS
        for k in "ABD":
            c1 = err[1e-4, k] / (1e-4 * scale[k])
            s = 1e-6 * scale[k]
            assert np.all(err[1e-6, k] <= 2 * (c1 * s + c0 * EPS / s)), k
        # the former method is still available (bit-identical to before: same diagram, steps)
        assert np.array_equal(linearize(trim, method="central_difference").A, fd[1e-6].A)


def test_drake_lqr_on_the_tiltrotor_hover_plant(trims):
    """LinearQuadraticRegulator(system, context, Q, R) on the plant + force systems at the
    hover trim: the gain stabilizes Drake's linearization of that same system."""
    hover = trims[0]
    diagram, context, h = trim_diagram(hover)
    Q, R = np.eye(16), np.diag([1 / 25.0, 1 / 25.0, 4.0, 4.0])
    controller = LinearQuadraticRegulator(diagram, context, Q, R)
    K = -controller.D()                                   # u = u0 − K (x − x0)
    x0 = context.get_continuous_state_vector().CopyToVector()
    u_at_trim = controller.y0() + controller.D() @ x0
    np.testing.assert_allclose(u_at_trim, np.r_[hover.n, hover.tau_s], rtol=0,
                               atol=16 * EPS * np.abs(K).max() * np.abs(x0).sum() + 1e-12)
    lin = Linearize(diagram, context)
    eig = np.linalg.eigvals(lin.A() - lin.B() @ K)
    assert eig.real.max() < 0, eig
    # the same A in thesis order as linearize() (no integral states): Drake's state is the
    # plant's [q; v] in Drake order, mapped by the coordinate map T
    T16 = np.kron(np.eye(2), h.model.T)
    np.testing.assert_allclose(T16.T @ lin.A() @ T16, linearize(hover).A[:16, :16], rtol=0, atol=1e-12)
    assert isinstance(h.forces, TiltrotorForces) and isinstance(h.model, TiltrotorModel)
    # the whole diagram converts to Expression too: its derivatives at the trim (constant
    # Expressions; MultibodyPlant regroups its sums) are the double ones
    sym = diagram.ToSymbolic()
    sctx = sym.CreateDefaultContext()
    sctx.SetTimeStateAndParametersFrom(context)
    sym.get_input_port(0).FixValue(sctx, diagram.get_input_port(0).Eval(context))
    ref = diagram.EvalTimeDerivatives(context).CopyToVector()
    got = [e.Evaluate() for e in sym.EvalTimeDerivatives(sctx).CopyToVector()]
    np.testing.assert_allclose(got, ref, rtol=0, atol=1000 * EPS * max(1.0, np.abs(ref).max()))
