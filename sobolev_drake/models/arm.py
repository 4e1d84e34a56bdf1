"""Planar two-link manipulator, thesis (5.119)–(5.122), Table 5.1 (Spong et al. 2006).

q = [q1, q2]: q1 angle of link 1 from the horizontal, q2 angle of link 2 relative to link 1;
both joints actuated (B = I), gravity in the plane of motion.

The thesis' printed d11 and d12 contain typos; the closed forms here are the standard Spong
model, which is also what the URDF produces::

    d11 = m1 lc1² + m2 (l1² + lc2² + 2 l1 lc2 cos q2) + I1 + I2
          (thesis prints an extra ``2 l1 (l2/2)²`` term inside the m2 bracket),
    d12 = m2 (lc2² + l1 lc2 cos q2) + I2
          (thesis prints ``l1 (l2/2)² cos q2``, i.e. lc2 squared once too often),
    d22 = m2 lc2² + I2,

with lc_i = l_i / 2 and I_i the moment of inertia of link i about its centre of mass.
C (5.121) and g (5.122) are printed correctly.

The printed matrix is kept as a reading (``inertia="thesis-printed"``,
:class:`ThesisPrintedArmModel`): it is what reproduces the thesis' Table 5.3 W2/W∞ row
(docs/experiments/manipulator.md).  It is not an Euler–Lagrange model (the printed C is not
built from its Christoffel symbols), so no URDF has it: the plant stays the physical
MultibodyPlant and its adapter applies the force that makes it follow the printed equations.

The closed forms and B accept arrays of Drake scalars (``AutoDiffXd``, ``Expression``) as well
as numbers, so scalar-converted controllers and adapters (``Linearize``) can use them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from pydrake.systems.framework import DiagramBuilder

from sobolev_drake.models.base import MechanicalModel
from sobolev_drake.models.handles import (PlantHandles, UrdfEditor, attach_adapter, build_plant,
                                          coordinate_map, urdf_text,
                                          verify_against_closed_forms)
from sobolev_drake.models.scalar_terms import scalar_vector
from sobolev_drake.validation import check_parameter_fields

__all__ = ["ArmParams", "INERTIA_READINGS", "TwoLinkArmModel", "ThesisPrintedArmModel",
           "make_arm_model", "add_arm"]

#: the arm's inertia matrix: the physical one (Spong) or the thesis' printed (5.120)
INERTIA_READINGS = ("physical", "thesis-printed")


@dataclass(frozen=True)
class ArmParams:
    """Table 5.1: I1 = I2 = 1 kg m², m1 = m2 = 1 kg, l1 = l2 = 1 m, g = 9.8 m/s².

    All fields must be positive.

    Parameters
    ----------
    m1, m2 : float, default 1.0
        Link masses (kg).
    l1, l2 : float, default 1.0
        Link lengths (m); the centres of mass are at mid-link, lc_i = l_i / 2.
    I1, I2 : float, default 1.0
        Moments of inertia of the links about their centres of mass (kg m²).
    g : float, default 9.8
        Gravitational acceleration (m/s²).
    """

    m1: float = 1.0
    m2: float = 1.0
    l1: float = 1.0
    l2: float = 1.0
    I1: float = 1.0
    I2: float = 1.0
    g: float = 9.8

    def __post_init__(self):
        check_parameter_fields(self, positive=("m1", "m2", "l1", "l2", "I1", "I2", "g"))

    @property
    def lc1(self) -> float:
        """Distance of link 1's centre of mass from joint 1, l1 / 2 (m)."""
        return self.l1 / 2

    @property
    def lc2(self) -> float:
        """Distance of link 2's centre of mass from joint 2, l2 / 2 (m)."""
        return self.l2 / 2


def _arm_urdf(p: ArmParams) -> str:
    ed = UrdfEditor(urdf_text("arm"))
    for name, m, l, inertia in (("link1", p.m1, p.l1, p.I1), ("link2", p.m2, p.l2, p.I2)):
        if min(m, l, inertia) <= 0:
            raise ValueError(f"arm masses, lengths and inertias must be positive, got {p}")
        # Ixx (along the link) only has to keep the inertia physically valid.
        ed.set_inertial(name, m, [l / 2, 0, 0], [0.05 * inertia, inertia, inertia])
        ed.set_visual(name, 0, xyz=[l / 2, 0, 0], box={"size": [l, 0.06, 0.06]})
    ed.set_joint_origin("q2", [p.l1, 0, 0])
    return ed.text()


class TwoLinkArmModel(MechanicalModel):
    """MechanicalModel of the two-link arm with the closed forms (5.120)–(5.122).

    Parameters
    ----------
    plant : MultibodyPlant, optional
        A finalized plant built from ``urdf/arm.urdf`` with the same ``params`` (checked
        against the closed forms); ``None`` builds a standalone one.
    params : ArmParams, optional
        Table 5.1 values by default.
    """

    num_inputs = 2

    def __init__(self, plant=None, params: ArmParams | None = None):
        self.params = params or ArmParams()
        if plant is None:
            plant, _ = build_plant(_arm_urdf(self.params), self.params.g)
        super().__init__(plant, coordinate_map=coordinate_map(plant, [("q1", 1.0), ("q2", 1.0)]),
                         dof_names=["q1", "q2"], name="arm")
        verify_against_closed_forms(self, np.array([0.3, -0.8]))

    # --- thesis closed forms -------------------------------------------------------------------
    def M_closed_form(self, q: ArrayLike) -> np.ndarray:
        """Inertia matrix (5.120) with the d11/d12 typos corrected (module docstring).

        Parameters
        ----------
        q : array_like, shape (2,)
            [q1, q2] (rad).

        Returns
        -------
        ndarray, shape (2, 2)
            M(q).
        """
        q = scalar_vector("q", q, 2)
        p = self.params
        c2 = np.cos(q[1])
        d11 = p.m1 * p.lc1**2 + p.m2 * (p.l1**2 + p.lc2**2 + 2 * p.l1 * p.lc2 * c2) + p.I1 + p.I2
        d12 = p.m2 * (p.lc2**2 + p.l1 * p.lc2 * c2) + p.I2
        d22 = p.m2 * p.lc2**2 + p.I2
        return np.array([[d11, d12], [d12, d22]])

    def M_printed(self, q: ArrayLike) -> np.ndarray:
        """Inertia matrix (5.120) exactly as printed: d11 with the extra m2·2 l1 lc2² and d12
        with l1 lc2² cos q2 (module docstring); positive definite for Table 5.1.

        Parameters
        ----------
        q : array_like, shape (2,)
            [q1, q2] (rad).

        Returns
        -------
        ndarray, shape (2, 2)
            The printed M(q).
        """
        q = scalar_vector("q", q, 2)
        p = self.params
        c2 = np.cos(q[1])
        d11 = (p.m1 * p.lc1**2 + p.m2 * (p.l1**2 + p.lc2**2 + 2 * p.l1 * p.lc2**2 + 2 * p.l1 * p.lc2 * c2)
               + p.I1 + p.I2)
        d12 = p.m2 * (p.lc2**2 + p.l1 * p.lc2**2 * c2) + p.I2
        d22 = p.m2 * p.lc2**2 + p.I2
        return np.array([[d11, d12], [d12, d22]])

    def C_closed_form(self, q: ArrayLike, qdot: ArrayLike) -> np.ndarray:
        """C(q, q̇) of (5.121), h = −m2 l1 lc2 sin q2.

        Parameters
        ----------
        q, qdot : array_like, shape (2,)
            Joint angles and rates.

        Returns
        -------
        ndarray, shape (2, 2)
            C(q, q̇).
        """
        q = scalar_vector("q", q, 2)
        qdot = scalar_vector("qdot", qdot, 2)
        p = self.params
        h = -p.m2 * p.l1 * p.lc2 * np.sin(q[1])
        return np.array([[h * qdot[1], h * (qdot[0] + qdot[1])], [-h * qdot[0], 0.0]])

    def Cqdot_closed_form(self, q: ArrayLike, qdot: ArrayLike) -> np.ndarray:
        """C(q, q̇) q̇ from :meth:`C_closed_form`.

        Parameters
        ----------
        q, qdot : array_like, shape (2,)
            Joint angles and rates.

        Returns
        -------
        ndarray, shape (2,)
            C(q, q̇) q̇.
        """
        return self.C_closed_form(q, qdot) @ scalar_vector("qdot", qdot, 2)

    def g_closed_form(self, q: ArrayLike) -> np.ndarray:
        """Gravity vector g(q) of (5.122).

        Parameters
        ----------
        q : array_like, shape (2,)
            [q1, q2] (rad).

        Returns
        -------
        ndarray, shape (2,)
            g(q).
        """
        q = scalar_vector("q", q, 2)
        p = self.params
        g2 = p.m2 * p.lc2 * p.g * np.cos(q[0] + q[1])
        return np.array([(p.m1 * p.lc1 + p.m2 * p.l1) * p.g * np.cos(q[0]) + g2, g2])

    def B(self, q: ArrayLike) -> np.ndarray:
        """B = I (both joints actuated, (5.119)).

        Parameters
        ----------
        q : array_like, shape (2,)
            Joint angles (checked only).

        Returns
        -------
        ndarray, shape (2, 2)
            The identity.
        """
        scalar_vector("q", q, 2)
        return np.eye(2)


class ThesisPrintedArmModel(TwoLinkArmModel):
    """The arm with the thesis' printed inertia matrix (5.120) in place of the physical one;
    C q̇ and g stay the plant's (printed correctly).  ``M_closed_form`` stays the physical one:
    the plant is checked against it.

    As a controller's model it gives the thesis' W2/W∞ law; as a simulated plant
    (``add_arm(..., inertia="thesis-printed")``) its adapter makes the physical MultibodyPlant
    follow M_printed q̈ + C q̇ + g = τ + w.

    Parameters
    ----------
    plant : MultibodyPlant, optional
        As for :class:`TwoLinkArmModel` (the physical plant).
    params : ArmParams, optional
        Table 5.1 values by default.
    """

    #: the adapter applies the force that makes the plant follow this model's equations
    follows_own_equations = True

    def M(self, q: ArrayLike) -> np.ndarray:
        """The printed inertia matrix :meth:`~TwoLinkArmModel.M_printed`.

        Parameters
        ----------
        q : array_like, shape (2,)
            [q1, q2] (rad).

        Returns
        -------
        ndarray, shape (2, 2)
        """
        return self.M_printed(q)


def _check_inertia(inertia):
    if inertia not in INERTIA_READINGS:
        raise ValueError(f"inertia must be one of {INERTIA_READINGS}, got {inertia!r}")
    return TwoLinkArmModel if inertia == "physical" else ThesisPrintedArmModel


def make_arm_model(params: ArmParams | None = None, inertia: str = "physical") -> TwoLinkArmModel:
    """Standalone arm model on its own plant (no SceneGraph).

    Parameters
    ----------
    params : ArmParams, optional
        Table 5.1 values by default.
    inertia : str, default "physical"
        One of :data:`INERTIA_READINGS`: the physical M or the thesis' printed (5.120).

    Returns
    -------
    TwoLinkArmModel
        A :class:`ThesisPrintedArmModel` for ``inertia="thesis-printed"``.
    """
    return _check_inertia(inertia)(None, params)


def add_arm(builder: DiagramBuilder, params: ArmParams | None = None,
            inertia: str = "physical") -> PlantHandles:
    """Add the arm (MultibodyPlant + SceneGraph + adapter) to ``builder``.

    Parameters
    ----------
    builder : DiagramBuilder
        The builder the systems are added to.
    params : ArmParams, optional
        Table 5.1 values by default.
    inertia : str, default "physical"
        One of :data:`INERTIA_READINGS`; "thesis-printed" simulates the printed (5.120).

    Returns
    -------
    PlantHandles
        ``u`` = joint torques [τ1, τ2] (N m); ``disturbance`` = [w1, w2];
        ``x`` = [q1 q2 q̇1 q̇2].
    """
    model_class = _check_inertia(inertia)
    params = params or ArmParams()
    plant, scene_graph = build_plant(_arm_urdf(params), params.g, builder)
    return attach_adapter(builder, plant, scene_graph, model_class(plant, params), "arm")


Params = ArmParams  # short alias
