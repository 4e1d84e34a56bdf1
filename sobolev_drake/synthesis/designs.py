"""Linear designs as values: which norm and which feedback structure a table row is.

Experiments compare designs row by row; each row is a :class:`LinearDesign` and code dispatches
on its fields, never on the printed label.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any
from dataclasses import dataclass

__all__ = ["LinearDesign", "NORMS", "FEEDBACKS", "FEEDBACK_ALIASES", "feedback_kind",
           "FeedbackTable"]

#: the performance measures a linear design minimizes: W∞ (Sobolev weights on the state and its
#: derivatives) or classic H∞ (weights Q on x and R on u)
NORMS = ("winf", "hinf")
#: the one public spelling of the feedback structure: static state feedback or dynamic output
#: feedback (the same words as ``SynthesisResult.kind`` and the ``*_state_feedback`` /
#: ``*_output_feedback`` function names)
FEEDBACKS = ("state_feedback", "output_feedback")
#: older spellings, accepted wherever a feedback kind is given and mapped by
#: :func:`feedback_kind` (older code and the dicts of earlier tilt-rotor designs say "sf"/"dyn")
FEEDBACK_ALIASES = {"state": "state_feedback", "sf": "state_feedback",
                    "output": "output_feedback", "of": "output_feedback",
                    "dyn": "output_feedback"}


def feedback_kind(value: str, name: str = "feedback") -> str:
    """The public spelling (one of :data:`FEEDBACKS`) of a feedback kind.

    Parameters
    ----------
    value : str
        ``"state_feedback"`` or ``"output_feedback"``, or an older spelling of
        :data:`FEEDBACK_ALIASES` (``"state"``, ``"sf"``; ``"output"``, ``"of"``, ``"dyn"``).
    name : str, optional
        The argument's name, for the error message.

    Returns
    -------
    str
        ``"state_feedback"`` or ``"output_feedback"``.

    Raises
    ------
    ValueError
        ``value`` is none of these; the message names ``name``, the value and the choices.

    Examples
    --------
    >>> from sobolev_drake.synthesis.designs import feedback_kind
    >>> feedback_kind("sf"), feedback_kind("dyn"), feedback_kind("output_feedback")
    ('state_feedback', 'output_feedback', 'output_feedback')
    >>> feedback_kind("lqr", "kind")
    Traceback (most recent call last):
    ...
    ValueError: kind must be 'state_feedback' or 'output_feedback' (or one of the older spellings 'dyn', 'of', 'output', 'sf', 'state'), got 'lqr'
    """
    if isinstance(value, str):
        if value in FEEDBACKS:
            return value
        if value in FEEDBACK_ALIASES:
            return FEEDBACK_ALIASES[value]
    old = ", ".join(repr(k) for k in sorted(FEEDBACK_ALIASES))
    raise ValueError(f"{name} must be 'state_feedback' or 'output_feedback' (or one of the older "
                     f"spellings {old}), got {value!r}")


class FeedbackTable(Mapping):
    """A read-only table with one value per feedback kind, looked up by any spelling.

    Parameters
    ----------
    state_feedback, output_feedback
        The two values.

    Examples
    --------
    >>> from sobolev_drake.synthesis.designs import FeedbackTable
    >>> radius = FeedbackTable(40.0, 150.0)
    >>> radius["state_feedback"], radius["sf"], radius["of"], list(radius)
    (40.0, 40.0, 150.0, ['state_feedback', 'output_feedback'])
    """

    def __init__(self, state_feedback: Any, output_feedback: Any) -> None:
        self._values = {"state_feedback": state_feedback, "output_feedback": output_feedback}

    def __getitem__(self, key: str) -> Any:
        try:
            return self._values[feedback_kind(key, "key")]
        except ValueError as exc:
            raise KeyError(str(exc)) from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._values)

    def __len__(self) -> int:
        return 2

    def __repr__(self) -> str:
        return f"FeedbackTable({self._values!r})"


@dataclass(frozen=True)
class LinearDesign:
    """One linear design of a comparison table.

    Attributes
    ----------
    label : str
        Its label in the tables, figures and metrics.
    norm : str
        One of :data:`NORMS`.
    feedback : str
        One of :data:`FEEDBACKS` (default state feedback); an older spelling
        (:data:`FEEDBACK_ALIASES`) is mapped to it on construction.
    """

    label: str
    norm: str
    feedback: str = "state_feedback"

    def __post_init__(self) -> None:
        object.__setattr__(self, "feedback", feedback_kind(self.feedback))
