"""Constants of the compiled force kernel (``native/forces.c``) from the Python force model.

:func:`force_model` packs what :class:`~sobolev_drake.tiltrotor.propulsion.PropulsionModel` and
:class:`~sobolev_drake.tiltrotor.aerodynamics.AeroModel` hold (geometry, tables, Ct/Cq terms) into
the kernel's model capsule, so the parameters, the data files and their validation stay in
Python; None when the kernel is not available.  The kernel is the double specialization of the
force systems (``TiltrotorForces_[float]``); their AutoDiffXd and Expression instantiations run
:mod:`sobolev_drake.tiltrotor.generic_forces` instead.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Sequence

from sobolev_drake.native import kernel

if TYPE_CHECKING:   # the tilt-rotor models (not imported at run time: no cycle)
    from sobolev_drake.tiltrotor.aerodynamics import AeroModel
    from sobolev_drake.tiltrotor.propulsion import PropulsionModel

__all__ = ["force_model"]


def force_model(prop: PropulsionModel, aero: AeroModel, *, perm16: Sequence[int] | None = None,
                perm8_inv: Sequence[int] | None = None,
                cos_beta_servo: float | None = None) -> Any:
    """Kernel model capsule for ``prop`` (PropulsionModel) and ``aero`` (AeroModel) of the same
    parameters, or None if the ``forces`` kernel is not built or disabled.

    ``perm16`` / ``perm8_inv``: the plant's Drake ↔ thesis permutations (see
    ``TiltrotorForces``; identity when omitted); ``cos_beta_servo``: the servo factor cos β as
    the force system computes it (default ``prop.cosb``).
    """
    k = kernel("forces")
    if k is None:
        return None
    if prop.params is not aero.params and prop.params != aero.params:
        raise ValueError("prop and aero must be built from the same TiltrotorParams")
    (pts, hrs, atab, btab, start, step, nmax, chord, span, cda, cde, cdr, indep,
     mirror) = aero._scalar_constants
    p, c = prop.params, prop.coef
    terms = [v for (i, j), a, b in c._terms for v in (i, j, a, b)]
    flat = lambda tab: [x for surface in tab for row in surface for x in row]   # noqa: E731
    cb = float(prop.cosb)
    return k.make_model({
        "samples": float(aero.tables.samples), "points": [x for r in pts for x in r],
        "half_rho_s": list(hrs), "alpha_tab": flat(atab), "beta_tab": flat(btab),
        "start": start, "step": step, "nmax": nmax, "chord": float(chord), "span": float(span),
        "c_delta_a": float(cda), "c_delta_e": float(cde), "c_delta_r": float(cdr),
        "independence": float(bool(indep)), "mirrored": float(bool(mirror)), "sin_beta": prop._sb, "cos_beta": prop._cb,
        "cos_beta_servo": cb if cos_beta_servo is None else float(cos_beta_servo),
        "cos_beta_B": cb, "nu": float(p.nu), "d_A_P": prop._dAP_f,
        "d_B_A": [x for r in prop._dBA_f for x in r], "lam": prop._lam_f,
        "kf": float(prop._kf), "kt": float(prop._kt), "diameter": float(c.diameter),
        "J_max": float(c.J_max), "rho": float(c.rho), "nterms": float(len(c._terms)),
        "terms": [float(v) for v in terms], "d_B_C1": [float(v) for v in p.d_B_C1],
        "perm16": [float(v) for v in (range(16) if perm16 is None else perm16)],
        "perm8_inv": [float(v) for v in (range(8) if perm8_inv is None else perm8_inv)],
    })
