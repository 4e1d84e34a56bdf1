"""The thesis' reference trajectories (tables 5.2, 5.5, 5.8, 6.3, 7.1 and the envelope mission).

Every entry is available as a pure :class:`PiecewiseTrajectory` (``trajectory(name)``) and as a
:class:`TrajectoryReference` LeafSystem (``table_5_2()`` …).  Each documents its coordinate
names and the smoothness at its breakpoints (verified in ``tests/systems/test_references.py``); the
thesis tables are partly garbled in the PDF text, the reconstructions are stated below.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sobolev_drake.systems.reference_smoothing import smooth_junctions
from sobolev_drake.systems.references import PiecewiseTrajectory, TrajectoryReference, const, poly, sine

__all__ = [
    "TRAJECTORIES", "trajectory", "table_5_2", "table_5_5", "table_5_8", "table_6_3", "table_7_1",
    "envelope_mission",
    "tiltrotor_mission_reference",
]

PI = np.pi


def _t52() -> PiecewiseTrajectory:
    """Table 5.2 (planar manipulator, joint angles [q1, q2] in rad), t ≥ 0:
    q1_r = π/2, q2_r = (π/2) sin(2πt/10).

    The PDF text reads "t≥0  π/2  π/2 sin(2π t/10)": two cells, a constant for q1 and a sinusoid
    for q2 (the experiment starts from q(0) = [π/4, 0]).  Smooth (single piece).
    """
    return PiecewiseTrajectory(
        ["q1", "q2"], [[const(PI / 2), sine(PI / 2, 2 * PI / 10)]],
        description="thesis Table 5.2: q1_r = pi/2, q2_r = (pi/2) sin(2 pi t/10)")


def _t55(psi: str = "printed") -> PiecewiseTrajectory:
    """Table 5.5 (quadrotor altitude and attitude [z m, φ, θ, ψ rad]).

    t ≤ 8:       z = 5 − sin(2πt/8)/2,  φ = θ = ψ = (π/4) sin(2πt/5)
    8 < t (≤30): z = 5,  φ = 0,  θ = (π/4) sin(2πt/5),  ψ = 2π sin(2πt/40)

    Read as printed.  At t = 8 the thesis itself says the switch "is not smooth": z is C0
    (ż jumps by π/8), φ jumps from −0.462 to 0, and ψ jumps from −0.462 to 2π sin(0.4π) = 5.98 rad
    (the printed amplitude "2π" of the second ψ piece is large but unambiguous in the text); θ is
    analytic.  The last piece is used for t > 30 as well.

    ``psi="continuous"`` keeps ψ = (π/4) sin(2πt/5) after t = 8 (no jump): the reading that
    reproduces the thesis' Table 5.6, whose ISE ψ ≈ ISE θ rules out a 6 rad jump.
    """
    if psi not in ("printed", "continuous"):
        raise ValueError(f"psi must be 'printed' or 'continuous', got {psi!r}")
    s5 = sine(PI / 4, 2 * PI / 5)
    return PiecewiseTrajectory(
        ["z", "phi", "theta", "psi"],
        [[sine(-0.5, 2 * PI / 8, offset=5.0), s5, s5, s5],
         [const(5.0), const(0.0), s5, sine(2 * PI, 2 * PI / 40) if psi == "printed" else s5]],
        breakpoints=[8.0],
        description="thesis Table 5.5 (z, phi, theta, psi); discontinuous at t = 8 as in the thesis")


def _figure8(with_psi: bool) -> PiecewiseTrajectory:
    x = sine(8.0, PI / 20, phase=PI / 2)            # 8 cos(πt/20)
    y = sine(8.0, PI / 10)                           # 8 sin(πt/10)
    z = sine(-1.0, PI / 20, phase=PI / 2, offset=3.0)  # 3 − cos(πt/20)
    if with_psi:
        return PiecewiseTrajectory(["x", "y", "z", "psi"], [[x, y, z, const(0.0)]],
                                   description="thesis Table 5.8 (x, y, z, psi): figure-8, psi_r = 0")
    return PiecewiseTrajectory(["x", "y", "z"], [[x, y, z]],
                               description="thesis Table 6.3 (x, y, z): figure-8")


def _t58() -> PiecewiseTrajectory:
    """Table 5.8 (quadrotor figure-8, [x, y, z m, ψ rad]), t ≥ 0:
    x = 8 cos(πt/20), y = 8 sin(πt/10), z = 3 − cos(πt/20), ψ = 0.

    The PDF prints z as "3 − cos(πt/20 t)"; the stray second t is a typo (Table 6.3 prints the
    same trajectory without it).  Note the thesis' controlled-DOF order is qc = [ψ x y z]; use
    ``trajectory("table_5_8").subset(["psi", "x", "y", "z"])`` for that order.  Smooth.
    """
    return _figure8(True)


def _t63() -> PiecewiseTrajectory:
    """Table 6.3 (quadrotor polytopic experiment, [x, y, z] m): the Table 5.8 figure-8 without ψ."""
    return _figure8(False)


# Tilt-rotor hover trim of the regulated DOF (thesis text next to Table 7.1)
TILTROTOR_TRIM = {"alpha_R": -0.137, "alpha_L": -0.137, "phi": 0.0, "theta": 0.137}


def _t71(full_state: bool = False) -> PiecewiseTrajectory:
    """Table 7.1 (tilt-rotor helicopter mode, [x, y, z m, ψ rad]; ψ_r = 0).

    ==================  ==================================  ===================  ===================
    t ≤ 105             x = 20 sin(2πt/35)                  y = 20 cos(2πt/35)   z = 2t/5 + 1
    105 < t ≤ 125       x = 3.59(t−105) − ½·0.1795(t−105)²  y = 20               z = 43
    125 < t ≤ 186.43    x = 35.9                            y = 20               z = 43 − 0.7(t−125)
    t > 186.43          x = 35.9                            y = 20               z = 0
    ==================  ==================================  ===================  ===================

    Reconstructions: the PDF prints the second x piece as "3.59(t−105) − 1 / 20.1795(t−105)²";
    reading it as ½·0.1795 makes x reach 35.9 with zero velocity at t = 125, which is what the
    third row (x = 35.9) requires (a 1/20.1795 coefficient would end at x = 51.98).  The thesis
    switches to z = 0 at t = 186.5, where 43 − 0.7·61.5 = −0.05 m; we switch where the descent
    reaches the ground, t = 125 + 43/0.7 ≈ 186.43 s, which removes that 5 cm position jump.

    Smoothness: x is C1 at 105 (velocity 40π/35 = 3.5904 vs the rounded 3.59: a 4e-4 m/s jump),
    C1 at 125; y is C1 at 105; z is C0 at 105 (ż: 0.4 → 0), 125 (0 → −0.7) and 186.43 (−0.7 → 0).

    ``full_state=True`` returns the 8 thesis coordinates [αR αL φ θ ψ x y z] with the regulated
    DOF at the hover trim stated with the table: αR = αL = −0.137, φ = 0, θ = 0.137.
    """
    t_ground = 125.0 + 43.0 / 0.7
    w = 2 * PI / 35
    pieces = [
        [sine(20.0, w), sine(20.0, w, phase=PI / 2), poly([1.0, 0.4]), const(0.0)],
        [poly([0.0, 3.59, -0.5 * 0.1795], t0=105.0), const(20.0), const(43.0), const(0.0)],
        [const(35.9), const(20.0), poly([43.0, -0.7], t0=125.0), const(0.0)],
        [const(35.9), const(20.0), const(0.0), const(0.0)],
    ]
    names = ["x", "y", "z", "psi"]
    desc = "thesis Table 7.1 (x, y, z; psi_r = 0), reconstructed, see docstring"
    if full_state:
        trim = [const(v) for v in TILTROTOR_TRIM.values()]
        pieces = [trim + [p[3], p[0], p[1], p[2]] for p in pieces]
        names = list(TILTROTOR_TRIM) + ["psi", "x", "y", "z"]
        desc += "; full thesis order [alpha_R alpha_L phi theta psi x y z] with hover trim"
    return PiecewiseTrajectory(names, pieces, [105.0, 125.0, t_ground], desc)


def _envelope() -> PiecewiseTrajectory:
    """Tilt-rotor full-envelope mission (thesis 7.3.2 scenario 2), [x, y, z m, ψ rad].

    From ``sobolev_drake/data/tiltrotor_missions.json`` (phase durations read from the file):

    1. accelerate_climb (0–66 s): x = ½·a t² with a = 33/66 = 0.5 m/s², y = 0,
       z = 1 + 50 (t/66)², ψ = 0.  Reaches 33 m/s at x = 1089 m, z = 51 m.
    2. cruise_1 (66–86 s): x = 1089 + 33 (t − 66), z = 51.
    3. turn (86–146 s): three quarters of a left circle of radius R = 33·80/(2π) ≈ 420.17 m
       (period 80 s, ω = 2π/80): x = x₂ + R sin ωτ, y = R (1 − cos ωτ), ψ = ωτ (0 → 3π/2).
    4. cruise_2 (146–166 s): along −y at 33 m/s, ψ = 3π/2.
    5. decelerate_descend (166–232 s): along −y, speed 33 − 0.5τ (rest at τ = 66);
       z = 2 + 49 (1 − τ/66)² — constant vertical acceleration, 49 m down.  The profile text
       does not say whether the vertical speed is zero at the start or at the end of the descent;
       we take the time-mirror of the climb (vertical speed zero at touchdown height), so the
       aircraft arrives at the hold point at rest.
    6. hold: hover at the final point (x = x₂ − R, y = R − 660 − 1089, z = 2).

    Smoothness (positions/velocities): the horizontal path is C1 everywhere (speed continuous,
    acceleration jumps at every phase boundary: 0.5 m/s² at 66, 166 and 232 s, the centripetal
    2.59 m/s² at 86 and 146 s); z is C0 at 66 s (ż: 100/66 = 1.52 m/s → 0) and at 166 s
    (0 → −98/66 = −1.48 m/s), C1 at 232 s; ψ is C0 at 86 and 146 s (ψ̇ = ω ↔ 0).
    """
    from sobolev_drake.data import load

    phases = load("tiltrotor_missions")["scenario_2_full_envelope"]["reference"]["phases"]
    dur = {p["name"]: p["duration"] for p in phases}
    T1, Tc1, Tt, Tc2, Td = (float(dur[k]) for k in
                            ("accelerate_climb", "cruise_1", "turn", "cruise_2", "decelerate_descend"))
    V = 33.0
    a = V / T1
    period = 80.0
    w = 2 * PI / period
    R = V * period / (2 * PI)
    z0, z_climb, z_end = 1.0, 50.0, 2.0
    z_cruise = z0 + z_climb
    b1 = T1
    b2 = b1 + Tc1
    b3 = b2 + Tt
    b4 = b3 + Tc2
    b5 = b4 + Td
    x1 = 0.5 * a * T1 ** 2
    x2 = x1 + V * Tc1
    psi_turn = w * Tt
    # heading after the turn, position at its end
    x3 = x2 + R * np.sin(psi_turn)
    y3 = R * (1 - np.cos(psi_turn))
    h3 = np.array([np.cos(psi_turn), np.sin(psi_turn)])  # unit heading (−y for 3/4 turn)
    s_c2 = V * Tc2
    x4, y4 = x3 + h3[0] * s_c2, y3 + h3[1] * s_c2
    ad = V / Td  # deceleration
    s_d = V * Td - 0.5 * ad * Td ** 2
    x5, y5 = x4 + h3[0] * s_d, y4 + h3[1] * s_d
    dz = z_cruise - z_end

    def along(p0, hk, v0, acc, t0):
        return poly([p0, hk * v0, 0.5 * hk * acc], t0=t0)

    pieces = [
        [poly([0.0, 0.0, 0.5 * a]), const(0.0), poly([z0, 0.0, z_climb / T1 ** 2]), const(0.0)],
        [poly([x1, V], t0=b1), const(0.0), const(z_cruise), const(0.0)],
        [sine(R, w, t0=b2, offset=x2), sine(-R, w, phase=PI / 2, t0=b2, offset=R), const(z_cruise),
         poly([0.0, w], t0=b2)],
        [along(x3, h3[0], V, 0.0, b3), along(y3, h3[1], V, 0.0, b3), const(z_cruise), const(psi_turn)],
        [along(x4, h3[0], V, -ad, b4), along(y4, h3[1], V, -ad, b4),
         poly([z_end + dz, -2 * dz / Td, dz / Td ** 2], t0=b4), const(psi_turn)],
        [const(x5), const(y5), const(z_end), const(psi_turn)],
    ]
    return PiecewiseTrajectory(["x", "y", "z", "psi"], pieces, [b1, b2, b3, b4, b5],
                               "tilt-rotor full-envelope mission (scenario 2), see docstring")


TRAJECTORIES = {
    "table_5_2": _t52,
    "table_5_5": _t55,
    "table_5_8": _t58,
    "table_6_3": _t63,
    "table_7_1": _t71,
    "envelope_mission": _envelope,
}


def trajectory(name: str, **kwargs: Any) -> PiecewiseTrajectory:
    """Pure-numpy catalogue entry by name (no LeafSystem is created)."""
    if name not in TRAJECTORIES:
        raise KeyError(f"unknown reference {name!r}; known: {sorted(TRAJECTORIES)}")
    return TRAJECTORIES[name](**kwargs)


def table_5_2() -> TrajectoryReference:
    return TrajectoryReference(_t52())


def table_5_5(psi: str = "printed") -> TrajectoryReference:
    """Table 5.5 (quadrotor altitude and attitude [z m, φ, θ, ψ rad]) as a reference system.

    Parameters
    ----------
    psi : {"printed", "continuous"}, default "printed"
        ψ after t = 8 s: the printed 2π sin(2πt/40) (a 6.44 rad jump at 8 s) or
        (π/4) sin(2πt/5) continued (the reading that reproduces Table 5.6).

    Returns
    -------
    TrajectoryReference
        Outputs [z φ θ ψ] with rates and accelerations (see ``PiecewiseTrajectory``).
    """
    return TrajectoryReference(_t55(psi))


def table_5_8() -> TrajectoryReference:
    return TrajectoryReference(_t58())


def table_6_3() -> TrajectoryReference:
    return TrajectoryReference(_t63())


def table_7_1(full_state: bool = False) -> TrajectoryReference:
    return TrajectoryReference(_t71(full_state))


def envelope_mission() -> TrajectoryReference:
    return TrajectoryReference(_envelope())


for _f, _src in ((table_5_2, _t52), (table_5_8, _t58), (table_6_3, _t63),
                 (table_7_1, _t71), (envelope_mission, _envelope)):
    _f.__doc__ = _src.__doc__


def tiltrotor_mission_reference(scenario: int,
                                smooth_reference: float | None = None) -> TrajectoryReference:
    """TrajectoryReference of [x y z ψ] for the tilt-rotor missions.

    Parameters
    ----------
    scenario : {1, 2}
        1: Table 7.1 (ψ_r = 0 added when the table has no ψ); 2: the envelope mission.
    smooth_reference : float, optional
        Given, the half-window h (s) of a C² blend at every phase junction
        (:func:`~sobolev_drake.systems.reference_smoothing.smooth_junctions`); default: the
        pieces as tabulated (steps in velocity/acceleration at the junctions).

    Returns
    -------
    TrajectoryReference

    Raises
    ------
    TypeError, ValueError
        If ``smooth_reference`` is not a positive number below half the shortest phase.
    """
    def wrap(t):
        if smooth_reference is None:
            return TrajectoryReference(t)
        try:
            return TrajectoryReference(smooth_junctions(t, smooth_reference))
        except (TypeError, ValueError) as e:   # name the caller's argument, keep the detail
            raise type(e)(f"smooth_reference: {e}") from e

    base = table_7_1() if scenario == 1 else envelope_mission()
    traj = base.trajectory
    names = ["x", "y", "z", "psi"]
    if all(n in traj.names for n in names):
        return wrap(traj.subset(names))
    if scenario == 1 and all(n in traj.names for n in names[:3]):  # ψ_r = 0 in scenario 1
        sub = traj.subset(names[:3])
        pieces = [list(p) + [const(0.0)] for p in sub.pieces]
        return wrap(PiecewiseTrajectory(names, pieces, sub.breakpoints, sub.description))
    raise KeyError(f"reference for scenario {scenario} lacks coordinates {names}: {traj.names}")
