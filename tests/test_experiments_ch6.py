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

from sobolev_drake.experiments import balance_linear as bl
from sobolev_drake.experiments import quadrotor_polytopic as qp


# ----------------------------------------------------------------------------- linearizations
def test_balance_linearization_matches_closed_form_4_30():
    A, B, D = bl.linearize()
    A2, B2, D2 = bl.closed_form_linearization()
    np.testing.assert_allclose(A, A2, atol=1e-8)
    np.testing.assert_allclose(B, B2, atol=1e-8)
    np.testing.assert_allclose(D, D2, atol=1e-8)
    # inverted pendulum: one unstable, one stable real pole of equal size (+ the slow friction mode)
    ev = np.sort(np.linalg.eigvals(A).real)
    assert ev[-1] > 3.0 and ev[0] < -3.0 and abs(ev[-1] + ev[0]) < 0.05


def test_balance_linearization_other_parameters():
    from sobolev_drake.models.two_wheeled import TwoWheeledParams, make_two_wheeled_model
    p = TwoWheeledParams(l=0.3, k=0.05, m=4.0)
    A, B, D = bl.linearize(make_two_wheeled_model(p))
    A2, B2, D2 = bl.closed_form_linearization(p)
    for X, Y in ((A, A2), (B, B2), (D, D2)):
        np.testing.assert_allclose(X, Y, atol=1e-7)
    assert abs(A[1, 1]) > 1e-3  # the friction k ϕ̇ reaches the linear model


def test_quadrotor_linearization_matches_hover_closed_form():
    p = qp._params()
    A, B, D = qp.linearize(p)
    A2, B2, D2 = qp.closed_form_linearization(p.m, p.Ixx, p.Iyy, p.Izz, params=p)
    np.testing.assert_allclose(A, A2, atol=1e-6)
    np.testing.assert_allclose(B, B2, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(D, D2, rtol=1e-7, atol=1e-9)
    assert A[9, 1] == pytest.approx(p.g) and A[10, 0] == pytest.approx(-p.g)
    # vertical acceleration per unit Ω² of one rotor: b cos α / m (tilted rotors)
    np.testing.assert_allclose(B[11], p.b * np.cos(p.alpha) / p.m, rtol=1e-9)
    # at a vertex of the ±10 % box (different m and inertia) the Drake model still agrees
    pv = replace(p, m=1.1 * p.m, Ixx=0.9 * p.Ixx, Iyy=1.1 * p.Iyy, Izz=0.9 * p.Izz)
    Av, Bv, Dv = qp.linearize(pv)
    A3, B3, D3 = qp.closed_form_linearization(pv.m, pv.Ixx, pv.Iyy, pv.Izz, params=p)
    np.testing.assert_allclose(Bv, B3, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(Dv, D3, rtol=1e-7, atol=1e-9)


def test_quadrotor_vertices_are_the_thesis_box():
    vs = qp.vertices()
    assert len(vs) == 16
    ms = sorted({round(pv["m"], 4) for pv, _ in vs})
    ixx = sorted({round(pv["Ixx"], 5) for pv, _ in vs})
    assert ms == [2.016, 2.464]  # thesis: m ∈ [2.0160, 2.4640]
    assert ixx[0] == pytest.approx(0.0346, abs=1e-4) and ixx[1] == pytest.approx(0.0422, abs=1e-4)


# ----------------------------------------------------------------------------- helpers
def test_match_parameter_monotone_and_largest_bracket():
    p, v, hist = bl.match_parameter(np.log10, 0.5, [0.1, 1.0, 10.0], iters=30, rtol=1e-6)
    assert p == pytest.approx(10 ** 0.5, rel=1e-4)
    # non-monotone: f crosses 0.5 near p = 0.3 and near p = 30; the largest p is refined
    f = lambda q: (np.log10(q) - 0.5) ** 2 * 0.5  # noqa: E731  zero at √10, 0.5 at 10^(0.5±1)
    p, v, _ = bl.match_parameter(f, 0.5, np.logspace(-2, 3, 6), iters=40, rtol=1e-8)
    assert p == pytest.approx(10 ** 1.5, rel=1e-4)
    # failures (nan) are skipped; without a bracket the closest grid point is returned
    g = lambda q: float("nan") if q > 5 else q  # noqa: E731
    p, v, _ = bl.match_parameter(g, 100.0, [1.0, 2.0, 10.0])
    assert p == 2.0
    with pytest.raises(ValueError, match="grid"):
        bl.match_parameter(np.log10, 0.0, [1.0])


# ----------------------------------------------------------------------------- smoke runs
@pytest.fixture(scope="module")
def balance_smoke(tmp_path_factory):
    out = tmp_path_factory.mktemp("balance_linear")
    return out, bl.run(out, smoke=True)


@pytest.fixture(scope="module")
def quad_smoke(tmp_path_factory):
    out = tmp_path_factory.mktemp("quadrotor_polytopic")
    return out, qp.run(out, smoke=True)


def test_balance_smoke_table_and_finite_numbers(balance_smoke):
    out, res = balance_smoke
    assert (out / "balance-linear_table.md").exists()
    table = json.loads((out / "balance-linear_table.json").read_text())
    assert [r[0] for r in table["rows"]] == list(bl.DESIGNS)
    assert len(table["thesis_rows"]) == 4 and table["thesis_rows"][1][3] == 1.8  # W∞ ISE θ (thesis)
    for name in bl.DESIGNS:
        m = res.metrics[name]
        for k in ("ise_theta", "ise_phidot", "iadu", "gamma"):
            assert np.isfinite(m[k]) and m[k] > 0, (name, k)
        assert m["finite"] and m["certified"]
    assert all(p.exists() for p in res.outputs.values())
    assert res.claims and all(isinstance(c.held, bool) for c in res.claims)


def test_balance_closed_loop_poles_in_disks(balance_smoke):
    _, res = balance_smoke
    A, B, D = bl.linearize()
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
            A, B, D = qp.closed_form_linearization(**{k: pv[k] for k in qp.UNCERTAIN})
            verts.append((A, B, D))  # B in Ω² units, as designed
        pts = verts + random_interior_points(verts, 3, rng=1)
        for A, B, D in pts:
            plant = (sb.winf_plant(A, B, D, qp.GAMMA0, qp.GAMMA1) if name == "W∞"
                     else sb.hinf_plant(A, B, D, qp.GAMMA0, m["rho"] / m["input_scale"] ** 2 * np.eye(4)))
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
        qp.design("H∞", [], rho=None)
    with pytest.raises(ValueError, match="which"):
        qp.design("LQR", [])
    with pytest.raises(ValueError, match="rho"):
        bl.design("H∞", bl.closed_form_linearization(), rho=-1.0)
