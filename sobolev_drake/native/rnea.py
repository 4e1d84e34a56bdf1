"""Constants of the compiled inverse-dynamics kernel (``native/rnea.c``) from a MultibodyPlant.

:func:`tree_model` reads the kinematic tree, joint frames and axes, inertias and gravity from a
finalized plant (and optionally a context's parameter values) and packs them into the kernel's
model capsule; ``_rnea.inverse_dynamics(capsule, x, vdot)`` then returns what
``plant.CalcForceElementsContribution(ctx, f); plant.CalcInverseDynamics(ctx, vdot, f)`` returns
after ``plant.SetPositionsAndVelocities(ctx, x)``, i.e. M(q) v̇ + C(q, v) v − τ_g(q).

The kernel covers trees of 1-DOF revolute and prismatic joints whose only force element is the
uniform gravity field.  Everything else Drake would add to that result is refused (None, the
caller keeps the pydrake path) rather than modelled: joint damping (a force element
contribution), the reflected inertia of joint actuators (added by CalcInverseDynamics), locked
joints (change CalcInverseDynamics), gravity switched off for a model instance, any other force
element or joint type, and discrete plants.  :func:`unsupported_reason` says why a plant is
refused.

The capsule holds the parameter values read when it is built: a later change of the context's
parameters (masses, frame poses, damping, ...) is not seen by it.
"""

from __future__ import annotations

from types import ModuleType
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

import sobolev_drake.native as _native
from sobolev_drake.native import kernel
from sobolev_drake.errors import ModelError

if TYPE_CHECKING:
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.systems.framework import Context

    from sobolev_drake.models.base import MechanicalModel

__all__ = ["tree_model", "cached_tree_kernel", "tree_constants", "unsupported_reason"]

REVOLUTE, PRISMATIC = 0, 1


class Unsupported(ModelError, ValueError):
    """The plant has a feature the kernel does not model."""


def tree_model(plant: MultibodyPlant, context: Context | None = None, *,
               coordinates: Sequence[int] | None = None) -> Any:
    """Kernel model capsule of ``plant`` or None when the ``rnea`` kernel is not built or
    disabled, or the plant is outside what the kernel covers (see the module docstring).

    ``context``: a context of ``plant`` whose parameter values (inertias, frame poses, damping,
    reflected inertias) and joint locks to use and check; None uses the plant's defaults.
    ``coordinates``: the caller's coordinate order, ``coordinates[k]`` = index in the caller's
    q, v, v̇ and τ of Drake's coordinate k (default: Drake's order), so a caller in another
    order needs no permutation per call.
    """
    k = kernel("rnea")
    if k is None:
        return None
    try:
        constants = tree_constants(plant, context, coordinates=coordinates)
    except Unsupported:
        return None
    return k.make_model(constants)


def cached_tree_kernel(cache: dict, model: MechanicalModel,
                       coordinates: Sequence[int] | None) -> tuple[ModuleType, Any] | None:
    """(kernel module, capsule) for the plant and context of ``model`` (a MechanicalModel) in
    the caller's ``coordinates`` (see :func:`tree_model`), or None: built once into
    ``cache["rnea"]`` (None cached too: not built, or a plant the kernel does not cover);
    ``sobolev_drake.native.enabled()`` is checked at every call, so ``native.disabled()``
    switches the kernel off after the capsule was built."""
    if not _native.enabled():
        return None
    try:
        return cache["rnea"]
    except KeyError:
        capsule = tree_model(model.plant, model.context, coordinates=coordinates)
        entry = cache["rnea"] = None if capsule is None else (kernel("rnea"), capsule)
        return entry


def unsupported_reason(plant: MultibodyPlant, context: Context | None = None) -> str | None:
    """Why :func:`tree_model` refuses ``plant`` (None if it is covered)."""
    try:
        tree_constants(plant, context)
    except Unsupported as exc:
        return str(exc)
    return None


def tree_constants(plant: MultibodyPlant, context: Context | None = None, *,
                   coordinates: Sequence[int] | None = None) -> dict:
    """The ``make_model`` dictionary of ``plant`` (bodies in topological order); raises
    :class:`Unsupported` naming the first feature the kernel does not cover."""
    from pydrake.multibody.tree import (BodyIndex, ForceElementIndex, PrismaticJoint,
                                        RevoluteJoint, UniformGravityFieldElement)

    if not plant.is_finalized():
        raise Unsupported("the plant is not finalized")
    if plant.time_step() != 0.0:
        raise Unsupported("discrete plant (time_step > 0)")
    if context is not None:
        plant.ValidateContext(context)
    _check_force_elements(plant, ForceElementIndex, UniformGravityFieldElement)
    _check_actuators(plant, context)
    inboard = {}                 # child body index -> its joint
    for index in plant.GetJointIndices():
        joint = plant.get_joint(index)
        if not isinstance(joint, (RevoluteJoint, PrismaticJoint)):
            raise Unsupported(f"joint {joint.name()!r} is a {joint.type_name()} joint")
        if joint.position_start() != joint.velocity_start():
            raise Unsupported(f"joint {joint.name()!r}: position and velocity indices differ")
        damping = joint.default_damping() if context is None else joint.GetDamping(context)
        if damping != 0.0:
            raise Unsupported(f"joint {joint.name()!r} has damping {damping}")
        if context is not None and joint.is_locked(context):
            raise Unsupported(f"joint {joint.name()!r} is locked in the context")
        child = int(joint.child_body().index())
        if child in inboard:
            raise Unsupported(f"body {joint.child_body().name()!r} has two inboard joints")
        inboard[child] = joint

    n = plant.num_positions()
    if n < 1 or plant.num_velocities() != n:
        raise Unsupported(f"needs nq = nv >= 1, got nq = {n}, nv = {plant.num_velocities()}")
    if plant.num_bodies() - 1 != n:
        raise Unsupported(f"{plant.num_bodies() - 1} bodies for {n} coordinates (not one "
                          "1-DOF joint per body)")
    order = list(range(n)) if coordinates is None else [int(c) for c in coordinates]
    if sorted(order) != list(range(n)):
        raise ValueError(f"coordinates must be a permutation of 0..{n - 1}, got {coordinates}")

    bodies = _topological_order(plant, inboard, BodyIndex)
    position = {b: i for i, b in enumerate(bodies)}
    keys = ("parent", "joint_type", "dof", "axis", "R_PF", "p_PF", "R_BM", "p_BM", "mass",
            "com", "inertia_Bo")
    out = {key: [] for key in keys}
    for b in bodies:
        joint, body = inboard[b], plant.get_body(BodyIndex(b))
        if not plant.is_gravity_enabled(body.model_instance()):
            raise Unsupported(f"gravity is disabled for the model instance of {body.name()!r}")
        parent = int(joint.parent_body().index())
        out["parent"].append(-1 if parent == 0 else position[parent])
        revolute = isinstance(joint, RevoluteJoint)
        out["joint_type"].append(REVOLUTE if revolute else PRISMATIC)
        out["dof"].append(order[joint.position_start()])
        axis = joint.revolute_axis() if revolute else joint.translation_axis()
        out["axis"] += np.asarray(axis, dtype=float).tolist()
        for frame, key in ((joint.frame_on_parent(), "PF"), (joint.frame_on_child(), "BM")):
            X = (frame.GetFixedPoseInBodyFrame() if context is None
                 else frame.CalcPoseInBodyFrame(context))
            out["R_" + key] += X.rotation().matrix().ravel().tolist()
            out["p_" + key] += np.asarray(X.translation(), dtype=float).tolist()
        M = (body.default_spatial_inertia() if context is None
             else body.CalcSpatialInertiaInBodyFrame(context))
        out["mass"].append(float(M.get_mass()))
        out["com"] += np.asarray(M.get_com(), dtype=float).tolist()
        out["inertia_Bo"] += M.CalcRotationalInertia().CopyToFullMatrix3().ravel().tolist()
    out = {key: [float(x) for x in values] for key, values in out.items()}
    out["gravity"] = np.asarray(plant.gravity_field().gravity_vector(), dtype=float).tolist()
    bad = [key for key, values in out.items() if not np.all(np.isfinite(values))]
    if bad:
        raise Unsupported(f"non-finite {', '.join(bad)}")
    out["n"] = n
    return out


def _check_force_elements(plant, ForceElementIndex, UniformGravityFieldElement):
    for i in range(plant.num_force_elements()):
        element = plant.get_force_element(ForceElementIndex(i))
        if not isinstance(element, UniformGravityFieldElement):
            raise Unsupported(f"force element {type(element).__name__} (only the uniform "
                              "gravity field is modelled)")


def _check_actuators(plant, context):
    for index in plant.GetJointActuatorIndices():
        act = plant.get_joint_actuator(index)
        reflected = (act.default_reflected_inertia() if context is None
                     else act.calc_reflected_inertia(context))
        if reflected != 0.0:
            raise Unsupported(f"actuator {act.name()!r} has reflected inertia {reflected}")


def _topological_order(plant, inboard, BodyIndex):
    """Non-world body indices, each after its parent (breadth first from the world)."""
    children = {}
    for child, joint in inboard.items():
        children.setdefault(int(joint.parent_body().index()), []).append(child)
    order, frontier = [], [0]
    while frontier:
        nxt = []
        for b in frontier:
            for c in sorted(children.get(b, ())):
                order.append(c)
                nxt.append(c)
        frontier = nxt
    missing = set(range(1, plant.num_bodies())) - set(order)
    if missing:
        names = sorted(plant.get_body(BodyIndex(b)).name() for b in missing)
        raise Unsupported(f"bodies not connected to the world by the joints: {names}")
    return order
