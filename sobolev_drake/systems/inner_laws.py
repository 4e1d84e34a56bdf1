"""The inner laws a :class:`~sobolev_drake.systems.mechanical_law.MechanicalLaw` wraps: the
W2/W∞ law (gains per DOF group) and the classic nonlinear H∞ law (Chen, Lee & Feng)."""

from __future__ import annotations

from dataclasses import dataclass

from sobolev_drake.synthesis.mechanical import HinfMechanicalGains, SobolevGains

__all__ = ["SobolevLaw", "HinfLaw"]


@dataclass
class SobolevLaw:
    """W2/W∞ inner law: gains per group (identical for W2 and W∞, Remarks 30/36).

    Parameters
    ----------
    controlled : SobolevGains
        Gains of the controlled DOF, from ``controlled_gains`` (required).
    regulated : SobolevGains, optional
        Gains of the regulated DOF, from ``regulated_gains``.
    stabilized : SobolevGains, optional
        Gains of the stabilized DOF, from ``stabilized_gains``.

    Notes
    -----
    Each group's gains must come from the matching ``*_gains`` function (``TypeError`` /
    ``ValueError`` otherwise); their sizes are checked against the partition by
    :class:`MechanicalLaw`.

    Examples
    --------
    One controlled and one stabilized DOF (W2 and W∞ give the same gains, Remarks 30/36):

    >>> import sobolev_drake as sd
    >>> law = sd.SobolevLaw(controlled=sd.controlled_gains(100.0, 50.0, 5.0, 1.0, norm="Winf"),
    ...                     stabilized=sd.stabilized_gains(4.0, 1.0))
    >>> law.name, law.controlled.n, law.stabilized.n
    ('W2/W∞', 1, 1)
    """

    controlled: SobolevGains
    regulated: SobolevGains | None = None
    stabilized: SobolevGains | None = None

    def __post_init__(self):
        if self.controlled is None:
            raise TypeError("SobolevLaw.controlled is required: SobolevGains from controlled_gains(...)")
        for name, grp in (("controlled", self.controlled), ("regulated", self.regulated),
                          ("stabilized", self.stabilized)):
            if grp is not None and not isinstance(grp, SobolevGains):
                raise TypeError(f"SobolevLaw.{name} must be SobolevGains ({name}_gains(...)), "
                                f"got {type(grp).__name__}")
            if grp is not None and grp.group != name:
                raise ValueError(f"SobolevLaw.{name} must be {name} gains, got {grp.group!r}")

    @property
    def name(self) -> str:
        """Display name of the law, ``"W2/W∞"``."""
        return "W2/W∞"


@dataclass
class HinfLaw:
    """Classic nonlinear H∞ inner law (Chen, Lee & Feng 1994 with integral action).

    Parameters
    ----------
    gains : HinfMechanicalGains
        From :func:`~sobolev_drake.synthesis.mechanical.hinf_mechanical_gains`.

    Examples
    --------
    >>> import sobolev_drake as sd
    >>> law = sd.HinfLaw(sd.hinf_mechanical_gains(10.0, 5.0, 1.0, omega_u=0.5, gamma=1.0))
    >>> law.name
    'H∞'
    """

    gains: HinfMechanicalGains

    def __post_init__(self):
        if not isinstance(self.gains, HinfMechanicalGains):
            raise TypeError("HinfLaw.gains must be HinfMechanicalGains (hinf_mechanical_gains(...)), "
                            f"got {type(self.gains).__name__}")

    @property
    def name(self) -> str:
        """Display name of the law, ``"H∞"``."""
        return "H∞"
