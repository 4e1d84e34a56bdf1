"""Two-wheeled self-balanced vehicle, thesis (4.30), Table 4.1 (Madero et al. 2010; Raffo et al. 2015).

    M(q) q̈ + C(q, q̇) q̇ + K(q̇) + G(q) = F(q) u + w,   q = [ϕ, θ],

    M = [[(M + m) r² + Ir, m l r cos θ], [m l r cos θ, m l² + Ip]],
    C q̇ = [−m l r sin θ θ̇², 0],  K(q̇) = [k ϕ̇, −k ϕ̇],  G = [0, −m g l sin θ],  F = [1, −1]ᵀ,

ϕ the wheel angle, θ the pendulum angle from the upright, u the motor torque (on the wheel, with
the reaction on the body).  Ip is the pendulum's inertia about its centre of mass (it appears as
m l² + Ip).

Drake model (docs/design.md §5): a prismatic axle coordinate x = r ϕ carrying the equivalent mass
M + Ir/r² and a revolute pendulum joint θ; the coordinate map T = diag(r, 1) turns Drake's M, C q̇,
g into exactly those of (4.30).  The friction K(q̇) is not part of the plant: the thesis adapter
subtracts ``friction(q̇)`` from the applied generalized force (τ = F u + w − K(q̇)).

The thesis' friction acts on the absolute wheel rate ϕ̇ (not on the motor's relative rate
ϕ̇ − θ̇); we follow the thesis.  Table 4.1 calls k a "static friction" but its unit
N m s/rad and its use make it viscous.  Chapters 5 (5.3.2) and 6 (6.5.2) reuse (4.30) and
Table 4.1 unchanged (no other parameter table is given).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from pydrake.systems.framework import DiagramBuilder

from sobolev_drake.models.base import MechanicalModel, check_vector
from sobolev_drake.models.handles import (PlantHandles, UrdfEditor, attach_adapter, build_plant,
                                          coordinate_map, urdf_text,
                                          verify_against_closed_forms)
from sobolev_drake.validation import check_parameter_fields

__all__ = ["TwoWheeledParams", "TwoWheeledModel", "make_two_wheeled_model", "add_two_wheeled"]


@dataclass(frozen=True)
class TwoWheeledParams:
    """Table 4.1 (SI units).

    All fields must be positive except ``k``, which may be zero.

    Parameters
    ----------
    Ir : float, default 0.0421
        Wheel inertia (kg m²).
    Ip : float, default 0.201
        Pendulum inertia about its centre of mass (kg m²).
    k : float, default 0.00215
        Viscous friction coefficient (N m s/rad).
    m : float, default 2.75
        Pendulum mass (kg).
    M : float, default 3.75
        Wheels' mass (kg).
    l : float, default 0.1435
        Distance from the axle to the pendulum's centre of mass (m).
    r : float, default 0.25
        Wheel radius (m).
    g : float, default 9.8
        Gravitational acceleration (m/s²).
    """

    Ir: float = 0.0421   # wheel inertia, kg m²
    Ip: float = 0.201    # pendulum inertia about its centre of mass, kg m²
    k: float = 0.00215   # viscous friction, N m s/rad
    m: float = 2.75      # pendulum mass, kg
    M: float = 3.75      # wheels' mass, kg
    l: float = 0.1435    # axle → pendulum centre of mass, m
    r: float = 0.25      # wheel radius, m
    g: float = 9.8       # gravity, m/s²

    def __post_init__(self):
        self.validate()

    def validate(self) -> "TwoWheeledParams":
        """Check the fields (positive, ``k`` non-negative; ``ValueError`` otherwise).

        Returns
        -------
        TwoWheeledParams
            ``self``, for chaining.
        """
        check_parameter_fields(self, positive=("Ir", "Ip", "m", "M", "l", "r", "g"), nonnegative=("k",))
        return self


def _two_wheeled_urdf(p: TwoWheeledParams) -> str:
    ed = UrdfEditor(urdf_text("two_wheeled"))
    ed.set_inertial("axle", p.M + p.Ir / p.r**2, [0, 0, 0], [1e-4] * 3)
    ed.set_inertial("body", p.m, [0, 0, p.l], [p.Ip, p.Ip, 0.5 * p.Ip])
    ed.set_joint_origin("x", [0, 0, p.r])
    for i, y in enumerate((0.2, -0.2)):
        ed.set_visual("axle", i, xyz=[0, y, 0], cylinder={"radius": p.r})
    height = max(2 * p.l, 2.5 * p.r)  # visual only: taller than the wheels so it shows
    ed.set_visual("body", 0, xyz=[0, 0, height / 2], box={"size": [0.08, 0.3, height]})
    return ed.text()


class TwoWheeledModel(MechanicalModel):
    """MechanicalModel of (4.30) in thesis coordinates q = [ϕ, θ] (Drake: [x = r ϕ, θ]).

    Parameters
    ----------
    plant : MultibodyPlant, optional
        A finalized plant built from ``urdf/two_wheeled.urdf`` with the same ``params``
        (checked against the closed forms); ``None`` builds a standalone one.
    params : TwoWheeledParams, optional
        Table 4.1 values by default.
    """

    num_inputs = 1

    def __init__(self, plant=None, params: TwoWheeledParams | None = None):
        self.params = (params or TwoWheeledParams()).validate()
        if plant is None:
            plant, _ = build_plant(_two_wheeled_urdf(self.params), self.params.g)
        T = coordinate_map(plant, [("x", self.params.r), ("theta", 1.0)])
        super().__init__(plant, coordinate_map=T, dof_names=["phi", "theta"], name="two_wheeled")
        verify_against_closed_forms(self, np.array([0.3, -0.8]))

    def M_closed_form(self, q: ArrayLike) -> np.ndarray:
        """Inertia matrix M(q) of (4.30).

        Parameters
        ----------
        q : array_like, shape (2,)
            [ϕ, θ] (rad).

        Returns
        -------
        ndarray, shape (2, 2)
            M(q).
        """
        q = check_vector("q", q, 2)
        p = self.params
        m12 = p.m * p.l * p.r * np.cos(q[1])
        return np.array([[(p.M + p.m) * p.r**2 + p.Ir, m12], [m12, p.m * p.l**2 + p.Ip]])

    def C_closed_form(self, q: ArrayLike, qdot: ArrayLike) -> np.ndarray:
        """C(q, q̇) of (4.30), with C q̇ = [−m l r sin θ θ̇², 0].

        Parameters
        ----------
        q, qdot : array_like, shape (2,)
            [ϕ, θ] and [ϕ̇, θ̇].

        Returns
        -------
        ndarray, shape (2, 2)
            C(q, q̇).
        """
        q = check_vector("q", q, 2)
        qdot = check_vector("qdot", qdot, 2)
        p = self.params
        return np.array([[0.0, -p.m * p.l * p.r * np.sin(q[1]) * qdot[1]], [0.0, 0.0]])

    def Cqdot_closed_form(self, q: ArrayLike, qdot: ArrayLike) -> np.ndarray:
        """C(q, q̇) q̇ from :meth:`C_closed_form`.

        Parameters
        ----------
        q, qdot : array_like, shape (2,)
            [ϕ, θ] and [ϕ̇, θ̇].

        Returns
        -------
        ndarray, shape (2,)
            C(q, q̇) q̇.
        """
        return self.C_closed_form(q, qdot) @ check_vector("qdot", qdot, 2)

    def g_closed_form(self, q: ArrayLike) -> np.ndarray:
        """G(q) = [0, −m g l sin θ] of (4.30).

        Parameters
        ----------
        q : array_like, shape (2,)
            [ϕ, θ] (rad).

        Returns
        -------
        ndarray, shape (2,)
            G(q).
        """
        q = check_vector("q", q, 2)
        p = self.params
        return np.array([0.0, -p.m * p.g * p.l * np.sin(q[1])])

    def friction(self, qdot: ArrayLike) -> np.ndarray:
        """K(q̇) = [k ϕ̇, −k ϕ̇] of (4.30) (left-hand side).

        Parameters
        ----------
        qdot : array_like, shape (2,)
            [ϕ̇, θ̇].

        Returns
        -------
        ndarray, shape (2,)
            K(q̇).
        """
        qdot = check_vector("qdot", qdot, 2)
        return self.params.k * qdot[0] * np.array([1.0, -1.0])

    def B(self, q: ArrayLike) -> np.ndarray:
        """F(q) = [1, −1]ᵀ: motor torque on the wheel, reaction on the body.

        Parameters
        ----------
        q : array_like, shape (2,)
            [ϕ, θ] (checked only).

        Returns
        -------
        ndarray, shape (2, 1)
            F.
        """
        check_vector("q", q, 2)
        return np.array([[1.0], [-1.0]])


def make_two_wheeled_model(params: TwoWheeledParams | None = None) -> TwoWheeledModel:
    """Standalone TwoWheeledModel on its own plant (no SceneGraph).

    Parameters
    ----------
    params : TwoWheeledParams, optional
        Table 4.1 values by default.

    Returns
    -------
    TwoWheeledModel
    """
    return TwoWheeledModel(None, params)


def add_two_wheeled(builder: DiagramBuilder, params: TwoWheeledParams | None = None) -> PlantHandles:
    """Add the vehicle (MultibodyPlant + SceneGraph + adapter) to ``builder``.

    The adapter applies τ = F u + w − K(q̇) (friction included).

    Parameters
    ----------
    builder : DiagramBuilder
        The builder the systems are added to.
    params : TwoWheeledParams, optional
        Table 4.1 values by default.

    Returns
    -------
    PlantHandles
        ``u`` = [motor torque] (N m); ``disturbance`` = [wϕ, wθ]; ``x`` = [ϕ θ ϕ̇ θ̇].
    """
    params = (params or TwoWheeledParams()).validate()
    plant, scene_graph = build_plant(_two_wheeled_urdf(params), params.g, builder)
    return attach_adapter(builder, plant, scene_graph, TwoWheeledModel(plant, params), "two_wheeled")


Params = TwoWheeledParams  # short alias
