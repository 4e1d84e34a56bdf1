"""Partitions of a mechanical system's DOF and the thesis assumptions each control law needs.

:class:`Partition` assigns every generalized coordinate to one group (controlled, regulated,
stabilized, uncontrolled).  :func:`check_actuation` verifies, at construction of a law, that the
plant's input matrix can do what the partition asks at the configurations the user expects to
fly through:

* fully actuated (only controlled DOF): B(q) square and invertible (5.26);
* reduced model (uncontrolled DOF): B̄ = B_c − M_cu M_uu⁻¹ B_u invertible, Assumption 5;
* input coupling (stabilized / regulated DOF): B_c of full row rank (Assumption 6) and the
  rows of B on the stabilized and regulated DOF linearly independent (Assumption 7), so the
  inputs act on those DOF directly.  A DOF that no input reaches (a zero row of B, e.g. the
  passive joint of an Acrobot or the pole of a cart-pole) cannot be stabilized by this law.

Ranks use numpy's rule (singular values above σ_max · max(shape) · machine epsilon), i.e. a
matrix is called rank-deficient only when it is so to rounding.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from sobolev_drake.models.base import MechanicalModel
from sobolev_drake.validation import index_tuple

__all__ = ["Partition", "check_actuation"]


@dataclass(frozen=True)
class Partition:
    """DOF partition by thesis indices (0-based, thesis order).

    Every DOF must be in exactly one group (checked against the model's size by
    :meth:`check`).  Mode: ``reduced`` if ``uncontrolled`` is non-empty, ``input_coupling`` if
    ``stabilized`` or ``regulated`` is, ``fully_actuated`` otherwise; a reduced model cannot
    also have stabilized or regulated DOF.

    Parameters
    ----------
    controlled : sequence of int
        DOF tracked with integral action (at least one).
    stabilized : sequence of int, optional
        DOF whose rates are driven to zero, q̇s → 0 (5.66).
    regulated : sequence of int, optional
        DOF tracked without integral action (7.66).
    uncontrolled : sequence of int, optional
        DOF eliminated by the reduced model (5.5).

    Each is stored as a tuple of ints.

    Examples
    --------
    A quadrotor-like split: x, y, z, yaw tracked with integral action, roll and pitch rates
    driven to zero:

    >>> import sobolev_drake as sd
    >>> partition = sd.Partition(controlled=[0, 1, 2, 3], stabilized=[4, 5])
    >>> partition.mode, partition.tracked
    ('input_coupling', (0, 1, 2, 3))
    >>> partition.check(6)                   # every one of the 6 DOF in exactly one group
    >>> sd.Partition(controlled=[0, 1], uncontrolled=[2]).mode
    'reduced'
    """

    controlled: tuple
    stabilized: tuple = ()
    regulated: tuple = ()
    uncontrolled: tuple = ()

    def __post_init__(self):
        seen = {}
        for name in ("controlled", "stabilized", "regulated", "uncontrolled"):
            idx = index_tuple(f"Partition.{name}", getattr(self, name), None)
            for i in idx:
                if i in seen:
                    raise ValueError(f"Partition: DOF {i} is in both {seen[i]} and {name}; "
                                     "each DOF belongs to exactly one group")
                seen[i] = name
            object.__setattr__(self, name, idx)
        if not self.controlled:
            raise ValueError("partition.controlled must name at least one DOF")
        if self.uncontrolled and (self.stabilized or self.regulated):
            raise ValueError("partition: a reduced model (uncontrolled DOF) cannot also have "
                             "stabilized or regulated DOF")

    @property
    def tracked(self) -> tuple:
        """The DOF with a reference: ``controlled + regulated``."""
        return self.controlled + self.regulated

    @property
    def mode(self) -> str:
        """``"reduced"``, ``"input_coupling"`` or ``"fully_actuated"`` (see the class)."""
        if self.uncontrolled:
            return "reduced"
        if self.stabilized or self.regulated:
            return "input_coupling"
        return "fully_actuated"

    def check(self, n: int) -> None:
        """Raise ``ValueError`` unless the groups together hold each of the ``n`` DOF once.

        Parameters
        ----------
        n : int
            Number of generalized coordinates of the model.
        """
        allidx = self.controlled + self.stabilized + self.regulated + self.uncontrolled
        if sorted(allidx) != list(range(n)):
            raise ValueError(f"partition must assign each of the {n} DOF to exactly one group, "
                             f"got {self}")


def _names(model, idx) -> str:
    names = getattr(model, "dof_names", None)
    return ", ".join(f"{i} ({names[i]!r})" if names else str(i) for i in idx)


def _rank(M) -> int:
    return int(np.linalg.matrix_rank(M)) if M.size else 0


def check_actuation(model: MechanicalModel, partition: Partition,
                    B_of_q: Callable[[np.ndarray], ArrayLike],
                    operating_points: Sequence[ArrayLike]) -> None:
    """Raise ``ValueError`` if ``partition`` asks the inputs for what they cannot do.

    Parameters
    ----------
    model : MechanicalModel
        The controller's model (``M(q)`` for the reduced model, ``dof_names`` for messages).
    partition : Partition
        The DOF partition to check.
    B_of_q : callable
        q ↦ B(q), the input matrix in the model's coordinates (n × n_τ).
    operating_points : sequence of array_like
        Configurations q (size n) at which the assumptions must hold.
    """
    p = partition
    ic, ir, is_, iu = (list(g) for g in (p.controlled, p.regulated, p.stabilized, p.uncontrolled))
    points = [np.asarray(q, dtype=float) for q in operating_points]
    inputs = [np.asarray(B_of_q(q), dtype=float) for q in points]      # B(q) once per point
    for q, B in zip(points, inputs):
        where = f"at q = {np.array2string(q, precision=3)}"
        if p.mode == "fully_actuated":
            if B.shape[0] != B.shape[1] or _rank(B) < B.shape[0]:
                raise ValueError(
                    f"partition {p} is fully actuated (every DOF controlled) but B(q) has shape "
                    f"{B.shape} and rank {_rank(B)} {where}; the law inverts B, which must be "
                    "square and invertible (5.26). Mark the DOF no input reaches as "
                    "uncontrolled (reduced model) or stabilized (input coupling)")
        elif p.mode == "reduced":
            M = np.asarray(model.M(q), dtype=float)
            X = np.linalg.solve(M[np.ix_(iu, iu)], M[np.ix_(iu, ic)]).T     # M_cu M_uu⁻¹
            Bbar = B[ic] - X @ B[iu]
            if Bbar.shape[0] != Bbar.shape[1] or _rank(Bbar) < len(ic):
                raise ValueError(
                    f"reduced model: B̄ = B_c − M_cu M_uu⁻¹ B_u has shape {Bbar.shape} and rank "
                    f"{_rank(Bbar)} {where}, but Assumption 5 needs it square and invertible "
                    f"(as many inputs as controlled DOF {_names(model, ic)}, acting on them)")
        else:
            dead = [i for i in is_ + ir if not np.any(B[i])]
            if dead and not any(np.any(Bx[dead]) for Bx in inputs):
                raise ValueError(
                    f"DOF {_names(model, dead)} receive no input (their rows of B(q) are zero "
                    "at every operating point), so the input-coupling law cannot stabilize or "
                    "regulate them (Assumption 7). Use Partition(controlled=..., uncontrolled="
                    f"{tuple(dead)}) to leave them to their own dynamics (reduced model (5.5)), "
                    "or a linear W∞ design about an equilibrium (winf_output_feedback on the "
                    "linearized plant, see diagrams/acrobot_upright.py)")
            if _rank(B[ic]) < len(ic):
                raise ValueError(
                    f"controlled DOF {_names(model, ic)}: B_c has rank {_rank(B[ic])} {where}, "
                    f"Assumption 6 needs {len(ic)} (every controlled DOF driven independently)")
            rows = is_ + ir
            if _rank(B[rows]) < len(rows):
                raise ValueError(
                    f"stabilized/regulated DOF {_names(model, rows)}: their rows of B have rank "
                    f"{_rank(B[rows])} {where}, Assumption 7 needs {len(rows)} (linearly "
                    "independent rows, so the inputs act on each of them)")
