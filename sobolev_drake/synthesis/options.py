"""One options type for the knobs every linear synthesis shares (python-control's way).

:class:`SynthesisOptions` holds method, time limit, pole region, LMI backend and its solver
options, the tolerances (certificate ``rtol``, LMI strictness ``margin``) and the
regularization (``regularize``, ``delta``).  ``options=`` is accepted by
:func:`~sobolev_drake.synthesis.hinf.state_feedback` and
:func:`~sobolev_drake.synthesis.hinf.output_feedback`, and so by the six public syntheses
(``winf_*``, ``hinf_*``, ``*_qr``) that forward their keywords there.  A keyword given
explicitly beside ``options`` must agree with it; a conflicting pair is refused naming both.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
from dataclasses import dataclass
from typing import Any, Callable

from ..validation import one_of, real_scalar
from .hinf_common import EPS
from .problem import SynthesisResult
from .regions import LMIRegion
from .strategy import DEFAULT_TIME_LIMIT, METHODS

__all__ = ["SynthesisOptions", "accepts_options"]


@dataclass(frozen=True)
class SynthesisOptions:
    """The shared knobs of the linear syntheses; defaults are the functions' defaults.

    Attributes
    ----------
    method : {"auto", "riccati", "lmi"}
        Which characterization computes the controller.
    time_limit : float or None
        Budget in seconds for the whole call; None: no limit.
    region : LMIRegion or None
        Closed-loop pole region (:mod:`~sobolev_drake.synthesis.regions`).
    backend : str, sequence of str or None
        LMI backend (``lmi.BACKENDS``); None: the default chain.
    solver_options : dict or None
        Passed to the LMI solver.
    rtol : float
        Relative tolerance of the certificate.
    margin : float
        Strictness margin of the LMIs.
    regularize : {"auto", True, False}
        Relax gamma to (1 + delta) gamma_opt for bounded gains.
    delta : float or None
        The relaxation; None: the synthesis chooses.

    Examples
    --------
    >>> import sobolev_drake as sd
    >>> opts = sd.SynthesisOptions(method="lmi", region=sd.regions.disk(50.0))
    >>> A, B, D = [[0, 1], [-1, -0.5]], [[0], [1]], [[1, 0], [0, 1]]
    >>> res = sd.winf_state_feedback(A, B, D, Gamma0=[1, 1], Gamma1=[0.1, 0.1], options=opts)
    >>> res.method, res.region is opts.region, res.certificate.ok
    ('lmi', True, True)
    >>> sd.winf_state_feedback(A, B, D, Gamma0=[1, 1], Gamma1=[0.1, 0.1], options=opts,
    ...                        method="riccati")
    Traceback (most recent call last):
    ...
    ValueError: method='riccati' conflicts with options.method='lmi' (give it in one place)
    """

    method: str = "auto"
    time_limit: float | None = DEFAULT_TIME_LIMIT
    region: LMIRegion | None = None
    backend: str | tuple | None = None
    solver_options: dict | None = None
    rtol: float = 1e-4
    margin: float = EPS
    regularize: bool | str = "auto"
    delta: float | None = None

    def __post_init__(self) -> None:
        one_of("method", self.method, METHODS)
        if self.time_limit is not None:
            real_scalar("time_limit", self.time_limit, low=0.0, low_open=True)
        if self.region is not None and not isinstance(self.region, LMIRegion):
            raise TypeError(f"region must be an LMIRegion or None, got {type(self.region).__name__}")
        real_scalar("rtol", self.rtol, low=0.0, low_open=True)
        real_scalar("margin", self.margin, low=0.0)
        if not (self.regularize is True or self.regularize is False or self.regularize == "auto"):
            raise ValueError(f"regularize must be 'auto', True or False, got {self.regularize!r}")
        if self.delta is not None:
            real_scalar("delta", self.delta, low=0.0, low_open=True)


def _same(a, b):
    """a and b are the same option value (arrays and regions compared without ambiguity)."""
    if a is b:
        return True
    try:
        return bool(a == b)
    except (TypeError, ValueError):   # arrays: elementwise, no single truth value
        return False


def merge_options(options: SynthesisOptions | None, keywords: dict[str, Any]) -> dict[str, Any]:
    """``keywords`` completed by ``options``; a ValueError when both give a knob differently."""
    if options is None:
        return keywords
    if not isinstance(options, SynthesisOptions):
        raise TypeError(f"options must be a SynthesisOptions, got {type(options).__name__}")
    merged = dict(keywords)
    for f in dataclasses.fields(SynthesisOptions):
        value = getattr(options, f.name)
        if f.name in keywords and not _same(keywords[f.name], value):
            raise ValueError(f"{f.name}={keywords[f.name]!r} conflicts with options.{f.name}="
                             f"{value!r} (give it in one place)")
        merged[f.name] = value
    return merged


def accepts_options(synthesis: Callable[..., SynthesisResult]) -> Callable[..., SynthesisResult]:
    """Decorate a synthesis ``f(plant, **keywords)`` to also take ``options=``.

    Parameters
    ----------
    synthesis : callable
        ``state_feedback`` or ``output_feedback``.

    Returns
    -------
    callable
        Same docstring and keywords, plus ``options`` (a :class:`SynthesisOptions`).
    """
    @functools.wraps(synthesis)
    def with_options(plant: Any, *, options: SynthesisOptions | None = None,
                     **keywords: Any) -> SynthesisResult:
        return synthesis(plant, **merge_options(options, keywords))
    sig = inspect.signature(synthesis)
    with_options.__signature__ = sig.replace(parameters=[
        *sig.parameters.values(),
        inspect.Parameter("options", inspect.Parameter.KEYWORD_ONLY, default=None,
                          annotation="SynthesisOptions | None")])
    # wraps() shared the synthesis' hints; add the keyword (as a resolved type: the synthesis'
    # module need not import SynthesisOptions for typing.get_type_hints to read it)
    with_options.__annotations__ = {**synthesis.__annotations__,
                                    "options": SynthesisOptions | None}
    return with_options
