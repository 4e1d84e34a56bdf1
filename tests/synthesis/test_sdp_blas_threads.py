"""The own SDP solver runs with one BLAS thread (threadpoolctl) and restores the caller's count."""

import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

from sobolev_drake.synthesis import sdp_ipm


def _blas_threads():
    return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]


def test_solve_sdp_limits_blas_to_one_thread_and_restores(monkeypatch):
    inside = []
    solve = sdp_ipm._solve_sdp

    def spy(*args, **kwargs):
        inside.append(_blas_threads())
        return solve(*args, **kwargs)

    monkeypatch.setattr(sdp_ipm, "_solve_sdp", spy)
    with threadpool_limits(limits=2, user_api="blas"):
        before = _blas_threads()
        # max x s.t. I - x I >= 0: x = 1
        x, status, _ = sdp_ipm.solve_sdp(np.array([-1.0]), [np.eye(2)], [np.eye(2)[None]])
        assert _blas_threads() == before
    assert status == "Solved" and abs(x[0] - 1.0) < 1e-6     # solver tol 1e-8, 100x margin
    assert inside and all(n == 1 for n in inside[0])
