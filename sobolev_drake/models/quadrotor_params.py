"""Physical parameters of the quadrotor of thesis 5.3 (Table 5.4) and chapter 6 (6.5.3).

:class:`~sobolev_drake.models.quadrotor.QuadrotorModel` and the quadrotor rigs take a
:class:`QuadrotorParams`; it is re-exported by :mod:`sobolev_drake.models.quadrotor`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sobolev_drake.validation import check_parameter_fields

__all__ = ["QuadrotorParams"]


@dataclass(frozen=True)
class QuadrotorParams:
    """Table 5.4 (SI units; ``alpha`` in radians).

    Parameters
    ----------
    Ixx, Iyy, Izz : float, default 0.0363, 0.0363, 0.0615
        Principal moments of inertia of the body (kg m²); positive, triangle inequality.
    m : float, default 2.2
        Mass (kg).
    alpha : float, default 5° in rad
        Rotor tilt toward the centre (rad), in (−π/2, π/2).
    l : float, default 0.21
        Distance from the centre to each rotor (m).
    g : float, default 9.8
        Gravitational acceleration (m/s²).
    b : float, default 2.9e-5
        Thrust coefficient: thrust b Ω² along the rotor axis.
    d : float, default 6e-6
        Drag (reaction torque) coefficient: torque d Ω².
    """

    Ixx: float = 0.0363
    Iyy: float = 0.0363
    Izz: float = 0.0615
    m: float = 2.2
    alpha: float = np.deg2rad(5.0)
    l: float = 0.21
    g: float = 9.8
    b: float = 2.9e-5
    d: float = 6e-6

    @classmethod
    def chapter6_nominal(cls) -> "QuadrotorParams":
        """Centres of the ±10 % uncertainty boxes of section 6.5.3 (m = 2.24, Ixx = Iyy = 0.0384).

        Returns
        -------
        QuadrotorParams
            Table 5.4 with m, Ixx, Iyy replaced (Izz = 0.0615 unchanged).
        """
        return cls(Ixx=0.0384, Iyy=0.0384, Izz=0.0615, m=2.24)

    def __post_init__(self):
        self.validate()

    def validate(self) -> "QuadrotorParams":
        """Check the fields (``ValueError`` otherwise): positive values, |alpha| < π/2 and the
        triangle inequality of the inertias.

        Returns
        -------
        QuadrotorParams
            ``self``, for chaining.
        """
        check_parameter_fields(self, positive=("Ixx", "Iyy", "Izz", "m", "l", "g", "b", "d"))
        if not abs(self.alpha) < np.pi / 2:
            raise ValueError(f"quadrotor tilt alpha must be in (-pi/2, pi/2) rad, got {self.alpha}")
        I = (self.Ixx, self.Iyy, self.Izz)
        if max(I) > sum(I) - max(I):
            raise ValueError(f"quadrotor inertia {I} violates the triangle inequality")
        return self

    def hover_input(self) -> float:
        """Ω² per rotor that balances gravity: m g / (4 b cos α).

        Returns
        -------
        float
            The hover input Ω² (rad²/s²).
        """
        return self.m * self.g / (4 * self.b * np.cos(self.alpha))
