"""URDF of the tilt-rotor UAV (thesis section 7.2, Table B.1), written from its parameters.

:func:`tiltrotor_urdf` writes the URDF from :class:`~sobolev_drake.tiltrotor.params.TiltrotorParams`
(``urdf/tiltrotor.urdf`` is its output for the default parameters, a test keeps them in sync):
main body C1 (fuselage, wings, V-tail visuals) attached to the world by the x, y, z, yaw, pitch,
roll joint chain of docs/design.md §3 (so q̇ = v), and two thruster groups on revolute servo
joints at A2/A3.  :func:`marker_frames` lists the massless marker frames (C1, surface points,
propeller hubs).  :mod:`sobolev_drake.tiltrotor.plant` builds the MultibodyPlant from it (and
re-exports :func:`tiltrotor_urdf`).
"""

from __future__ import annotations

import numpy as np

from sobolev_drake.tiltrotor.params import TiltrotorParams

__all__ = ["tiltrotor_urdf", "marker_frames"]


def _f(*vals) -> str:
    return " ".join(f"{float(v):.10g}" for v in vals)


def _link(name, mass=None, com=(0, 0, 0), inertia=None, visuals=()):
    s = f'  <link name="{name}">\n'
    if mass is not None:
        I = np.asarray(inertia, dtype=float)
        s += (f'    <inertial>\n      <origin xyz="{_f(*com)}" rpy="0 0 0"/>\n'
              f'      <mass value="{float(mass):.10g}"/>\n'
              f'      <inertia ixx="{I[0, 0]:.10g}" ixy="{I[0, 1]:.10g}" ixz="{I[0, 2]:.10g}" '
              f'iyy="{I[1, 1]:.10g}" iyz="{I[1, 2]:.10g}" izz="{I[2, 2]:.10g}"/>\n    </inertial>\n')
    for vname, xyz, rpy, geom, rgba in visuals:
        s += (f'    <visual name="{vname}">\n      <origin xyz="{_f(*xyz)}" rpy="{_f(*rpy)}"/>\n'
              f'      <geometry>{geom}</geometry>\n'
              f'      <material name="{vname}_mat"><color rgba="{_f(*rgba)}"/></material>\n    </visual>\n')
    return s + "  </link>\n"


def _joint(name, jtype, parent, child, xyz=(0, 0, 0), rpy=(0, 0, 0), axis=None):
    s = (f'  <joint name="{name}" type="{jtype}">\n    <parent link="{parent}"/>\n'
         f'    <child link="{child}"/>\n    <origin xyz="{_f(*xyz)}" rpy="{_f(*rpy)}"/>\n')
    if axis is not None:
        s += f'    <axis xyz="{_f(*axis)}"/>\n'
    return s + "  </joint>\n"


def marker_frames(p: TiltrotorParams) -> list[tuple[str, str, np.ndarray]]:
    """The massless marker frames: C1, the surface points and the propeller hubs.

    Parameters
    ----------
    p : TiltrotorParams
        Vehicle parameters.

    Returns
    -------
    list of (str, str, ndarray)
        (frame name, parent link, offset (3,) in the parent link's frame, m) of each frame.
    """
    return ([(f"frame_{ln}", "body", d) for ln, d in
             (("C1", p.d_B_C1), ("F", p.d_B_F), ("WR", p.d_B_WR), ("WL", p.d_B_WL),
              ("TR", p.d_B_TR), ("TL", p.d_B_TL))]
            + [("frame_PR", "thruster_right", p.d_A_P), ("frame_PL", "thruster_left", p.d_A_P)])


def tiltrotor_urdf(params: TiltrotorParams | None = None, *, marker_links: bool = True) -> str:
    """URDF text of the tilt-rotor for ``params`` (default: Table B.1).

    Parameters
    ----------
    params : TiltrotorParams, optional
        Table B.1 by default.
    marker_links : bool, default True
        Include the massless ``frame_*`` links (and their fixed joints).  False leaves them
        out: the plant builder of :mod:`sobolev_drake.tiltrotor.plant` adds them as FixedOffsetFrames instead, which spares
        MultibodyPlant eight welded bodies in every dynamics evaluation (same frames, same
        dynamics).

    Returns
    -------
    str
        The URDF document.
    """
    p = TiltrotorParams() if params is None else params
    b, eps, mu = p.beta, p.epsilon, p.mu
    grey, blue, dark, prop = (0.8, 0.8, 0.85, 1), (0.2, 0.4, 0.8, 1), (0.2, 0.2, 0.2, 1), (0.1, 0.1, 0.1, 0.35)
    box = lambda x, y, z: f'<box size="{_f(x, y, z)}"/>'  # noqa: E731
    cyl = lambda r, l: f'<cylinder radius="{r:.6g}" length="{l:.6g}"/>'  # noqa: E731
    half = 0.5 * p.span
    body_vis = [
        ("fuselage", (0.0, 0, 0.13), (0, np.pi / 2, 0), cyl(0.075, 1.1), grey),
        ("nose", (0.55, 0, 0.13), (0, 0, 0), '<sphere radius="0.075"/>', grey),
        ("wing_right", (p.d_B_WR[0], -0.5 * half, p.d_B_WR[2]), (-eps, 0, 0), box(0.22, half, 0.02), blue),
        ("wing_left", (p.d_B_WL[0], 0.5 * half, p.d_B_WL[2]), (eps, 0, 0), box(0.22, half, 0.02), blue),
        ("spar_right", (p.d_B_A2[0], 0.5 * (p.d_B_A2[1] - half), p.d_B_A2[2]), (0, 0, 0),
         box(0.03, abs(p.d_B_A2[1]) - half, 0.02), dark),
        ("spar_left", (p.d_B_A3[0], 0.5 * (p.d_B_A3[1] + half), p.d_B_A3[2]), (0, 0, 0),
         box(0.03, abs(p.d_B_A3[1]) - half, 0.02), dark),
        ("tail_right", p.d_B_TR, (-mu, 0, 0), box(0.16, 0.36, 0.012), blue),
        ("tail_left", p.d_B_TL, (mu, 0, 0), box(0.16, 0.36, 0.012), blue),
    ]

    def thruster_vis(side):
        return [(f"nacelle_{side}", (0, 0, 0.02), (0, 0, 0), cyl(0.035, 0.16), dark),
                (f"prop_disc_{side}", p.d_A_P, (0, 0, 0), cyl(0.5 * 0.6096, 0.004), prop),
                (f"hub_{side}", p.d_A_P + np.array([0, 0, 0.01]), (0, 0, 0), '<sphere radius="0.02"/>', dark)]

    s = '<?xml version="1.0"?>\n<!-- generated by sobolev_drake.tiltrotor.plant.tiltrotor_urdf -->\n'
    s += '<robot name="tiltrotor">\n'
    for ln in ("x_link", "y_link", "z_link", "yaw_link", "pitch_link"):
        s += _link(ln)  # zero-mass links of the floating-base joint chain (docs/design.md §3)
    s += _link("body", p.m1, p.d_B_C1, p.I_C1, body_vis)
    s += _link("thruster_right", p.m2, p.d_A_C, p.I_C2, thruster_vis("right"))
    s += _link("thruster_left", p.m3, p.d_A_C, p.I_C3, thruster_vis("left"))
    markers = marker_frames(p) if marker_links else []
    for name, _, _ in markers:
        s += _link(name)
    s += _joint("base_x", "prismatic", "world", "x_link", axis=(1, 0, 0))
    s += _joint("base_y", "prismatic", "x_link", "y_link", axis=(0, 1, 0))
    s += _joint("base_z", "prismatic", "y_link", "z_link", axis=(0, 0, 1))
    s += _joint("base_yaw", "continuous", "z_link", "yaw_link", axis=(0, 0, 1))
    s += _joint("base_pitch", "continuous", "yaw_link", "pitch_link", axis=(0, 1, 0))
    s += _joint("base_roll", "continuous", "pitch_link", "body", axis=(1, 0, 0))
    # servo joints: child frame = A2 = Ry(αR) Rx(−β), A3 = Ry(αL) Rx(β) (7.4), (7.6)
    s += _joint("tilt_right", "continuous", "body", "thruster_right", p.d_B_A2, (-b, 0, 0),
                (0, np.cos(b), np.sin(b)))
    s += _joint("tilt_left", "continuous", "body", "thruster_left", p.d_B_A3, (b, 0, 0),
                (0, np.cos(b), -np.sin(b)))
    for name, parent, d in markers:
        s += _joint(f"fix_{name[len('frame_'):]}", "fixed", parent, name, d)
    return s + "</robot>\n"
