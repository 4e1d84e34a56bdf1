"""Chapter-6 experiments: balance-linear (Table 6.2) and quadrotor-polytopic (Table 6.4).

Checks the linearizations against the closed-form Jacobians, the controllers' certificates
independently of the synthesis code (closed-loop eigenvalues on the linear models, the
common-Lyapunov bounded-real and disk LMIs at every polytope vertex and at interior points),
the helper pieces (parameter matching), and that the smoke runs write their tables with
finite numbers.  (The balance rig's controllers are the library LeafSystems, tested in
test_linear_controllers.py.)
"""

import json
from dataclasses import replace

import numpy as np
import pytest

from sobolev_drake.experiments import _balance_linear_designs as bl
from sobolev_drake.tuning import match_parameter
from sobolev_drake.experiments import balance_linear as blt
from sobolev_drake.experiments import quadrotor_polytopic as qp
from sobolev_drake.models import quadrotor_linear as ql
from sobolev_drake.models import two_wheeled_linear as twl
from sobolev_drake.synthesis.designs import LinearDesign
from sobolev_drake.rigs import balance_linear as blr


# ----------------------------------------------------------------------------- linearizations
def test_balance_linearization_matches_closed_form_4_30():
    A, B, D = twl.linearize()
    A2, B2, D2 = twl.closed_form_linearization()
    np.testing.assert_allclose(A, A2, atol=1e-8)
    np.testing.assert_allclose(B, B2, atol=1e-8)
    np.testing.assert_allclose(D, D2, atol=1e-8)
    # inverted pendulum: one unstable, one stable real pole of equal size (+ the slow friction mode)
    ev = np.sort(np.linalg.eigvals(A).real)
    assert ev[-1] > 3.0 and ev[0] < -3.0 and abs(ev[-1] + ev[0]) < 0.05


def test_balance_linearization_other_parameters():
    from sobolev_drake.models.two_wheeled import TwoWheeledParams, make_two_wheeled_model
    p = TwoWheeledParams(l=0.3, k=0.05, m=4.0)
    A, B, D = twl.linearize(make_two_wheeled_model(p))
    A2, B2, D2 = twl.closed_form_linearization(p)
    for X, Y in ((A, A2), (B, B2), (D, D2)):
        np.testing.assert_allclose(X, Y, atol=1e-7)
    assert abs(A[1, 1]) > 1e-3  # the friction k ϕ̇ reaches the linear model


def test_quadrotor_linearization_matches_hover_closed_form():
    from sobolev_drake.models.quadrotor import QuadrotorParams
    p = QuadrotorParams.chapter6_nominal()
    A, B, D = ql.linearize(p)
    A2, B2, D2 = ql.closed_form_linearization(p.m, p.Ixx, p.Iyy, p.Izz, params=p)
    np.testing.assert_allclose(A, A2, atol=1e-6)
    np.testing.assert_allclose(B, B2, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(D, D2, rtol=1e-7, atol=1e-9)
    assert A[9, 1] == pytest.approx(p.g) and A[10, 0] == pytest.approx(-p.g)
    # vertical acceleration per unit Ω² of one rotor: b cos α / m (tilted rotors)
    np.testing.assert_allclose(B[11], p.b * np.cos(p.alpha) / p.m, rtol=1e-9)
    # at a vertex of the ±10 % box (different m and inertia) the Drake model still agrees
    pv = replace(p, m=1.1 * p.m, Ixx=0.9 * p.Ixx, Iyy=1.1 * p.Iyy, Izz=0.9 * p.Izz)
    Av, Bv, Dv = ql.linearize(pv)
    A3, B3, D3 = ql.closed_form_linearization(pv.m, pv.Ixx, pv.Iyy, pv.Izz, params=p)
    np.testing.assert_allclose(Bv, B3, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(Dv, D3, rtol=1e-7, atol=1e-9)


def test_quadrotor_vertices_are_the_thesis_box():
    vs = ql.vertices()
    assert len(vs) == 16
    ms = sorted({round(pv["m"], 4) for pv, _ in vs})
    ixx = sorted({round(pv["Ixx"], 5) for pv, _ in vs})
    assert ms == [2.016, 2.464]  # thesis: m ∈ [2.0160, 2.4640]
    assert ixx[0] == pytest.approx(0.0346, abs=1e-4) and ixx[1] == pytest.approx(0.0422, abs=1e-4)


# ----------------------------------------------------------------------------- helpers
def test_match_parameter_monotone_and_largest_bracket():
    p, v, hist = match_parameter(np.log10, 0.5, [0.1, 1.0, 10.0], iters=30, rtol=1e-6)
    assert p == pytest.approx(10 ** 0.5, rel=1e-4)
    # non-monotone: f crosses 0.5 near p = 0.3 and near p = 30; the largest p is refined
    f = lambda q: (np.log10(q) - 0.5) ** 2 * 0.5  # noqa: E731  zero at √10, 0.5 at 10^(0.5±1)
    p, v, _ = match_parameter(f, 0.5, np.logspace(-2, 3, 6), iters=40, rtol=1e-8)
    assert p == pytest.approx(10 ** 1.5, rel=1e-4)
    # failures (nan) are skipped; without a bracket (and no refinement) the closest grid point
    g = lambda q: float("nan") if q > 5 else q  # noqa: E731
    p, v, _ = match_parameter(g, 100.0, [1.0, 2.0, 10.0])
    assert p == 2.0
    with pytest.raises(ValueError, match="grid"):
        match_parameter(np.log10, 0.0, [1.0])


def test_match_parameter_finds_dip_between_grid_points():
    """V-shaped f (the O.F. settling time vs ρ): both grid neighbours of the dip lie above the
    target; refinement halves the intervals around the closest point and finds the crossing
    on the large-p side of the dip."""
    f = lambda q: abs(np.log10(q) - 0.5) + 0.1  # noqa: E731  minimum 0.1 at p = 10^0.5
    p, v, _ = match_parameter(f, 0.15, [1.0, 10.0, 100.0])
    assert p in (1.0, 10.0)  # no refinement: a grid point, target missed
    p, v, hist = match_parameter(f, 0.15, [1.0, 10.0, 100.0], refine=3, iters=40, rtol=1e-8)
    assert p == pytest.approx(10 ** 0.55, rel=1e-5) and v == pytest.approx(0.15, abs=1e-6)


def test_settling_time_of_an_exponential():
    """2 % settling of θ0 e^(-t/τ) is τ ln 50 (linear interpolation between 1 ms samples)."""
    tau = 0.3
    t = np.arange(0.0, 5.0, 1e-3)

    def settling_time(t, theta):  # a flight logging θ as the plant's second state
        return blr.theta_settling_time({"t": t, "x": np.vstack([np.zeros_like(theta), theta])})

    ts = settling_time(t, blr.THETA0 * np.exp(-t / tau))
    assert ts == pytest.approx(tau * np.log(50.0), abs=1e-6)
    # an undershoot that re-enters the band counts until it is inside for good
    from scipy.optimize import brentq
    shape = lambda s: np.exp(-s / 0.1) - 0.05 * np.exp(-s / 1.0)  # noqa: E731
    ts2 = settling_time(t, blr.THETA0 * shape(t))
    exact = brentq(lambda s: shape(s) + 0.02, 0.5, 2.0)  # the slow negative tail decides
    assert ts2 == pytest.approx(exact, abs=1e-6) and exact == pytest.approx(np.log(2.5), abs=0.01)
    assert settling_time(t, np.zeros_like(t)) == 0.0


# ----------------------------------------------------------------------------- smoke runs
@pytest.fixture(scope="module")
def balance_smoke(tmp_path_factory):
    out = tmp_path_factory.mktemp("balance_linear")
    return out, blt.run(out, smoke=True)


@pytest.fixture(scope="module")
def quad_smoke(tmp_path_factory):
    out = tmp_path_factory.mktemp("quadrotor_polytopic")
    return out, qp.run(out, smoke=True)


def test_balance_smoke_table_and_finite_numbers(balance_smoke):
    out, res = balance_smoke
    assert (out / "balance-linear_table.md").exists()
    table = json.loads((out / "balance-linear_table.json").read_text())
    assert [r[0] for r in table["rows"]] == list(bl.DESIGNS)
    assert len(table["thesis_rows"]) == 4 and table["thesis_rows"][1][4] == 1.8  # W∞ ISE θ (thesis)
    for name in bl.DESIGNS:
        m = res.metrics[name]
        for k in ("ise_theta", "ise_phidot", "iadu", "gamma"):
            assert np.isfinite(m[k]) and m[k] > 0, (name, k)
        assert m["finite"] and m["certified"]
    assert all(p.exists() for p in res.outputs.values())
    assert res.claims and all(isinstance(c.held, bool) for c in res.claims)


def test_balance_closed_loop_poles_in_disks(balance_smoke):
    _, res = balance_smoke
    A, B, D = twl.linearize()
    for name in bl.DESIGNS:
        m = res.metrics[name]
        if "K" in m:
            Acl = A + B @ np.array(m["K"])
            r = bl.RADIUS["sf"]
        else:  # plant + full-order controller on y = C x (independent assembly)
            c = {k: np.array(v) for k, v in m["controller"].items()}
            Acl = np.block([[A + B @ c["DK"] @ bl.C_OF, B @ c["CK"]], [c["BK"] @ bl.C_OF, c["AK"]]])
            r = bl.RADIUS["of"]
            assert Acl.shape == (6, 6)
        ev = np.linalg.eigvals(Acl)
        assert ev.real.max() < 0, name
        assert np.abs(ev).max() <= r * (1 + 1e-6), (name, np.abs(ev).max())


def test_balance_tuned_rho_gives_equal_settling_on_nonlinear_plant(balance_smoke):
    """The thesis' tuning rule, checked as a fact of the smoke runs (nonlinear plant, ρ from
    RHO_TUNED): each H∞ design settles within 10 % of its W∞ counterpart."""
    _, res = balance_smoke
    for a, b in (("H∞", "W∞"), ("H∞-O.F.", "W∞-O.F.")):
        ta, tb = res.metrics[a]["settling_s"], res.metrics[b]["settling_s"]
        assert 0.2 < tb < blr.DISTURBANCE_START - 1, (b, tb)  # settled well inside the window
        assert abs(ta - tb) <= 0.1 * tb, (a, ta, b, tb)
        assert res.metrics[a]["rho"] == bl.RHO_TUNED[a]


def _winf_channel_peak(A, B, D, C, ctrl, G0, G1, omega):
    """max σ(T_zw(jω)) of z = [Γ0^½x; Γ1^½ẋ] for plant + dynamic controller on y = Cx,
    assembled here (not by the synthesis)."""
    AK, BK, CK, DK = ctrl
    n, nk = A.shape[0], AK.shape[0]
    Acl = np.block([[A + B @ DK @ C, B @ CK], [BK @ C, AK]])
    Bcl = np.vstack([D, np.zeros((nk, D.shape[1]))])
    xdot_row = np.hstack([A + B @ DK @ C, B @ CK])  # ẋ = xdot_row ξ + D w
    G0h, G1h = np.sqrt(G0), np.sqrt(G1)  # diagonal weights
    Ccl = np.vstack([np.hstack([G0h, np.zeros((n, nk))]), G1h @ xdot_row])
    Dcl = np.vstack([np.zeros((n, D.shape[1])), G1h @ D])
    I = np.eye(n + nk)
    return max(np.linalg.norm(Ccl @ np.linalg.solve(1j * w * I - Acl, Bcl) + Dcl, 2) for w in omega)


def test_balance_of_designs_regularized_and_certified_independently(balance_smoke):
    """O.F. designs are the regularized ones (γ = (1+δ)γ*), and the W∞-O.F. γ bounds the
    W∞ channel of the closed loop assembled independently (frequency sweep)."""
    _, res = balance_smoke
    A, B, D = twl.linearize()
    for name in ("H∞-O.F.", "W∞-O.F."):
        m = res.metrics[name]
        assert m["regularized"] and m["gamma"] == pytest.approx((1 + bl.OF_REG_DELTA) * m["gamma_opt"], rel=1e-6)
    c = [np.array(v) for v in (res.metrics["W∞-O.F."]["controller"][k] for k in ("AK", "BK", "CK", "DK"))]
    peak = _winf_channel_peak(A, B, D, bl.C_OF, c, bl.GAMMA0_OF, bl.GAMMA1_OF, np.logspace(-3, 4, 1500))
    g = res.metrics["W∞-O.F."]["gamma"]
    assert 0.9 * g < peak <= g * (1 + 1e-4)


def test_balance_of_lmi_optimum_is_not_attained_and_fixed_gamma_design_is_backend_independent():
    """Singular O.F. problem (y = [θ, ϕ̇] noise-free): the least-gain controller at
    γ = (1+δ)γ* needs a Lyapunov variable Y and a controller peak gain that grow as δ → 0.
    Given γ, the least-gain controller is the same with Clarabel and Drake/Clarabel."""
    from sobolev_drake.experiments import _balance_linear_posedness as bp
    from sobolev_drake.harness import quiet
    from sobolev_drake.synthesis import regions
    from sobolev_drake.synthesis import sobolev as sb
    from sobolev_drake.synthesis.hinf import output_feedback
    lin = twl.linearize()
    A, B, D = lin
    disk = regions.disk(bl.RADIUS["of"])
    rho = bl.RHO_TUNED["H∞-O.F."]
    r0, _, _ = bl.design("H∞-O.F.", lin, rho=rho, regularize=False)
    plant = sb.hinf_plant(A, B, bl.C_OF, D, Q=bl.GAMMA0_OF, R=np.array([[rho]]))
    rows = bp.gain_growth(plant, disk, r0.gamma_opt, (0.2, 0.05), backend=bl.OF_BACKEND)
    assert all("error" not in r and r["certified"] for r in rows)
    assert rows[1]["norm_Y"] > 3 * rows[0]["norm_Y"] and rows[1]["peak_gain"] > 1.5 * rows[0]["peak_gain"]
    # the raw LMI optimum sits farther out on that curve
    assert np.linalg.norm(r0.Y, 2) > 3 * rows[1]["norm_Y"]
    # the experiment's W∞-O.F. design (pinned backend) re-solved by Drake at the same γ
    rw, _, _ = bl.design("W∞-O.F.", lin)
    assert rw.regularized and rw.certificate.ok and rw.solver.lower().startswith("clarabel")
    pw = sb.winf_plant(A, B, bl.C_OF, D, Gamma0=bl.GAMMA0_OF, Gamma1=bl.GAMMA1_OF)
    rd, _ = quiet(output_feedback, pw, region=disk, gamma=rw.gamma, backend="drake")
    np.testing.assert_allclose(rd.controller.DK, rw.controller.DK, rtol=1e-2, atol=0.05)
    pk = [bp.controller_peak_gain(r.controller) for r in (rw, rd)]
    assert abs(pk[0] - pk[1]) <= 1e-2 * max(pk)


def test_balance_variant_rows_and_claims_margin():
    """Variant table rows carry W∞/H∞ ratios; "W∞ lower" needs a margin (LOWER), so a 1 %
    difference does not count as a win."""
    from sobolev_drake.experiments import _balance_linear_variants as bv
    h = {"settling_s": 2.0, "ise_theta": 1.0, "ise_phidot": 60.0, "iadu": 50.0, "gain": 1.5, "max_abs_u": 40.0}
    w_clear = {**h, "ise_phidot": 40.0, "iadu": 30.0, "gain": 1.2}
    w_tie = {**h, "ise_phidot": 59.5, "iadu": 30.0, "gain": 1.2}
    vs = [{"label": "a", "rho": 3.0, "W": w_clear, "H": h}, {"label": "b", "rho": 4.0, "W": w_tie, "H": h}]
    rows = bv.variant_rows(vs)
    assert len(rows) == 4 and all(len(r) == len(bv.VARIANT_COLUMNS) for r in rows)
    assert rows[1][5] == "40.0 (67%)" and rows[0][2] == "3"
    held = [c[1] for c in bv.variant_claims(vs)]
    assert held == [True, False]


def test_balance_controller_peak_gain_and_bad_input():
    from sobolev_drake.experiments import _balance_linear_posedness as bp
    # K(s) = 2/(s+1) + 0.5: peak 2.5 at ω → 0
    k = bp.controller_peak_gain((np.array([[-1.0]]), np.array([[1.0]]), np.array([[2.0]]), np.array([[0.5]])))
    assert k == pytest.approx(2.5, rel=1e-3)
    with pytest.raises(ValueError, match="ctrl"):
        bp.controller_peak_gain((np.eye(2), np.ones((3, 1)), np.ones((1, 2)), np.zeros((1, 1))))
    with pytest.raises(ValueError, match="regularize"):
        bl.design("W∞-O.F.", twl.closed_form_linearization(), regularize="yes")


def test_quadrotor_smoke_table_and_finite_numbers(quad_smoke):
    out, res = quad_smoke
    table = json.loads((out / "quadrotor-polytopic_table.json").read_text())
    assert [r[0] for r in table["rows"]] == ["H∞", "W∞"]
    for name in ("H∞", "W∞"):
        m = res.metrics[name]
        assert np.isfinite(m["ise"]) and np.isfinite(m["iadu"]) and m["iadu"] > 0
        assert m["finite"] and m["all_vertex_certificates_ok"]
        assert m["min_omega2"] < m["max_omega2"]
    assert all(p.exists() for p in res.outputs.values())


def _brl(Acl, B1, C, D, P, gamma):
    return np.block([[Acl.T @ P + P @ Acl, P @ B1, C.T], [B1.T @ P, -gamma ** 2 * np.eye(B1.shape[1]), D.T],
                     [C, D, -np.eye(C.shape[0])]])


def test_quadrotor_polytopic_certificate_every_vertex_and_inside(quad_smoke):
    """Corollary 1 re-checked: one P satisfies the bounded-real LMI and the disk LMI at every
    vertex, hence (affine data) at random convex combinations; poles lie in the disk."""
    from sobolev_drake.synthesis import sobolev as sb
    from sobolev_drake.synthesis.polytopic import random_interior_points
    _, res = quad_smoke
    for name in ("W∞", "H∞"):
        m = res.metrics[name]
        K, P = np.array(m["K"]), np.array(m["P"])
        gamma = m["gamma"] * (1 + qp.W_RTOL)
        X = np.linalg.inv(P)
        assert np.linalg.eigvalsh(P).min() > 0
        verts = []
        for pv in m["vertex_params"]:
            A, B, D = ql.closed_form_linearization(**{k: pv[k] for k in ql.UNCERTAIN})
            verts.append((A, B, D))  # B in Ω² units, as designed
        pts = verts + random_interior_points(verts, 3, rng=1)
        for A, B, D in pts:
            plant = (sb.winf_plant(A, B, D=D, Gamma0=qp.GAMMA0, Gamma1=qp.GAMMA1) if name == "W∞"
                     else sb.hinf_plant(A, B, D=D, Q=qp.GAMMA0, R=m["rho"] / m["input_scale"] ** 2 * np.eye(4)))
            Acl, B1, C, Dcl = plant.closed_loop(K=K)
            M = _brl(Acl, B1, C, Dcl, P, gamma)
            assert np.linalg.eigvalsh(0.5 * (M + M.T)).max() <= 1e-9 * np.abs(M).max(), name
            R = qp.RADIUS
            region = np.block([[-R * X, Acl @ X], [(Acl @ X).T, -R * X]])  # disk LMI (6.39)
            assert np.linalg.eigvalsh(region).max() < 0, name
            ev = np.linalg.eigvals(Acl)
            assert ev.real.max() < 0 and np.abs(ev).max() < R, name


def test_quadrotor_design_rejects_bad_input():
    with pytest.raises(ValueError, match="rho"):
        qp.design(qp.HINF, [], rho=None)
    with pytest.raises(ValueError, match="norm"):
        qp.design(LinearDesign("LQR", "lqr"), [])
    with pytest.raises(ValueError, match="rho"):
        bl.design("H∞", twl.closed_form_linearization(), rho=-1.0)
