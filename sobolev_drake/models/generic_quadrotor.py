"""The thesis quadrotor (5.123), Table 5.4, described as drone packages describe one: one
floating body (Drake's quaternion floating joint) and four Drake ``PropellerInfo``s, modelled by
``MechanicalModel.from_plant(plant, propellers=...)``.

Propeller i sits at l p̂_i with its axis tilted by α toward the centre (the poses of
:func:`~sobolev_drake.models.quadrotor.rotor_poses`), thrust ratio b and moment ratio s_i d
(command = Ω_i², so thrust b Ω² along the axis and reaction torque s_i d Ω² about it).  Drake's
``Propeller`` puts the reaction torque along the tilted axis (the dedicated model's
``reaction_torque="axial"``); the thesis' B₀ of (5.123) (the dedicated default
``"thesis"``) keeps only its body-z component s_i d cos α, which the generic model gives with
``from_plant(..., reaction_torque="body_z")``.  Either way the generic model equals the
dedicated one to rounding (tests/models/test_generic_quadrotor.py).  No Drake ``Propeller``
applies the body-z-only torque: the dedicated simulated plant applies B(q) τ of its model as a
generalized force (its adapter), and at the experiments' untilted truth (α = 0) the two
readings coincide.
"""

from __future__ import annotations

import numpy as np
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant, PropellerInfo

from sobolev_drake.models.base import MechanicalModel
from sobolev_drake.models.floating_base import FloatingBaseModel
from sobolev_drake.models.quadrotor import REACTION_MODES, ROTOR_SPIN, rotor_poses
from sobolev_drake.models.quadrotor_params import QuadrotorParams

__all__ = ["quadrotor_description", "quadrotor_propellers", "make_generic_quadrotor_model"]


def quadrotor_description(params: QuadrotorParams | None = None) -> str:
    """SDFormat text of the thesis quadrotor's body: mass and inertia of Table 5.4, no joints
    (Drake gives the free body a quaternion floating joint).

    Parameters
    ----------
    params : QuadrotorParams, optional
        Table 5.4 by default.

    Returns
    -------
    str
    """
    p = (params or QuadrotorParams()).validate()
    return (f'<sdf version="1.7"><model name="quadrotor"><link name="body"><inertial>'
            f"<mass>{p.m!r}</mass><inertia><ixx>{p.Ixx!r}</ixx><iyy>{p.Iyy!r}</iyy>"
            f"<izz>{p.Izz!r}</izz><ixy>0</ixy><ixz>0</ixz><iyz>0</iyz></inertia></inertial>"
            f'<visual name="arms"><geometry><box><size>{2 * p.l!r} {2 * p.l!r} 0.02</size></box>'
            "</geometry></visual></link></model></sdf>")


def quadrotor_propellers(plant: MultibodyPlant, params: QuadrotorParams | None = None, *,
                         tilt: float | None = None) -> list[PropellerInfo]:
    """The four rotors of (5.123) as Drake ``PropellerInfo`` (command Ω_i²).

    Parameters
    ----------
    plant : MultibodyPlant
        Plant holding the body ``body``.
    params : QuadrotorParams, optional
        Table 5.4 by default.
    tilt : float, optional
        Rotor inclination α (rad, default ``params.alpha``).

    Returns
    -------
    list of PropellerInfo
    """
    p = (params or QuadrotorParams()).validate()
    alpha = p.alpha if tilt is None else float(tilt)
    body = plant.GetBodyByName("body").index()
    return [PropellerInfo(body, X_BR, p.b, s * p.d)
            for X_BR, s in zip(rotor_poses(p.l, alpha), ROTOR_SPIN)]


#: the dedicated model's reaction-torque readings → the floating-base model's
_REACTION_TORQUE = {"thesis": "body_z", "axial": "axial"}


def make_generic_quadrotor_model(params: QuadrotorParams | None = None, *,
                                 tilt: float | None = None,
                                 reaction_torque: str = "thesis") -> FloatingBaseModel:
    """The thesis quadrotor through the generic path: its description parsed into a plant with a
    quaternion floating base, modelled by ``from_plant(plant, propellers=...)``.

    Parameters
    ----------
    params : QuadrotorParams, optional
        Table 5.4 by default (its ``g`` sets the plant's gravity).
    tilt : float, optional
        Rotor inclination α (rad, default ``params.alpha``).
    reaction_torque : {"thesis", "axial"}, default "thesis"
        As in :class:`~sobolev_drake.models.quadrotor.QuadrotorModel`: ``"thesis"`` is the
        body-z drag torque d cos α of (5.123) (``from_plant(..., reaction_torque="body_z")``),
        ``"axial"`` the torque along the tilted axis (Drake's ``Propeller``).

    Returns
    -------
    FloatingBaseModel
        q = [ϕ θ ψ x y z], inputs Ω_i², equal to ``QuadrotorModel(reaction_torque=...)``.

    Raises
    ------
    ValueError
        ``reaction_torque`` is not one of ``"thesis"``, ``"axial"``.

    Examples
    --------
    >>> import numpy as np
    >>> from sobolev_drake.models.generic_quadrotor import make_generic_quadrotor_model
    >>> from sobolev_drake.models.quadrotor import make_quadrotor_model
    >>> q = np.array([0.1, -0.2, 0.3, 1.0, 2.0, 3.0])
    >>> generic = make_generic_quadrotor_model()          # the thesis reading, (5.123)
    >>> dedicated = make_quadrotor_model()
    >>> bool(np.allclose(generic.B(q), dedicated.B(q)) and np.allclose(generic.M(q), dedicated.M(q)))
    True
    """
    if reaction_torque not in REACTION_MODES:
        raise ValueError(f"reaction_torque must be one of {REACTION_MODES}, got {reaction_torque!r}")
    p = (params or QuadrotorParams()).validate()
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModelsFromString(quadrotor_description(p), "sdf")
    plant.mutable_gravity_field().set_gravity_vector(np.array([0.0, 0.0, -p.g]))
    plant.Finalize()
    return MechanicalModel.from_plant(plant, propellers=quadrotor_propellers(plant, p, tilt=tilt),
                                      name="quadrotor (generic)",
                                      reaction_torque=_REACTION_TORQUE[reaction_torque])
