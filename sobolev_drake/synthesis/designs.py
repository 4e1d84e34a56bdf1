"""Linear designs as values: which norm and which feedback structure a table row is.

Experiments compare designs row by row; each row is a :class:`LinearDesign` and code dispatches
on its fields, never on the printed label.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["LinearDesign", "NORMS", "FEEDBACKS"]

#: the performance measures a linear design minimizes: W∞ (Sobolev weights on the state and its
#: derivatives) or classic H∞ (weights Q on x and R on u)
NORMS = ("winf", "hinf")
#: static state feedback or dynamic output feedback
FEEDBACKS = ("sf", "of")


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
        One of :data:`FEEDBACKS` (default state feedback).
    """

    label: str
    norm: str
    feedback: str = "sf"
