"""What one campaign case is, and what a campaign is made of.

A :class:`Case` is a small picklable description: the campaign (an experiment's name), one of
its designs, a seed and the parameter perturbations asked for.  Everything random in a case is
derived from the seed alone (:meth:`Case.rng`), never from the design, so every design of a
campaign meets the same disturbance realization and the same parameter draw on a given seed:
comparisons between designs are paired.  The worker that runs a case builds its own Drake
diagram from it (Drake systems do not pickle) and returns a small record.

A :class:`CampaignDefinition` is what an experiment declares to be run as a campaign: its
designs, what a seed randomizes, which parameters may be perturbed, the indices its records
carry and the function that runs one case.  A campaign whose designs come from a numerical
synthesis also declares ``synthesize``: each design is then synthesized once per campaign and
pinned in the output folder, so every case and every resume flies the same controller even where
the solver's stopping point is not reproducible (singular LMI optima).
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from sobolev_drake.errors import CampaignError

__all__ = ["Case", "CampaignDefinition", "DesignFailed"]


class DesignFailed(CampaignError):
    """A campaign design could not be synthesized; its message is recorded as the failure of
    every case of that design (it must depend on the design only — no wall times)."""


@dataclass(frozen=True)
class Case:
    """One design flown on one seed.

    Attributes
    ----------
    campaign : str
        The campaign (registered experiment) name.
    design : str
        One of the campaign's designs.
    seed : int
        Non-negative seed; all randomness of the case derives from it.
    perturb : tuple of (str, float)
        (parameter, fraction) pairs, sorted by name: each parameter is scaled by a factor drawn
        uniformly in [1 − fraction, 1 + fraction] (:meth:`draws`).
    duration : float or None
        Simulated time (s); None for the campaign's default.
    smoke : bool
        The short version used by the tests.
    """

    campaign: str
    design: str
    seed: int
    perturb: tuple = ()
    duration: float | None = None
    smoke: bool = False

    def __post_init__(self):
        if not isinstance(self.seed, (int, np.integer)) or isinstance(self.seed, bool) or self.seed < 0:
            raise ValueError(f"seed must be a non-negative integer, got {self.seed!r}")
        for item in self.perturb:
            if not (isinstance(item, tuple) and len(item) == 2 and isinstance(item[0], str)
                    and isinstance(item[1], float) and 0.0 <= item[1] < 1.0):
                raise ValueError("perturb must hold (name, fraction) pairs with 0 <= fraction < 1, "
                                 f"got {item!r}")

    @property
    def key(self) -> str:
        """Identity of the case inside its campaign ("design|seed")."""
        return f"{self.design}|{self.seed}"

    def rng(self, stream: str) -> np.random.Generator:
        """A generator for one named source of randomness ("turbulence", "disturbance", …).

        It depends on the seed and the stream name only, so two designs on the same seed draw
        the same numbers, and two streams of one case are independent.

        Parameters
        ----------
        stream : str
            Name of the random source.

        Returns
        -------
        numpy.random.Generator
        """
        return np.random.default_rng([int(self.seed), zlib.crc32(stream.encode("utf-8"))])

    def draws(self) -> dict:
        """The parameter factors of this case: {name: factor in [1 − f, 1 + f]}.

        Returns
        -------
        dict
            One factor per perturbed parameter, drawn from the "parameters" stream in name
            order (so adding a parameter does not change the others' draws only if it sorts
            last — fixed sets of parameters are what campaigns use).
        """
        rng = self.rng("parameters")
        return {name: float(1.0 + frac * rng.uniform(-1.0, 1.0)) for name, frac in self.perturb}


@dataclass(frozen=True)
class CampaignDefinition:
    """What an experiment runs as a campaign.

    Attributes
    ----------
    designs : tuple of str
        The design labels, in table order.
    indices : tuple of str
        Names of the indices every successful record carries ("lower is better").
    randomizes : str
        What a seed randomizes, in words (shown by ``sobolev-drake campaign --help`` and in
        the summary).
    run : callable
        ``run(case) -> dict`` with "indices" ({name: float}), "success" (bool), optionally
        "failure" (str) and "peaks" ({name: float}).  It must depend on the case only.  With
        ``synthesize`` it is ``run(case, design)``, ``design`` being what ``synthesize``
        returned for ``case.design``.
    parameters : dict
        {parameter name: description} of what ``--perturb NAME=FRACTION`` may scale.
    default_perturb : dict
        {parameter name: fraction} used when the user gives no ``--perturb``.
    smoke_duration : float
        Simulated time of a smoke case (s).
    claims : tuple of (str, str, str, str)
        The thesis' comparison claims this campaign tests, as (text, design A, design B,
        index): "A has the smaller index"; the summary states each as the share of paired
        seeds where it holds.
    synthesize : callable, optional
        ``synthesize(label) -> design``: the controller of one design, picklable (arrays, not
        Drake systems).  The runner calls it once per campaign and design, in a worker, and
        pins the result in the output folder (``designs.json``); a resume reuses it.  It raises
        :class:`DesignFailed` (or any exception) when the synthesis fails; every case of that
        design is then a failed record.  None: ``run(case)`` builds its own controller.
        The design must be data (numbers, strings, lists, dicts with string keys, numpy arrays):
        it is pinned as JSON (:mod:`sobolev_drake.datafile`), never pickled.
    design_spec : callable, optional
        ``design_spec(label) -> object``: what defines design ``label`` (its specification
        dataclass, weights, …).  Its fingerprint is pinned with the design; a resume whose code
        defines the design differently is refused.  None: the label alone.
    check_design : callable, optional
        ``check_design(label, design)`` raising ``ValueError`` when ``design`` is not of the
        structure ``synthesize`` produces (keys, shapes, finiteness).  Run on every design read
        back from the output folder.
    """

    designs: tuple
    indices: tuple
    randomizes: str
    run: Callable
    parameters: dict = field(default_factory=dict)
    default_perturb: dict = field(default_factory=dict)
    smoke_duration: float = 1.0
    claims: tuple = ()
    synthesize: Callable | None = None
    design_spec: Callable | None = None
    check_design: Callable | None = None

    def __post_init__(self):
        if not self.designs or len(set(self.designs)) != len(self.designs):
            raise ValueError(f"designs must be distinct labels, got {self.designs!r}")
        unknown = set(self.default_perturb) - set(self.parameters)
        if unknown:
            raise ValueError(f"default_perturb names unknown parameters {sorted(unknown)}")
        for claim in self.claims:
            if (len(claim) != 4 or claim[1] not in self.designs or claim[2] not in self.designs
                    or claim[3] not in self.indices):
                raise ValueError(f"a claim is (text, design, design, index) of this campaign, got {claim!r}")
        for attr in ("synthesize", "design_spec", "check_design"):
            value = getattr(self, attr)
            if value is not None and not callable(value):
                raise TypeError(f"{attr} must be callable or None, got {type(value).__name__}")
        if not (math.isfinite(self.smoke_duration) and self.smoke_duration > 0):
            raise ValueError(f"smoke_duration must be > 0, got {self.smoke_duration!r}")
