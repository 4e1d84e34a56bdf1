"""The linear hover controller of thesis §7.3.1 as a Drake LeafSystem.

u = u_trim + K Δx (state feedback) or a dynamic controller on y = C Δx, with Δx the 20-state
error of the hover linearization (7.57): attitude, tilt and position against the trim and the
path, rates, and four integral states.

It is not composed from :mod:`sobolev_drake.systems.linear_controllers`: those keep the
gains in a numeric parameter read back in C order, while the synthesis returns K in Fortran
order, so K Δx goes through another BLAS kernel and differs in the last bits; the published
flights would move by about 1e-15 (docs/experiments/tiltrotor-hover-linear.md).

See docs/experiments/tiltrotor-hover-linear.md.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from pydrake.systems.framework import LeafSystem_
from pydrake.systems.scalar_conversion import TemplateSystem

from sobolev_drake.synthesis.controller import DynamicController
from sobolev_drake.synthesis.problem import SynthesisResult
from sobolev_drake.tiltrotor.linear_design import measurement_matrix
from sobolev_drake.tiltrotor.scalars import default_instantiation, scalar_math

if TYPE_CHECKING:
    from pydrake.systems.framework import Context, ContinuousState

__all__ = ["VELOCITY_REFERENCES", "check_velocity_reference", "LinearHoverController",
           "LinearHoverController_"]

#: Δq̇ against q̇_r = 0 (the thesis' trim) or against the path velocity
VELOCITY_REFERENCES = ("zero", "path")


def check_velocity_reference(velocity_reference: str) -> str:
    """Validate a velocity reference name.

    Parameters
    ----------
    velocity_reference : str
        One of :data:`VELOCITY_REFERENCES`.

    Returns
    -------
    str
        ``velocity_reference``.
    """
    if velocity_reference not in VELOCITY_REFERENCES:
        raise ValueError(f"velocity_reference must be one of {VELOCITY_REFERENCES}, "
                         f"got {velocity_reference!r}")
    return velocity_reference


@TemplateSystem.define("LinearHoverController_")
def LinearHoverController_(T):                   # noqa: D103 - the template of the class below
    m = scalar_math(T)
    dtype = float if T is float else object

    class Impl(LeafSystem_[T]):
        """u = u_trim + K Δx (state feedback) or the dynamic controller on y = C Δx.

        .. pydrake_system::

            name: LinearHoverController
            input_ports:
            - x
            - reference
            output_ports:
            - propeller_speed
            - servo_torque
            - surface_deflection
            - delta_u

        Δx = [q − q_r(t); q̇ − q̇_r(t); ∫Δψ ∫Δx ∫Δy ∫Δz] with q_r = trim attitude/tilt + the path
        [x_r y_r z_r], ψ_r = 0, and q̇_r = 0 (``velocity_reference="zero"``, the thesis' trim) or
        the path velocity (``"path"``).  Continuous states: the four integrals and the controller
        state.  Inputs ``x`` (16), ``reference`` (12, [x y z ψ] stacked with rates and
        accelerations); outputs ``propeller_speed``, ``servo_torque`` (clipped to n ≥ 0,
        |τs| ≤ 2 N m), ``surface_deflection`` (zeros) and ``delta_u`` (4, unclipped Δu).
        ``ToAutoDiffXd()`` and ``ToSymbolic()`` give the same law in those scalars (the clips
        as ``if_then_else``), e.g. to linearize a closed loop with Drake.

        Parameters
        ----------
        ctrl : SynthesisResult or DynamicController
            A hover design (:func:`sobolev_drake.tiltrotor.linear_design.design`) or its
            controller: a state feedback's gain K (4 × 20) or a controller on y = C Δx, C =
            :func:`~sobolev_drake.tiltrotor.linear_design.measurement_matrix` (20 or 18
            inputs).
        trim : Trim
            The hover trim (``q``, ``n``, ``tau_s``).
        velocity_reference : str, default "zero"
            One of :data:`VELOCITY_REFERENCES`.
        """

        def _construct(self, ctrl, trim, velocity_reference="zero", converter=None):
            LeafSystem_[T].__init__(self, converter=converter)
            self._args = (ctrl, trim, velocity_reference)
            self.path_velocity = check_velocity_reference(velocity_reference) == "path"
            if isinstance(ctrl, DynamicController):
                ctrl = SynthesisResult("output_feedback", np.nan, controller=ctrl)
            C = measurement_matrix(ctrl)     # refuses a controller reading neither Δx nor y
            if ctrl.controller.nu != 4 or ctrl.controller.dt != 0:
                raise ValueError(f"ctrl must be a continuous-time controller with 4 outputs (Δu), "
                                 f"got {ctrl.controller.nu} outputs and dt = {ctrl.controller.dt}")
            # a gain is applied as K Δx with the synthesis' array as is (same BLAS kernel, same
            # bits as the published flights; see the module docstring)
            self.static = ctrl.K is not None
            self.q_trim = np.asarray(trim.q, float).copy()
            self.u_trim = np.r_[trim.n, trim.tau_s]
            if self.static:
                self.K = np.asarray(ctrl.K)
                nk = 0
            else:
                self.AK, self.BK, self.CK, self.DK = ctrl.controller
                self.C = C
                nk = self.AK.shape[0]
            self.nk = nk
            self.x_port = self.DeclareVectorInputPort("x", 16)
            self.ref_port = self.DeclareVectorInputPort("reference", 12)
            self.DeclareContinuousState(4 + nk)
            # explicit prerequisites: the feedthrough is known without symbolic inspection
            deps = {self.all_input_ports_ticket(), self.xc_ticket()}
            self.DeclareVectorOutputPort("propeller_speed", 2, self._calc_n, prerequisites_of_calc=deps)
            self.DeclareVectorOutputPort("servo_torque", 2, self._calc_ts, prerequisites_of_calc=deps)
            self.DeclareVectorOutputPort("surface_deflection", 4, self._calc_zero,
                                         prerequisites_of_calc={self.nothing_ticket()})
            self.DeclareVectorOutputPort("delta_u", 4, self._calc_du, prerequisites_of_calc=deps)

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, *other._args, converter=converter)

        def delta_x(self, context: Context) -> tuple[np.ndarray, np.ndarray]:
            """Δx (20) and the dynamic controller's state in ``context``.

            Parameters
            ----------
            context : Context
                This system's context.

            Returns
            -------
            (ndarray, ndarray)
                Δx and the controller state (empty for a state feedback).
            """
            x = self.x_port.Eval(context)
            r = self.ref_port.Eval(context)
            qr = np.array(self.q_trim, dtype=dtype)
            qr[5:8] = r[0:3]
            qr[4] = r[3]
            qdr = np.zeros(8, dtype=dtype)
            if self.path_velocity:
                qdr[5:8], qdr[4] = r[4:7], r[7]
            s = context.get_continuous_state_vector().CopyToVector()
            return np.concatenate([x[:8] - qr, x[8:] - qdr, s[:4]]), s[4:]

        def _du(self, context):
            dx, xk = self.delta_x(context)
            if self.static:
                return self.K @ dx
            return self.CK @ xk + self.DK @ (self.C @ dx)

        def DoCalcTimeDerivatives(self, context: Context, derivatives: ContinuousState) -> None:
            dx, xk = self.delta_x(context)
            d = np.empty(4 + self.nk, dtype=dtype)
            d[:4] = dx[[4, 5, 6, 7]]
            if self.nk:
                d[4:] = self.AK @ xk + self.BK @ (self.C @ dx)
            derivatives.get_mutable_vector().SetFromVector(d)

        def _calc_n(self, context, output):
            n = self.u_trim[:2] + self._du(context)[:2]
            output.SetFromVector(np.maximum(n, 0.0) if T is float else
                                 [m.where(v >= 0.0, v, 0.0) for v in n])

        def _calc_ts(self, context, output):
            ts = self.u_trim[2:] + self._du(context)[2:]
            output.SetFromVector(np.clip(ts, -2.0, 2.0) if T is float else
                                 [m.where(v < -2.0, -2.0, m.where(v > 2.0, 2.0, v)) for v in ts])

        def _calc_zero(self, context, output):
            output.SetFromVector(np.zeros(4))

        def _calc_du(self, context, output):
            output.SetFromVector(self._du(context))

    return Impl


LinearHoverController = default_instantiation(LinearHoverController_, "LinearHoverController")
