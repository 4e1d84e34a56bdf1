"""The tilt-rotor's wind-tunnel tables (Appendix B), stacked per aerodynamic surface.

:class:`AeroTables` reads ``data/tiltrotor_aero_tables.json`` (24 tables: lift, drag, pitch
moment against α; side force, drag, yaw moment against β, per component) and interpolates them;
:class:`~sobolev_drake.tiltrotor.aerodynamics.AeroModel` computes the loads from them (and
:mod:`sobolev_drake.tiltrotor.aerodynamics` re-exports :class:`AeroTables`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from sobolev_drake.data import load
from sobolev_drake.tiltrotor.params import SURFACES

__all__ = ["AeroTables"]

_COMPONENT = {"F": "fuselage", "WR": "wing", "WL": "wing", "TR": "tail", "TL": "tail", "I": "interference"}


class AeroTables:
    """The 24 wind-tunnel tables stacked per surface for vectorized interpolation.

    ``alpha_tab[k] = [lift, drag_alpha, pitch_moment]`` and ``beta_tab[k] = [side_force,
    drag_beta, yaw_moment]`` of surface ``SURFACES[k]``, sampled at −90° … 90° every 0.5°.

    Parameters
    ----------
    data : dict, optional
        Contents of ``data/tiltrotor_aero_tables.json`` (read when omitted).
    """

    def __init__(self, data: dict | None = None) -> None:
        data = load("tiltrotor_aero_tables") if data is None else data
        self.start = np.deg2rad(float(data["angle_deg_start"]))
        self.step = np.deg2rad(float(data["angle_deg_step"]))
        self.samples = int(data["samples"])
        t = data["tables"]
        self.alpha_tab = np.array([[t[_COMPONENT[s]][k] for k in ("lift_alpha", "drag_alpha", "pitch_moment_alpha")]
                                   for s in SURFACES])
        self.beta_tab = np.array([[t[_COMPONENT[s]][k] for k in ("side_force_beta", "drag_beta", "yaw_moment_beta")]
                                  for s in SURFACES])
        if self.alpha_tab.shape != (6, 3, self.samples):
            raise ValueError("aerodynamic tables must all have 'samples' entries")
        self._rows = np.arange(6)

    def lookup(self, tab: np.ndarray, angle: np.ndarray) -> NDArray[np.float64]:
        """Interpolate a stacked table at one angle per surface (linear, clamped to ±90°).

        Parameters
        ----------
        tab : ndarray, shape (6, 3, N)
            ``alpha_tab`` or ``beta_tab``.
        angle : ndarray, shape (6,)
            Table argument per surface (rad, NED convention).

        Returns
        -------
        ndarray, shape (6, 3)
            The three coefficients of each surface.
        """
        x = (np.clip(angle, self.start, -self.start) - self.start) / self.step
        i = np.minimum(x.astype(int), self.samples - 2)
        fr = (x - i)[:, None]
        return tab[self._rows, :, i] * (1.0 - fr) + tab[self._rows, :, i + 1] * fr

    def coefficients(self, name: str, alpha_ned: float | None = None,
                     beta_ned: float | None = None) -> dict[str, float]:
        """Scalar look-up for tests and reports, e.g. ``coefficients("wing", alpha_ned=0.1)``.

        Parameters
        ----------
        name : str
            Component: ``"fuselage"``, ``"wing"``, ``"tail"`` or ``"interference"``.
        alpha_ned, beta_ned : float, optional
            Table arguments α_NED and β_NED (rad); 0 when omitted.

        Returns
        -------
        dict
            ``lift``, ``drag_alpha``, ``pitch_moment`` (at α_NED) and ``side_force``,
            ``drag_beta``, ``yaw_moment`` (at β_NED).
        """
        k = [_COMPONENT[s] for s in SURFACES].index(name)
        a = self.lookup(self.alpha_tab, np.full(6, 0.0 if alpha_ned is None else alpha_ned))[k]
        b = self.lookup(self.beta_tab, np.full(6, 0.0 if beta_ned is None else beta_ned))[k]
        return {"lift": a[0], "drag_alpha": a[1], "pitch_moment": a[2],
                "side_force": b[0], "drag_beta": b[1], "yaw_moment": b[2]}
