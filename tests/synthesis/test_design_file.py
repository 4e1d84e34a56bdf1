"""Synthesis results saved to JSON / npz and read back exactly; wrong files refused clearly."""

import json
import warnings
import zipfile

import numpy as np
import pytest

from sobolev_drake.datafile import DataFileError, fingerprint, from_tree, to_tree
from sobolev_drake.synthesis.design_file import load_result, save_result
from sobolev_drake.synthesis.hinf import output_feedback, state_feedback
from sobolev_drake.synthesis.random_plants import random_plant
from sobolev_drake.synthesis.regions import disk


@pytest.fixture(scope="module")
def results():
    p = random_plant(np.random.default_rng(3), 4, "unstable").plant
    import control
    import sobolev_drake as sd
    oscillator = control.ss([[0, 1], [-4, -0.2]], [[0, 0], [1, 1]],
                            [[1, 0], [0, 0], [1, 0]], [[0, 0], [0, 1], [0.1, 0]])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return {"sf": state_feedback(p), "of": output_feedback(p),
                "sf_region": state_feedback(p, region=disk(50.0)),
                "discrete": sd.hinf_discrete(control.c2d(oscillator, 0.01), 1, 1)}


def same(a, b):
    """Field-by-field equality, arrays exact (NaN equal to NaN)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True) and \
            np.asarray(a).dtype == np.asarray(b).dtype
    if isinstance(a, float) and isinstance(b, float) and np.isnan(a) and np.isnan(b):
        return True
    if isinstance(a, (list, tuple)):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if hasattr(a, "__dataclass_fields__"):
        return type(a) is type(b) and all(same(getattr(a, f), getattr(b, f))
                                          for f in a.__dataclass_fields__)
    return a == b


@pytest.mark.parametrize("suffix", [".json", ".npz"])
@pytest.mark.parametrize("which", ["sf", "of", "sf_region", "discrete"])
def test_round_trip_is_exact(results, tmp_path, suffix, which):
    res = results[which]
    back = load_result(save_result(res, tmp_path / f"design{suffix}"))
    assert same(back, res)
    assert back.closed_loop.__self__ is back and back.certificate.ok
    assert back.dt == res.dt and back.controller.dt == res.dt
    if res.dt:   # the discrete record, with the continuous design inside, comes back too
        assert same(back.discrete.continuous, res.discrete.continuous)
        assert back.discrete.continuous.dt == 0 and back.discrete.closed_loop[0].shape == \
            res.discrete.closed_loop[0].shape


@pytest.mark.parametrize("which", ["sf", "of"])
def test_a_schema_1_file_still_loads(results, tmp_path, which):
    """Schema 1 (before dt / discrete, no controller for state feedback) reads as the
    continuous-time result it holds; the state-feedback controller is rebuilt from K."""
    res = results[which]
    path = save_result(res, tmp_path / "design.json")
    doc = json.loads(path.read_text(encoding="utf-8"))
    tree = doc["result"]
    del tree["dt"], tree["discrete"]
    if which == "sf":
        tree["controller"] = None
    else:
        del tree["controller"]["dt"]
    doc.update(schema=1, checksum=fingerprint(to_tree(from_tree(tree))))
    path.write_text(json.dumps(doc), encoding="utf-8")
    back = load_result(path)
    assert same(back, res) and back.dt == 0.0 and back.discrete is None


def test_json_file_is_readable_text(results, tmp_path):
    path = save_result(results["of"], tmp_path / "design.json")
    doc = json.loads(path.read_text(encoding="utf-8"))
    assert doc["format"] == "sobolev_drake synthesis result" and doc["schema"] == 2
    assert doc["result"]["controller"]["AK"]["__array__"] == "float64"


def test_wrong_schema_edit_and_corruption_are_refused(results, tmp_path):
    path = save_result(results["sf"], tmp_path / "design.json")
    doc = json.loads(path.read_text(encoding="utf-8"))
    doc["schema"] = 99
    path.write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(DataFileError, match=r"schema 99, this version reads schemas \[1, 2\]"):
        load_result(path)
    doc["schema"] = 2
    doc["result"]["gamma"] = 0.5 * doc["result"]["gamma"]   # a better gamma than certified
    path.write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(DataFileError, match="does not match its checksum"):
        load_result(path)
    path.write_text('{"format": "something else"}', encoding="utf-8")
    with pytest.raises(DataFileError, match="not a synthesis result file"):
        load_result(path)
    path.write_text("{not json", encoding="utf-8")
    with pytest.raises(DataFileError, match="design.json"):
        load_result(path)


def test_npz_corruption_and_pickles_are_refused(results, tmp_path):
    path = save_result(results["of"], tmp_path / "design.npz")
    path.write_bytes(path.read_bytes()[:200])          # truncated archive
    with pytest.raises(DataFileError, match="not a readable synthesis result archive"):
        load_result(path)
    # an object array (a pickle inside the archive) is never unpickled
    np.savez(path, document=np.array([{"format": 1}], dtype=object))
    with pytest.raises(DataFileError, match="not a readable"):
        load_result(path)
    # a valid archive with an array removed
    good = save_result(results["of"], tmp_path / "good.npz")
    with zipfile.ZipFile(good) as z, zipfile.ZipFile(tmp_path / "cut.npz", "w") as out:
        for name in z.namelist():
            if name != "a0.npy":
                out.writestr(name, z.read(name))
    with pytest.raises(DataFileError, match="refers to array 'a0'"):
        load_result(tmp_path / "cut.npz")


def test_bad_arguments_name_what_was_expected(results, tmp_path):
    with pytest.raises(ValueError, match=r"path must end in \.json or \.npz"):
        save_result(results["sf"], tmp_path / "design.pkl")
    with pytest.raises(TypeError, match="result must be a SynthesisResult, got dict"):
        save_result({"K": 1}, tmp_path / "design.json")
    with pytest.raises(FileNotFoundError):
        load_result(tmp_path / "missing.json")
