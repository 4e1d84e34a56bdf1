"""The tilt-rotor W∞ law's whole per-sample update as one compiled call (``native/fused.c``).

:func:`compiled_sample` prepares, for a law made by ``tiltrotor.law.make_law`` with the thesis
design, the default allocation and a schedule of known form (``compiled_form``), the constants
of ``_fused.sample``: from x, the reference, the measured wind and the controller's old record
to the new record — tilt reference, q̈_des, u* (7.81), B and ϑ_passive (7.62), the bounds
(7.85)–(7.89), the allocation (7.84), the thrust inversion (7.90), residual, saturation flags
and the error integral — calling the same compiled kernels as the Python path in the same
order, so the record is the Python path's to the bit except the residual (numpy's BLAS there;
equal to rounding).  Wherever the Python path would decide something the C code does not
(an input it rejects, the bracketing thrust solver, the general allocation solver, a
non-finite value), the call declines and the controller runs :meth:`TiltrotorWInfLaw.step`.

The allocation's warm start is the previous sample's active set, which the controller keeps in
its Context (a discrete state group); the record's saturation flags are not the same set (a
box narrower than the flags' ``min_width`` is "switched off" there but may be active in the
solver: 44 % of the samples of the first 20 s of scenario 2 differ).  The warm start affects
the iterations, not the solution (the active set PDAS settles on decides every value).

A law with its own ``desired_acceleration`` (the ``"scheduled"`` design's Python
``EnvelopeSchedule``) is compiled too: the kernel calls that function with the lists the Python
path gives it (q, q̇, ∫e_c, the tracked and full references, the wind) and computes the rest; a
declined sample calls it again on the Python path, so it must be a function of its arguments.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from sobolev_drake.native import kernel

if TYPE_CHECKING:
    from sobolev_drake.tiltrotor.controller import TiltrotorWInfLaw

__all__ = ["CompiledSample", "compiled_sample", "REGULARIZATION", "MAX_ITERATIONS"]

#: bounded_least_squares' default Tikhonov weight and the fast path's PDAS iteration limit
REGULARIZATION, MAX_ITERATIONS = 1e-12, 25
#: the warm Newton thrust inversion's steps and tolerance (make_law's speeds and the compiled update)
NEWTON_ITERATIONS, NEWTON_RTOL = 4, 1e-9
#: saturation_flag_list's tolerances
REL_TOL, MIN_WIDTH = 1e-3, 1e-3


def _parts(law: TiltrotorWInfLaw) -> tuple:
    return (law.mech_law, law.input_affine, law.bounds, law.allocate, law.thrust_to_speed,
            law.tilt_schedule, law.desired_acceleration)


class CompiledSample:
    """Constants of the compiled per-sample update of one law (build with :func:`compiled_sample`).

    Parameters
    ----------
    law : TiltrotorWInfLaw
        The law whose Python path this call reproduces.
    constants : dict
        ``_fused.make_sample``'s constants without the period.
    """

    def __init__(self, law: TiltrotorWInfLaw, constants: dict[str, Any]) -> None:
        self.constants = constants
        self.parts = _parts(law)

    def matches(self, law: TiltrotorWInfLaw) -> bool:
        """Whether ``law`` still has the pieces this call was made for (the same objects).

        Parameters
        ----------
        law : TiltrotorWInfLaw
            The law.

        Returns
        -------
        bool
        """
        return _parts(law) == self.parts

    def kernel(self, period: float) -> Callable[..., bool] | None:
        """``f(x, reference, wind, old_record, old_active, record_out, active_out) -> bool``:
        one sample with the error integral over ``period`` (``_fused.sample`` bound to its
        constants); None when the kernel is not built or switched off, or refuses these
        constants (then the controller runs the Python path).

        Parameters
        ----------
        period : float
            Sample period (s) of the forward-Euler error integral.

        Returns
        -------
        callable or None
        """
        fused = kernel("fused")
        if fused is None:
            return None
        try:
            capsule = fused.make_sample({**self.constants, "period": float(period)})
        except ValueError:      # constants the kernel does not take (e.g. a reversed speed
            return None         # range): the Python path computes this law
        return functools.partial(fused.sample, capsule)


def compiled_sample(law: TiltrotorWInfLaw, forces_capsule: Any, *,
                    default_allocation: bool) -> CompiledSample | None:
    """The compiled per-sample update of ``law`` (module docstring), or None where it does
    not apply: kernels not built or switched off, an allocation other than the default, a
    schedule without ``compiled_form``, a model with friction or outside the inverse-dynamics
    kernel.  A law's own ``desired_acceleration`` (the scheduled design) is called by the
    kernel for q̈_des.

    Parameters
    ----------
    law : TiltrotorWInfLaw
        A law from ``make_law``.
    forces_capsule : object
        The force kernel's model capsule of the law's model (``input_affine.native_core``).
    default_allocation : bool
        Whether ``law.allocate`` is make_law's warm-started ``bounded_least_squares``.

    Returns
    -------
    CompiledSample or None

    Examples
    --------
    make_law attaches it (None without the compiled kernels):

    >>> from sobolev_drake.tiltrotor.law import make_law
    >>> from sobolev_drake.tiltrotor.plant import TiltrotorModel
    >>> law = make_law(TiltrotorModel(), schedule="data")
    >>> law.compiled_sample is None or law.compiled_sample.matches(law)
    True
    """
    from sobolev_drake.systems.mechanical_sample import compiled_desired_acceleration
    from sobolev_drake.tiltrotor.allocation import thesis_bounds_constants

    form = getattr(law.tilt_schedule, "compiled_form", None)
    if kernel("fused") is None or not default_allocation or form is None or not law.model.frictionless:
        return None
    rnea = law.mech_law.dynamics.compiled_inverse_dynamics()
    qdd = compiled_desired_acceleration(law.mech_law)
    if rnea is None or qdd is None or forces_capsule is None:
        return None
    return CompiledSample(law, {
        "rnea_model": rnea[1], "qdd_law": qdd.capsule, "forces_model": forces_capsule, **form,
        "bounds": list(thesis_bounds_constants()), "reg": REGULARIZATION,
        "max_iter": MAX_ITERATIONS, "newton_iterations": NEWTON_ITERATIONS,
        "newton_rtol": NEWTON_RTOL, "rel_tol": REL_TOL, "min_width": MIN_WIDTH,
        "qdd_callback": law.desired_acceleration})
