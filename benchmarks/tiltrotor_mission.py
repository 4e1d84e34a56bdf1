"""Real-time factor of the full-envelope tilt-rotor mission (scenario 2) and its profile.

    python benchmarks/tiltrotor_mission.py [--duration 250] [--profile-seconds 10] [--top 25]
        [--integrator runge_kutta3] [--accuracy 1e-3] [--period 0.01] [--skip-full]
        [--skip-profile] [--breakdown] [--floor] [--no-compare]

Runs the mission (no Meshcat recording) with the compiled kernels, then, as baselines in the
same run, with pure Python (``native.disabled()``) and with fixed-step RK2, and prints
simulated time / CPU and wall time, the compiled/Python ratio, integrator steps and derivative
evaluations per simulated second; ``--breakdown`` wraps the hot
callables with CPU timers (much less distortion than cProfile for many small calls) and prints
the share of the controller update and its parts, of the plant force system and of the rest
(MultibodyPlant dynamics, Drake's simulator loop, log sinks).  Then profiles a shorter run with
cProfile (top cumulative and internal costs).  ``--floor`` measures what the diagram costs
without the Python work: the controller update holds its first command and the force system
returns a constant (not a valid flight, only the cost of Drake's side).  Target (issue 7):
≥ 20× real time.

On a shared machine wall time mostly measures the other processes: compare CPU times, and
compare two code versions back-to-back (A/B) rather than against numbers from another day.

Outcome (issue 7, 2-core machine shared with 3 other sessions, load 2–8; CPU times):

* before (scalar plant forces only): 250 s in 92–129 s CPU (1.9–2.7× real time), 30-s slices
  2.3–2.9×; after the per-sample controller rewrite (scalar one-pass B/ϑ_passive/air speeds/
  inflow, Python-float bounded LS with LAPACK-direct solves and active-set warm start, scalar
  Newton thrust inversion, plain-float references and trim spline) and a numpy-free plant force
  path: 250 s in 42–48 s CPU (5.3–6.0×), 30-s slices 6.2–8.3×; A/B on the same segment 2.5–3.2×
  faster.  Same integrator steps (121.7/s) and derivative evaluations (365/s); states equal to
  5e-13 over the whole mission.
* third round (Drake plumbing and per-sample paths): the force system reads its four actuator
  ports through one cache entry with input-port prerequisites (recomputed once per controller
  sample instead of 4 HasValue + 3 Eval per derivative); the controller's plant-facing outputs
  are Drake state output ports (no Python output callbacks); u* by Drake's recursive
  Newton–Euler (``MechanicalLaw.recursive_inverse_dynamics``, one state write, no mass matrix)
  and q̈_des in floats; inputs validated once per sample; generated straight-line Ct/Cq; the
  bounded LS skips the residual comparison of its polish when the free block has full rank
  (155 → 116 µs on 6000 recorded mission problems, same active sets); the plant's eight
  massless ``frame_*`` links are FixedOffsetFrames (17 → 9 bodies: MultibodyPlant derivative
  21.7 → 17.3 µs).  Instruction counts (callgrind, deterministic, first 10 s): 373 → 318 M
  per simulated second (−15 %; force system 349k → 296k per evaluation, controller update
  1.78 M → 1.52 M per sample, MultibodyPlant without the forces −22 %).  CPU over the whole
  250 s, old and new code run *concurrently* (same load): 44.3 → 39.8 s and 40.2 → 35.6 s
  (−10 %, −11 %); run one after the other the load swings dominate (37.7 → 35.2/33.3 s, then
  30.8 → 30.8/29.8 s; 6.5–8.4× real time).  Same steps and derivative evaluations; states
  within 4.5e-13 of the previous code over the whole mission, every phase RMS within 7e-14 m.
  Measured and dropped: a list-built Drake-order force output (more instructions than numpy's
  fancy index), no SceneGraph (−0.2 %), coarser log sinks (they publish at 20 Hz: negligible).
* now, shares of the instructions (callgrind, first 10 s): controller update 48 % (its Python
  law, the reference system and the update glue), plant force system 35 %, MultibodyPlant
  11 %, integrator, events and log sinks 6 % (Drake's cache invalidation, 8 %, is spread over
  all of them).  CPU timers (``--breakdown``, 100 s, loaded machine): controller law ≈ 44 %
  (allocation 15 %, B/ϑ 9 %, u* by RNEA 5–6 %, thrust inversion 4 %, q̈_des 2 %, bounds 2 %),
  plant force system 26 % (≈ 60 µs hot, 110 µs in the loaded loop × 342/s), the rest 30 %.
* ``--floor``: the same diagram with the controller update replaced by a constant command and
  the force system by a constant force still takes 27–36 ms CPU per simulated second (28–37×
  real time: MultibodyPlant, simulator, event handling, Drake cache notifications, pybind
  callbacks, the Python reference system).
* ``--integrator runge_kutta2`` (fixed step = controller period) needs 207 instead of 338–365
  derivative evaluations/s: 10–20 % faster; over the full mission the states move by ≤ 8 mm /
  0.12° and every phase RMS by < 1 mm (the RK3 run itself is ~1 mm from an RK5 1e-7 reference
  after 20 s).
* pure Python stops at ≈ 8×: 20× (50 ms CPU per simulated second) leaves 15–20 ms/s for the
  Python work above the diagram's floor, which needed ≈ 60–100 ms/s.
* compiled kernels (``sobolev_drake/native``, plain C built at install, each equal to its
  Python reference: forces to the bit, the rest to rounding): the plant force system, the
  input-affine terms, the bounds, the bounded least squares (≈ 95 → 5.5 µs), the Newton thrust
  inversion and the saturation flags, plus a fused per-sample path in ``make_law`` that calls
  them directly.  Full 250 s, same steps and derivative evaluations (121.7/s, 365.4/s),
  runs one after the other on the shared machine (CPU times; the machine's speed drifts by
  ±15 % between runs, so compare within one session):
  - default RK3 (accuracy 1e-3): 12.3–16.7 s CPU, **15.0–20.4×** (Python: 28.5–32.4 s, 7.7–8.8×);
  - fixed-step RK2 at the controller period (``--integrator runge_kutta2``, 207 derivative
    evaluations/s): 11.6–13.1 s, **19.1–21.5×**.  ``benchmarks/tiltrotor_integrators.py``:
    against an RK5 (1e-7) reference over the whole mission RK2 stays within 9.4 mm, 0.075° of
    attitude and 0.14° of tilt, every phase RMS within 1.0 mm (RK3: 1.2 mm, 0.007°).
  - floor (constant command and force, RK3): 31 ms/s (32×); a MultibodyPlant with a C++
    zero-order hold alone: 11 ms/s (91×).  What remains above the floor is Python glue per
    call (ports, arrays, the RNEA through pydrake: ≈ 35 µs hot, ≈ 60 µs in the loop), not
    arithmetic.
* fourth round (Drake plumbing, then the RNEA):
  - ulp-sized steps: with ``max_step`` equal to the controller period, many integrator steps
    ended an ulp before the sample event and the simulator then took an extra full RK3 step of
    ~1e-16 s to reach it; the log sinks' 0.05 s events and the controller's 0.01 s events also
    differ by an ulp at some instants (k·0.05 ≠ 5k·0.01 in floating point).  121.7 steps/s
    where 100 suffice.  ``simulate`` now applies ``max_step`` with a relative slack of 1e-6
    and the missions log at the controller period: 100.1 steps/s, 300.6 derivative
    evaluations/s; states within 1.2e-11 of before after 60 s.
  - the four Python slicer outputs the log sinks read per sample (τ̄, u*, residual, saturation)
    became one C++ state output port (``sample_record``); ``handles.x`` is a C++ Selector
    instead of a Python output: floor 31 → 21 ms/s (48×).
  - ``native/rnea.c``: u* = M q̈ + C q̇ + g by a compiled recursive Newton–Euler pass equal to
    Drake's CalcInverseDynamics within 3.4e-15 (relative): 2.5–3 µs hot instead of 12 µs,
    5–8 µs instead of 29–43 µs in the loop.
  - Full 250 s, runs alternating with the previous code (the other core busy with
    ``make reproduce``): before 15.6–17.0× (median 16.2×), now 17.3–20.7× (median 20.3×) at
    the default RK3; on a quieter machine 17.3–21.1× in three runs.  Fixed-step RK2
    23.1–26.4×; pure Python 8.9–9.6×.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import pstats
import time


def _timer(f, acc, key):
    """``f`` wrapped to accumulate its CPU seconds and calls in ``acc[key]``."""
    acc.setdefault(key, [0.0, 0])

    def wrapper(*a, **k):
        t0 = time.process_time()
        try:
            return f(*a, **k)
        finally:
            rec = acc[key]
            rec[0] += time.process_time() - t0
            rec[1] += 1
    if hasattr(f, "parts"):               # the law's fused sample checks its parts
        wrapper.parts = f.parts
    return wrapper


def _timed(obj, name, acc, key=None):
    """Replace ``obj.name`` by :func:`_timer`'s wrapper (under ``key``, default ``name``)."""
    setattr(obj, name, _timer(getattr(obj, name), acc, key or name))


def instrument(built):
    """CPU timers on the controller law and its parts (the force system: timed_force_calcs)."""
    from sobolev_drake.tiltrotor import controller as tc
    acc = {}
    law = built["law"]
    if law.fused_sample is not None:
        # the fused path calls the kernels directly and binds the RNEA when it is made
        _timed(law, "fused_sample", acc, "  law.fused_sample (B, u*, bounds, allocation, n)")
    else:
        for name in ("input_affine", "bounds", "allocate", "thrust_to_speed"):
            _timed(law, name, acc, f"  law.{name}")
        _timed(law.mech_law, "recursive_inverse_dynamics", acc, "  mech_law M q̈ + C q̇ + g (RNEA)")
    _timed(law.mech_law, "desired_acceleration_scalar", acc, "  mech_law q̈_des (floats)")
    _timed(law, "step", acc, "controller law.step (per sample)")
    _timed(tc, "saturation_flags", acc, "controller saturation flags (per sample)")
    return acc


def timed_force_calcs(acc):
    """Context manager: force systems built inside it time their output calcs (the kernel's
    or Python's) in ``acc`` under "plant force system (per derivative)"."""
    import contextlib

    from sobolev_drake.tiltrotor.plant import TiltrotorForces

    def timing(make):
        return lambda self, drake_order: _timer(make(self, drake_order), acc,
                                                "plant force system (per derivative)")

    @contextlib.contextmanager
    def patched():
        saved = TiltrotorForces._native_calc, TiltrotorForces._python_calc
        TiltrotorForces._native_calc, TiltrotorForces._python_calc = map(timing, saved)
        try:
            yield
        finally:
            TiltrotorForces._native_calc, TiltrotorForces._python_calc = saved
    return patched()


def floor_patches():
    """Context manager: the tilt-rotor law's step returns its first result, the controller's
    compiled update (``tiltrotor.compiled_sample``) writes its first record again, and the
    plant force system gives a constant zero force (the cost of the diagram without the law's
    and the forces' work).  Controllers built inside the block are patched."""
    import contextlib

    import numpy as np

    from sobolev_drake.tiltrotor.compiled_sample import CompiledSample
    from sobolev_drake.tiltrotor.plant import TiltrotorForces
    from sobolev_drake.tiltrotor.controller import TiltrotorWInfLaw

    @contextlib.contextmanager
    def patched():
        step, force = TiltrotorWInfLaw.step, TiltrotorForces.thesis_force
        native, compiled = TiltrotorForces._native_calc, CompiledSample.kernel
        first = {}

        def const_step(self, *a, **k):
            if "s" not in first:
                first["s"] = step(self, *a, **k)
            return first["s"]

        def const_kernel(self, period):
            sample, kept = compiled(self, period), []
            if sample is None:
                return None

            def const_sample(x, ref, wind, old, old_active, record, active):
                if not kept:                     # the first accepted sample, then copies of it
                    if not sample(x, ref, wind, old, old_active, record, active):
                        return False
                    kept.extend((record.copy(), active.copy()))
                    return True
                record[:], active[:] = kept
                return True
            return const_sample
        zero = np.zeros(8)
        TiltrotorWInfLaw.step = const_step
        CompiledSample.kernel = const_kernel
        TiltrotorForces.thesis_force = lambda self, context: zero
        TiltrotorForces._native_calc = lambda self, drake_order: (
            lambda context, output: output.get_mutable_value().fill(0.0))
        try:
            yield
        finally:
            TiltrotorWInfLaw.step, TiltrotorForces.thesis_force = step, force
            TiltrotorForces._native_calc, CompiledSample.kernel = native, compiled
    return patched()


def run(duration, args, breakdown=False, integrator=None, label=""):
    from sobolev_drake.tiltrotor.mission import simulate_mission
    import sobolev_drake.tiltrotor.mission as tm

    acc = None
    if breakdown:
        build = tm.build_mission

        def build_instrumented(*a, **k):
            nonlocal acc
            forces = {}
            with timed_force_calcs(forces):
                built = build(*a, **k)
            acc = {**instrument(built), **forces}
            return built
        tm.build_mission = build_instrumented
    try:
        t0, c0 = time.perf_counter(), time.process_time()
        built, _ = simulate_mission(2, duration, integrator=integrator or args.integrator,
                                    period=args.period, accuracy=args.accuracy)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    finally:
        if breakdown:
            tm.build_mission = build
    sim = built["simulator"]
    steps = sim.get_num_steps_taken()
    derivs = sim.get_integrator().get_num_derivative_evaluations()
    print(f"{label}scenario 2, {duration:g} s simulated in {wall:.1f} s wall ({cpu:.1f} s CPU): "
          f"real-time factor {duration / wall:.2f}x wall, {duration / cpu:.2f}x CPU (target 20x); "
          f"controller period {built['controller'].period} s, integrator {integrator or args.integrator} "
          f"(accuracy {args.accuracy:g}): {steps / duration:.1f} steps/s, "
          f"{derivs / duration:.1f} derivative evaluations/s")
    if acc:
        print(f"CPU breakdown over {cpu:.2f} s (per simulated second / per call):")
        for key, (sec, calls) in acc.items():
            print(f"  {key:42s} {100 * sec / cpu:5.1f} %  {1e3 * sec / duration:7.2f} ms/s  "
                  f"{1e6 * sec / max(calls, 1):7.1f} µs × {calls / duration:.0f}/s")
        top = sum(acc[k][0] for k in ("controller law.step (per sample)",
                                      "controller saturation flags (per sample)",
                                      "plant force system (per derivative)"))
        print(f"  {'rest (MultibodyPlant, simulator, logs, ports)':42s} {100 * (cpu - top) / cpu:5.1f} %  "
              f"{1e3 * (cpu - top) / duration:7.2f} ms/s")
    built["cpu_s"] = cpu
    return built


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=250.0, help="simulated seconds (full run)")
    ap.add_argument("--profile-seconds", type=float, default=10.0, help="simulated seconds profiled")
    ap.add_argument("--top", type=int, default=25, help="rows of the profile to print")
    ap.add_argument("--skip-full", action="store_true", help="only profile")
    ap.add_argument("--skip-profile", action="store_true", help="no cProfile run")
    ap.add_argument("--breakdown", action="store_true",
                    help="CPU timers on the controller parts and the plant force system")
    ap.add_argument("--floor", action="store_true",
                    help="also time the diagram with a constant command and a constant force")
    ap.add_argument("--integrator", default="runge_kutta3",
                    help="Drake integrator (runge_kutta3 error-controlled; runge_kutta2 fixed step)")
    ap.add_argument("--accuracy", type=float, default=1e-3, help="error-controlled accuracy")
    ap.add_argument("--no-compare", dest="compare", action="store_false",
                    help="skip the pure-Python and fixed-step RK2 runs of the full mission")
    ap.add_argument("--period", type=float, default=0.01, help="controller sampling period [s]")
    args = ap.parse_args(argv)

    from sobolev_drake.tiltrotor.mission import build_mission, simulate_mission

    # building (imports, URDF parse, gains) is timed separately from simulating
    t0 = time.perf_counter()
    build_mission(2, 1.0)
    print(f"diagram build (incl. imports): {time.perf_counter() - t0:.2f} s")

    if not args.skip_full:
        fast = run(args.duration, args, breakdown=args.breakdown, label="compiled kernels: ")
        if args.compare:
            # baselines measured in the same run: pure Python with the same integrator, and
            # the compiled kernels with fixed-step RK2 at the controller period
            from sobolev_drake import native
            with native.disabled():
                slow = run(args.duration, args, label="pure Python:      ")
            print(f"  compiled / pure Python: {slow['cpu_s'] / fast['cpu_s']:.2f}x faster (CPU)")
            if args.integrator != "runge_kutta2":
                run(args.duration, args, integrator="runge_kutta2", label="compiled kernels: ")
    if args.floor:
        print("floor (constant command, constant force; not a valid flight):")
        with floor_patches():
            run(args.duration, args)
    if args.skip_profile:
        return

    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    simulate_mission(2, args.profile_seconds, integrator=args.integrator, period=args.period,
                     accuracy=args.accuracy)
    prof.disable()
    wall = time.perf_counter() - t0
    print(f"\nprofiled {args.profile_seconds:g} s simulated in {wall:.1f} s wall "
          f"({args.profile_seconds / wall:.2f}x real time; cProfile inflates small calls)")
    for key in ("tottime", "cumulative"):
        s = io.StringIO()
        pstats.Stats(prof, stream=s).sort_stats(key).print_stats(args.top)
        print(f"\n--- top {args.top} by {key} ---")
        print("\n".join(line for line in s.getvalue().splitlines() if line.strip())[:12000])


if __name__ == "__main__":
    main()
