"""Acceptance tests of the bounded-real-lemma synthesis (hinf.py, lmi.py, certificates.py)."""

import warnings

import numpy as np
import pytest

from sobolev_drake.synthesis.certificates import hinf_norm, hinf_norm_sweep
from sobolev_drake.synthesis.hinf import GeneralizedPlant, output_feedback, state_feedback
from sobolev_drake.synthesis.problem import SynthesisResult
from sobolev_drake.synthesis.interop import hinf_state_feedback
from sobolev_drake.synthesis.lmi import InfeasibleLMIError, LMIProgram, SynthesisError, bmat, kron
from sobolev_drake.synthesis.regions import disk, half_plane, sector, strip
from sobolev_drake.synthesis.sobolev import winf_plant

warnings.simplefilter("ignore", UserWarning)


def sgc_example7():
    """Scherer, Gahinet & Chilali (1997), example 7 (H∞ part); gamma* = 9.5081."""
    A = np.array([[0, 10, 2], [-1, 1, 0], [0, 2, -5.0]])
    B1 = np.array([[1.0], [0], [1]])
    B2 = np.array([[0.0], [1], [0]])
    C1 = np.array([[1.0, 0, 0], [0, 0, 0]])
    D12 = np.array([[0.0], [1]])
    C2 = np.array([[0.0, 1, 0]])
    D21 = np.array([[2.0]])
    return GeneralizedPlant.make(A, B1, B2, C1, None, D12, C2, D21)


@pytest.mark.parametrize("backend", ["clarabel", "cvxpy", "drake", "drake:csdp", "ipm", "auto"])
def test_sgc_example7_output_feedback(backend):
    res = output_feedback(sgc_example7(), backend=backend)
    ctrl, gamma = res.controller, res.gamma
    assert abs(gamma - 9.5081) < 1e-3
    assert res.certificate.ok and res.certificate.achieved <= gamma * (1 + 1e-4)
    # re-check independently with a frequency sweep of the closed loop
    cl = sgc_example7().closed_loop(controller=ctrl)
    assert hinf_norm_sweep(*cl)[0] <= gamma * (1 + 1e-4)
    assert np.all(np.linalg.eigvals(cl[0]).real < 0)


@pytest.mark.parametrize("backend, options", [
    ("cvxpy:scs", {"eps_abs": 1e-3, "eps_rel": 1e-3, "max_iters": 2000}), ("cvxpy:scs", None),
    ("drake:scs", None)])
def test_sgc_scs_rejected_or_verified(backend, options):
    """SCS (loose or default tolerance): a SynthesisError, or a result that passes the checks.
    Measured: SCS's gammas are 6.5e-4 .. 12x below its controllers' norms; a stable controller
    within ``delta`` (1e-2) of the LMI optimum is certified at its own norm (the status says
    so), the others are rejected.  A certified gamma can never be below the published optimum
    9.5081 (5 digits: >= 9.50805) and is within delta of it."""
    try:  # (regularize="auto" adds up to three more SCS solves: 15-40 s, measured rejected too)
        res = output_feedback(sgc_example7(), backend=backend, regularize=False,
                              solver_options=options)
        gamma = res.gamma
    except SynthesisError as e:
        assert "rejected" in str(e) or "not solved" in str(e)
    else:
        cl = sgc_example7().closed_loop(controller=res.controller)
        assert hinf_norm(*cl)[0] <= gamma * (1 + 1e-4)
        assert 9.50805 <= gamma <= 9.5081 * (1 + 1e-2)
        assert abs(gamma - 9.5081) < 1e-3 or "raised to the certified norm" in res.status


def test_hinf_norm_matches_sweep_with_feedthrough():
    rng = np.random.default_rng(3)
    for _ in range(5):
        A = rng.normal(size=(4, 4))
        A -= (np.linalg.eigvals(A).real.max() + 0.2) * np.eye(4)
        B, C, D = rng.normal(size=(4, 2)), rng.normal(size=(3, 4)), 0.7 * rng.normal(size=(3, 2))
        h, w = hinf_norm(A, B, C, D)
        grid = np.linspace(0, 30, 1501)
        s, _ = hinf_norm_sweep(A, B, C, D, grid)
        assert s <= h * (1 + 1e-7)  # the Hamiltonian value is an upper bound of every sample
        if np.isfinite(w):  # and it is attained at the reported peak frequency
            assert hinf_norm_sweep(A, B, C, D, [w])[0] >= h * (1 - 1e-9)
        assert s >= h * (1 - 2e-2)


def random_plant(rng, n, sensor_noise=0.1):
    nu, nw, ny = 1 + n % 2, 1 + (n // 2) % 2, max(1, n // 2)
    A = rng.normal(size=(n, n))
    A -= (np.linalg.eigvals(A).real.max() - 0.5) * np.eye(n)  # mildly unstable
    B, D, C = rng.normal(size=(n, nu)), rng.normal(size=(n, nw)), rng.normal(size=(ny, n))
    G0 = np.diag(rng.uniform(0.5, 2, n))
    G1 = np.diag(rng.uniform(0.01, 0.2, n))
    p = winf_plant(A, B, C, D, Gamma0=G0, Gamma1=G1)
    # measurement noise as extra disturbance inputs keeps the output-feedback problem regular
    B1 = np.hstack([p.B1, np.zeros((n, ny))])
    D11 = np.hstack([p.D11, np.zeros((p.nz, ny))])
    D21 = np.hstack([np.zeros((ny, nw)), sensor_noise * np.eye(ny)])
    return p, GeneralizedPlant.make(p.A, B1, p.B2, p.C1, D11, p.D12, p.C2, D21)


# (seed, states, disk region?): 2-12 states; output feedback on all but the 12-state disk case
# (Drake/Clarabel needs 85 s CPU for that one; cvxpy 14 s), which seeds 21-22 replace by
# 10- and 12-state output-feedback plants without region (measured: 3.5 s cvxpy, 4.6 s Drake)
RANDOM_CASES = [(s, [2, 3, 4, 5, 6][s % 5], bool(s % 2)) for s in range(18)] + \
    [(18, 8, False), (19, 12, True), (20, 7, False), (21, 10, False), (22, 12, False)]
# seed 21 (10 states) is an unattained infimum (|Y| ~ 5e5): checked separately in
# test_unattained_infimum_output_feedback.
OF_UNATTAINED = {21}

# Full-accuracy statuses of Clarabel (direct, through cvxpy / through Drake); anything else
# ("optimal_inaccurate", "AlmostSolved") is a stop at Clarabel's reduced tolerances.
FULL_ACCURACY = ("optimal", "(Solved)")


def assert_backends_agree(results):
    """Two backends' results for the same plant describe the same optimum.

    Both at full accuracy (Clarabel: relative gap and feasibility <= 1e-8 of the scaled
    problem): the LMI optima must agree to 1e-4.  Derivation: the objective error is the
    tolerance times the size of the optimal variables relative to gamma; on these plants
    |Y|/|X| reaches 5e4 (infima approached with Y growing), so 1e-8 * 5e4 = 5e-4 is the worst
    case, and the measured spread is <= 2.2e-5 under all four OpenBLAS kernel families.
    Either at reduced accuracy (relative gap 5e-5, feasibility 1e-4): the LMI point may be
    infeasible and gamma_opt may even lie below the infimum (measured: 5.8e-4 below the
    controller's norm on seed 1 under SkylakeX kernels), so the LMI optima are not comparable;
    the certified bounds gamma are (each >= the infimum, each certified independently), and
    must agree to 1e-3 = 10x the reduced feasibility tolerance (measured <= 3.6e-4).
    """
    a, b = results
    if all(any(f in r.status for f in FULL_ACCURACY) for r in results):
        assert abs(a.gamma_opt - b.gamma_opt) <= 1e-4 * a.gamma_opt, (a.status, b.status)
    else:
        assert abs(a.gamma - b.gamma) <= 1e-3 * min(a.gamma, b.gamma), (a.status, b.status)
    assert a.regularized == b.regularized   # the same kind of answer from both backends


@pytest.mark.parametrize("seed, n, with_disk", RANDOM_CASES)
def test_random_winf_plants_backends_agree(seed, n, with_disk):
    rng = np.random.default_rng(100 + seed)
    sf_plant, of_plant = random_plant(rng, n)
    region = disk(4 * max(1.0, np.abs(np.linalg.eigvals(sf_plant.A)).max())) if with_disk else None
    sf = [state_feedback(sf_plant, backend=b, region=region) for b in ("cvxpy", "drake")]
    assert_backends_agree(sf)
    checks = list(sf)
    if not (n > 8 and with_disk) and seed not in OF_UNATTAINED:
        of = [output_feedback(of_plant, backend=b, region=region) for b in ("cvxpy", "drake")]
        assert_backends_agree(of)
        checks += of
    for r in checks:
        c = r.certificate
        assert c.ok and c.achieved <= r.gamma * (1 + 1e-4)
        if region is not None:
            assert np.all(region.contains(c.eigenvalues, 1e-6 * max(1, np.abs(c.eigenvalues).max())))


def test_unattained_infimum_output_feedback():
    """Seed 21 (10 states): the OF infimum is approached with Y growing without bound, so each
    solver stops somewhere along that ray (|Y| 4.9e5-5.4e5 measured) and its LMI optimum moves
    with the CPU's rounding (21.1287-21.1404 over four OpenBLAS kernel families).  What holds:
    both controllers certify; their certified norms lie below both LMI optima (the LMI points
    are above the infimum); and they agree to 1e-3, the reduced-accuracy bound of
    :func:`assert_backends_agree` (measured spread <= 1.8e-4)."""
    rng = np.random.default_rng(121)
    _, of_plant = random_plant(rng, 10)
    # no time budget: under a budget the solvers stop on the wall clock, and a run on a loaded
    # machine was seen to stop at an LMI point below the certified norm (21.119 vs 21.124)
    of = [output_feedback(of_plant, backend=b, time_limit=None) for b in ("cvxpy", "drake")]
    ach = [r.certificate.achieved for r in of]
    assert all(r.certificate.ok for r in of)
    assert abs(ach[0] - ach[1]) <= 1e-3 * min(ach)
    assert max(ach) < min(r.gamma_opt for r in of)
    assert min(np.linalg.norm(r.Y, 2) for r in of) > 1e5 * max(np.linalg.norm(r.X, 2) for r in of) / 10


@pytest.mark.parametrize("region", [disk(5.0), half_plane(1.0), sector(np.pi / 4), strip(0.5, 8.0),
                                    disk(6.0, center=-3.0) & half_plane(1.0)])
def test_regions_state_and_output_feedback(region):
    p = sgc_example7()
    for r in (state_feedback(p, region=region), output_feedback(p, region=region)):
        assert r.certificate.region_ok
        assert np.all(region.contains(r.certificate.eigenvalues, 1e-6))


def test_region_membership_formulas():
    d = disk(2.0, center=-1.0)
    assert d.contains(-1 + 1.9j) and not d.contains(-1 + 2.1j) and not d.contains(1.5)
    assert half_plane(1).contains(-1.1) and not half_plane(1).contains(-0.9 + 5j)
    s = sector(np.pi / 6)
    assert s.contains(-1 + 0.5j) and not s.contains(-1 + 0.6j)
    st = strip(1, 3)
    assert st.contains(-2 + 100j) and not st.contains(-0.5) and not st.contains(-3.5)


def test_infeasible_region_raises_with_status():
    p = sgc_example7()
    with pytest.raises(InfeasibleLMIError) as e:
        state_feedback(p, region=disk(0.5, center=20.0) & half_plane(-0.0) & strip(30, 40))
    assert e.value.status


def test_lmi_expression_layer():
    rng = np.random.default_rng(0)
    prog = LMIProgram()
    X, W, g = prog.sym(3), prog.full(2, 3), prog.scalar()
    A, B = rng.normal(size=(3, 3)), rng.normal(size=(3, 2))
    x = rng.normal(size=prog.nvar)
    Xv, Wv = X.value(x), W.value(x)
    E = bmat([[(A @ X + B @ W).sym(), B], [B.T, -g * np.eye(2)]]).value(x)
    ref = np.block([[A @ Xv + B @ Wv + (A @ Xv + B @ Wv).T, B], [B.T, -x[-1] * np.eye(2)]])
    assert np.allclose(E, ref) and np.allclose(Xv, Xv.T)
    a = np.array([[1.0, 2], [0, -1]])
    assert np.allclose(kron(a, X @ A).value(x), np.kron(a, Xv @ A))


def test_functional_state_feedback_api():
    res = hinf_state_feedback(sgc_example7(), region=disk(50.0))
    assert res.K.shape == (1, 3) and res.P.shape == (3, 3)
    assert np.allclose(res.P, np.linalg.inv(res.X))


def test_bad_input_errors():
    p = sgc_example7()
    with pytest.raises(ValueError, match="B1 must have shape"):
        GeneralizedPlant.make(p.A, np.ones((2, 1)), p.B2, p.C1)
    with pytest.raises(ValueError, match="not stabilizable"):
        GeneralizedPlant.make(np.diag([1.0, -1]), [[1.0], [1]], [[0.0], [1]], np.eye(2)) and \
            state_feedback(GeneralizedPlant.make(np.diag([1.0, -1]), [[1.0], [1]], [[0.0], [1]], np.eye(2)))
    with pytest.raises(ValueError, match="not detectable"):
        output_feedback(GeneralizedPlant.make(np.diag([1.0, -1]), [[1.0], [1]], [[1.0], [1]], np.eye(2),
                                              C2=[[0.0, 1]], D21=[[1.0]]))
    with pytest.raises(ValueError, match="feedthrough"):
        state_feedback(GeneralizedPlant.make(p.A, p.B1, p.B2, p.C1, [[2.0], [0]], p.D12), gamma=1.0)
    with pytest.raises(ValueError, match="backend"):
        state_feedback(p, backend="matlab")
    with pytest.raises(ValueError, match="radius must be > 0, got -1.0"):
        disk(-1)


def test_fixed_gamma_request_minimizes_gain_and_certifies():
    p = sgc_example7()
    free = state_feedback(p, region=disk(50.0))
    g = 1.5 * free.gamma
    r = state_feedback(p, region=disk(50.0), gamma=g)
    assert r.gamma == g and r.certificate.achieved <= g * (1 + 1e-4)
    assert np.linalg.norm(r.K) <= np.linalg.norm(free.K) * (1 + 1e-6)  # relaxed gamma: smaller gain


def test_performance_compression_preserves_norm():
    from sobolev_drake.synthesis.hinf import compress_performance
    rng = np.random.default_rng(5)
    A = rng.normal(size=(4, 4)) - 4 * np.eye(4)
    p = winf_plant(A, rng.normal(size=(4, 1)), D=rng.normal(size=(4, 1)), Gamma0=np.eye(4), Gamma1=0.1 * np.eye(4))
    q = compress_performance(p)
    assert q.nz < p.nz
    K = rng.normal(size=(1, 4))
    assert np.isclose(hinf_norm(*p.closed_loop(K=K))[0], hinf_norm(*q.closed_loop(K=K))[0], rtol=1e-9)


def test_svec_conic_data_reproduces_the_lmis():
    """Direct Clarabel data: A x + s = b with s = svec(-F(x) - margin I) for every LMI."""
    rng = np.random.default_rng(2)
    prog = LMIProgram()
    X, W, g = prog.sym(3), prog.full(2, 3), prog.scalar()
    A, B = rng.normal(size=(3, 3)), rng.normal(size=(3, 2))
    prog.add_lmi(bmat([[(A @ X + B @ W).sym(), B], [B.T, -g * np.eye(2)]]), 1e-3)
    prog.add_pos(X, 0.5)
    Amat, b, sizes = prog._svec_data()
    x = rng.normal(size=prog.nvar)
    s_vec = b - Amat @ x
    k = 0
    for (_, F, margin), n in zip(prog.lmis, sizes):
        S = -F.value(x) - margin * np.eye(n)
        j, i = np.meshgrid(np.arange(n), np.arange(n))
        mask = i <= j
        order = np.lexsort((i[mask], j[mask]))  # upper triangle column by column
        vals = S[mask][order] * np.where(i[mask][order] == j[mask][order], 1.0, np.sqrt(2.0))
        assert np.allclose(s_vec[k:k + len(vals)], vals)
        k += len(vals)
    assert k == len(b)


def test_direct_clarabel_equals_cvxpy_clarabel():
    rng = np.random.default_rng(104)
    sf_plant, of_plant = random_plant(rng, 6)
    for fn, p in ((state_feedback, sf_plant), (output_feedback, of_plant)):
        a, b = (fn(p, backend=bk, region=disk(30.0)) for bk in ("clarabel", "cvxpy"))
        assert a.backend == "clarabel" and b.backend == "cvxpy"
        assert abs(a.gamma_opt - b.gamma_opt) <= 1e-7 * b.gamma_opt


@pytest.mark.parametrize("seed, n", [(101, 3), (104, 6), (106, 3)])
def test_ipm_backend_state_feedback_matches_clarabel(seed, n):
    rng = np.random.default_rng(seed)
    sf_plant, _ = random_plant(rng, n)
    region = disk(4 * max(1.0, np.abs(np.linalg.eigvals(sf_plant.A)).max())) if n == 3 else None
    a, b = (state_feedback(sf_plant, backend=bk, region=region) for bk in ("ipm", "clarabel"))
    assert a.certificate.ok and a.backend == "ipm"
    assert abs(a.gamma_opt - b.gamma_opt) <= 1e-5 * b.gamma_opt


def _bench3_plant():
    """3-state W∞ output-feedback plant (benchmarks/synthesis.py) on which the own IPM
    stalls: the infimum needs Y -> infinity (Clarabel: |Y| ~ 7e6) and the IPM's point
    (gamma 1.002) fails the norm certificate by 18 %."""
    A = np.array([[0, 0, 1.0], [0, -0.5, 2], [30, 1, -0.5]])
    B, D = np.array([[0.0], [2], [-3]]), np.array([[0.0, 0], [1, 0], [0, 1]])
    return winf_plant(A, B, np.array([[1.0, 0, 0]]), D, Gamma0=np.eye(3), Gamma1=0.1 * np.eye(3))


def test_auto_backend_falls_back_and_says_so():
    p = _bench3_plant()
    r = output_feedback(p, backend="auto")
    assert r.backend == "clarabel" and "ipm" in r.fallback and "after fallback" in r.status
    assert r.certificate.ok
    ref = output_feedback(p, method="lmi")
    assert r.gamma_opt == pytest.approx(ref.gamma_opt, rel=1e-9) and ref.fallback == ""
    # a well-posed plant: the IPM result is kept (no fallback) and agrees with Clarabel
    rng = np.random.default_rng(106)
    sf_plant, _ = random_plant(rng, 3)
    a, b = (state_feedback(sf_plant, backend=bk, region=disk(30.0)) for bk in ("auto", "clarabel"))
    assert a.backend == "ipm" and a.fallback == "" and a.certificate.ok
    assert abs(a.gamma_opt - b.gamma_opt) <= 1e-5 * b.gamma_opt


def test_backend_chain_behaves_like_auto_without_drake():
    """backend=("ipm", "clarabel") rejects the IPM result the way "auto" does and stops
    before the Drake fallbacks; bad chains are refused by name."""
    p = _bench3_plant()
    r = output_feedback(p, backend=("ipm", "clarabel"))
    auto = output_feedback(p, backend="auto")
    assert r.backend == auto.backend == "clarabel" and "ipm" in r.fallback and r.certificate.ok
    assert r.gamma_opt == pytest.approx(auto.gamma_opt, rel=1e-9)
    for bad in ((), ("auto",), ("ipm", 3), ("ipm", "nope")):
        with pytest.raises(ValueError, match="backend chain"):
            output_feedback(p, backend=bad)


def test_strict_check_rejects_a_wrong_lyapunov_matrix():
    from sobolev_drake.synthesis.hinf_common import strict_check
    p = sgc_example7()
    r = state_feedback(p, region=disk(50.0))
    assert strict_check(r, [p], r.region, 1e-4, "").certificate.ok
    r = r.replace(P=0.2 * r.P)  # same controller and norm, P no longer a bounded-real certificate
    c = strict_check(r, [p], r.region, 1e-4, "").certificate
    assert not c.ok and "bounded-real" in c.failures[-1]


@pytest.mark.parametrize("backend", [None, "auto"])
def test_reported_P_satisfies_gamma2_form_brl(backend):
    """SynthesisResult.P is the closed-loop Lyapunov matrix in the gamma^2 form:
    [[A'P + PA + C'C, PB + C'D], [., D'D - gamma^2 I]] <= 0, for state and output feedback;
    state feedback: P = X^-1; output feedback: P = [[Y, N], [N', *]], P^-1 = [[X, M], [M', *]].
    backend=None takes the Riccati path for output feedback (no region): P is then the
    stabilizing bounded-real Riccati solution of the closed loop, which must satisfy the same
    inequality."""
    from sobolev_drake.synthesis.certificates import brl_residual
    rng = np.random.default_rng(104)
    sf_plant, of_plant = random_plant(rng, 6)
    for p in (sgc_example7(), sf_plant):
        r = state_feedback(p, backend=backend, region=disk(30.0))
        assert np.allclose(r.P, np.linalg.inv(r.X), rtol=1e-6, atol=1e-9 * np.abs(r.P).max())
        assert brl_residual(*p.closed_loop(K=r.K), r.P, r.gamma) <= 1e-8
    for p in (sgc_example7(), of_plant):
        r = output_feedback(p, backend=backend)
        n = p.n
        assert r.P.shape == (2 * n, 2 * n) and np.allclose(r.P[:n, :n], r.Y, rtol=1e-6)
        Pi = np.linalg.inv(r.P)
        assert np.allclose(Pi[:n, :n], r.X, rtol=1e-5, atol=1e-8 * np.abs(r.X).max())
        assert brl_residual(*p.closed_loop(controller=r.controller), r.P, r.gamma) <= 1e-8


def test_singular_output_feedback_problem_is_flagged():
    """A noise-free measurement (D21 = 0) makes the OF problem singular: the result says so
    (warning, well_posed False) and regularize=True returns the least-gain controller; the
    regular SGC plant (D21 = 2) carries no such warning."""
    from sobolev_drake.synthesis.output_feedback import singular_problem

    p = sgc_example7()
    assert singular_problem(p) == ""
    r = output_feedback(p)
    assert r.well_posed and not any("singular" in w for w in r.warnings)
    ps = GeneralizedPlant.make(p.A, p.B1, p.B2, p.C1, None, p.D12, p.C2, np.zeros((1, 1)))
    assert singular_problem(ps) == "rank D21 = 0 < 1"
    with pytest.warns(UserWarning, match="singular problem"):
        rs = output_feedback(ps, regularize=False)  # the LMI optimum's controller, flagged
    assert not rs.well_posed and not rs.regularized and rs.method == "lmi"
    with pytest.warns(UserWarning, match="singular problem.*regularized"):
        rr = output_feedback(ps)  # default: bounded gains at (1 + delta) x the estimate
    assert rr.regularized and rr.method == "riccati" and rr.certificate.ok
    # the estimate is an upper bound of the infimum, so it may not exceed the LMI optimum by
    # more than the LMI's own inaccuracy on this unattained infimum (measured 1e-5 relative)
    assert rr.gamma_opt <= rs.gamma_opt * (1 + 1e-3)
    assert rr.gamma <= (1 + 1e-2) * rr.gamma_opt * (1 + 1e-6) * (1 + 1e-9)  # level + margin
    rr = output_feedback(ps, regularize=True, method="lmi")  # LMI least-gain controller
    assert rr.regularized and rr.certificate.ok
    assert rr.gamma == pytest.approx(1.01 * rr.gamma_opt, rel=1e-9)


def test_deliberate_regularization_escalates_once():
    """The regularized re-solve at (1+δ)γ* that fails (or is rejected) is retried at (1+5δ)γ*;
    when both fail the last error is raised, and a certified first step is kept."""
    from types import SimpleNamespace

    from sobolev_drake.synthesis.hinf_common import regularization_ladder

    tried = []

    def solve_at(g, fail_below):
        tried.append(g)
        if g < fail_below:
            raise SynthesisError(f"rejected at {g}")
        return SynthesisResult("state_feedback", g, certificate=SimpleNamespace(ok=True))

    r, d = regularization_ladder(lambda g: solve_at(g, 1.02), 1.0, 0.01, True, None)
    assert d == pytest.approx(0.05) and r.gamma == pytest.approx(1.05) and r.regularized
    assert tried == pytest.approx([1.01, 1.05])
    tried.clear()
    r, d = regularization_ladder(lambda g: solve_at(g, 0.0), 1.0, 0.01, True, None)
    assert d == 0.01 and tried == pytest.approx([1.01])
    with pytest.raises(SynthesisError, match="rejected at 1.05"):
        regularization_ladder(lambda g: solve_at(g, 2.0), 1.0, 0.01, True, None)
