"""The port layout a state-feedback tracking controller shares with Drake's controllers
(``InverseDynamicsController``, ``PidController``), as a mixin of a LeafSystem.

Input ports:

* ``estimated_state`` — the plant state [q; q̇] (size 2n);
* ``desired_state`` — [q_r; q̇_r] of the tracked DOF (size 2 n_ref) and ``desired_acceleration``
  — q̈_r (size n_ref, zero when unconnected, like Drake's ``InverseDynamicsController`` built
  with ``has_reference_acceleration=False``);
* or, instead of those two, ``reference`` — the library's stacked [q_r; q̇_r; q̈_r] (size
  3 n_ref, the output of its reference sources);
* ``x`` — the former name of ``estimated_state``, kept as an alias (connect one of the two).

Output ports (declared by the controller): ``control`` (actuator command; aliases
``actuation``, the name in Drake's ``InverseDynamicsController``, and ``u``),
``generalized_force`` and ``error_integral``.  The ``get_input_port_*`` / ``get_output_port_*``
methods have Drake's names, so a diagram written for Drake's controller needs no change
besides the line that constructs the controller.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from pydrake.systems.framework import Context, InputPort, OutputPort

__all__ = ["DropInPorts"]


class DropInPorts:
    """Mixin of a LeafSystem: the ports of the module docstring and their Drake-named getters.

    The system calls :meth:`declare_tracking_ports` in its constructor and reads the inputs
    with :meth:`read_tracking_inputs`.
    """

    def declare_tracking_ports(self, n: int, n_ref: int) -> None:
        """Declare the input ports (module docstring), in Drake's order.

        Parameters
        ----------
        n : int
            Number of generalized coordinates (the state has 2n entries).
        n_ref : int
            Number of tracked DOF.
        """
        self._n_state, self._n_ref = n, n_ref
        self._est = self.DeclareVectorInputPort("estimated_state", 2 * n)
        self._des = self.DeclareVectorInputPort("desired_state", 2 * n_ref)
        self._acc = self.DeclareVectorInputPort("desired_acceleration", n_ref)
        self._ref = self.DeclareVectorInputPort("reference", 3 * n_ref)
        self._x = self.DeclareVectorInputPort("x", 2 * n)

    def read_tracking_inputs(self, context: Context) -> tuple[np.ndarray, np.ndarray]:
        """The plant state and the stacked reference [q_r; q̇_r; q̈_r] from whichever ports are
        connected (``RuntimeError`` naming the ports for a missing or doubled connection).

        Parameters
        ----------
        context : Context
            The system's context.

        Returns
        -------
        x : ndarray, shape (2 n,)
            [q; q̇].
        reference : ndarray, shape (3 n_ref,)
            [q_r; q̇_r; q̈_r] of the tracked DOF.
        """
        x, desired, qddot_r = self.read_tracking_parts(context)
        return x, np.concatenate([desired, np.zeros(self._n_ref) if qddot_r is None else qddot_r])

    def read_tracking_parts(self, context: Context
                            ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """:meth:`read_tracking_inputs` without stacking the reference: the per-sample read
        (one ``Eval`` per input, no copy of the reference).

        Parameters
        ----------
        context : Context
            The system's context.

        Returns
        -------
        x : ndarray, shape (2 n,)
            [q; q̇].
        desired : ndarray, shape (2 n_ref,)
            [q_r; q̇_r] of the tracked DOF.
        qddot_r : ndarray, shape (n_ref,), or None
            q̈_r of the tracked DOF; None when ``desired_acceleration`` is unconnected (zero).
        """
        est, alias = self._est.HasValue(context), self._x.HasValue(context)
        if est == alias:
            raise RuntimeError(
                f"{self.get_name()}: connect exactly one of the input ports 'estimated_state' and "
                f"'x' (its former name) to the plant state [q; q̇] (size {2 * self._n_state}); "
                f"connected: {'both' if est else 'neither'}")
        x = (self._est if est else self._x).Eval(context)
        desired, acc = self._des.HasValue(context), self._acc.HasValue(context)
        if self._ref.HasValue(context):
            if desired or acc:
                raise RuntimeError(
                    f"{self.get_name()}: 'reference' ([q_r; q̇_r; q̈_r]) and 'desired_state'/"
                    "'desired_acceleration' are alternatives; connect one form only")
            ref = self._ref.Eval(context)
            k = 2 * self._n_ref
            return x, ref[:k], ref[k:]
        if not desired:
            raise RuntimeError(
                f"{self.get_name()}: no reference: connect 'desired_state' ([q_r; q̇_r], size "
                f"{2 * self._n_ref}, optionally 'desired_acceleration') or 'reference' "
                f"([q_r; q̇_r; q̈_r], size {3 * self._n_ref})")
        return x, self._des.Eval(context), (self._acc.Eval(context) if acc else None)

    def get_input_port_estimated_state(self) -> InputPort:
        """The ``estimated_state`` input port, [q; q̇] (Drake's name).

        Returns
        -------
        InputPort
        """
        return self._est

    def get_input_port_desired_state(self) -> InputPort:
        """The ``desired_state`` input port, [q_r; q̇_r] of the tracked DOF (Drake's name).

        Returns
        -------
        InputPort
        """
        return self._des

    def get_input_port_desired_acceleration(self) -> InputPort:
        """The ``desired_acceleration`` input port, q̈_r (zero when unconnected).

        Returns
        -------
        InputPort
        """
        return self._acc

    def get_input_port_reference(self) -> InputPort:
        """The ``reference`` input port, [q_r; q̇_r; q̈_r] (alternative to the two above).

        Returns
        -------
        InputPort
        """
        return self._ref

    def get_output_port_control(self) -> OutputPort:
        """The ``control`` output port: the actuator command (Drake's name; aliases
        ``actuation`` and ``u``).

        Returns
        -------
        OutputPort
        """
        return self.GetOutputPort("control")

    def get_output_port_generalized_force(self) -> OutputPort:
        """The ``generalized_force`` output port: u* (B̄τ in the reduced mode).

        Returns
        -------
        OutputPort
        """
        return self.GetOutputPort("generalized_force")

    def get_output_port_error_integral(self) -> OutputPort:
        """The ``error_integral`` output port: ∫q̃c.

        Returns
        -------
        OutputPort
        """
        return self.GetOutputPort("error_integral")
