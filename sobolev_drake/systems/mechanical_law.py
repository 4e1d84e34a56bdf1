"""The mechanical W2/W∞ and classic H∞ control laws as pure maths (no LeafSystem).

:class:`MechanicalLaw` computes, from the plant model, a :class:`Partition` of the DOF and an
inner law (:class:`SobolevLaw` or :class:`HinfLaw`), the desired accelerations, the
generalized input u* and the actuator command; see :mod:`.mechanical_controller` for the
equations and the LeafSystem that wraps it.

Its methods take numbers (the double specialization: per-state caches, the permutation fast
path, the compiled Newton–Euler kernel) or arrays of Drake scalars (``AutoDiffXd``,
``Expression``), which they hand to the generic law of :mod:`.scalar_law`.
"""

from __future__ import annotations

import copy
import math
from typing import Callable

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import lsq_linear

from sobolev_drake.models.base import MechanicalModel, check_vector
from sobolev_drake.models.scalar_terms import ScalarTerms, quiet, scalar_type, scalar_vector
from sobolev_drake.systems import scalar_law
from sobolev_drake.systems.bounded_ls import bounded_least_squares
from sobolev_drake.systems.inner_laws import HinfLaw, SobolevLaw
from sobolev_drake.systems.mechanical_hinf import hinf_force
from sobolev_drake.systems.mechanical_sample import compiled_desired_acceleration
from sobolev_drake.systems.partition import Partition, check_actuation
from sobolev_drake.systems.plant_dynamics import PlantDynamics
from sobolev_drake.validation import bounds_pair, real_matrix

__all__ = ["SobolevLaw", "HinfLaw", "MechanicalLaw"]


class MechanicalLaw:
    """Pure control law (see module docstring).

    Parameters
    ----------
    model : MechanicalModel
        Model used by the controller (M, C q̇, g, C(q,q̇)v, B, friction).
    partition : Partition
        DOF groups; must cover the model's n DOF.
    law : SobolevLaw or HinfLaw
        The inner law (the H∞ law has no regulated-DOF form).
    allocation : callable, optional
        ``allocation(u_star, q, qdot) -> tau``; None uses B⁻¹ (square B), B̄⁻¹ (reduced model)
        or B† (input coupling).
    lower, upper : array_like, optional
        Actuator bounds (size n_τ) enforced by bounded least squares when no ``allocation``
        callable is given.
    operating_points : array_like, optional
        Configurations q (rows, thesis order) along the expected operating range at which the
        partition's actuation assumptions are checked (:func:`~sobolev_drake.systems.partition.
        check_actuation`; Assumptions 5–7); default q = 0.  A partition the inputs cannot
        serve there raises ``ValueError``.  Skipped with an ``allocation`` callable, which
        then owns the mapping from u* to the inputs.
    """

    def __init__(self, model: MechanicalModel, partition: Partition, law: SobolevLaw | HinfLaw, *,
                 allocation: Callable | None = None, lower: ArrayLike | None = None,
                 upper: ArrayLike | None = None, operating_points: ArrayLike | None = None) -> None:
        if not all(hasattr(model, k) for k in ("n", "M", "Cqdot", "g")):
            raise TypeError("model must be a MechanicalModel (M(q), C(q,q̇)q̇, g(q) of a plant), "
                            f"got {type(model).__name__}")
        if not isinstance(partition, Partition):
            raise TypeError(f"partition must be a Partition, got {type(partition).__name__}")
        partition.check(model.n)
        if allocation is not None and not callable(allocation):
            raise TypeError("allocation must be None or a callable(u_star, q, qdot) -> tau, "
                            f"got {allocation!r}")
        self.model, self.partition, self.law = model, partition, law
        self.n = model.n
        self.allocation = allocation
        self.dynamics = PlantDynamics(model)
        self._cache, self._scalar_terms = {}, {}
        p = partition
        self.ic = np.array(p.controlled, dtype=int)
        self.ir = np.array(p.regulated, dtype=int)
        self.is_ = np.array(p.stabilized, dtype=int)
        self.iu = np.array(p.uncontrolled, dtype=int)
        self.nc, self.nr, self.ns = len(self.ic), len(self.ir), len(self.is_)
        self.n_ref = self.nc + self.nr
        self._tracked = np.array(p.tracked, dtype=int)
        self._check_inner(law)
        q0 = np.zeros(self.n)
        try:
            self.num_inputs = int(np.asarray(model.B(q0)).shape[1])
        except NotImplementedError:
            if allocation is None:
                raise ValueError("model has no B(q): give an allocation callable") from None
            self.num_inputs = int(getattr(model, "num_inputs", self.n))
        points = (np.zeros((1, self.n)) if operating_points is None else
                  real_matrix("operating_points", np.atleast_2d(operating_points), (None, self.n)))
        self.operating_points = points
        if allocation is None:
            check_actuation(model, p, self.dynamics.input_matrix, points)
        if p.mode == "reduced" and self.num_inputs != self.nc:
            raise ValueError(f"reduced model needs as many inputs as controlled DOF (Assumption 5):"
                             f" {self.num_inputs} inputs, {self.nc} controlled DOF")
        self.lower = None if lower is None else check_vector("lower", lower, self.num_inputs)
        self.upper = None if upper is None else check_vector("upper", upper, self.num_inputs)
        if self.lower is not None and self.upper is not None:
            bounds_pair("lower", self.lower, "upper", self.upper, self.num_inputs)

    def _check_inner(self, law):
        if not isinstance(law, (SobolevLaw, HinfLaw)):
            raise TypeError(f"law must be a SobolevLaw or an HinfLaw, got {type(law).__name__}")
        if isinstance(law, HinfLaw) and self.nr:
            raise ValueError("the classic H∞ law (Chen, Lee & Feng) has no regulated-DOF form: "
                             "use controlled or stabilized DOF, or the SobolevLaw")
        if isinstance(law, SobolevLaw):
            self._check_group("controlled", law.controlled, self.nc)
            self._check_group("regulated", law.regulated, self.nr)
            self._check_group("stabilized", law.stabilized, self.ns)

    def with_inner(self, law: SobolevLaw | HinfLaw) -> MechanicalLaw:
        """This law with another inner law: same model, partition, allocation, bounds and
        dynamics (whose per-state caches do not depend on the gains); sizes are checked.

        Parameters
        ----------
        law : SobolevLaw or HinfLaw
            The new inner law.

        Returns
        -------
        MechanicalLaw
        """
        new = copy.copy(self)
        new._check_inner(law)
        new.law, new._cache = law, {}
        return new

    @staticmethod
    def _check_group(name, gains, size):
        if size and gains is None:
            raise ValueError(f"partition has {size} {name} DOF but the law has no {name} gains")
        if gains is not None and gains.n != size:
            raise ValueError(f"{name} gains are for {gains.n} DOF, partition has {size}")

    # --- errors ----------------------------------------------------------------------------
    def split_reference(self, reference: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Split the stacked reference of the tracked DOF.

        Parameters
        ----------
        reference : array_like, shape (3 n_ref,)
            [q_r; q̇_r; q̈_r] of ``partition.tracked`` (controlled then regulated DOF).

        Returns
        -------
        q_r, qdot_r, qddot_r : ndarray, shape (n_ref,)
        """
        r = check_vector("reference", reference, 3 * self.n_ref)
        return r[:self.n_ref], r[self.n_ref:2 * self.n_ref], r[2 * self.n_ref:]

    def integral_derivative(self, q: ArrayLike, reference: ArrayLike) -> np.ndarray:
        """d/dt ∫q̃c = q_c − q_cr.

        Parameters
        ----------
        q : array_like, shape (n,)
            Generalized coordinates, thesis order.
        reference : array_like, shape (3 n_ref,)
            Stacked reference (see :meth:`split_reference`).

        Returns
        -------
        ndarray, shape (n_c,)
            Position error of the controlled DOF.
        """
        T = self._drake_scalar(q, reference)
        if T is not None:
            with quiet(T):
                return scalar_law.integral_derivative(
                    self, scalar_vector("q", q, self.n),
                    scalar_vector("reference", reference, 3 * self.n_ref))
        qr, _, _ = self.split_reference(reference)
        return np.asarray(q, dtype=float)[self.ic] - qr[:self.nc]

    def _errors(self, q, qdot, reference):
        qr, qdr, qddr = self.split_reference(reference)
        tr = self._tracked
        return q[tr] - qr, qdot[tr] - qdr, qddr

    def _h(self, q, qdot):
        return self.dynamics.mass_and_bias(q, qdot)[1]

    def _parse(self, q, qdot, e_int):
        return check_vector("q", q, self.n), check_vector("qdot", qdot, self.n), check_vector("e_int", e_int, self.nc)

    # --- Drake scalar types (AutoDiffXd, Expression): the generic law of .scalar_law -----------
    @staticmethod
    def _drake_scalar(*arrays):
        """The Drake scalar type of the arguments, None for numbers (the double path)."""
        arrays = [a for a in arrays if a is not None]
        if all(getattr(a, "dtype", object) != object for a in arrays):
            return None
        T = scalar_type(*arrays)
        return None if T is float else T

    def _parse_scalar(self, q, qdot, e_int, reference):
        return (scalar_vector("q", q, self.n), scalar_vector("qdot", qdot, self.n),
                scalar_vector("e_int", e_int, self.nc),
                scalar_vector("reference", reference, 3 * self.n_ref))

    def scalar_terms(self, scalar: type) -> ScalarTerms:
        """The model's terms for a scalar type (made once per type and shared with the laws of
        :meth:`with_inner`), as the generic law uses them.

        Parameters
        ----------
        scalar : type
            ``float``, ``AutoDiffXd`` or ``Expression``.

        Returns
        -------
        ScalarTerms
        """
        terms = self._scalar_terms.get(scalar)
        if terms is None:
            terms = self._scalar_terms[scalar] = ScalarTerms(self.model, scalar)
        return terms

    # --- W laws ------------------------------------------------------------------------------
    def desired_acceleration(self, q: ArrayLike, qdot: ArrayLike, e_int: ArrayLike,
                             reference: ArrayLike) -> np.ndarray:
        """q̈_des (thesis order, size n; uncontrolled entries are NaN) of the Sobolev law.

        ``TypeError`` for the H∞ law.

        Parameters
        ----------
        q, qdot : array_like, shape (n,)
            Generalized coordinates and velocities, thesis order.
        e_int : array_like, shape (n_c,)
            Error integral ∫q̃c of the controlled DOF.
        reference : array_like, shape (3 n_ref,)
            Stacked reference (see :meth:`split_reference`).

        Returns
        -------
        ndarray, shape (n,)
            q̈_r − K[ė; e; ∫e] on the controlled DOF, q̈_r − K[ė; e] on the regulated DOF,
            −K q̇s on the stabilized DOF, NaN on the uncontrolled DOF.
        """
        if not isinstance(self.law, SobolevLaw):
            raise TypeError("desired_acceleration is defined for the Sobolev law only")
        T = self._drake_scalar(q, qdot, e_int, reference)
        if T is not None:
            with quiet(T):
                return scalar_law.desired_acceleration(
                    self, *self._parse_scalar(q, qdot, e_int, reference))
        q, qdot, e_int = self._parse(q, qdot, e_int)
        return self._desired_acceleration_core(q, qdot, e_int, reference)

    def _desired_acceleration_core(self, q, qdot, e_int, reference) -> np.ndarray:
        """:meth:`desired_acceleration` without the checks of q, q̇ and ∫e (float vectors of
        the right size, already validated by the caller, e.g. the tilt-rotor law per sample)."""
        e, ed, qddr = self._errors(q, qdot, reference)
        acc = np.full(self.n, np.nan)
        nc = self.nc
        acc[self.ic] = qddr[:nc] - self.law.controlled.K @ np.concatenate([ed[:nc], e[:nc], e_int])
        if self.nr:
            acc[self.ir] = qddr[nc:] - self.law.regulated.K @ np.concatenate([ed[nc:], e[nc:]])
        if self.ns:
            acc[self.is_] = -self.law.stabilized.K @ qdot[self.is_]
        return acc

    def desired_acceleration_scalar(self, q: list[float], qdot: list[float], e_int: list[float],
                                    reference: list[float]) -> list[float]:
        """:meth:`desired_acceleration` of the Sobolev law on lists of Python floats (q, q̇: n,
        ∫e: n_c, reference: 3 n_ref; validated by the caller), as a list: the tilt-rotor law's
        per-sample path, by the compiled kernel when built (the same operations in the same order,
        :func:`~.mechanical_sample.compiled_desired_acceleration`).  Equal to the numpy form to
        rounding (tested), not to the bit: the tilt-rotor results would move by that rounding.

        Parameters
        ----------
        q, qdot : list of float, length n
            Generalized coordinates and velocities, thesis order.
        e_int : list of float, length n_c
            Error integral of the controlled DOF.
        reference : list of float, length 3 n_ref
            Stacked reference (see :meth:`split_reference`).

        Returns
        -------
        list of float, length n
            q̈_des (NaN on the uncontrolled DOF).
        """
        compiled = self._cache.get("qdd_kernel", False)
        if compiled is False:                # built once per law (with_inner clears the cache)
            compiled = self._cache["qdd_kernel"] = compiled_desired_acceleration(self)
        if compiled is not None:
            return compiled(q, qdot, e_int, reference)
        rows = self._cache.get("K_rows")
        if rows is None:
            lw = self.law
            rows = self._cache["K_rows"] = tuple(
                None if g is None else g.K.tolist()
                for g in (lw.controlled, lw.regulated, lw.stabilized))
        Kc, Kr, Ks = rows
        nr, nc = self.n_ref, self.nc
        tr = self.partition.tracked
        e = [q[i] - reference[k] for k, i in enumerate(tr)]
        ed = [qdot[i] - reference[nr + k] for k, i in enumerate(tr)]
        qddr = reference[2 * nr:]
        acc = [math.nan] * self.n
        z = ed[:nc] + e[:nc] + list(e_int)
        for k, i in enumerate(self.partition.controlled):
            acc[i] = qddr[k] - sum([a * b for a, b in zip(Kc[k], z)])
        if self.nr:
            z = ed[nc:] + e[nc:]
            for k, i in enumerate(self.partition.regulated):
                acc[i] = qddr[nc + k] - sum([a * b for a, b in zip(Kr[k], z)])
        if self.ns:
            z = [qdot[i] for i in self.partition.stabilized]
            for k, i in enumerate(self.partition.stabilized):
                acc[i] = -sum([a * b for a, b in zip(Ks[k], z)])
        return acc

    def reduced_model(self, q: ArrayLike, qdot: ArrayLike
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(M̄, B̄, h̄, Mcu Muu⁻¹) of (5.5) with h = C q̇ + g + friction: h̄ = h_c − Mcu Muu⁻¹ h_u.

        Cached per (q, q̇); callers must not mutate the returned arrays.

        Parameters
        ----------
        q, qdot : array_like, shape (n,)
            Generalized coordinates and velocities, thesis order.

        Returns
        -------
        Mbar : ndarray, shape (n_c, n_c)
            M_cc − Mcu Muu⁻¹ M_uc.
        Bbar : ndarray, shape (n_c, n_τ)
            B_c − Mcu Muu⁻¹ B_u.
        hbar : ndarray, shape (n_c,)
            h_c − Mcu Muu⁻¹ h_u.
        X : ndarray, shape (n_c, n_u)
            Mcu Muu⁻¹.
        """
        key = (np.asarray(q, float).tobytes(), np.asarray(qdot, float).tobytes())
        if self._cache.get("red_key") == key:
            return self._cache["red"]
        M, h = self.dynamics.mass_and_bias(q, qdot)
        ic, iu = self.ic, self.iu
        Mcu = M[ic][:, iu]
        X = Mcu @ np.linalg.inv(M[iu][:, iu])           # Mcu Muu⁻¹
        Mbar = M[ic][:, ic] - X @ M[iu][:, ic]
        B = self.dynamics.input_matrix(q)
        out = (Mbar, B[ic] - X @ B[iu], h[ic] - X @ h[iu], X)
        self._cache["red_key"], self._cache["red"] = key, out
        return out

    # --- generalized input and actuation -----------------------------------------------------
    def generalized_input(self, q: ArrayLike, qdot: ArrayLike, e_int: ArrayLike, reference: ArrayLike,
                          extra: ArrayLike | None = None) -> np.ndarray:
        """u* (generalized force, size n; reduced mode: B̄τ, size n_c), minus ``extra``.

        Sobolev: M q̈_des + C q̇ + g (+ friction) (5.26)/(5.84)/(7.81); reduced model:
        M̄ q̈c_des + h̄.
        H∞: M a + h − C(q,q̇)T11⁻¹σ − T11⁻¹R⁻¹σ (docs/design.md §4.3, same inverse dynamics).

        Parameters
        ----------
        q, qdot : array_like, shape (n,)
            Generalized coordinates and velocities, thesis order.
        e_int : array_like, shape (n_c,)
            Error integral ∫q̃c of the controlled DOF.
        reference : array_like, shape (3 n_ref,)
            Stacked reference (see :meth:`split_reference`).
        extra : array_like, optional
            Force subtracted from u* (same size), e.g. ϑ_passive(q, q̇, ζ) of the tilt-rotor
            law (7.81).

        Returns
        -------
        ndarray, shape (n,) or (n_c,)
            u* (size n_c in the reduced mode).
        """
        T = self._drake_scalar(q, qdot, e_int, reference, extra)
        if T is not None:
            with quiet(T):
                args = self._parse_scalar(q, qdot, e_int, reference)
                out = scalar_law.generalized_input(self, self.scalar_terms(T), *args)
                return out if extra is None else out - scalar_vector("extra", extra, len(out))
        q, qdot, e_int = self._parse(q, qdot, e_int)
        if isinstance(self.law, SobolevLaw):
            acc = self.desired_acceleration(q, qdot, e_int, reference)
            if self.partition.mode == "reduced":
                Mbar, _, hbar, _ = self.reduced_model(q, qdot)
                out = Mbar @ acc[self.ic] + hbar
            else:
                out = self.dynamics.inverse_dynamics(q, qdot, acc)
        else:
            out = hinf_force(self, q, qdot, e_int, reference)
        if extra is not None:
            out = out - check_vector("extra", extra, out.shape[0])
        return out

    def allocate(self, u_star: ArrayLike, q: ArrayLike, qdot: ArrayLike) -> np.ndarray:
        """τ from the generalized input (B⁻¹, B̄⁻¹, B† or the allocation callable; bounds).

        With ``lower``/``upper`` the least-squares solution is returned when it is within
        the bounds, else the bounded least-squares one.

        Parameters
        ----------
        u_star : array_like
            Generalized input from :meth:`generalized_input`.
        q, qdot : array_like, shape (n,)
            Generalized coordinates and velocities, thesis order.

        Returns
        -------
        ndarray, shape (n_τ,)
            Actuator command τ.
        """
        T = self._drake_scalar(u_star, q, qdot)
        if T is not None:
            with quiet(T):
                return scalar_law.allocate(self, self.scalar_terms(T), np.asarray(u_star),
                                           scalar_vector("q", q, self.n),
                                           scalar_vector("qdot", qdot, self.n))
        if self.allocation is not None:
            return np.asarray(self.allocation(u_star, q, qdot), dtype=float)
        if self.partition.mode == "reduced":
            _, Bmat, _, _ = self.reduced_model(q, qdot)
        else:
            Bmat = self.dynamics.input_matrix(q)
        if self.lower is not None or self.upper is not None:
            lo = -np.inf * np.ones(self.num_inputs) if self.lower is None else self.lower
            hi = np.inf * np.ones(self.num_inputs) if self.upper is None else self.upper
            tau = np.linalg.lstsq(Bmat, u_star, rcond=None)[0]
            if np.all(tau >= lo) and np.all(tau <= hi):  # unconstrained optimum is feasible
                return tau
            if np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)):
                # our active-set solver (pure numpy, faster than BVLS on these sizes)
                return bounded_least_squares(Bmat, u_star, lo, hi)
            return lsq_linear(Bmat, u_star, bounds=(lo, hi), method="bvls").x
        if Bmat.shape[0] == Bmat.shape[1]:
            return np.linalg.solve(Bmat, u_star)
        return np.linalg.pinv(Bmat) @ u_star

    def actuation(self, q: ArrayLike, qdot: ArrayLike, e_int: ArrayLike, reference: ArrayLike,
                  extra: ArrayLike | None = None) -> np.ndarray:
        """Applied actuator command τ: :meth:`allocate` of :meth:`generalized_input`.

        Parameters
        ----------
        q, qdot, e_int, reference, extra
            As in :meth:`generalized_input`.

        Returns
        -------
        ndarray, shape (n_τ,)
            Actuator command τ.
        """
        u_star = self.generalized_input(q, qdot, e_int, reference, extra)
        if self._drake_scalar(q, qdot, e_int, reference, extra) is not None:
            return self.allocate(u_star, q, qdot)
        return self.allocate(u_star, np.asarray(q, float), np.asarray(qdot, float))

    def closed_loop_matrix(self) -> np.ndarray:
        """Linear closed loop of the Sobolev law (5.27)/(5.86): blkdiag of the group chains.

        ``TypeError`` for the H∞ law.

        Returns
        -------
        ndarray
            Block diagonal of the stabilized, regulated and controlled chains' closed-loop
            matrices (in that order, absent groups left out).
        """
        if not isinstance(self.law, SobolevLaw):
            raise TypeError("closed_loop_matrix is defined for the Sobolev law")
        mats = [g.closed_loop for g in (self.law.stabilized, self.law.regulated, self.law.controlled)
                if g is not None]
        n = sum(m.shape[0] for m in mats)
        out = np.zeros((n, n))
        i = 0
        for m in mats:
            out[i:i + m.shape[0], i:i + m.shape[0]] = m
            i += m.shape[0]
        return out
