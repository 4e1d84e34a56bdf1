"""Random generalized plants in families that stress a synthesis (tests and benchmarks).

Families (``FAMILIES``):

* ``"stable"``: Hurwitz A with a spread of time constants;
* ``"unstable"``: one to three open-loop eigenvalues in the right half plane;
* ``"lightly_damped"``: a chain of mechanical modes with damping ratios 0.001-0.01;
* ``"ill_conditioned"``: an unstable plant in coordinates scaled by 10^-3 ... 10^3 per state;
* ``"feedthrough"``: D11 != 0 of the size of the rest of the channel;
* ``"singular"``: D21 = 0 (noise-free measurements) -- no Riccati solution exists.

Every plant except the singular family is regular: D12 has full column rank and D21 full row
rank; (A, B2) is stabilizable and (A, C2) detectable generically.
"""

from __future__ import annotations

from dataclasses import dataclass

from typing import Sequence

import numpy as np

from ..validation import one_of
from .problem import GeneralizedPlant

__all__ = ["FAMILIES", "PlantCase", "random_plant", "plant_family", "SINGULAR_VARIANTS",
           "SingularCase", "singular_family", "reference_infimum"]

FAMILIES = ("stable", "unstable", "lightly_damped", "ill_conditioned", "feedthrough",
            "singular")


@dataclass
class PlantCase:
    """One generated plant with what generated it."""

    family: str
    seed: int
    plant: GeneralizedPlant

    @property
    def regular(self) -> bool:
        return self.family != "singular"

    def __str__(self) -> str:
        p = self.plant
        return f"{self.family}[seed {self.seed}] n={p.n} nw={p.nw} nu={p.nu} nz={p.nz} ny={p.ny}"


def _state_matrix(rng, n, family):
    if family == "lightly_damped":
        k = n // 2
        A = np.zeros((n, n))
        w = rng.uniform(0.5, 20.0, k)
        zeta = rng.uniform(1e-3, 1e-2, k)
        for i in range(k):  # modal blocks, then a random similarity couples them
            A[2 * i:2 * i + 2, 2 * i:2 * i + 2] = [[0.0, 1.0], [-w[i] ** 2, -2 * zeta[i] * w[i]]]
        if n % 2:
            A[-1, -1] = -rng.uniform(0.1, 5.0)
        Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
        S = Q * rng.uniform(0.5, 2.0, n)
        return S @ A @ np.linalg.inv(S)
    M = rng.normal(size=(n, n)) / np.sqrt(n)
    ev = np.linalg.eigvals(M).real
    A = M - (ev.max() + rng.uniform(0.1, 1.0)) * np.eye(n)  # Hurwitz
    if family in ("unstable", "ill_conditioned"):
        k = int(rng.integers(1, 4))
        V = rng.normal(size=(n, k))
        A = A + V @ np.diag(rng.uniform(1.0, 3.0, k)) @ np.linalg.pinv(V)  # lift k modes
    return A


def random_plant(rng: np.random.Generator, n: int, family: str = "stable", *, nw: int | None = None,
                 nu: int | None = None, nz: int | None = None, ny: int | None = None,
                 seed: int = -1) -> PlantCase:
    """One :class:`PlantCase` of ``family`` with ``n`` states (channel sizes random if None)."""
    one_of("family", family, FAMILIES)
    nu = int(rng.integers(1, 4)) if nu is None else nu
    ny = int(rng.integers(1, 4)) if ny is None else ny
    nw = ny + int(rng.integers(1, 3)) if nw is None else nw
    nz = nu + int(rng.integers(1, 4)) if nz is None else nz
    A = _state_matrix(rng, n, family)
    B1, B2 = rng.normal(size=(n, nw)), rng.normal(size=(n, nu))
    C1, C2 = rng.normal(size=(nz, n)) / np.sqrt(n), rng.normal(size=(ny, n))
    D12 = rng.normal(size=(nz, nu))
    D21 = np.zeros((ny, nw)) if family == "singular" else rng.normal(size=(ny, nw))
    D11 = rng.normal(size=(nz, nw)) if family == "feedthrough" else np.zeros((nz, nw))
    if family == "ill_conditioned":
        t = 10.0 ** rng.uniform(-3, 3, n)  # x_new = diag(1/t) x: entries spread over 1e12
        A, B1, B2 = A * t[None, :] / t[:, None], B1 / t[:, None], B2 / t[:, None]
        C1, C2 = C1 * t, C2 * t
    return PlantCase(family, seed, GeneralizedPlant.make(A, B1, B2, C1, D11, D12, C2, D21))


def plant_family(count: int, sizes: tuple[int, int] = (10, 40), *, seed: int = 0,
                 families: Sequence[str] = FAMILIES) -> list[PlantCase]:
    """``count`` plants cycling through ``families`` with sizes spread over ``sizes`` (inclusive);
    plant i uses the generator seeded (seed, i), so any case is reproducible on its own."""
    lo, hi = sizes
    out = []
    for i in range(count):
        rng = np.random.default_rng([seed, i])
        n = lo + (i * 7) % (hi - lo + 1)
        out.append(random_plant(rng, n, families[i % len(families)], seed=i))
    return out


#: singular variants of :func:`singular_family`: which matrix is rank deficient, and the kind
SINGULAR_VARIANTS = ("D21=0", "rank-1 D21", "D12 column 0 (OF)", "D12 column 0 (SF)")


@dataclass
class SingularCase:
    """One singular problem of :func:`singular_family`: the plant, the variant and the kind."""

    variant: str
    seed: int
    plant: GeneralizedPlant
    output_feedback: bool

    def __str__(self) -> str:
        p = self.plant
        return f"{self.variant}[seed {self.seed}] n={p.n} nu={p.nu} ny={p.ny}"


def singular_family(count: int, sizes: tuple[int, int] = (2, 20), *, seed: int = 0
                    ) -> list[SingularCase]:
    """``count`` singular problems (D12 or D21 rank deficient) cycling through
    ``SINGULAR_VARIANTS``, sizes spread over ``sizes`` (inclusive), from unstable plants (one to
    three right-half-plane modes; ``"stable"`` below 3 states).  Case i uses the generator
    seeded (seed, i).

    Parameters
    ----------
    count : int
        Number of problems.
    sizes : (int, int)
        Smallest and largest number of states.
    seed : int
        Family seed.

    Returns
    -------
    list of SingularCase

    Examples
    --------
    >>> from sobolev_drake.synthesis.random_plants import singular_family
    >>> [(c.variant, c.plant.n) for c in singular_family(2)]
    [('D21=0', 2), ('rank-1 D21', 9)]
    """
    lo, hi = sizes
    out = []
    for i in range(count):
        rng = np.random.default_rng([seed, 1000 + i])
        n = lo + (i * 7) % (hi - lo + 1)
        variant = SINGULAR_VARIANTS[i % len(SINGULAR_VARIANTS)]
        ny = 1 if variant == "D21=0" else 2
        nu = 2 if variant.startswith("D12") else None
        base = random_plant(rng, n, "unstable" if n >= 3 else "stable", ny=ny, nu=nu, seed=i)
        A, B1, B2, C1, D11, D12, C2, D21 = base.plant.as_tuple()
        if variant == "D21=0":
            D21 = np.zeros_like(D21)
        elif variant == "rank-1 D21":  # one measurement noise-free direction
            D21 = np.outer(rng.normal(size=ny), rng.normal(size=D21.shape[1]))
        else:  # the second input reaches z only through the state: cheap
            D12 = D12.copy()
            D12[:, 1] = 0.0
        plant = GeneralizedPlant.make(A, B1, B2, C1, D11, D12, C2, D21)
        if variant == "D12 column 0 (SF)":
            plant = GeneralizedPlant.make(A, B1, B2, C1, D11, D12)
        out.append(SingularCase(variant, i, plant, variant != "D12 column 0 (SF)"))
    return out


def reference_infimum(plant: GeneralizedPlant, output_feedback: bool) -> float:
    """Upper estimate of a singular problem's infimum apart from the synthesis' own ladder, for
    tests and benchmarks: the upper end of a Riccati bisection (1e-7 relative) on the regular
    problem made by a perturbation of relative size 1e-7 (cost on u, noise on y), or 1e-6, 1e-5
    where the Riccati tests refuse every level at the smaller one.  It tends to the infimum from
    above as the perturbation shrinks.

    Parameters
    ----------
    plant : GeneralizedPlant
        The (singular) plant.
    output_feedback : bool
        Output feedback (else state feedback).

    Returns
    -------
    float

    Raises
    ------
    RiccatiInfeasible
        The Riccati tests refuse every level at all three perturbations.
    """
    from .certificates import parrott_bound
    from .hinf_riccati import perturbed_plant
    from .riccati import (RiccatiInfeasible, bisect_gamma, normalize, output_feedback_test,
                          state_feedback_test)
    p = plant
    scale = max(1.0, np.abs(np.hstack([p.C1, p.D12])).max(), np.abs(np.vstack([p.B1, p.D21])).max())
    last = None
    for rel in (1e-7, 1e-6, 1e-5):
        q = perturbed_plant(p, rel * scale, rel * scale if output_feedback else 0.0)
        if output_feedback:
            nrm = normalize(q)
            test = lambda g, nrm=nrm: output_feedback_test(nrm.plant, g)  # noqa: E731
            lower = parrott_bound(q.D11, q.D12, q.D21)
        else:
            test, lower = (lambda g, q=q: state_feedback_test(q, g)), np.linalg.norm(q.D11, 2)
        try:
            return bisect_gamma(test, lower, rtol=1e-7)[1]
        except RiccatiInfeasible as exc:
            last = exc
    raise last
