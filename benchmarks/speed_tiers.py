"""Speed tiers of the hot paths: the readable reference, a Python tier kept for speed, the kernel.

    python benchmarks/speed_tiers.py [--repeat 7] [--min-time 0.02] [--states 32]

Every hot path of the simulations has a readable reference (numpy written like the equations,
or Drake) and, for most, a compiled kernel in ``sobolev_drake/native`` (optional: without a C
compiler the package runs without it).  Some paths also have a Python tier in between, written
for speed.  Such a tier stays only where it is needed: at least ``NEEDED`` (1.5×) faster than
the reference on a path the simulations take when the kernel is not built, or that the kernel
does not cover.  This script times every implementation in the same run, on the same inputs
(tilt-rotor states from hover to cruise tilt), as process CPU time per call, best of
``--repeat`` rounds that interleave the implementations (load on a shared machine hits them
alike), checks each against its reference (largest deviation relative to 1 + |reference|) and
prints a markdown table and the verdict per Python tier.  Nothing asserts on these timings.

Where each implementation runs (C: the kernels are built and enabled, the default; no C: not
built, or ``SOBOLEV_DRAKE_NATIVE=0``):

* ϑ_aero and ϑ_P (plant forces per derivative; trims; the standalone force LeafSystems): C in
  the plant, the Python tier in the trims and the LeafSystems (no kernel entry), the Python
  tier everywhere without C.  The numpy reference runs in no simulation.
* B, ϑ_passive (7.62) per controller sample: C, else the Python tier.
* bounded least squares per sample: C, else the Python tier (warm-started in the tilt-rotor
  law, cold in ``MechanicalLaw.allocate``); the general numpy path for other arguments.
* u* by inverse dynamics per sample: C (plants the kernel covers), else Drake's recursive
  Newton–Euler; the mass-matrix form for models without a permutation to Drake's order.
* q̈_des per sample: C (the Python tier's operations in its order: the same bits), else the
  Python tier.
* saturation flags per sample: C for 8-vectors, else the Python tier; numpy for other shapes.
* thrust inversion (7.90) and surface bounds (7.87)–(7.89): C, else the Python reference.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import platform
import time

import numpy as np

from sobolev_drake import native
from sobolev_drake.native.forces import force_model
from sobolev_drake.systems import bounded_ls
from sobolev_drake.systems.mechanical_law import MechanicalLaw
from sobolev_drake.tiltrotor import controller as tc
from sobolev_drake.tiltrotor.allocation import tiltrotor_bounds
from sobolev_drake.tiltrotor.controller import PARTITION, thesis_inner_law
from sobolev_drake.tiltrotor.input_affine import (affine_terms_scalar_python, cores,
                                                  input_affine_terms, input_affine_vectorized)
from sobolev_drake.tiltrotor.law import newton_speed_for_thrust
from sobolev_drake.tiltrotor.plant import TiltrotorModel

NEEDED = 1.5          # a Python tier must be this much faster than the reference to stay
REG = 1e-12           # bounded_least_squares' default regularization
QDD = "q̈_des (7.81), per sample"
# tiers kept for another reason than speed
KEPT_ANYWAY = {
    QDD: "kept all the same: the numpy form sums in another order, and flying it moves the "
         "tilt-rotor smoke results at rounding level (≤ 6e-13 relative; a maximum roll of "
         "3e-13° becomes 1e-13°), so the default path stays as it was",
}


def _module(name):
    """The compiled kernel module ``sobolev_drake.native._<name>`` or None (not built)."""
    try:
        return importlib.import_module(f"sobolev_drake.native._{name}")
    except ImportError:
        return None


def _with_kernels(fn, enabled):
    """``fn`` run with the kernels switched on or off (the library dispatches on that)."""
    def call(case):
        previous = native.set_enabled(enabled)
        try:
            return fn(case)
        finally:
            native.set_enabled(previous)
    return call


@contextlib.contextmanager
def _general_bls_path():
    """bounded_least_squares without its default fast path: the general numpy PDAS + polish."""
    saved = bounded_ls._bls_fast
    bounded_ls._bls_fast = lambda *args, **kwargs: None
    try:
        yield
    finally:
        bounded_ls._bls_fast = saved


def _states(count, seed=1):
    """Tilt-rotor states from hover (tilt ≈ 90°) to cruise tilt, with wind, propeller speeds
    and deflections: (q, q̇, ζ, n, δ) arrays."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(count):
        tilt = 1.45 if k % 2 else rng.uniform(0.0, 1.2)
        q = np.concatenate([tilt + rng.normal(scale=0.05, size=2), rng.normal(scale=0.1, size=3),
                            rng.normal(size=3)])
        speed = rng.uniform(0.0, 4.0) if k % 2 else rng.uniform(12.0, 30.0)
        qd = np.concatenate([rng.normal(scale=0.3, size=5), [speed, 0.0, 0.0] + rng.normal(size=3)])
        out.append((q, qd, rng.normal(size=3) * 2.0, rng.uniform(40.0, 60.0, 2),
                    rng.normal(size=4) * 0.1))
    return out


def paths(n_states):
    """[(hot path, [(implementation, role, fn)], cases)]: every fn maps a case to an array."""
    model = TiltrotorModel()
    params = model.params
    prop, aero = cores(params)
    kf, kb = _module("forces"), _module("bls")
    cap = force_model(prop, aero) if kf is not None else None
    states = _states(n_states)
    lists = [tuple(a.tolist() for a in s) for s in states]
    cases = list(zip(states, lists))
    out = []

    def aero_reference(c):
        (q, qd, z, _, d), _ = c
        passive, Bd = aero.terms(q, qd, z)
        return passive + Bd @ d

    def prop_reference(c):
        (q, qd, z, n, _), _ = c
        f, t, _, _ = prop.thrust_and_torque(q, qd, z, n)
        Gf, Gt = prop.unit_columns(q)
        return Gf @ f + Gt @ t

    rows = [("numpy `AeroModel.terms`: ϑ_passive + B_δ δ", "reference", aero_reference),
            ("Python `AeroModel.generalized_force`", "Python tier",
             lambda c: aero.generalized_force(c[0][0], c[0][1], c[0][2], c[0][4]))]
    if kf is not None:
        rows.append(("C `_forces.aero_loads`", "kernel",
                     lambda c: np.array(kf.aero_loads(cap, c[1][0], c[1][1], c[1][2], c[1][4],
                                                      False)[0])))
    out.append(("ϑ_aero (7.34)–(7.56)", rows, cases))

    rows = [("numpy `unit_columns` · `thrust_and_torque`", "reference", prop_reference),
            ("Python `PropulsionModel.propeller_force`", "Python tier",
             lambda c: prop.propeller_force(*c[0][:4]))]
    if kf is not None:
        rows.append(("C `_forces.propeller_force`", "kernel",
                     lambda c: np.array(kf.propeller_force(cap, *c[1][:4]))))
    out.append(("ϑ_P (7.32)", rows, cases))

    def affine_reference(c):
        B, passive = input_affine_vectorized(model, *c[0][:4])
        return np.concatenate([B.ravel(), passive])

    def affine_python(c):
        t = affine_terms_scalar_python(params, *c[1][:4])
        return np.concatenate([t.B.ravel(), t.passive])

    rows = [("numpy `input_affine_vectorized`", "reference", affine_reference),
            ("Python `affine_terms_scalar_python`", "Python tier", affine_python)]
    if kf is not None:
        rows.append(("C `_forces.affine_terms`", "kernel",
                     lambda c: np.concatenate(kf.affine_terms(cap, *c[1][:4], True)[:2])))
    out.append(("B, ϑ_passive (7.62), per sample", rows, cases))

    # allocation problems as the law builds them: B at the state, bounds at the surface air
    # speeds, a demand partly outside the box; warm start = the previous sample's active set
    rng = np.random.default_rng(2)
    problems = []
    with native.disabled():
        for (q, qd, z, n, _) in states:
            t = input_affine_terms(model, q, qd, z, n)
            lo, hi = tiltrotor_bounds(t.surface_speed[1:5])
            u = t.B @ rng.uniform(lo, hi) + rng.normal(size=8) * 10.0
            cold = bounded_ls.bounded_least_squares(t.B, u, lo, hi, return_info=True)[1]
            problems.append((t.B, u, lo, hi, cold["active"]))
    for label, warm in (("warm-started (tilt-rotor law)", True), ("cold (MechanicalLaw)", False)):
        def general(p, warm=warm):
            with _general_bls_path():
                return bounded_ls.bounded_least_squares(*p[:4], warm_start=p[4] if warm else None)

        rows = [("numpy general path (`_box_qp_pdas` + `_polish`)", "reference", general),
                ("Python `_bls_fast_python`", "Python tier",
                 lambda p, warm=warm: bounded_ls._bls_fast_python(*p[:4], REG,
                                                                  p[4] if warm else None)[0])]
        if kb is not None:
            rows.append(("C `_bls.solve`", "kernel",
                         lambda p, warm=warm: kb.solve(*p[:4], REG, p[4] if warm else None, 25)[0]))
        out.append((f"bounded least squares (7.84), {label}", rows, problems))

    mech = MechanicalLaw(model, PARTITION, thesis_inner_law(), allocation=lambda u, q, qd: u)
    dyn = [(q, qd, rng.normal(size=8)) for (q, qd, *_) in states]

    rows = [("Drake mass matrix `inverse_dynamics`: M q̈ + h", "reference",
             lambda c: mech.dynamics.inverse_dynamics(*c)),
            ("Drake RNEA `recursive_inverse_dynamics_drake`", "Python tier",
             lambda c: mech.dynamics.recursive_inverse_dynamics_drake(*c))]
    if _module("rnea") is not None:
        rows.append(("C `_rnea` via `recursive_inverse_dynamics`", "kernel",
                     _with_kernels(lambda c: mech.dynamics.recursive_inverse_dynamics(*c), True)))
    out.append(("u* = M q̈ + C q̇ + g, per sample", rows, dyn))

    qdd = []
    for (q, qd, *_) in states:
        e_int, tracked = rng.normal(size=3) * 0.1, rng.normal(size=18)
        qdd.append((q, qd, e_int.tolist(), tracked.tolist(), q.tolist(), qd.tolist()))
    # a law decides once whether its q̈_des uses the kernel: one copy per tier
    py_law, c_law = mech.with_inner(mech.law), mech.with_inner(mech.law)
    with native.disabled():
        py_law.desired_acceleration_scalar(*qdd[0][4:6], *qdd[0][2:4])
    rows = [("numpy `desired_acceleration` (its unchecked core)", "reference",
             lambda c: mech._desired_acceleration_core(c[0], c[1], np.array(c[2]), np.array(c[3]))),
            ("Python `desired_acceleration_scalar`", "Python tier",
             lambda c: np.array(py_law.desired_acceleration_scalar(c[4], c[5], c[2], c[3])))]
    if _module("rnea") is not None:
        rows.append(("C `_rnea.desired_acceleration` via `desired_acceleration_scalar`", "kernel",
                     lambda c: np.array(c_law.desired_acceleration_scalar(c[4], c[5], c[2], c[3]))))
    out.append((QDD, rows, qdd))

    flags = []
    for (B, u, lo, hi, _) in problems:
        tau = np.clip(lo + rng.uniform(-0.2, 1.2, 8) * (hi - lo), lo, hi)
        flags.append((tau, lo, hi))

    rows = [("numpy form (a (1, 8) batch)", "reference",
             lambda c: tc.saturation_flags(c[0][None], c[1][None], c[2][None])[0]),
            ("Python float loop", "Python tier",
             _with_kernels(lambda c: tc.saturation_flags(*c), False))]
    if kf is not None:
        rows.append(("C `_forces.saturation_flags`", "kernel",
                     _with_kernels(lambda c: tc.saturation_flags(*c), True)))
    out.append(("saturation flags, per sample", rows, flags))

    thrusts = []
    for (q, qd, z, n, _) in states:
        t = input_affine_terms(model, q, qd, z, n)
        f = prop.coef.thrust(n, np.minimum(t.rotor_vxz / (n * prop.coef.diameter), prop.coef.J_max),
                             t.rotor_phi) * rng.uniform(0.95, 1.05, 2)
        thrusts.append((f, t.rotor_vxz, t.rotor_phi, n))
    rows = [("Python `newton_speed_for_thrust`", "reference",
             lambda c: newton_speed_for_thrust(prop.coef, *c))]
    if kf is not None:
        rows.append(("C `_forces.newton_speed`", "kernel",
                     lambda c: np.array(kf.newton_speed(cap, *c, 4, 1e-9))))
    out.append(("thrust inversion (7.90), per sample", rows, thrusts))

    air = [np.abs(s[1][5:8]).sum() * np.ones(4) for s in states]
    rows = [("Python `tiltrotor_bounds`", "reference",
             _with_kernels(lambda v: np.concatenate(tiltrotor_bounds(v)), False))]
    if kf is not None:
        rows.append(("C `_forces.surface_bounds` via `tiltrotor_bounds`", "kernel",
                     _with_kernels(lambda v: np.concatenate(tiltrotor_bounds(v)), True)))
    out.append(("surface bounds (7.87)–(7.89), per sample", rows, air))
    return out


def _loop(fn, cases, loops):
    t0 = time.process_time()
    for _ in range(loops):
        for c in cases:
            fn(c)
    return time.process_time() - t0


def time_path(rows, cases, repeat, min_time):
    """Best µs per call of each implementation, rounds interleaved."""
    loops = []
    for _, _, fn in rows:
        n = 1
        while _loop(fn, cases, n) < min_time:
            n *= 2
        loops.append(n)
    best = [np.inf] * len(rows)
    for _ in range(repeat):
        for i, (_, _, fn) in enumerate(rows):
            best[i] = min(best[i], _loop(fn, cases, loops[i]) / (loops[i] * len(cases)))
    return [b * 1e6 for b in best]


def deviation(fn, ref, cases):
    """max |fn − ref| / (1 + |ref|) over the cases (NaN entries of the reference skipped: the
    uncontrolled DOF of q̈_des)."""
    worst = 0.0
    for c in cases:
        a, b = np.asarray(fn(c), dtype=float), np.asarray(ref(c), dtype=float)
        m = ~np.isnan(b)
        worst = max(worst, float(np.max(np.abs(a[m] - b[m]) / (1.0 + np.abs(b[m])), initial=0.0)))
    return worst


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7, help="interleaved timing rounds")
    ap.add_argument("--min-time", type=float, default=0.02, help="CPU seconds per timing")
    ap.add_argument("--states", type=int, default=32, help="inputs per path")
    args = ap.parse_args(argv)
    built = {k: _module(k) is not None for k in ("forces", "bls", "rnea")}
    print(f"Python {platform.python_version()}, numpy {np.__version__}; kernels built: "
          + ", ".join(f"{k} {'yes' if v else 'no'}" for k, v in built.items()))
    print()
    print("| hot path | implementation | role | µs per call | speed-up vs reference "
          "| max deviation |")
    print("|---|---|---|---:|---:|---:|")
    verdicts = []
    for name, rows, cases in paths(args.states):
        times = time_path(rows, cases, args.repeat, args.min_time)
        ref_fn = rows[0][2]
        for (label, role, fn), t in zip(rows, times):
            dev = "—" if role == "reference" else f"{deviation(fn, ref_fn, cases):.1e}"
            print(f"| {name} | {label} | {role} | {t:.2f} | {times[0] / t:.1f}× | {dev} |")
        for (label, role, _), t in zip(rows, times):
            if role == "Python tier":
                ratio = times[0] / t
                verdict = "needed" if ratio >= NEEDED else f"not needed for speed (< {NEEDED}×)"
                if name in KEPT_ANYWAY and ratio < NEEDED:
                    verdict += "; " + KEPT_ANYWAY[name]
                verdicts.append(f"* {name}: {label} is {ratio:.2f}× as fast as the reference: "
                                + verdict)
    print()
    print(f"Python tiers (kept where ≥ {NEEDED}× faster than the reference):")
    print("\n".join(verdicts))


if __name__ == "__main__":
    main()
