"""Tilt-rotor UAV plant (thesis section 7.2, Table B.1) on a MultibodyPlant.

* :func:`tiltrotor_urdf` (from :mod:`sobolev_drake.tiltrotor.urdf`, re-exported here) writes
  the URDF from :class:`TiltrotorParams`: main body C1 attached to the world by the x, y, z,
  yaw, pitch, roll joint chain of docs/design.md §3 (so q̇ = v), and two thruster groups on
  revolute servo joints at A2/A3.  The joint frame is rotated by Rx(∓β) and the axis written
  in it is Rx(∓β)ᵀ e_y, so the child frame is exactly A2 = Ry(αR) Rx(−β) (resp. A3 = Ry(αL) Rx(β)) and the tilt axis is B's y axis.
* :class:`TiltrotorModel` — MechanicalModel in thesis order q = [αR αL φ θ ψ x y z].
* :func:`add_tiltrotor` — plant + SceneGraph + force system in a DiagramBuilder.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike
from pydrake.multibody.parsing import Parser
from pydrake.math import RigidTransform
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.multibody.tree import FixedOffsetFrame

from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem_, ValueProducer
from pydrake.systems.scalar_conversion import TemplateSystem

from sobolev_drake.models.base import MechanicalModel
from sobolev_drake.models.handles import PlantHandles, add_state_selector
from sobolev_drake.tiltrotor.params import DOF_NAMES, TiltrotorParams
from sobolev_drake.tiltrotor.generic_forces import force_at_c1, tiltrotor_force_generic
from sobolev_drake.tiltrotor.propulsion import body_kinematics_scalar
from sobolev_drake.tiltrotor.scalars import default_instantiation, scalar_math
from sobolev_drake.tiltrotor.urdf import marker_frames, tiltrotor_urdf

if TYPE_CHECKING:
    from pydrake.systems.framework import Context, DiagramBuilder

__all__ = [
    "tiltrotor_urdf", "thesis_coordinate_map", "TiltrotorModel", "TiltrotorForces",
    "TiltrotorForces_", "TiltrotorHandles", "add_tiltrotor",
]

#: Drake joint of each thesis coordinate
JOINTS = ("tilt_right", "tilt_left", "base_roll", "base_pitch", "base_yaw", "base_x", "base_y", "base_z")


def _build_plant(params, builder=None):
    if builder is None:
        plant, scene_graph = MultibodyPlant(time_step=0.0), None
    else:
        plant, scene_graph = AddMultibodyPlantSceneGraph(builder, time_step=0.0)
    (instance,) = Parser(plant).AddModelsFromString(tiltrotor_urdf(params, marker_links=False),
                                                    "urdf")
    for name, parent, d in marker_frames(params):       # the URDF's frame_* links as frames
        plant.AddFrame(FixedOffsetFrame(name, plant.GetBodyByName(parent, instance).body_frame(),
                                        RigidTransform(np.asarray(d, dtype=float)), instance))
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, -float(params.g)])
    plant.Finalize()
    return plant, scene_graph


def thesis_coordinate_map(plant: MultibodyPlant) -> np.ndarray:
    """Permutation T with q_drake = T q_thesis for q_thesis = [αR αL φ θ ψ x y z].

    Parameters
    ----------
    plant : MultibodyPlant
        A finalized tilt-rotor plant (built from :func:`tiltrotor_urdf`), whose joints are
        named as in ``JOINTS``.

    Returns
    -------
    ndarray, shape (8, 8)
        T, a permutation matrix: column j has its 1 at the Drake position index of thesis
        coordinate j (the same T maps the velocities).
    """
    n = plant.num_positions()
    T = np.zeros((n, n))
    for j, name in enumerate(JOINTS):
        T[plant.GetJointByName(name).position_start(), j] = 1.0
    return T


class TiltrotorModel(MechanicalModel):
    """Euler–Lagrange model (7.14) of the tilt-rotor in thesis order q = [αR αL φ θ ψ x y z].

    ``M``, ``Cqdot``, ``g`` come from Drake (equal to (7.16) and its Christoffel symbols, tested);
    the generalized forces (7.18) are in :mod:`sobolev_drake.tiltrotor.propulsion`,
    :mod:`sobolev_drake.tiltrotor.aerodynamics` and :func:`sobolev_drake.tiltrotor.input_affine.input_affine`.

    Parameters
    ----------
    params : TiltrotorParams, optional
        Table B.1 by default.
    plant : MultibodyPlant, optional
        A finalized plant built from ``params`` (as :func:`add_tiltrotor` does); ``None``
        builds a standalone one.
    """

    num_inputs = 8

    def __init__(self, params: TiltrotorParams | None = None,
                 plant: MultibodyPlant | None = None) -> None:
        self.params = TiltrotorParams() if params is None else params
        if plant is None:
            plant, _ = _build_plant(self.params)
        super().__init__(plant, coordinate_map=thesis_coordinate_map(plant), dof_names=DOF_NAMES,
                         name="tiltrotor")

    frictionless = True

    def friction(self, qdot: ArrayLike) -> np.ndarray:
        """K(q̇) = 0: the servo friction ν α̇ (7.33) is part of the generalized forces (passive
        term of (7.62)), not of the left-hand side.  Same as the base class, cheaper check
        (the controller asks for it at every sample).

        Parameters
        ----------
        qdot : array_like, shape (8,)
            Generalized velocities, thesis order.

        Returns
        -------
        ndarray, shape (8,)
            Zeros.
        """
        arr = np.asarray(qdot, dtype=float)
        if arr.shape != (8,) or not np.isfinite(arr).all():
            return super().friction(qdot)          # raises the descriptive error
        return np.zeros(8)

    def B(self, q: ArrayLike, qdot: ArrayLike | None = None,
          zeta: ArrayLike | None = None) -> np.ndarray:
        """Input-coupling matrix B(q, q̇, ζ) of (7.62) (columns ``ACTUATOR_NAMES``).

        Computed by :func:`sobolev_drake.tiltrotor.input_affine.input_affine` with its defaults
        (reference propeller speeds, drag torque through the thrust columns).

        Parameters
        ----------
        q : array_like, shape (8,)
            Generalized coordinates, thesis order.
        qdot : array_like, shape (8,), optional
            Generalized velocities (default zero).
        zeta : array_like, shape (3,), optional
            Wind velocity ζ, inertial frame, m/s (default zero).

        Returns
        -------
        ndarray, shape (8, 8)
            B(q, q̇, ζ).
        """
        from sobolev_drake.tiltrotor.input_affine import input_affine
        qdot = np.zeros(8) if qdot is None else qdot
        zeta = np.zeros(3) if zeta is None else zeta
        return input_affine(self, q, qdot, zeta)[0]


_NOTHING_KNOWN = (False,) * 7     # no port of the force system known to have a value


@TemplateSystem.define("TiltrotorForces_")
def TiltrotorForces_(T):                         # noqa: D103 - the template of the class below
    m = scalar_math(T)

    class Impl(LeafSystem_[T]):
        """All generalized forces of the tilt-rotor in one LeafSystem (one Python call per evaluation).

        .. pydrake_system::

            name: TiltrotorForces
            input_ports:
            - plant_state
            - u
            - propeller_speed
            - servo_torque
            - surface_deflection
            - wind
            - force_disturbance
            - disturbance
            output_ports:
            - x
            - applied_generalized_force
            - generalized_force

        Input ports (all read zero when unconnected, except ``plant_state``):
        ``u`` (8, thesis τ = [nPR nPL τsR τsL δWR δWL δTR δTL]), ``propeller_speed`` (2, rev/s),
        ``servo_torque`` (2, N m), ``surface_deflection`` (4, rad) — the last three are *added* to the
        matching parts of ``u`` (connect either); ``wind`` (3, inertial m/s), ``force_disturbance``
        (3, inertial N at the main-body centre of mass), ``disturbance`` (8, thesis generalized force
        w), ``plant_state`` (Drake state).
        Output ports: ``applied_generalized_force`` (Drake order, to the plant), ``x`` (16, thesis
        order [q; q̇], state-only), ``generalized_force`` (8, thesis order ϑ + w, for logging).

        ``native``: None (default) computes the forces with the compiled kernel
        (``native/forces.c``, equal to :meth:`thesis_force` to the bit) when it is built and with
        Python otherwise; False always uses Python; True requires the kernel.  That is the double
        system; ``ToAutoDiffXd()`` and ``ToSymbolic()`` (``TiltrotorForces_[T]``) compute with
        :func:`~sobolev_drake.tiltrotor.generic_forces.tiltrotor_force_generic`, so Drake's
        ``Linearize`` and ``LinearQuadraticRegulator`` apply to a diagram holding the plant.

        Parameters
        ----------
        model : TiltrotorModel
            The model whose parameters (Table B.1) define the propulsion and aerodynamic force
            cores and whose coordinate map T orders the Drake and thesis vectors.
        native : bool or None, optional
            None (default): the compiled force kernel when it is built, else Python; False:
            always Python; True: the kernel, or ``RuntimeError`` if it is not built.
        """

        def _construct(self, model: TiltrotorModel, *, native: bool | None = None, converter=None):
            LeafSystem_[T].__init__(self, converter=converter)
            from sobolev_drake.native import kernel
            from sobolev_drake.native.forces import force_model
            from sobolev_drake.tiltrotor.input_affine import cores
            if native not in (None, True, False) or (native and T is not float):
                raise ValueError(f"native must be None (use the compiled kernel if built), True or False "
                                 f"(True only for the double system), got {native!r} for T = {T.__name__}")
            self.model, self._native_request = model, native
            self.prop, self.aero = cores(model.params)
            self._state = self.DeclareVectorInputPort("plant_state", 16)
            self._ports = {name: self.DeclareVectorInputPort(name, size) for name, size in
                           (("u", 8), ("propeller_speed", 2), ("servo_torque", 2),
                            ("surface_deflection", 4), ("wind", 3), ("force_disturbance", 3),
                            ("disturbance", 8))}
            self._port_list = [self._ports[k] for k in ("u", "propeller_speed", "servo_torque",
                                                         "surface_deflection", "wind",
                                                         "force_disturbance", "disturbance")]
            # The actuator inputs change only when their sources do (a sampled controller: once per
            # period): one cache entry holds their sum u, so a force evaluation reads it with one
            # call instead of four look-ups and three copies.
            self._inputs = self.DeclareCacheEntry(
                "actuator inputs", ValueProducer(allocate=lambda: AbstractValue.Make(object()),
                                                 calc=self._calc_inputs),
                {self.input_port_ticket(p.get_index()) for p in self._port_list[:4]})
            self.input_evaluations = 0    # recomputations of that cache entry (tests, benchmarks)
            # T is a permutation (q_drake = T q_thesis): index arrays instead of matrix products
            perm = np.argmax(model.T, axis=0)          # q_thesis[j] = q_drake[perm[j]]
            self._perm16 = np.concatenate([perm, perm + 8])
            self._perm8_inv = np.argsort(perm)         # τ_drake[i] = τ_thesis[perm⁻¹[i]]
            self._cosb, self._nu = float(np.cos(model.params.beta)), float(model.params.nu)
            self._dC1 = [float(v) for v in model.params.d_B_C1]
            self.evaluations = 0          # number of force evaluations (benchmarks)
            # The compiled kernel (native/forces.c) computes exactly thesis_force (tested equal to
            # the bit); thesis_force stays the reference and the fallback without a C compiler.
            self._kernel = kernel("forces") if native is not False and T is float else None
            if native and self._kernel is None:
                raise RuntimeError("native=True but the compiled 'forces' kernel is not built (or "
                                   "SOBOLEV_DRAKE_NATIVE=0); reinstall with a C compiler")
            self._native = None if self._kernel is None else force_model(
                self.prop, self.aero, perm16=self._perm16.tolist(),
                perm8_inv=self._perm8_inv.tolist(), cos_beta_servo=self._cosb)
            st = {self.input_port_ticket(self._state.get_index())}
            self.DeclareVectorOutputPort("x", 16, self._calc_x, prerequisites_of_calc=st)
            inputs = {self.all_input_ports_ticket()}   # explicit: no symbolic feedthrough probe
            # the kernel's calc functions are closures over the per-evaluation calls, bound once
            # (a pybind attribute look-up costs about a kernel call; Drake calls these 3 times
            # per RK3 step)
            for name, drake_order in (("applied_generalized_force", True), ("generalized_force", False)):
                calc = (self._python_calc(drake_order) if self._native is None
                        else self._native_calc(drake_order))
                self.DeclareVectorOutputPort(name, 8, calc, prerequisites_of_calc=inputs)

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.model, native=other._native_request if T is float else False,
                            converter=converter)

        @property
        def native(self) -> bool:
            """True when the forces are computed by the compiled kernel."""
            return self._native is not None

        def _calc_x(self, context, output) -> None:
            output.SetFromVector(self._state.Eval(context)[self._perm16])

        def _calc_inputs(self, context, value) -> None:
            """(u, has): u = ``u`` plus the propeller speeds, servo torques and deflections (a
            list of 8 floats; unconnected ports read zero) and ``has``, whether each of the seven
            optional ports (``_port_list`` order) has a value.  A port that has a value keeps it in this context (Drake
            can neither disconnect nor unfix a port; a clone copies fixed values with the cache),
            so neither this entry's next computation (it reads its previous, immutable value) nor
            a force evaluation asks such a port's ``HasValue`` again; a port without a value is
            asked every time (a later ``FixValue`` need not recompute this entry)."""
            self.input_evaluations += 1
            previous = value.get_value()
            known = previous[1] if type(previous) is tuple else _NOTHING_KNOWN
            has = tuple([k or p.HasValue(context) for k, p in zip(known, self._port_list)])
            p_u, p_n, p_s, p_d = self._port_list[:4]
            u = p_u.Eval(context).tolist() if has[0] else [0.0] * 8
            if has[1]:
                a, b = p_n.Eval(context).tolist()
                u[0] += a
                u[1] += b
            if has[2]:
                a, b = p_s.Eval(context).tolist()
                u[2] += a
                u[3] += b
            if has[3]:
                u[4:8] = [x + y for x, y in zip(u[4:8], p_d.Eval(context).tolist())]
            value.set_value((u, has))

        def thesis_force(self, context: Context) -> np.ndarray:
            """ϑ + w (thesis order) from the current inputs; the hot path of the simulation, so it
            reads the actuator inputs from their cache entry, touches each other port once, skips
            unconnected ones and uses the scalar force cores with one shared body-kinematics pass.

            Parameters
            ----------
            context : Context
                This system's context (its ``plant_state`` and actuator/disturbance input ports
                are read).

            Returns
            -------
            ndarray, shape (8,)
                Generalized force ϑ (7.18) of propellers, servos (7.33) and aerodynamic surfaces,
                plus the force disturbance at C1 and the generalized disturbance w, in thesis
                order [αR αL φ θ ψ x y z] (N m on the angles, N on x, y, z).
            """
            self.evaluations += 1
            ql = self._state.Eval(context)[self._perm16].tolist()
            q, qd = ql[:8], ql[8:]
            u = self._inputs.Eval(context)[0]                # read only: the cached list
            p_w, p_f, p_dist = self._port_list[4:]
            zeta = p_w.Eval(context).tolist() if p_w.HasValue(context) else [0.0] * 3
            if T is not float:              # scalar-generic tier, the same sums (module docstring)
                f = p_f.Eval(context).tolist() if p_f.HasValue(context) else None
                tau = tiltrotor_force_generic(self.prop, self.aero, q, qd, u, zeta, f, m, cos_beta=self._cosb,
                                              nu=self._nu, d_B_C1=self._dC1)
                w = p_dist.Eval(context).tolist() if p_dist.HasValue(context) else [0.0] * 8
                return np.array([a + b for a, b in zip(tau, w)], dtype=object)
            kin = body_kinematics_scalar(q, qd, zeta)
            tp = self.prop.propeller_force_scalar(kin, self.prop.rotors_scalar(q, qd, kin), u[0:2])
            ta = self.aero.loads_scalar(kin, u[4:8])[0]
            tau = [a + b for a, b in zip(tp, ta)]
            tau[0] += self._cosb * u[2] - self._nu * qd[0]          # servos (7.33)
            tau[1] += self._cosb * u[3] - self._nu * qd[1]
            if p_f.HasValue(context):
                f = p_f.Eval(context).tolist()
                if f[0] != 0.0 or f[1] != 0.0 or f[2] != 0.0:    # inertial force at C1
                    w = force_at_c1(kin, f, self._dC1)
                    for i in range(6):
                        tau[2 + i] += w[i]
            tau = np.array(tau)
            if p_dist.HasValue(context):
                tau += p_dist.Eval(context)
            return tau

        def _native_calc(self, drake_order):
            """The output calc of :meth:`thesis_force` by the compiled kernel (``drake_order``:
            permuted to Drake's velocity order), written into the output's buffer."""
            force, model, state, inputs = (self._kernel.plant_force, self._native, self._state.Eval,
                                           self._inputs.EvalAbstract)
            wind, has_wind, fd, has_fd, dist, has_dist = (f for p in self._port_list[4:]
                                                          for f in (p.Eval, p.HasValue))

            def calc(context, output):
                self.evaluations += 1
                # EvalAbstract(...).get_value(): the cached tuple itself, cheaper than CacheEntry.Eval
                u, has = inputs(context).get_value()
                force(model, state(context), u, wind(context) if has[4] or has_wind(context) else None,
                      fd(context) if has[5] or has_fd(context) else None,
                      dist(context) if has[6] or has_dist(context) else None,
                      output.get_mutable_value(), drake_order)
            return calc

        def _python_calc(self, drake_order):
            """The output calc of :meth:`thesis_force` (``drake_order``: permuted to Drake's
            velocity order)."""
            if drake_order:
                return lambda context, output: output.SetFromVector(
                    self.thesis_force(context)[self._perm8_inv])
            return lambda context, output: output.SetFromVector(self.thesis_force(context))

    return Impl


TiltrotorForces = default_instantiation(TiltrotorForces_, "TiltrotorForces")


class TiltrotorHandles(PlantHandles):
    """PlantHandles plus the tilt-rotor's extra input ports and its force system.

    Parameters
    ----------
    forces : TiltrotorForces
        The force system; its ports ``propeller_speed``, ``servo_torque``,
        ``surface_deflection``, ``wind``, ``force_disturbance`` (inputs) and
        ``generalized_force`` (output) become attributes of the same names.
    **kw
        The :class:`PlantHandles` fields.
    """

    def __init__(self, *, forces: TiltrotorForces, **kw: Any) -> None:
        super().__init__(**kw)
        self.forces = forces
        self.propeller_speed = forces.GetInputPort("propeller_speed")
        self.servo_torque = forces.GetInputPort("servo_torque")
        self.surface_deflection = forces.GetInputPort("surface_deflection")
        self.wind = forces.GetInputPort("wind")
        self.force_disturbance = forces.GetInputPort("force_disturbance")
        self.generalized_force = forces.GetOutputPort("generalized_force")


def add_tiltrotor(builder: DiagramBuilder, params: TiltrotorParams | None = None, *,
                  native: bool | None = None) -> TiltrotorHandles:
    """Add the tilt-rotor (MultibodyPlant + SceneGraph + :class:`TiltrotorForces`) to ``builder``.

    Parameters
    ----------
    builder : DiagramBuilder
        The builder the systems are added to.
    params : TiltrotorParams, optional
        Table B.1 by default.
    native : bool or None, optional
        See :class:`TiltrotorForces` (None: the compiled force kernel when it is built, else
        Python).

    Returns
    -------
    TiltrotorHandles
        ``plant, scene_graph, model, u, disturbance, x`` (shared contract; ``adapter`` is None)
        and ``propeller_speed, servo_torque, surface_deflection, wind, force_disturbance,
        generalized_force, forces``.
    """
    params = TiltrotorParams() if params is None else params
    plant, scene_graph = _build_plant(params, builder)
    plant.set_name("tiltrotor_plant")
    model = TiltrotorModel(params, plant=plant)
    forces = builder.AddSystem(TiltrotorForces(model, native=native))
    forces.set_name("tiltrotor_forces")
    builder.Connect(plant.get_state_output_port(), forces.GetInputPort("plant_state"))
    builder.Connect(forces.GetOutputPort("applied_generalized_force"),
                    plant.get_applied_generalized_force_input_port())
    # handles.x: the same thesis-ordered state as the force system's ``x`` port, copied by a C++
    # Selector (the controller and the log sinks read it every sample: no Python callback)
    x = add_state_selector(builder, plant.get_state_output_port(), forces._perm16,
                           "tiltrotor_thesis_state")
    return TiltrotorHandles(plant=plant, scene_graph=scene_graph, model=model,
                            u=forces.GetInputPort("u"), disturbance=forces.GetInputPort("disturbance"),
                            x=x, adapter=None, forces=forces)
