"""Tilt-rotor plant benchmark: real-time factor of 60 s of hover held by an LQR, with propellers,
aerodynamics and von Kármán turbulence, plus evaluations per second of each force system.

Usage: ``python benchmarks/tiltrotor_plant.py [--duration 60] [--accuracy 1e-3] [--no-turbulence]``

The LQR (scipy CARE on the linearization (7.57) about the hover trim in the mean wind) is a
C++ ``AffineSystem`` so the timing is dominated by the plant side.  The force-path comparison
times one diagram derivative evaluation with the generalized-force path (what ``add_tiltrotor``
uses, scalar Python cores) against the numpy-vectorized cores sent either as a generalized force
or as a Python list of ``ExternallyAppliedSpatialForce``.  Times are process CPU time where
noted: on a shared machine wall time mostly measures the other processes.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from pydrake.multibody.plant import ExternallyAppliedSpatialForce
from pydrake.multibody.math import SpatialForce
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.common.value import Value
from pydrake.systems.primitives import AffineSystem, Demultiplexer
from scipy.linalg import solve_continuous_are

from sobolev_drake.tiltrotor.plant import add_tiltrotor
from sobolev_drake.tiltrotor.linearization import linearize
from sobolev_drake.tiltrotor.trim import trim_hover
from sobolev_drake.tiltrotor.aerodynamics import AerodynamicSurfaces
from sobolev_drake.tiltrotor.propulsion import PropellerForces

MEAN_WIND = np.array([-3.0, 0.0, 0.0])   # thesis 7.3.1: ζx decremented by 3 m/s


def lqr_hover(trim):
    lin = linearize(trim)
    Q = np.diag([1, 1, 20, 20, 20, 10, 10, 10] + [0.1, 0.1, 1, 1, 1, 2, 2, 2] + [1, 1, 1, 1.0])
    R = np.diag([1e-2, 1e-2, 10, 10])
    P = solve_continuous_are(lin.A, lin.B, Q, R)
    K = np.linalg.solve(R, lin.B.T @ P)
    return lin, K


def build(turbulence=True, sample_time=0.01):
    trim = trim_hover(zeta=MEAN_WIND)
    lin, K = lqr_hover(trim)
    b = DiagramBuilder()
    h = add_tiltrotor(b)
    x0 = np.concatenate([trim.q, trim.qdot])
    sel = np.zeros((4, 16))
    sel[[0, 1, 2, 3], [4, 5, 6, 7]] = 1.0
    Kx, Ki = K[:, :16], K[:, 16:]
    # integral states ∫(Sel x − Sel x0); u = u0 − Kx (x − x0) − Ki ∫
    ctrl = b.AddSystem(AffineSystem(A=np.zeros((4, 4)), B=sel, f0=-sel @ x0, C=-Ki, D=-Kx,
                                    y0=trim.u[:4] + Kx @ x0))
    ctrl.set_name("lqr")
    demux = b.AddSystem(Demultiplexer([2, 2]))
    b.Connect(h.x, ctrl.get_input_port())
    b.Connect(ctrl.get_output_port(), demux.get_input_port())
    b.Connect(demux.get_output_port(0), h.propeller_speed)
    b.Connect(demux.get_output_port(1), h.servo_torque)
    wind = None
    if turbulence:
        try:
            from sobolev_drake.systems.wind import VonKarmanTurbulence
            wind = b.AddSystem(VonKarmanTurbulence(offset=tuple(MEAN_WIND), sample_time=sample_time))
        except ImportError:  # pragma: no cover - wind module absent
            wind = None
    if wind is None:
        from pydrake.systems.primitives import ConstantVectorSource
        wind = b.AddSystem(ConstantVectorSource(MEAN_WIND))
        b.Connect(wind.get_output_port(), h.wind)
    else:
        b.Connect(wind.GetOutputPort("wind"), h.wind)
    d = b.Build()
    return d, h, trim, wind


def run_hover(duration=60.0, accuracy=1e-3, turbulence=True, seed=7, sample_time=0.1):
    d, h, trim, wind = build(turbulence, sample_time)
    sim = Simulator(d)
    ctx = sim.get_mutable_context()
    h.set_state(ctx, d, trim.q, trim.qdot)
    if turbulence and hasattr(wind, "seed"):
        wind.seed(ctx, seed)
    integ = sim.get_mutable_integrator()
    integ.set_target_accuracy(accuracy)
    h.forces.evaluations = 0
    sim.Initialize()
    t0, c0 = time.perf_counter(), time.process_time()
    sim.AdvanceTo(duration)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    q, _ = h.get_state(ctx)
    return {"duration": duration, "wall_s": wall, "real_time_factor": duration / wall,
            "cpu_s": cpu, "cpu_real_time_factor": duration / cpu, "sample_time": sample_time,
            "force_evaluations": h.forces.evaluations, "steps": integ.get_num_steps_taken(),
            "final_position_error": float(np.linalg.norm(q[5:8] - trim.q[5:8])),
            "final_attitude_error": float(np.abs(q[2:5] - trim.q[2:5]).max()),
            "integrator": type(integ).__name__, "accuracy": accuracy}


class _LoadsBase(LeafSystem):
    """Input ``x`` (thesis state); constant propeller speeds and wind (timing only)."""

    def __init__(self, model, n, zeta):
        super().__init__()
        from sobolev_drake.tiltrotor.input_affine import cores
        self.model, self.n, self.zeta = model, np.asarray(n, float), np.asarray(zeta, float)
        self.prop, self.aero = cores(model.params)
        self._x = self.DeclareVectorInputPort("x", 16)


class _VectorizedGeneralized(_LoadsBase):
    """Propeller + aerodynamic generalized force with the numpy-vectorized cores (Drake order)."""

    def __init__(self, model, n, zeta):
        super().__init__(model, n, zeta)
        self.DeclareVectorOutputPort("applied_generalized_force", 8, self._calc)

    def _calc(self, context, output):
        x = self._x.Eval(context)
        q, qd = x[:8], x[8:]
        f, t, _, _ = self.prop.thrust_and_torque(q, qd, self.zeta, self.n)
        Gf, Gt = self.prop.unit_columns(q)
        passive, _ = self.aero.terms(q, qd, self.zeta)          # δ = 0
        tau = Gf @ f + Gt @ t + passive
        output.SetFromVector(self.model.force_to_drake(tau))


class _SpatialForceLoads(_LoadsBase):
    """Same loads (numpy-vectorized cores) as a list of ExternallyAppliedSpatialForce."""

    def __init__(self, model, n, zeta):
        super().__init__(model, n, zeta)
        plant = model.plant
        self.body = plant.GetBodyByName("body").index()
        self.thr = [plant.GetBodyByName("thruster_right").index(), plant.GetBodyByName("thruster_left").index()]
        self.DeclareAbstractOutputPort("spatial_forces", lambda: Value([ExternallyAppliedSpatialForce()]),
                                       self._calc)

    def _calc(self, context, output):
        from sobolev_drake.tiltrotor.params import R_IB
        x = self._x.Eval(context)
        q, qd = x[:8], x[8:]
        R = R_IB(q)
        F, M, *_ = self.aero.surface_loads(q, qd, self.zeta)
        forces = []
        for k in range(6):
            f = ExternallyAppliedSpatialForce()
            f.body_index = self.body
            f.p_BoBq_B = self.aero.points[k]
            f.F_Bq_W = SpatialForce(R @ M[k], R @ F[k])
            forces.append(f)
        fth, t, _, _ = self.prop.thrust_and_torque(q, qd, self.zeta, self.n)
        RA, _, _ = self.prop.rotor_frames(q)
        for k in range(2):
            z = R @ RA[k][:, 2]
            f = ExternallyAppliedSpatialForce()
            f.body_index = self.thr[k]
            f.p_BoBq_B = self.model.params.d_A_P
            f.F_Bq_W = SpatialForce(t[k] * z, fth[k] * z)
            forces.append(f)
        output.set_value(forces)


def force_path_comparison(reps=2000):
    """Process-CPU µs per diagram derivative evaluation (plant + loads) for three force paths:
    ``scalar_generalized`` (what add_tiltrotor uses), ``vectorized_generalized`` and
    ``vectorized_spatial_list`` (same numpy cores, loads sent as ExternallyAppliedSpatialForce)."""
    from pydrake.systems.primitives import MatrixGain
    from sobolev_drake.tiltrotor.plant import TiltrotorModel, _build_plant
    from sobolev_drake.tiltrotor.params import TiltrotorParams
    trim = trim_hover(zeta=MEAN_WIND)
    out = {}
    for variant in ("scalar_generalized", "vectorized_generalized", "vectorized_spatial_list"):
        b = DiagramBuilder()
        if variant == "scalar_generalized":
            h = add_tiltrotor(b)
            plant, model = h.plant, h.model
        else:
            plant, _ = _build_plant(TiltrotorParams(), b)
            model = TiltrotorModel(plant=plant)
            P = np.kron(np.eye(2), model.T_inv)
            perm = b.AddSystem(MatrixGain(P))
            b.Connect(plant.get_state_output_port(), perm.get_input_port())
            cls = _VectorizedGeneralized if variant == "vectorized_generalized" else _SpatialForceLoads
            loads = b.AddSystem(cls(model, trim.n, MEAN_WIND))
            b.Connect(perm.get_output_port(), loads.GetInputPort("x"))
            target = (plant.get_applied_generalized_force_input_port() if cls is _VectorizedGeneralized
                      else plant.get_applied_spatial_force_input_port())
            b.Connect(loads.get_output_port(0), target)
        d = b.Build()
        ctx = d.CreateDefaultContext()
        pc = plant.GetMyMutableContextFromRoot(ctx)
        if variant == "scalar_generalized":
            fctx = h.forces.GetMyMutableContextFromRoot(ctx)
            h.propeller_speed.FixValue(fctx, trim.n)
            h.wind.FixValue(fctx, MEAN_WIND)
        elif variant == "vectorized_spatial_list":
            plant.get_applied_generalized_force_input_port().FixValue(pc, np.zeros(8))
        plant.SetPositions(pc, model.to_drake(trim.q))
        plant.SetVelocities(pc, model.to_drake(trim.qdot + 0.01))
        deriv = d.AllocateTimeDerivatives()
        q0 = plant.GetPositions(pc)
        t0 = time.process_time()
        for i in range(reps):
            plant.SetPositions(pc, q0 + 1e-9 * (i % 2))   # invalidate caches
            d.CalcTimeDerivatives(ctx, deriv)
        out[variant] = (time.process_time() - t0) / reps
    return out


def evaluations_per_second(reps=3000):
    """Evaluations per second (process CPU) of each force LeafSystem's output, cache invalidated."""
    trim = trim_hover(zeta=MEAN_WIND)
    x = np.concatenate([trim.q, trim.qdot])
    res = {}
    for name, sys, fix in (
            ("PropellerForces", PropellerForces(), {"propeller_speed": trim.n, "servo_torque": trim.tau_s}),
            ("AerodynamicSurfaces", AerodynamicSurfaces(), {"surface_deflection": np.zeros(4)})):
        ctx = sys.CreateDefaultContext()
        for port, val in fix.items():
            sys.GetInputPort(port).FixValue(ctx, val)
        sys.GetInputPort("wind").FixValue(ctx, MEAN_WIND)
        xport = sys.GetInputPort("x")
        out = sys.GetOutputPort("generalized_force")
        t0 = time.process_time()
        for i in range(reps):
            xport.FixValue(ctx, x + 1e-9 * (i % 2))
            out.Eval(ctx)
        res[name] = reps / (time.process_time() - t0)
    b = DiagramBuilder()
    h = add_tiltrotor(b)
    d = b.Build()
    ctx = d.CreateDefaultContext()
    fctx = h.forces.GetMyMutableContextFromRoot(ctx)
    h.propeller_speed.FixValue(fctx, trim.n)
    h.wind.FixValue(fctx, MEAN_WIND)
    pc = h.plant.GetMyMutableContextFromRoot(ctx)
    q0 = h.plant.GetPositions(pc)
    port = h.forces.GetOutputPort("applied_generalized_force")
    t0 = time.process_time()
    for i in range(reps):
        h.plant.SetPositions(pc, q0 + 1e-9 * (i % 2))
        port.Eval(fctx)
    res["TiltrotorForces (all, plant input)"] = reps / (time.process_time() - t0)
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--accuracy", type=float, default=1e-3)
    ap.add_argument("--no-turbulence", action="store_true")
    ap.add_argument("--sample-time", type=float, default=0.1,
                    help="turbulence noise sample time [s]; the von Kármán filters' bandwidth is "
                         "~V/L = 0.26 rad/s, far below the 1/(2Δt) Nyquist limit of held samples")
    args = ap.parse_args(argv)
    for name, rate in evaluations_per_second().items():
        print(f"{name:40s} {rate:10.0f} evaluations/s")
    cmp = force_path_comparison()
    print("diagram derivative (plant + loads), process CPU per evaluation: "
          + ", ".join(f"{k} {1e6 * v:.0f} µs" for k, v in cmp.items()))
    r = run_hover(args.duration, args.accuracy, not args.no_turbulence, sample_time=args.sample_time)
    print(f"hover {r['duration']:.0f} s: wall {r['wall_s']:.2f} s, real-time factor {r['real_time_factor']:.1f}x "
          f"(process CPU {r['cpu_s']:.2f} s, {r['cpu_real_time_factor']:.1f}x; turbulence Δt {r['sample_time']} s), "
          f"{r['steps']} steps, {r['force_evaluations']} force evaluations, integrator {r['integrator']} "
          f"(accuracy {r['accuracy']}), final position error {r['final_position_error']:.3f} m, "
          f"attitude error {r['final_attitude_error']:.3f} rad")
    return r


if __name__ == "__main__":
    main()
