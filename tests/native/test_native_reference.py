"""The compiled reference evaluation (sobolev_drake/native/reference.c) against the Python path.

The kernel repeats ``PiecewiseTrajectory.evaluate_scalar``'s operations in the same order (the
same libm sin/cos, no FMA contraction), so every value is equal to the bit — at breakpoints,
one ulp either side of them, before the first and after the last piece.
"""

import importlib
import math

import numpy as np
import pytest

import sobolev_drake.native as native_pkg
from sobolev_drake.systems import reference_catalogue as catalogue
from sobolev_drake.systems.reference_smoothing import smooth_junctions
from sobolev_drake.systems.references import (Coordinate, PiecewiseTrajectory, TrajectoryReference,
                                              const, poly, sine)

K = importlib.import_module("sobolev_drake.native._reference")   # ImportError: not built


@pytest.fixture(autouse=True)
def kernels_on(monkeypatch):
    """These tests compare the kernel with Python, so they switch it on even under
    SOBOLEV_DRAKE_NATIVE=0."""
    monkeypatch.setattr(native_pkg, "_ENABLED", True)


def probe_times(traj, rng, n=4000):
    bp = traj.breakpoints
    end = float(bp[-1]) + 50.0 if bp.size else 100.0
    return np.concatenate([rng.uniform(-10.0, end, n), bp, np.nextafter(bp, np.inf),
                           np.nextafter(bp, -np.inf), [0.0, -0.0, 1e6]])


def system_values(system, times):
    context = system.CreateDefaultContext()
    port = system.GetOutputPort("reference")
    out = []
    for t in times:
        context.SetTime(float(t))
        out.append(port.Eval(context))
    return np.array(out)


def python_values(traj, times):
    return np.array([sum(traj.evaluate_scalar(float(t)), []) for t in times])


def assert_same_bits(a, b):
    """Equal to the bit: the sign of zero and NaN payloads included (== would not see them)."""
    a, b = np.ascontiguousarray(a, dtype=float), np.ascontiguousarray(b, dtype=float)
    assert a.shape == b.shape
    np.testing.assert_array_equal(a.view(np.uint64), b.view(np.uint64))


@pytest.mark.parametrize("name", sorted(catalogue.TRAJECTORIES))
def test_catalogue_references_compile_and_equal_python_to_the_bit(name):
    traj = catalogue.trajectory(name)
    system = TrajectoryReference(traj)
    assert system._program is not None, "const/sine/poly pieces must take the compiled path"
    times = probe_times(traj, np.random.default_rng(len(name)))
    assert_same_bits(system_values(system, times), python_values(traj, times))


def test_random_pieces_equal_python_to_the_bit():
    rng = np.random.default_rng(7)
    for trial in range(30):
        m, k = int(rng.integers(1, 6)), int(rng.integers(1, 6))
        bp = np.cumsum(rng.uniform(0.1, 20.0, k - 1)) + rng.uniform(-5, 5)

        def coordinate():
            kind = rng.integers(3)
            if kind == 0:
                return const(rng.normal() * 10)
            if kind == 1:
                return sine(rng.normal() * 5, rng.uniform(0.01, 10), phase=rng.normal(),
                            offset=rng.normal(), t0=rng.normal() * 10)
            return poly(rng.normal(size=int(rng.integers(1, 9))) * 10.0 ** rng.integers(-3, 3),
                        t0=rng.normal() * 10)
        traj = PiecewiseTrajectory([f"q{i}" for i in range(m)],
                                   [[coordinate() for _ in range(m)] for _ in range(k)], bp)
        system = TrajectoryReference(traj)
        assert system._program is not None
        times = probe_times(traj, rng, 200)
        assert_same_bits(system_values(system, times), python_values(traj, times))


def test_other_coordinates_keep_the_python_path():
    custom = Coordinate(lambda t: (np.sin(t) ** 2, np.sin(2 * t), 2 * np.cos(2 * t)),
                        scalar=lambda t: (math.sin(t) ** 2, math.sin(2 * t), 2 * math.cos(2 * t)))
    traj = PiecewiseTrajectory(["a", "b"], [[custom, const(1.0)], [const(0.0), poly([1.0, 2.0])]], [3.0])
    system = TrajectoryReference(traj)
    assert system._program is None
    times = probe_times(traj, np.random.default_rng(1), 100)
    assert_same_bits(system_values(system, times), python_values(traj, times))
    # the smoothed mission blends neighbouring pieces in Python
    smooth = smooth_junctions(catalogue.trajectory("envelope_mission"), 2.0)
    assert TrajectoryReference(smooth)._program is None
    # a polynomial beyond the kernel's 64 coefficients stays in Python too
    long = PiecewiseTrajectory(["a"], [[poly(np.full(70, 1e-3))]])
    assert TrajectoryReference(long)._program is None


def test_kernel_switched_off_at_construction_uses_python():
    with native_pkg.disabled():
        system = TrajectoryReference(catalogue.trajectory("envelope_mission"))
    assert system._program is None


def test_scalar_converted_systems_evaluate_generically():
    traj = catalogue.trajectory("table_5_5")
    system = TrajectoryReference(traj)
    ad = system.ToAutoDiffXd()
    assert ad._program is None
    context = ad.CreateDefaultContext()
    context.SetTime(3.3)
    values = [v.value() for v in ad.GetOutputPort("reference").Eval(context)]
    assert values == sum(traj.evaluate_scalar(3.3), [])


def test_signed_zeros_and_non_finite_results_follow_python():
    traj = PiecewiseTrajectory(["a", "b", "c"], [[const(-0.0), poly([-0.0, 0.0]), sine(1.0, 2.0)]])
    system = TrajectoryReference(traj)
    assert system._program is not None
    assert_same_bits(system_values(system, [0.0, -0.0, 1.0]), python_values(traj, [0.0, -0.0, 1.0]))
    # an infinite time: the kernel's values are not finite, so the Python path decides (here
    # math.sin's domain error, as without the kernel)
    context = system.CreateDefaultContext()
    context.SetTime(math.inf)
    with pytest.raises(ValueError, match="math domain"):
        system.GetOutputPort("reference").Eval(context)
    out = np.zeros(9)
    assert K.evaluate(system._program, math.inf, out) is False
    assert K.evaluate(system._program, 1.0, out) is True


@pytest.mark.parametrize("breakpoints, pieces, error, text", [
    ([1.0], [[(0, 1.0)]], ValueError, "1 pieces need 0 breakpoints"),
    ([2.0, 1.0], [[(0, 1.0)]] * 3, ValueError, "strictly increasing"),
    ([], [[(0, 1.0)], ], None, None),
    ([], [[(3, 1.0)]], ValueError, "kind 3"),
    ([], [[(1, 1.0, 2.0)]], ValueError, "expected"),
    ([], [[(2, 0.0, 1, 1, 1, 1.0, 0.0)]], ValueError, "announces 3 coefficients but holds 2"),
    ([], [[(2, 0.0, 0, 1, 1, 0.0, 0.0)]], ValueError, "1 to 64 coefficients"),
    ([], [[(0, "a")]], TypeError, "pieces\\[0\\]\\[0\\] entry 1 must be a float"),
    ([], [[[0, 1.0]]], TypeError, "must be a tuple"),
    ([], [[("x", 1.0)]], TypeError, "pieces\\[0\\]\\[0\\] kind must be an int"),
    ([], [[(2, 0.0, 1.5, 1, 1, 0.0, 0.0, 0.0)]], TypeError, "coefficient count 0 must be an int"),
    ([float("nan")], [[(0, 1.0)]] * 2, ValueError, "breakpoints\\[0\\] must be finite"),
    (["a"], [[(0, 1.0)]] * 2, TypeError, "breakpoints\\[0\\] must be a float"),
    ([], [3.0], TypeError, "pieces\\[0\\] must be a sequence"),
    ([], [[(0, 1.0)], ], None, None),
    ([0.0], [[(0, 1.0)], [(0, 1.0), (0, 2.0)]], ValueError, "pieces\\[1\\] has 2 coordinates"),
    ([], [[]], ValueError, "at least one"),
    ([], [], ValueError, "0 pieces"),
    (3.0, [[(0, 1.0)]], TypeError, "breakpoints must be a sequence"),
])
def test_bad_programs_are_refused_naming_the_entry(breakpoints, pieces, error, text):
    if error is None:
        assert K.coordinates(K.make_program(breakpoints, pieces)) == 1
        return
    with pytest.raises(error, match=text):
        K.make_program(breakpoints, pieces)


def test_bad_output_buffers_are_refused():
    program = K.make_program([], [[(0, 1.0), (0, 2.0)]])
    out = np.zeros(6)
    K.evaluate(program, 0.5, out)
    np.testing.assert_array_equal(out, [1.0, 2.0, 0, 0, 0, 0])
    for bad in (np.zeros(5), np.zeros(6, dtype=np.float32)):
        with pytest.raises(ValueError, match="out must be a float64 array of 6 entries"):
            K.evaluate(program, 0.5, bad)
    read_only = np.zeros(6)
    read_only.flags.writeable = False
    for bad in (np.zeros(12)[::2], np.zeros(6).tolist(), read_only):
        with pytest.raises(TypeError, match="out must be a writable float64 array"):
            K.evaluate(program, 0.5, bad)
    with pytest.raises(TypeError, match="3 arguments"):
        K.evaluate(program, 0.5)
    with pytest.raises(TypeError):
        K.evaluate(program, "t", out)
    with pytest.raises(ValueError):
        K.evaluate(object(), 0.5, out)
