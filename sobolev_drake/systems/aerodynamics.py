"""Fuselage, wings, V-tail and interference aerodynamics of the tilt-rotor (7.34)–(7.56), (B.1)–(B.15).

Conventions (our reading of the partly garbled Appendix B, chosen so that drag opposes the air-
relative motion, lift is perpendicular to it and side force / moments are restoring where the
wind-tunnel slopes say so):

* surfaces ``SURFACES = (F, WR, WL, TR, TL, I)`` at the body points of Table B.1 (I at C1);
  every surface frame has the body orientation (Appendix B: R_I^S = R_I^B);
* air-relative velocity (u, v, w) = R_Bᵀ(ṗ_S − ζ) (7.37); V = |(u, v, w)| (7.38);
  α = atan2(w, u) clipped to [−π/2, π/2] ((7.39) with a sign-safe arctangent, continuous through
  u = 0 when w ≠ 0, e.g. vertical climb in hover), β = asin(v / V) (7.40);
* table arguments α_NED = −α, β_NED = −β (App. B), linear interpolation on the 0.5° grid;
* wind-axes forces (after the NED → z-up rotation Rx(π) of (B.1)–(B.4)):
  f_d = −κ s (c_d^xy(β_NED) + c_d^xz(α_NED)), f_y = κ s (c_y(β_NED) [+ c_δr δr]),
  f_l = κ s (c_l(α_NED) [+ c_δa δW | + c_δe δe]), κ = ½ ρ V²;
* wind axes → surface axes by R_S^W = Ry(−α) Rz(β), whose first column is the air-relative
  velocity direction.  The thesis writes Ry(−α) Rz(−β); with β = asin(v/V) that would make the
  drag push sideways *with* the sideslip, so we read it as a sign slip;
* moments in surface axes [L, M, N] = Rx(π) [0, κ s c̄ c_M(α_NED), κ s b c_N(β_NED)] (B.5)–(B.11);
* areas: s = S for fuselage and interference, S/2 for each wing and tail half (App. B);
  δe = ½(δTR + δTL), δr = ½(δTR − δTL) act on both tail halves.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

from sobolev_drake.data import load
from sobolev_drake.models.tiltrotor_params import SURFACES, R_IB, W_eta, TiltrotorParams

_COMPONENT = {"F": "fuselage", "WR": "wing", "WL": "wing", "TR": "tail", "TL": "tail", "I": "interference"}


class AeroTables:
    """The 24 wind-tunnel tables stacked per surface for vectorized interpolation.

    ``alpha_tab[k] = [lift, drag_alpha, pitch_moment]`` and ``beta_tab[k] = [side_force,
    drag_beta, yaw_moment]`` of surface ``SURFACES[k]``, sampled at −90° … 90° every 0.5°.
    """

    def __init__(self, data: dict | None = None):
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

    def lookup(self, tab, angle):
        """Interpolate the (6, 3, N) table ``tab`` at one angle (rad) per surface → (6, 3)."""
        x = (np.clip(angle, self.start, -self.start) - self.start) / self.step
        i = np.minimum(x.astype(int), self.samples - 2)
        fr = (x - i)[:, None]
        return tab[self._rows, :, i] * (1.0 - fr) + tab[self._rows, :, i + 1] * fr

    def coefficients(self, name: str, alpha_ned=None, beta_ned=None):
        """Scalar look-up for tests and reports, e.g. ``coefficients("wing", alpha_ned=0.1)``."""
        k = [_COMPONENT[s] for s in SURFACES].index(name)
        a = self.lookup(self.alpha_tab, np.full(6, 0.0 if alpha_ned is None else alpha_ned))[k]
        b = self.lookup(self.beta_tab, np.full(6, 0.0 if beta_ned is None else beta_ned))[k]
        return {"lift": a[0], "drag_alpha": a[1], "pitch_moment": a[2],
                "side_force": b[0], "drag_beta": b[1], "yaw_moment": b[2]}


class AeroModel:
    """Numpy core of the aerodynamic generalized forces (affine in the surface deflections)."""

    def __init__(self, params: TiltrotorParams | None = None, tables: AeroTables | None = None):
        self.params = TiltrotorParams() if params is None else params
        self.tables = AeroTables() if tables is None else tables
        p = self.params
        self.points = p.aero_points()
        self.area = p.S * np.array([1.0, 0.5, 0.5, 0.5, 0.5, 1.0])

    def surface_air_data(self, q, qdot, zeta):
        """(v_rel (6,3) body axes, V (6,), α (6,), β (6,)) of every surface (7.37)–(7.40)."""
        R = R_IB(q)
        w = W_eta(q) @ qdot[2:5]
        v = (R.T @ (qdot[5:8] - zeta))[None, :] + np.cross(w, self.points)
        V = np.sqrt(np.einsum("ij,ij->i", v, v))
        alpha = np.clip(np.arctan2(v[:, 2], v[:, 0]), -np.pi / 2, np.pi / 2)
        beta = np.arcsin(np.clip(v[:, 1] / np.where(V > 1e-12, V, 1.0), -1.0, 1.0))
        return v, V, alpha, beta

    def surface_loads(self, q, qdot, zeta):
        """Passive loads per surface: (F (6,3) body-axes forces at the aerodynamic centres,
        M (6,3) body-axes moments, κs (6,), y_w (6,3), z_w (6,3)) (B.1)–(B.11) with δ = 0."""
        p = self.params
        _, V, alpha, beta = self.surface_air_data(q, qdot, zeta)
        ca = self.tables.lookup(self.tables.alpha_tab, -alpha)   # α_NED = −α
        cb = self.tables.lookup(self.tables.beta_tab, -beta)     # β_NED = −β
        ks = 0.5 * p.rho * V * V * self.area                     # κ s per surface
        sa, cal, sb, cbe = np.sin(alpha), np.cos(alpha), np.sin(beta), np.cos(beta)
        xw = np.stack([cal * cbe, sb, sa * cbe], axis=1)         # columns of R_S^W = Ry(−α) Rz(β)
        yw = np.stack([-cal * sb, cbe, -sa * sb], axis=1)
        zw = np.stack([-sa, np.zeros(6), cal], axis=1)
        fd = -ks * (cb[:, 1] + ca[:, 1])
        fy = ks * cb[:, 0]
        fl = ks * ca[:, 0]
        F = xw * fd[:, None] + yw * fy[:, None] + zw * fl[:, None]
        M = np.zeros((6, 3))
        M[:, 1] = -ks * p.chord * ca[:, 2]
        M[:, 2] = -ks * p.span * cb[:, 2]
        return F, M, ks, yw, zw

    def terms(self, q, qdot, zeta):
        """(ϑ_aero_passive (8,), B_delta (8, 4)) with ϑ_aero = ϑ_passive + B_delta δ,
        δ = [δWR, δWL, δTR, δTL] ((B.12)–(B.15), Appendix C)."""
        p = self.params
        F, M, ks, yw, zw = self.surface_loads(q, qdot, zeta)
        # generalized force of main-body forces/moments: η ← Wηᵀ Σ(r × F + M), ξ ← R Σ F
        Wt = W_eta(q).T
        R = R_IB(q)
        passive = np.zeros(8)
        passive[2:5] = Wt @ (np.cross(self.points, F).sum(axis=0) + M.sum(axis=0))
        passive[5:8] = R @ F.sum(axis=0)
        # control columns: unit δ gives a force at one or two surfaces
        Fc = np.zeros((4, 2, 3))       # per input: force at surface a and b
        Fc[0, 0] = ks[1] * p.c_delta_a * zw[1]
        Fc[1, 0] = ks[2] * p.c_delta_a * zw[2]
        for j, sgn in ((2, 1.0), (3, -1.0)):
            Fc[j, 0] = 0.5 * ks[3] * (p.c_delta_e * zw[3] + sgn * p.c_delta_r * yw[3])
            Fc[j, 1] = 0.5 * ks[4] * (p.c_delta_e * zw[4] + sgn * p.c_delta_r * yw[4])
        pts = np.array([[self.points[1], self.points[1]], [self.points[2], self.points[2]],
                        [self.points[3], self.points[4]], [self.points[3], self.points[4]]])
        Bd = np.zeros((8, 4))
        Bd[2:5] = Wt @ np.cross(pts, Fc).sum(axis=1).T
        Bd[5:8] = R @ Fc.sum(axis=1).T
        return passive, Bd

    def generalized_force(self, q, qdot, zeta, delta):
        passive, Bd = self.terms(q, qdot, zeta)
        return passive + Bd @ delta


class AerodynamicSurfaces(LeafSystem):
    """LeafSystem: thesis-ordered generalized force of fuselage, wings, V-tail and interference.

    Inputs: ``x`` (16, thesis order [q; q̇]), ``wind`` (3, inertial m/s; zero if unconnected),
    ``surface_deflection`` (4, [δWR δWL δTR δTL] rad; zero if unconnected).
    Output: ``generalized_force`` (8, thesis order).
    """

    def __init__(self, params: TiltrotorParams | None = None):
        super().__init__()
        self.core = AeroModel(params)
        self._x = self.DeclareVectorInputPort("x", 16)
        self._wind = self.DeclareVectorInputPort("wind", 3)
        self._delta = self.DeclareVectorInputPort("surface_deflection", 4)
        self.DeclareVectorOutputPort("generalized_force", 8, self._calc)

    def _calc(self, context, output: BasicVector) -> None:
        x = self._x.Eval(context)
        zeta = self._wind.Eval(context) if self._wind.HasValue(context) else np.zeros(3)
        delta = self._delta.Eval(context) if self._delta.HasValue(context) else np.zeros(4)
        output.SetFromVector(self.core.generalized_force(x[:8], x[8:], np.asarray(zeta), np.asarray(delta)))
