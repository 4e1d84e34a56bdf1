"""The double specialization of a :class:`~sobolev_drake.systems.mechanical_law.MechanicalLaw`'s
per-sample path: u*, τ and d∫e/dt of the W2/W∞ law in one call on float arrays.

The generic law (:meth:`MechanicalLaw.generalized_input`, :meth:`MechanicalLaw.allocate`,
:meth:`MechanicalLaw.integral_derivative`) is the reference; this path computes the same
numbers (equal to rounding, tested in ``tests/systems/test_mechanical_sample.py``) with what
can be done once at construction taken out of the sample:

* q̈_des of every group, (5.26)/(5.84), as one gain matrix applied to the stacked errors
  [e; ė; ∫e; q̇s] (the per-group K of :class:`SobolevLaw`, columns rearranged);
* u* = M q̈_des + C q̇ + g (+ D q̇) by one recursive Newton–Euler pass, the compiled kernel
  ``native/rnea.c`` when it covers the plant, else Drake's ``CalcInverseDynamics`` — no mass
  matrix, no bias term, no conversion of M through pybind.  When the kernel covers the plant
  and the friction is joint damping (or none), q̈_des, u* and d∫e/dt are one compiled call
  (``_rnea.tracking_sample``, the numpy form below being its reference);
* τ = B⁻¹u* (or B†u*) with B⁻¹ precomputed when the model's B is constant (a
  :class:`~sobolev_drake.models.base.PlantModel`), skipped when B is the identity; with
  actuator bounds, a command outside them goes to the law's bounded least squares;
* no per-call validation: the ports' sizes are fixed by Drake, and a non-finite result sends
  the sample to the generic law, whose checks name the offending input.

It covers the Sobolev law on models that keep the base class' Drake evaluations with a
permutation coordinate map (:class:`~sobolev_drake.systems.plant_dynamics.PlantDynamics`
``permutation``), fully actuated or input-coupled, without an ``allocation`` callable;
:meth:`FloatSample.of` returns None otherwise (the reduced model, the H∞ law), and the
controller keeps the generic law.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from sobolev_drake.models.base import PlantModel
from sobolev_drake.systems.inner_laws import SobolevLaw

if TYPE_CHECKING:   # mechanical_law imports this module
    from sobolev_drake.systems.mechanical_law import MechanicalLaw

__all__ = ["FloatSample", "compiled_desired_acceleration"]


def compiled_desired_acceleration(law: MechanicalLaw
                                  ) -> Callable[[list, list, list, list], list] | None:
    """``f(q, qdot, e_int, reference) -> list``: :meth:`MechanicalLaw.desired_acceleration_scalar`
    by the compiled kernel (``_rnea.desired_acceleration``, the same operations in the same
    order: equal to the bit on Python < 3.12, whose ``sum`` is not compensated, to rounding
    after), or None (kernel not built or switched off, no Sobolev law, a reduced model).
    The function's ``capsule`` attribute holds the kernel's gains (for other kernels).

    Parameters
    ----------
    law : MechanicalLaw
        The law.

    Returns
    -------
    callable or None

    Examples
    --------
    >>> from sobolev_drake.models.serial_chain import seven_link_arm
    >>> from sobolev_drake.models.base import MechanicalModel
    >>> from sobolev_drake.synthesis.mechanical import controlled_gains
    >>> from sobolev_drake.systems.mechanical_law import MechanicalLaw, SobolevLaw
    >>> from sobolev_drake.systems.partition import Partition
    >>> law = MechanicalLaw(MechanicalModel.from_plant(seven_link_arm()),
    ...                     Partition(controlled=range(7)),
    ...                     SobolevLaw(controlled_gains(*[[1.0] * 7] * 4)))
    >>> f = compiled_desired_acceleration(law)      # None without the compiled kernel
    >>> args = ([0.1] * 7, [0.0] * 7, [0.0] * 7, [0.0] * 21)
    >>> f is None or f(*args) == law.desired_acceleration_scalar(*args)
    True
    """
    from sobolev_drake.native import kernel
    module = kernel("rnea")
    inner = law.law
    if (module is None or not hasattr(module, "desired_acceleration")
            or not isinstance(inner, SobolevLaw) or law.partition.mode == "reduced"):
        return None
    p = law.partition
    blocks = [g.K.ravel() for g in (inner.controlled, inner.regulated, inner.stabilized)
              if g is not None]
    capsule = module.make_desired_acceleration({
        "n": law.n, "nc": law.nc, "nr": law.nr, "ns": law.ns, "tracked": list(p.tracked),
        "controlled": list(p.controlled), "regulated": list(p.regulated),
        "stabilized": list(p.stabilized), "K": np.concatenate(blocks).tolist()})
    evaluate = module.desired_acceleration

    def desired_acceleration(q, qdot, e_int, reference):
        return evaluate(capsule, q, qdot, e_int, reference)
    desired_acceleration.capsule = capsule      # for kernels composing it in C (native/fused.c)
    return desired_acceleration


class FloatSample:
    """The per-sample path of a law for float inputs (module docstring); build with :meth:`of`.

    Parameters
    ----------
    law : MechanicalLaw
        A law :meth:`of` accepts.

    Examples
    --------
    The per-sample path of a controller on a 7-joint arm equals the generic law:

    >>> import numpy as np
    >>> from sobolev_drake.models.serial_chain import seven_link_arm
    >>> from sobolev_drake.synthesis.mechanical import controlled_gains
    >>> from sobolev_drake.systems.mechanical_controller import MechanicalController, SobolevLaw
    >>> ctrl = MechanicalController.from_plant(seven_link_arm(),
    ...                                        SobolevLaw(controlled_gains(*[[1.0] * 7] * 4)))
    >>> fast = FloatSample.of(ctrl.law)
    >>> x, desired = np.full(14, 0.1), np.zeros(14)
    >>> u_star, tau, rate = fast(x, desired, None, np.zeros(7))
    >>> reference = np.concatenate([desired, np.zeros(7)])
    >>> bool(np.allclose(u_star, ctrl.law.generalized_input(x[:7], x[7:], np.zeros(7), reference),
    ...                  rtol=0, atol=1e-12))
    True
    """

    def __init__(self, law):
        self.law = law
        n, p = law.n, law.partition
        self.n, self.nc, self.n_ref = n, law.nc, law.n_ref
        tracked = list(p.tracked)
        self._err_index = np.array(tracked + [n + i for i in tracked], dtype=int)
        self._qdot_s = np.array([n + i for i in p.stabilized], dtype=int)
        self._identity_tracking = tracked == list(range(n))
        self._tracked = np.array(tracked, dtype=int)
        self.gain = self._gain_matrix(law)
        dyn = law.dynamics
        self._rnea = dyn.compiled_inverse_dynamics()
        model = law.model
        self._damping = None if model.frictionless else (
            model.damping if type(model).friction is PlantModel.friction else None)
        self._friction = None if model.frictionless or self._damping is not None else model.friction
        self._alloc = self._allocation(law)
        self._compiled = self._compiled_law()
        self._bounded = law.lower is not None or law.upper is not None
        self._lo = -np.inf if law.lower is None else law.lower
        self._hi = np.inf if law.upper is None else law.upper

    def _compiled_law(self):
        """The kernel's law capsule when the whole of u* fits in one compiled call (the
        kernel covers the plant, friction is joint damping or none), else None."""
        if self._rnea is None or self._friction is not None:
            return None
        module = self._rnea[0]
        if not hasattr(module, "tracking_sample"):     # a kernel built before the law entry
            return None
        law = self.law
        damping = np.zeros(self.n) if self._damping is None else self._damping
        return module.make_tracking_law({
            "n": self.n, "n_ref": self.n_ref, "nc": self.nc, "ns": law.ns,
            "err_index": self._err_index.tolist(), "qdot_s": self._qdot_s.tolist(),
            "tracked": self._tracked.tolist(), "gain": self.gain.ravel().tolist(),
            "damping": np.asarray(damping, float).tolist()})

    @classmethod
    def of(cls, law: MechanicalLaw) -> FloatSample | None:
        """The float path of ``law``, or None when it does not cover the law.

        Parameters
        ----------
        law : MechanicalLaw
            The law (see the module docstring for what is covered).

        Returns
        -------
        FloatSample or None
        """
        if (not isinstance(law.law, SobolevLaw) or law.partition.mode == "reduced"
                or law.allocation is not None or law.dynamics.permutation is None):
            return None
        return cls(law)

    @staticmethod
    def _gain_matrix(law):
        """K (n × (2 n_ref + n_c + n_s)) with q̈_des = S q̈_r − K [e; ė; ∫e; q̇s] (e, ė of the
        tracked DOF, controlled then regulated; S places q̈_r on the tracked DOF)."""
        n, nc, nr, ns, n_ref = law.n, law.nc, law.nr, law.ns, law.n_ref
        K = np.zeros((n, 2 * n_ref + nc + ns))
        inner = law.law
        c = inner.controlled.K                      # [ė_c, e_c, ∫e] (5.26)
        for k, i in enumerate(law.ic):
            K[i, 0:nc] = c[k, nc:2 * nc]
            K[i, n_ref:n_ref + nc] = c[k, 0:nc]
            K[i, 2 * n_ref:2 * n_ref + nc] = c[k, 2 * nc:]
        if nr:
            r = inner.regulated.K                   # [ė_r, e_r] (5.84)
            for k, i in enumerate(law.ir):
                K[i, nc:n_ref] = r[k, nr:]
                K[i, n_ref + nc:2 * n_ref] = r[k, :nr]
        if ns:
            s = inner.stabilized.K                  # q̇s (5.84)
            for k, i in enumerate(law.is_):
                K[i, 2 * n_ref + nc:] = s[k]
        return K

    @staticmethod
    def _allocation(law):
        """("identity" | "matrix", A) for a constant B (τ = A u*), or ("solve", None)."""
        model = law.model
        if type(model).B is not PlantModel.B:     # B may depend on q: solve per sample
            return "solve", None
        B = law.dynamics.input_matrix(np.zeros(law.n))
        if B.shape[0] == B.shape[1] and np.array_equal(B, np.eye(B.shape[0])):
            return "identity", None
        if B.shape[0] == B.shape[1]:
            return "matrix", np.linalg.inv(B)
        return "matrix", np.linalg.pinv(B)

    def __call__(self, x, desired, qddot_r, e_int):
        """(u*, τ, d∫e/dt) at one sample, or None when a result is not finite (the caller
        then runs the generic law, which names the bad input).

        Parameters
        ----------
        x : ndarray, shape (2 n,)
            [q; q̇], thesis order.
        desired : ndarray, shape (2 n_ref,)
            [q_r; q̇_r] of the tracked DOF.
        qddot_r : ndarray, shape (n_ref,) or None
            q̈_r of the tracked DOF (None: zero).
        e_int : ndarray, shape (n_c,)
            ∫q̃c.

        Returns
        -------
        tuple of ndarray or None
            u* (n,), τ (n_τ,), q_c − q_cr (n_c,).
        """
        n = self.n
        if self._compiled is not None:          # q̈_des, u* and d∫e/dt in one compiled call
            u_star, rate = np.empty(n), np.empty(self.nc)
            if not self._rnea[0].tracking_sample(self._rnea[1], self._compiled, x, desired,
                                                 qddot_r, e_int, u_star, rate):
                return None
            return u_star, self._allocate(u_star, x), rate
        err = x[self._err_index] - desired                        # [e; ė] of the tracked DOF
        z = np.concatenate((err, e_int, x[self._qdot_s])) if len(self._qdot_s) else \
            np.concatenate((err, e_int))
        acc = -(self.gain @ z)
        if qddot_r is not None:
            if self._identity_tracking:
                acc += qddot_r
            else:
                acc[self._tracked] += qddot_r
        if self._rnea is not None:
            u = self._rnea[0].inverse_dynamics(self._rnea[1], x, acc)
            if not math.isfinite(sum(u)):
                return None
            u_star = np.array(u)
            if self._damping is not None:
                u_star += self._damping * x[n:]
            elif self._friction is not None:
                u_star = u_star + self._friction(x[n:])
        else:                                   # Drake's C++ pass, friction included
            u_star = self.law.dynamics.recursive_inverse_dynamics_drake(x[:n], x[n:], acc)
            if not np.isfinite(u_star).all():
                return None
        return u_star, self._allocate(u_star, x), err[:self.nc]

    def _allocate(self, u_star, x):
        n = self.n
        kind, A = self._alloc
        if kind == "identity":
            tau = u_star.copy()
        elif kind == "matrix":
            tau = A @ u_star
        else:
            return self.law.allocate(u_star, x[:n], x[n:])
        if self._bounded and not (np.all(tau >= self._lo) and np.all(tau <= self._hi)):
            tau = self.law.allocate(u_star, x[:n], x[n:])
        return tau
