"""The Riccati path (``riccati.py``, ``hinf_riccati.py``) and the dispatch (``strategy.py``)."""

import warnings

import numpy as np
import pytest

from sobolev_drake.synthesis import riccati, strategy
from sobolev_drake.synthesis.certificates import hinf_norm
from sobolev_drake.synthesis.hinf import GeneralizedPlant, output_feedback, state_feedback
from sobolev_drake.synthesis.lmi import InfeasibleLMIError, SynthesisError
from sobolev_drake.synthesis.random_plants import random_plant
from sobolev_drake.synthesis.sobolev import winf_plant


def scalar_plant(a, b1=1.0, b2=2.0, c=3.0, d=0.5):
    """x' = a x + b1 w + b2 u, z = [c x; d u]."""
    return GeneralizedPlant.make([[a]], [[b1]], [[b2]], [[c], [0.0]], None, [[0.0], [d]])


@pytest.mark.parametrize("a", [-2.0, -0.3, 0.7, 3.0])
def test_scalar_state_feedback_optimum_closed_form(a):
    """Scalar full information: the Hamiltonian [[a, -k], [-c^2, -a]], k = b2^2/d^2 - b1^2/g^2,
    has no imaginary eigenvalues iff a^2 + c^2 k > 0, and X = (a + sqrt(a^2 + c^2 k)) / k >= 0
    needs k > 0 when a > 0.  Hence gamma_opt = b1 / sqrt(b2^2/d^2 + a^2/c^2) for a < 0 and
    b1 d / b2 for a > 0.  The bisection stops at 1e-6 relative width; the controller is built
    at (1 + 2e-5) gamma_opt, so its certified gamma lies within [1, 1 + 1e-4] x the closed form."""
    b1, b2, c, d = 1.0, 2.0, 3.0, 0.5
    exact = b1 / np.sqrt(b2 ** 2 / d ** 2 + a ** 2 / c ** 2) if a < 0 else b1 * d / b2
    res = state_feedback(scalar_plant(a, b1, b2, c, d))
    assert res.method == "riccati"
    assert res.gamma_opt == pytest.approx(exact, rel=2e-6)
    assert exact <= res.certificate.achieved * (1 + 2e-7) and res.gamma <= exact * (1 + 1e-4)


def test_normalization_is_exact():
    rng = np.random.default_rng(5)
    p = random_plant(rng, 5, "feedthrough").plant
    nrm = riccati.normalize(p)
    pn = nrm.plant
    assert np.allclose(pn.D12, np.vstack([np.zeros((p.nz - p.nu, p.nu)), np.eye(p.nu)]), atol=1e-12)
    assert np.allclose(pn.D21, np.hstack([np.zeros((p.ny, p.nw - p.ny)), np.eye(p.ny)]), atol=1e-12)
    # a controller of the normalized plant, mapped back, gives the same closed-loop norm
    lev = riccati.output_feedback_test(pn, 10.0 * riccati.parrott_bound(p.D11, p.D12, p.D21) + 50)
    k_n = riccati.central_controller(pn, lev)
    n1 = hinf_norm(*pn.closed_loop(controller=k_n))[0]
    n2 = hinf_norm(*p.closed_loop(controller=nrm.controller(k_n)))[0]
    assert n1 == pytest.approx(n2, rel=1e-7)  # 2 Hamiltonian tolerances (1e-7 each)
    assert n1 <= lev.gamma


def test_requested_gamma_is_the_certified_bound_and_below_optimum_is_refused():
    p = random_plant(np.random.default_rng(2), 6, "unstable").plant
    opt = output_feedback(p)
    r = output_feedback(p, gamma=1.3 * opt.gamma_opt)
    assert r.method == "riccati" and r.gamma == pytest.approx(1.3 * opt.gamma_opt, rel=1e-12)
    assert r.certificate.achieved <= r.gamma
    with pytest.raises(InfeasibleLMIError, match="not achievable"):
        output_feedback(p, gamma=0.99 * opt.gamma_opt)


def test_time_budget_error_lists_what_was_tried():
    p = random_plant(np.random.default_rng(3), 8, "stable").plant
    with pytest.raises(SynthesisError, match=r"within the time budget; tried: Riccati: .* s, "
                                             r"time budget exhausted"):
        output_feedback(p, time_limit=1e-9)
    with pytest.raises(SynthesisError, match="time budget exhausted before backend"):
        state_feedback(p, method="lmi", time_limit=1e-9)


def test_failed_riccati_path_falls_back_to_the_lmi_and_says_so(monkeypatch):
    p = random_plant(np.random.default_rng(4), 5, "stable").plant

    def broken(*args, **kwargs):
        raise SynthesisError("injected failure")
    monkeypatch.setattr(strategy, "riccati_synthesis", broken)
    r = output_feedback(p)
    assert r.method == "lmi" and r.certificate.ok
    assert "Riccati path failed" in r.fallback
    assert r.attempts[0].startswith("Riccati:") and "injected failure" in r.attempts[0]
    assert r.attempts[1].startswith("LMI:")
    with pytest.raises(SynthesisError, match="tried: Riccati: .*injected failure"):
        output_feedback(p, method="riccati")


def test_singular_state_feedback_is_regularized_with_bounded_gain():
    """Gamma1 = 0 removes u from z (D12 = 0): the infimum needs unbounded gains.  The default
    call perturbs the plant, certifies at (1 + delta) x its estimate, and says so; the LMI
    path's optimum agrees with the estimate to the LMI's accuracy on this unattained infimum."""
    A = np.array([[0.0, 1.0], [2.0, -0.5]])
    B = np.array([[0.0], [1.0]])
    p = winf_plant(A, B, D=np.array([[1.0], [0.0]]), Gamma0=np.eye(2), Gamma1=np.zeros((2, 2)))  # unmatched w
    with pytest.warns(UserWarning, match=r"singular problem \(rank D12 = 0 < 1\)"):
        r = state_feedback(p)
    assert r.regularized and r.method == "riccati" and r.certificate.ok
    assert np.isfinite(np.abs(r.K).max())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lmi = state_feedback(p, method="lmi", regularize=False, verify=False)
    assert r.gamma_opt <= lmi.certificate.achieved * (1 + 1e-3)


def test_region_problem_falls_back_to_a_riccati_controller_in_the_region(monkeypatch):
    """When the LMI path fails on a pole-region problem, Riccati controllers at levels above
    the optimum without region are tried until one certifies with its poles in the region
    (the benchmark's four region failures were all answered this way, at 1.01-1.1 x)."""
    import sobolev_drake.synthesis.output_feedback as of_module
    from sobolev_drake.synthesis.regions import disk

    p = random_plant(np.random.default_rng(6), 6, "unstable").plant
    region = disk(10 * max(1.0, np.abs(np.linalg.eigvals(p.A)).max()))

    def failing(*args, **kwargs):
        raise InfeasibleLMIError("injected LMI failure", "NumericalError")
    monkeypatch.setattr(of_module, "_lmi_output_feedback", failing)
    with pytest.warns(UserWarning, match="the LMI path failed .*injected"):
        r = output_feedback(p, region=region)
    assert r.method == "riccati" and r.certificate.ok and r.certificate.region_ok
    ev = np.linalg.eigvals(p.closed_loop(controller=r.controller)[0])
    assert np.all(region.contains(ev, 1e-9))
    assert r.gamma_opt <= r.gamma <= 10.0 * r.gamma_opt * (1 + 1e-6)
    with pytest.raises(InfeasibleLMIError, match="injected"):  # a requested gamma: no fallback
        output_feedback(p, region=region, gamma=2.0 * r.gamma)


# ------------------------------------------------------------- the deadline inside every loop
# No wall-clock comparisons: a deadline already in the past, or a module clock jumped forward,
# and counters of the steps started after it.

def test_region_fallback_stops_at_the_budget(monkeypatch):
    """The Riccati fallback of a region problem tried all six levels after the budget was
    spent (each call raising BudgetExceeded was caught and the next level started)."""
    from sobolev_drake.synthesis import hinf_riccati
    p = random_plant(np.random.default_rng(3), 4, "stable").plant
    free, _ = hinf_riccati.riccati_synthesis(p, False)
    calls = []

    def spent(*args, **kwargs):
        calls.append(kwargs.get("gamma"))
        if len(calls) == 1:
            return free, []
        raise riccati.BudgetExceeded("time budget exhausted (injected)")
    monkeypatch.setattr(strategy, "riccati_synthesis", spent)
    from sobolev_drake.synthesis import regions
    found = strategy._riccati_in_region(p, False, regions.disk(1.0), None, 1e-4, True, None,
                                        "LMI failed (injected)")
    assert found is None and len(calls) == 2   # the first level's BudgetExceeded ends the search


def test_backoff_levels_consult_the_deadline(monkeypatch):
    """After the bisection, the back-off levels (5 controllers and certificates) ran whatever
    the time: with the deadline passed, only the first level is tried, then BudgetExceeded."""
    from sobolev_drake.synthesis import hinf_riccati
    p = random_plant(np.random.default_rng(3), 4, "stable").plant
    real_bisect, real_result = hinf_riccati.bisect_gamma, hinf_riccati._result
    monkeypatch.setattr(hinf_riccati, "bisect_gamma",   # the search itself runs in time here
                        lambda *a, **k: real_bisect(*a, **{**k, "deadline": None}))
    built = []

    def rejected(*args, **kwargs):  # every level fails its certificate (as on a hard plant)
        res = real_result(*args, **kwargs)
        built.append(res.gamma)
        res.certificate.failures.append("injected failure")
        return res
    monkeypatch.setattr(hinf_riccati, "_result", rejected)
    with pytest.raises(riccati.BudgetExceeded, match="backing off from the optimum"):
        hinf_riccati.riccati_synthesis(p, False, deadline=-np.inf)   # long past
    assert len(built) == 1


def test_singular_levels_keep_the_certified_controller_when_time_runs_out(monkeypatch):
    """A singular W∞ problem (Gamma1 = 0: rank D12 = 0) climbs the target levels while the
    controller's poles are too fast; the budget running out after the first level raised
    BudgetExceeded and dropped its certified controller.  Now the climb stops and returns it."""
    import types
    from sobolev_drake.synthesis import hinf_riccati
    p = winf_plant([[0.0, 1.0], [-1.0, -0.5]], [[0.0], [1.0]], D=np.eye(2), Gamma0=[1, 1], Gamma1=[0, 0])
    monkeypatch.setattr(hinf_riccati, "pole_ratio", lambda res, plant: 1e9)  # always too fast
    offset = [0.0]   # hinf_riccati's own clock, jumped past the deadline after one level
    monkeypatch.setattr(hinf_riccati, "time", types.SimpleNamespace(
        perf_counter=lambda: riccati.time.perf_counter() + offset[0]))
    real_ladder, levels = hinf_riccati._ladder, []

    def ladder(*args):
        levels.append(args[1])
        out = real_ladder(*args)
        offset[0] = 1e9
        return out
    monkeypatch.setattr(hinf_riccati, "_ladder", ladder)
    deadline = riccati.time.perf_counter() + 1e6   # the estimate (riccati's clock) runs in time
    res, warns = hinf_riccati.riccati_synthesis(p, False, deadline=deadline)
    assert len(levels) == 1 and res.certificate.ok and res.regularized
    assert "time budget reached" in warns[-1]
    assert hinf_norm(*res.closed_loop(p))[0] <= res.gamma  # re-checked independently


def test_own_ipm_stops_at_its_time_limit(monkeypatch):
    """The own IPM (first backend of backend="auto") had no time limit.  min x s.t.
    [[x, 1], [1, 1]] >= 0 (optimum 1) solves in about ten iterations; on a clock that advances
    1 s per reading, time_limit=2.5 lets exactly two iterations start."""
    import types
    from sobolev_drake.synthesis import sdp_ipm
    c, C, A = np.array([1.0]), [np.array([[0.0, 1.0], [1.0, 1.0]])], [np.array([[[-1.0, 0.0], [0.0, 0.0]]])]
    x, status, info = sdp_ipm.solve_sdp(c, C, A)
    assert status == "Solved" and x[0] == pytest.approx(1.0, rel=1e-6) and info["iterations"] > 3
    ticks = iter(range(10 ** 6))
    monkeypatch.setattr(sdp_ipm, "time", types.SimpleNamespace(perf_counter=lambda: next(ticks)))
    _, status, info = sdp_ipm.solve_sdp(c, C, A, time_limit=2.5)
    assert status == "MaxTime" and info["iterations"] == 3


def test_automatic_chain_gives_the_ipm_the_remaining_time():
    from sobolev_drake.synthesis.hinf_common import solve_lmi_program
    seen = []

    class Refusing:
        def solve(self, backend, options):
            seen.append((backend, dict(options or {})))
            raise InfeasibleLMIError("refused (test double)")
    deadline = riccati.time.perf_counter() + 1e6
    with pytest.raises(InfeasibleLMIError, match="does not keep to the time budget"):
        solve_lmi_program(Refusing(), "auto", None, {}, "lmi", deadline=deadline)
    assert [b for b, _ in seen] == ["ipm", "clarabel"]   # Drake's fallbacks skipped
    assert all(0 < opts["time_limit"] <= 1e6 for _, opts in seen)
