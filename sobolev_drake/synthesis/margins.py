"""Loop margins at the plant input: how much uniform delay or gain change a design tolerates.

The loop is broken at the plant input u of ẋ = A x + B u, y = C x, closed by the controller
u = K y (a matrix: static feedback) or by a :class:`~sobolev_drake.synthesis.hinf.DynamicController`
(ẋ_K = A_K x_K + B_K y, u = C_K x_K + D_K y) — the positive-feedback convention of the synthesis
(u = K x).  Every input channel gets the same perturbation, as an actuator chain or a sampled
implementation would add it:

* :func:`input_delay_margin` — the smallest delay τ with u(t) = [K y](t − τ) at the stability
  boundary (exact, from the eigenvalues of the loop gain G(jω) = K(jω) P(jω): a closed-loop pole
  reaches jω when e^{−jωτ} λ(G(jω)) = 1, i.e. |λ| = 1 and ωτ = arg λ (mod 2π));
* :func:`input_gain_margins` — the interval of uniform gains k (u = k K y) around 1 that keeps the
  loop stable (closed-loop eigenvalues, bisection).

MATLAB's ``allmargin`` / ``diskmargin`` report the same kind of numbers loop by loop; here the
perturbation is simultaneous on all inputs.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..validation import real_scalar

from .certificates import as_matrix

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from sobolev_drake.synthesis.problem import DynamicController

__all__ = ["input_gain_margins", "input_delay_margin"]

#: largest frequency grid of :func:`input_delay_margin` (one eigenvalue problem per point)
MAX_POINTS = 100_000


def _controller(K, ny, nu):
    """(AK, BK, CK, DK) of a static gain or a dynamic controller (checked shapes)."""
    if hasattr(K, "AK"):
        AK, BK, CK, DK = (np.asarray(M, float) for M in (K.AK, K.BK, K.CK, K.DK))
    else:
        DK = as_matrix("K", K, (nu, ny))
        AK, BK, CK = np.zeros((0, 0)), np.zeros((0, ny)), np.zeros((nu, 0))
    nk = AK.shape[0]
    if AK.shape != (nk, nk) or BK.shape != (nk, ny) or CK.shape != (nu, nk) or DK.shape != (nu, ny):
        raise ValueError(f"controller must map y ({ny}) to u ({nu}); got AK {AK.shape}, BK {BK.shape}, "
                         f"CK {CK.shape}, DK {DK.shape}")
    return AK, BK, CK, DK


def _plant(A, B, C):
    A = as_matrix("A", A)
    n = A.shape[0]
    if A.shape != (n, n):
        raise ValueError(f"A must be square, got shape {A.shape}")
    B = as_matrix("B", B, (n, None))
    C = np.eye(n) if C is None else as_matrix("C", C, (None, n))
    return A, B, C


def _closed_loop(A, B, C, ctrl, k=1.0):
    AK, BK, CK, DK = ctrl
    return np.block([[A + k * B @ DK @ C, k * B @ CK], [BK @ C, AK]])


def _stable(M):
    return M.shape[0] == 0 or np.linalg.eigvals(M).real.max() < 0


def input_gain_margins(A: ArrayLike, B: ArrayLike, K: ArrayLike | DynamicController,
                       C: ArrayLike | None = None, *, k_max: float = 1e3,
                       rtol: float = 1e-6) -> tuple[float, float]:
    """(k_low, k_high): the loop u = k K y is stable for every k in (k_low, k_high) ∋ 1.

    ``C`` defaults to the identity (state feedback).  ``k_high`` is ``inf`` when no gain up to
    ``k_max`` destabilizes, ``k_low`` is 0 when no gain down to 0 does.  Bisection on the
    closed-loop eigenvalues (the first crossing on each side of 1; a loop can regain stability
    further out, which is not reported).  Raises ValueError if the nominal loop is unstable.
    """
    real_scalar("k_max", k_max, low=1.0, low_open=True)
    real_scalar("rtol", rtol, low=0.0, low_open=True)
    A, B, C = _plant(A, B, C)
    ctrl = _controller(K, C.shape[0], B.shape[1])
    if not _stable(_closed_loop(A, B, C, ctrl)):
        raise ValueError("the nominal closed loop (k = 1) is unstable: no gain margin")

    def first_loss(grid, none_lost):
        """Stable edge of the first gain on ``grid`` (walking away from 1) that destabilizes."""
        prev = 1.0
        for k in grid:
            if not _stable(_closed_loop(A, B, C, ctrl, k)):
                a, b = prev, k                      # a stable, b unstable: bisect
                while abs(b - a) > rtol * max(abs(a), abs(b), 1.0):
                    m = 0.5 * (a + b)
                    if _stable(_closed_loop(A, B, C, ctrl, m)):
                        a = m
                    else:
                        b = m
                return a
            prev = k
        return none_lost

    return (first_loss(np.linspace(1.0, 0.0, 201)[1:], 0.0),
            first_loss(np.geomspace(1.0, k_max, 200)[1:], np.inf))


def input_delay_margin(A: ArrayLike, B: ArrayLike, K: ArrayLike | DynamicController,
                       C: ArrayLike | None = None, *, w_min: float = 1e-4,
                       w_max: float | None = None, points: int = 4000) -> float:
    """Smallest uniform input delay τ (s) that puts a closed-loop pole on the imaginary axis.

    Exact up to the frequency grid: the loop gain G(jω) = K(jω) C (jωI − A)⁻¹ B is evaluated on
    ``points`` log-spaced frequencies in [``w_min``, ``w_max``] (default: 100 × the largest
    eigenvalue modulus of the open and closed loop); where the number of eigenvalues λ of G
    with modulus above 1 changes, the crossing frequency is bisected and τ = (arg λ mod 2π) / ω.  Returns
    ``inf`` when |λ| never crosses 1 (no delay destabilizes).  Raises ValueError if the
    nominal loop is unstable.
    """
    w_min = real_scalar("w_min", w_min, low=0.0, low_open=True)
    if w_max is not None:
        w_max = real_scalar("w_max", w_max, low=w_min, low_open=True)
    if isinstance(points, (bool, np.bool_)) or not isinstance(points, (int, np.integer)) \
            or not 2 <= points <= MAX_POINTS:
        raise ValueError(f"points must be an integer in [2, {MAX_POINTS}], got {points!r}")
    A, B, C = _plant(A, B, C)
    ctrl = _controller(K, C.shape[0], B.shape[1])
    AK, BK, CK, DK = ctrl
    ev = np.linalg.eigvals(_closed_loop(A, B, C, ctrl))
    if ev.real.max() >= 0:
        raise ValueError("the nominal closed loop is unstable: no delay margin")
    if w_max is None:
        w_max = 100.0 * max(np.abs(ev).max(), np.abs(np.linalg.eigvals(A)).max(), 1.0)
    n, nk = A.shape[0], AK.shape[0]

    def loop_eigs(w):
        s = 1j * w
        P = C @ np.linalg.solve(s * np.eye(n) - A, B)
        Kw = DK + (CK @ np.linalg.solve(s * np.eye(nk) - AK, BK) if nk else 0.0)
        return np.linalg.eigvals(Kw @ P)

    def outside(w):
        return int(np.sum(np.abs(loop_eigs(w)) > 1.0))

    ws = np.geomspace(w_min, w_max, points)
    counts = [outside(w) for w in ws]
    best = np.inf
    for i in range(points - 1):
        if counts[i] == counts[i + 1]:
            continue
        a, b, ca = ws[i], ws[i + 1], counts[i]
        for _ in range(60):
            m = np.sqrt(a * b)
            if outside(m) == ca:
                a = m
            else:
                b = m
        w = np.sqrt(a * b)
        lam = loop_eigs(w)
        j = int(np.argmin(np.abs(np.abs(lam) - 1.0)))
        best = min(best, float(np.mod(np.angle(lam[j]), 2 * np.pi) / w))
    return best
