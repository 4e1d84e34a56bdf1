"""``tiltrotor-hover-linear``: linear W∞ designs for the tilt-rotor in helicopter mode, flown on the
nonlinear plant (thesis §7.3.1, Table 7.2).

The hover controller (:class:`LinearHoverController`: u = u_trim + K Δx, or a dynamic
controller on y = C Δx, inputs clipped to n ≥ 0, |τs| ≤ 2 N m), the flights along the Table 7.1
path in von Kármán wind, the Table 7.2 indices and the registered run.  The syntheses are in
:mod:`._tiltrotor_linear_designs` (the thesis' disturbance-model LMIs are degenerate,
docs/design.md §8.3, and are flown beside their well-posed form), tables and claims in
:mod:`._tiltrotor_linear_report`.  The turbulence is σ-normalized (docs/design.md §6); a
second table flies the noise read literally.

See docs/experiments/tiltrotor-hover-linear.md.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.primitives import ConstantVectorSource, VectorLogSink

from sobolev_drake.experiments import ExperimentResult, register

from sobolev_drake.experiments._tiltrotor_linear_designs import (  # noqa: F401 (re-exported)
    DESIGN_SPECS, DESIGNS, DISK_RADIUS, GAMMA0, GAMMA1, OF_MEASURED, UPSILON0, UPSILON1_OF,
    UPSILON1_SF, design, output_matrix)
from sobolev_drake.experiments._tiltrotor_linear_report import (  # noqa: F401 (re-exported)
    COLUMNS, SENS_COLUMNS, THESIS_TABLE_7_2, add_claims, design_cells, plot_flights,
    sensitivity_row, table_title)

Q0 = np.array([0, 0, 0, 0, 0, -1.0, 20.0, 0])
#: smoke mode: the cheapest certified design only (state feedback, ~10 s synthesis)
SMOKE_DESIGNS = ("W∞",)
SMOKE_DURATION = 10.0


VELOCITY_REFERENCES = ("zero", "path")


def _check_velocity_reference(velocity_reference):
    if velocity_reference not in VELOCITY_REFERENCES:
        raise ValueError(f"velocity_reference must be one of {VELOCITY_REFERENCES}, "
                         f"got {velocity_reference!r}")
    return velocity_reference


class LinearHoverController(LeafSystem):
    """u = u_trim + K Δx (state feedback) or the dynamic controller on y = C Δx.

    Δx = [q − q_r(t); q̇ − q̇_r(t); ∫Δψ ∫Δx ∫Δy ∫Δz] with q_r = trim attitude/tilt + the path
    [x_r y_r z_r], ψ_r = 0, and q̇_r = 0 (``velocity_reference="zero"``, the thesis' trim) or
    the path velocity (``"path"``).  Continuous states: the four integrals and the controller state.
    Inputs ``x`` (16), ``reference`` (12, [x y z ψ] stacked with rates and accelerations);
    outputs ``propeller_speed``, ``servo_torque`` (clipped to n ≥ 0, |τs| ≤ 2 N m),
    ``surface_deflection`` (zeros) and ``delta_u`` (4, unclipped Δu).
    """

    def __init__(self, ctrl, trim, velocity_reference="zero"):
        super().__init__()
        self.path_velocity = _check_velocity_reference(velocity_reference) == "path"
        self.kind = ctrl["kind"]
        self.q_trim = np.asarray(trim.q, float).copy()
        self.u_trim = np.r_[trim.n, trim.tau_s]
        if self.kind == "sf":
            self.K = np.asarray(ctrl["K"])
            nk = 0
        else:
            self.AK, self.BK, self.CK, self.DK = (np.asarray(ctrl[k]) for k in ("AK", "BK", "CK", "DK"))
            self.C = np.asarray(ctrl["C"])
            nk = self.AK.shape[0]
        self.nk = nk
        self.x_port = self.DeclareVectorInputPort("x", 16)
        self.ref_port = self.DeclareVectorInputPort("reference", 12)
        self.DeclareContinuousState(4 + nk)
        self.DeclareVectorOutputPort("propeller_speed", 2, self._calc_n)
        self.DeclareVectorOutputPort("servo_torque", 2, self._calc_ts)
        self.DeclareVectorOutputPort("surface_deflection", 4, self._calc_zero,
                                     prerequisites_of_calc={self.nothing_ticket()})
        self.DeclareVectorOutputPort("delta_u", 4, self._calc_du)

    def delta_x(self, context):
        x = self.x_port.Eval(context)
        r = self.ref_port.Eval(context)
        qr = self.q_trim.copy()
        qr[5:8] = r[0:3]
        qr[4] = r[3]
        qdr = np.zeros(8)
        if self.path_velocity:
            qdr[5:8], qdr[4] = r[4:7], r[7]
        s = context.get_continuous_state_vector().CopyToVector()
        return np.concatenate([x[:8] - qr, x[8:] - qdr, s[:4]]), s[4:]

    def _du(self, context):
        dx, xk = self.delta_x(context)
        if self.kind == "sf":
            return self.K @ dx
        return self.CK @ xk + self.DK @ (self.C @ dx)

    def DoCalcTimeDerivatives(self, context, derivatives):
        dx, xk = self.delta_x(context)
        d = np.empty(4 + self.nk)
        d[:4] = dx[[4, 5, 6, 7]]
        if self.nk:
            d[4:] = self.AK @ xk + self.BK @ (self.C @ dx)
        derivatives.get_mutable_vector().SetFromVector(d)

    def _calc_n(self, context, output):
        output.SetFromVector(np.maximum(self.u_trim[:2] + self._du(context)[:2], 0.0))

    def _calc_ts(self, context, output):
        output.SetFromVector(np.clip(self.u_trim[2:] + self._du(context)[2:], -2.0, 2.0))

    def _calc_zero(self, context, output):
        output.SetFromVector(np.zeros(4))

    def _calc_du(self, context, output):
        output.SetFromVector(self._du(context))


def initial_error(trim, velocity_reference="zero"):
    """Δx(0) of the flight: q(0) = :data:`Q0`, q̇(0) = 0 against the trim and the path at t = 0
    (velocity error only with ``velocity_reference="path"``); integrals 0."""
    _check_velocity_reference(velocity_reference)
    q, qd, _ = _reference_xyz_psi().evaluate(0.0)
    dx = np.zeros(20)
    dx[:8] = Q0 - np.asarray(trim.q, float)
    dx[5:8] = Q0[5:8] - np.asarray(q, float)[:3]
    dx[4] = Q0[4] - float(q[3])
    if velocity_reference == "path":
        dx[13:16] = -np.asarray(qd, float)[:3]
        dx[12] = -float(qd[3])
    return dx


def literal_noise_turbulence():
    """§7.3.1 turbulence with the thesis' "unit variance, sampling time 0.01 s" noise taken
    literally: intensities scaled by √(Δt/π) (``systems/wind.py`` explains the factor)."""
    from dataclasses import replace

    from sobolev_drake.systems.wind import hover_linear_turbulence
    p = hover_linear_turbulence()
    k = np.sqrt(p.sample_time / np.pi)
    return replace(p, sigma=tuple(float(k * v) for v in p.sigma))


def _reference_xyz_psi():
    from sobolev_drake.systems.reference_catalogue import tiltrotor_mission_reference as mission_reference
    return mission_reference(1)


def simulate_design(ctrl, trim, duration, *, seed=7, log_period=0.01, meshcat=None, turbulence=None,
                    max_wall_s=600.0, controller_state0=None, velocity_reference="zero"):
    """Fly ``ctrl`` on the nonlinear plant (Table 7.1 path, von Kármán wind); returns logs.

    The run stops early (``data["stopped"]`` says why, ``data["t"][-1]`` when) if the state
    stops being finite, |φ| or |θ| exceeds 90° (the linear design has lost the aircraft), or
    the wall time exceeds ``max_wall_s`` (stiff or chattering closed loop).

    ``turbulence``: VonKarmanParameters replacing the §7.3.1 defaults (for sensitivity runs).
    ``controller_state0``: initial state of a dynamic controller (default 0).
    ``velocity_reference``: "zero" (Δq̇ = q̇, the thesis' q̇_r = 0) or "path" (q̇ − q̇_path).
    The plant has the parameters of the model ``trim`` was computed on (``crossflow``).
    With a ``meshcat`` the run is recorded (``data["recorder"]``)."""
    from pydrake.systems.analysis import Simulator
    from sobolev_drake.tiltrotor.plant import add_tiltrotor
    from sobolev_drake.systems.wind import mission_wind_sources

    b = DiagramBuilder()
    h = add_tiltrotor(b, trim.info["model"].params)  # the plant the trim was computed on
    ref = b.AddSystem(_reference_xyz_psi())
    c = b.AddSystem(LinearHoverController(ctrl, trim, velocity_reference))
    (turb,) = mission_wind_sources("hover_linear", turbulence=turbulence)
    b.AddSystem(turb)
    b.Connect(turb.GetOutputPort("wind"), h.wind)
    zero = b.AddSystem(ConstantVectorSource(np.zeros(3)))
    b.Connect(zero.get_output_port(), h.force_disturbance)
    b.Connect(h.x, c.GetInputPort("x"))
    b.Connect(ref.GetOutputPort("reference"), c.GetInputPort("reference"))
    for name in ("propeller_speed", "servo_torque", "surface_deflection"):
        b.Connect(c.GetOutputPort(name), getattr(h, name))
    sinks = {}
    for label, port in [("x", h.x), ("reference", ref.GetOutputPort("reference")),
                        ("du", c.GetOutputPort("delta_u")), ("wind", turb.GetOutputPort("wind")),
                        ("n", c.GetOutputPort("propeller_speed")),
                        ("ts", c.GetOutputPort("servo_torque"))]:
        s = b.AddSystem(VectorLogSink(port.size(), log_period))
        b.Connect(port, s.get_input_port())
        sinks[label] = s
    recorder = None
    if meshcat is not None and h.scene_graph is not None:
        from sobolev_drake import viz
        recorder = viz.add_meshcat_recorder(b, h.scene_graph, meshcat, publish_period=0.1)
    diagram = b.Build()
    sim = Simulator(diagram)
    ctx = sim.get_mutable_context()
    turb.seed(ctx, seed)
    h.set_state(ctx, diagram, Q0, np.zeros(8))
    if controller_state0 is not None:
        cv = c.GetMyMutableContextFromRoot(ctx).get_mutable_continuous_state_vector()
        v = cv.CopyToVector()
        if np.shape(controller_state0) != (v.size - 4,):
            raise ValueError(f"controller_state0 must have shape ({v.size - 4},), got {np.shape(controller_state0)}")
        v[4:] = controller_state0
        cv.SetFromVector(v)
    sim.get_mutable_integrator().set_target_accuracy(1e-3)
    sim.get_mutable_integrator().set_maximum_step_size(0.01)
    from pydrake.systems.framework import EventStatus
    t0 = time.perf_counter()
    why = []

    def monitor(root_ctx):
        xs = h.x.Eval(h.x.get_system().GetMyContextFromRoot(root_ctx))
        if not np.all(np.isfinite(xs)):
            why.append("state not finite")
        elif np.max(np.abs(xs[2:4])) > np.pi / 2:
            why.append("|roll| or |pitch| > 90°")
        elif time.perf_counter() - t0 > max_wall_s:
            why.append(f"wall time > {max_wall_s:g} s")
        else:
            return EventStatus.Succeeded()
        return EventStatus.ReachedTermination(diagram, why[-1])

    sim.set_monitor(monitor)
    sim.AdvanceTo(duration)
    wall = time.perf_counter() - t0
    data = {k: s.FindLog(ctx).data().copy() for k, s in sinks.items()}
    data["t"] = sinks["x"].FindLog(ctx).sample_times().copy()
    n = min(v.shape[-1] for v in data.values())
    data = {k: v[..., :n] for k, v in data.items()}
    data["wall_s"] = wall
    data["stopped"] = (f"stopped at t = {ctx.get_time():.2f} s: {why[-1]}" if why else "")
    data["recorder"] = recorder
    data["ctx_integrals"] = c.GetMyContextFromRoot(ctx).get_continuous_state_vector().CopyToVector()[:4]
    return data


def indices(data, trim):
    """ISE = ∫ΔxᵀΔx dt (20 states; integral states rebuilt from the logs by the trapezoid rule)
    and IADU = ∫Σ|dΔu/dt| dt (total variation of the logged Δu)."""
    from sobolev_drake.norms import iadu, ise
    t, x, r = data["t"], data["x"], data["reference"]
    q, qd = x[:8].copy(), x[8:].copy()
    q -= np.asarray(trim.q)[:, None]
    q[5:8] -= r[0:3]
    q[4] -= r[3]
    qd[5:8] -= r[4:7]
    qd[4] -= r[7]
    e = q[[4, 5, 6, 7]]
    ints = np.concatenate([np.zeros((4, 1)), np.cumsum(0.5 * (e[:, 1:] + e[:, :-1]) * np.diff(t), axis=1)], axis=1)
    dx = np.vstack([q, qd, ints])
    per = np.asarray(ise(t, dx.T), dtype=float)
    groups = {"tilt": [0, 1], "attitude": [2, 3, 4], "position": [5, 6, 7], "rates": list(range(8, 16)),
              "integrals": [16, 17, 18, 19]}
    early = t <= min(10.0, t[-1])  # the initial-offset transient, reported separately
    ise_early = float(np.sum(ise(t[early], dx[:, early].T))) if early.sum() > 1 else 0.0
    return {"ise": float(np.sum(per)), "iadu": float(np.sum(iadu(t, data["du"].T))),
            "ise_first_10s": ise_early,
            "ise_by_group": {k: float(per[v].sum()) for k, v in groups.items()},
            "rms_pos_m": float(np.sqrt(np.mean(np.sum(q[5:8] ** 2, axis=0)))),
            "final_pos_err_m": float(np.linalg.norm(q[5:8, -1])),
            "max_tilt_deg": float(np.degrees(np.max(np.abs(x[:2])))),
            "max_attitude_deg": float(np.degrees(np.max(np.abs(x[2:4])))),  # |φ|, |θ|
            "max_lateral_wind_m_s": float(np.max(np.abs(data["wind"][1]))) if "wind" in data else None,
            "finite": bool(np.all(np.isfinite(x)))}



_METRIC_KEYS = ("gamma", "gamma_opt", "feedthrough_bound", "transient_bound", "certified", "achieved",
                "gamma_wind", "gamma_common", "certificate_failures", "solver", "status", "solve_s",
                "notes", "max_real", "max_abs", "kind", "order", "delay_margin_s", "gain_margins")



def _sensitivity_flight(ctrl, trim, duration, velocity_reference):
    """Metrics of one flight with :func:`literal_noise_turbulence` (a failed run is reported)."""
    try:
        d = simulate_design(ctrl, trim, duration, turbulence=literal_noise_turbulence(),
                            velocity_reference=velocity_reference)
    except Exception as exc:  # the integrator gives up on a diverging loop
        return {"sim_error": f"{type(exc).__name__}: {exc}"}
    idx = indices(d, trim)
    idx.update(stopped=d["stopped"], sim_end_s=float(d["t"][-1]))
    return idx


@register("tiltrotor-hover-linear", "Tilt-rotor hover: linear W∞ state/output feedback and "
          "disturbance-model (von Kármán) designs flown on the nonlinear plant (Table 7.2)",
          default_duration=200.0, thesis_ref="7.3.1, Table 7.2")
def run(out_dir, *, duration=None, record=False, smoke=False, designs=None, record_design=None,
        backend=None, velocity_reference="zero", regularization="transient", sensitivity=None,
        crossflow="independence"):
    """Synthesize ``designs`` (default: all of :data:`DESIGNS`; smoke: :data:`SMOKE_DESIGNS`),
    fly each on the nonlinear plant, write the table beside Table 7.2, plots and metrics.

    ``record``: Meshcat recording of one design (``record_design``, default the first).
    ``velocity_reference``: "zero" (thesis, Δq̇ = q̇) or "path"; ``regularization``:
    "transient" (minimize Δx(0)ᵀ P Δx(0) at the certified γ) or "gain" (least gain);
    ``sensitivity`` (default: not in smoke mode): fly every design again with the literal
    noise reading (:func:`literal_noise_turbulence`) and write a second table.
    ``crossflow``: the plant's aerodynamic crossflow model (``TiltrotorParams.crossflow``;
    "thesis" reads (7.41)–(7.45) literally) for trim, linearization and flights."""
    _check_velocity_reference(velocity_reference)  # before minutes of synthesis
    if regularization not in ("transient", "gain"):
        raise ValueError(f"regularization must be 'transient' or 'gain', got {regularization!r}")
    from sobolev_drake.report import write_table
    from sobolev_drake.tiltrotor.trim import hover_wind_limit, linearize, trim_hover

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    designs = tuple(designs) if designs is not None else (SMOKE_DESIGNS if smoke else DESIGNS)
    bad = [d for d in designs if d not in DESIGN_SPECS]
    if bad:
        raise ValueError(f"designs must be names from {DESIGNS}, got {bad}")
    duration = (SMOKE_DURATION if smoke else 200.0) if duration is None else float(duration)
    record_design = record_design or designs[0]
    sensitivity = (not smoke) if sensitivity is None else bool(sensitivity)
    from sobolev_drake.tiltrotor.params import TiltrotorParams
    from sobolev_drake.tiltrotor.trim import tiltrotor_model
    # validates the name before minutes of synthesis; the model (and the linearization's
    # diagram) is shared by every run with the same parameters
    model = tiltrotor_model(TiltrotorParams(crossflow=crossflow))
    trim = trim_hover(model)
    lin = linearize(trim)
    x0 = initial_error(trim, velocity_reference) if regularization == "transient" else None
    res = ExperimentResult(name="tiltrotor-hover-linear")
    rows, srows, all_data, gains = [], [], {}, {}
    wind_limit = hover_wind_limit(90.0, model=model)  # steady lateral wind it can hover in, heading held
    metrics = {"setup": {"velocity_reference": velocity_reference, "regularization": regularization,
                         "initial_error": None if x0 is None else x0.tolist(),
                         "crossflow": crossflow,
                         "hover_wind_limit_lateral_m_s": wind_limit.limit,
                         "hover_wind_limit_reason": wind_limit.reason}}
    mjson = out_dir / "tiltrotor-hover-linear_metrics.json"
    meshcat = None

    def write_outputs():  # tables and metrics; also after every design (interrupted runs)
        mjson.write_text(json.dumps(metrics, indent=1, default=str))
        if srows:
            write_table(out_dir, "tiltrotor-hover-linear_literal_noise", SENS_COLUMNS, srows,
                        title=f"Sensitivity: the same controllers with the noise read literally "
                              f"(σ × √(Δt/π), gusts ≈ 6 % of σ), {duration:g} s")
        return write_table(out_dir, "tiltrotor-hover-linear_table", COLUMNS, rows, title=table_title(duration))

    for name in designs:
        col = DESIGN_SPECS[name][1]
        thesis = THESIS_TABLE_7_2[col] if col else ("-", "-")
        try:
            ctrl = design(lin, name, backend=backend, initial_state=x0)
        except Exception as exc:  # report a failed synthesis instead of aborting the table
            metrics[name] = {"error": f"{type(exc).__name__}: {exc}"}
            rows.append([name, "synthesis failed", "-", "-", "-", "-", "-", "-", *thesis, str(exc)[:200]])
            continue
        m = {k: ctrl[k] for k in _METRIC_KEYS if k in ctrl}
        i = sum(k.endswith("_name") for k in gains)
        gains.update({f"d{i}_name": np.array(name), f"d{i}_kind": np.array(ctrl["kind"]),
                      **{f"d{i}_{k}": np.asarray(ctrl[k]) for k in ("K", "AK", "BK", "CK", "DK", "C")
                         if k in ctrl}})
        if record and name == record_design:
            from sobolev_drake import viz
            meshcat = viz.start_meshcat()
        try:
            d = simulate_design(ctrl, trim, duration, meshcat=meshcat if name == record_design else None,
                                velocity_reference=velocity_reference)
        except Exception as exc:  # e.g. the integrator gives up on a diverging closed loop
            m["sim_error"] = f"{type(exc).__name__}: {exc}"
            metrics[name] = m
            rows.append([*design_cells(name, ctrl), "sim failed", "-", *thesis, m["sim_error"][:200]])
            continue
        idx = indices(d, trim)
        all_data[name] = d
        m.update(idx, sim_wall_s=d["wall_s"], stopped=d["stopped"], sim_end_s=float(d["t"][-1]))
        metrics[name] = m
        rows.append([*design_cells(name, ctrl), f"{idx['ise']:.1f}", f"{idx['iadu']:.1f}", *thesis,
                     "; ".join(([d["stopped"].upper()] if d["stopped"] else []) + ctrl["notes"])[:300]])
        if sensitivity:
            m["literal_noise"] = _sensitivity_flight(ctrl, trim, duration, velocity_reference)
            srows.append(sensitivity_row(name, m["literal_noise"]))
        if record and name == record_design and d["recorder"] is not None:
            from sobolev_drake import viz
            from sobolev_drake.viz import draw_reference_and_flown as draw_paths
            draw_paths(meshcat, _reference_xyz_psi(), duration, d["x"][5:8])
            html = out_dir / "tiltrotor-hover-linear.html"
            viz.save_recording_html(meshcat, d["recorder"], html)
            res.outputs["recording"] = html
        write_outputs()
    md, js, text = write_outputs()
    if all_data:
        res.outputs.update(plot_flights(all_data, out_dir))
    res.outputs.update({"table_md": md, "table_json": js, "metrics_json": mjson})
    if gains:
        # controllers (u = u_trim + K Δx, or AK..DK on y = C Δx) for independent re-checks
        np.savez(out_dir / "tiltrotor-hover-linear_controllers.npz", **gains)
        res.outputs["controllers_npz"] = out_dir / "tiltrotor-hover-linear_controllers.npz"
    if srows:
        res.outputs["literal_noise_md"] = out_dir / "tiltrotor-hover-linear_literal_noise.md"
    res.metrics, res.table_markdown = metrics, text
    add_claims(res, metrics, smoke or duration < 200.0)
    return res
