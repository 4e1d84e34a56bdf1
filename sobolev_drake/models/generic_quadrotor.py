"""The thesis quadrotor (5.123), Table 5.4, described as drone packages describe one: one
floating body (Drake's quaternion floating joint) and four Drake ``PropellerInfo``s, modelled by
``MechanicalModel.from_plant(plant, propellers=...)``.

Propeller i sits at l p̂_i with its axis tilted by α toward the centre (the poses of
:func:`~sobolev_drake.models.quadrotor.rotor_poses`), thrust ratio b and moment ratio s_i d
(command = Ω_i², so thrust b Ω² along the axis and reaction torque s_i d Ω² about it).  Drake's
``Propeller`` puts the reaction torque along the tilted axis: this is the dedicated model's
``reaction_torque="axial"`` reading, which the generic model equals to rounding
(tests/models/test_generic_quadrotor.py); the default ``"thesis"`` reading keeps only the
body-z component of that torque, which no propeller produces.
"""

from __future__ import annotations

import numpy as np
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant, PropellerInfo

from sobolev_drake.models.base import MechanicalModel
from sobolev_drake.models.floating_base import FloatingBaseModel
from sobolev_drake.models.quadrotor import ROTOR_SPIN, rotor_poses
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


def make_generic_quadrotor_model(params: QuadrotorParams | None = None, *,
                                 tilt: float | None = None) -> FloatingBaseModel:
    """The thesis quadrotor through the generic path: its description parsed into a plant with a
    quaternion floating base, modelled by ``from_plant(plant, propellers=...)``.

    Parameters
    ----------
    params : QuadrotorParams, optional
        Table 5.4 by default (its ``g`` sets the plant's gravity).
    tilt : float, optional
        Rotor inclination α (rad, default ``params.alpha``).

    Returns
    -------
    FloatingBaseModel
        q = [ϕ θ ψ x y z], inputs Ω_i², the dedicated model's ``reaction_torque="axial"``.

    Examples
    --------
    >>> import numpy as np
    >>> from sobolev_drake.models.generic_quadrotor import make_generic_quadrotor_model
    >>> from sobolev_drake.models.quadrotor import make_quadrotor_model
    >>> q = np.array([0.1, -0.2, 0.3, 1.0, 2.0, 3.0])
    >>> generic = make_generic_quadrotor_model()
    >>> dedicated = make_quadrotor_model(reaction_torque="axial")
    >>> bool(np.allclose(generic.B(q), dedicated.B(q)) and np.allclose(generic.M(q), dedicated.M(q)))
    True
    """
    p = (params or QuadrotorParams()).validate()
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModelsFromString(quadrotor_description(p), "sdf")
    plant.mutable_gravity_field().set_gravity_vector(np.array([0.0, 0.0, -p.g]))
    plant.Finalize()
    return MechanicalModel.from_plant(plant, propellers=quadrotor_propellers(plant, p, tilt=tilt),
                                      name="quadrotor (generic)")
