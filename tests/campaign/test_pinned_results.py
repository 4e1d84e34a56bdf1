"""Designs that are synthesis results are pinned in the design-file encoding inside the store's
integrity envelope (schema 2): they come back as the same SynthesisResult, and every refusal of
docs/reliability.md still holds for them (edited, wrong structure, unreadable result schema,
an object to build, a schema-1 file of an older version)."""

import json
import warnings

import numpy as np
import pytest

import sobolev_drake as sd
from sobolev_drake.campaign.errors import CampaignFolderError
from sobolev_drake.campaign.store import DESIGNS_SCHEMA, CampaignStore
from sobolev_drake.datafile import fingerprint, from_tree, to_tree
from sobolev_drake.synthesis.design_file import RESULT_SCHEMA, decode_result, encode_result

SPECS = {"OF": "spec-of", "data": "spec-data"}
CONFIG = {"campaign": "c", "designs": list(SPECS), "perturb": [], "duration": None, "smoke": True}


@pytest.fixture(scope="module")
def result():
    """A certified output-feedback result: controller, P, X, Y, certificate, warnings."""
    plant = sd.GeneralizedPlant.make([[0, 1], [-1, -0.5]], B1=[[0], [1]], B2=[[0], [1]],
                                     C1=[[1, 0], [0, 0]], D12=[[0], [1]], C2=[[1.0, 0.0]], D21=[[0.1]])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.SobolevDrakeWarning)
        return sd.hinf_output_feedback(plant)


@pytest.fixture
def pinned(tmp_path, result):
    store = CampaignStore(tmp_path)
    with store.locked() as s:
        s.start(CONFIG, resume=False)
        s.save_designs("c", {"OF": {"design": result}, "data": {"design": {"K": np.ones((2, 3))}}}, SPECS)
    return store, tmp_path / "designs.json"


def _edit(path, edit, fix_checksum=True):
    doc = json.loads(path.read_text(encoding="utf-8"))
    edit(doc)
    if fix_checksum:
        doc["checksum"] = fingerprint(from_tree(doc["designs"]))
    path.write_text(json.dumps(doc), encoding="utf-8")


def test_a_pinned_result_comes_back_as_the_same_result(pinned, result):
    store, path = pinned
    back = store.load_designs("c", SPECS)
    got = back["OF"]["design"]
    assert type(got) is sd.SynthesisResult and got.kind == "output_feedback"
    assert got.gamma == result.gamma and got.certificate.ok and got.warnings == result.warnings
    for a, b in zip(got.controller, result.controller):
        np.testing.assert_array_equal(a, b)          # exact: typed arrays, not decimal text
    np.testing.assert_array_equal(got.P, result.P)
    np.testing.assert_array_equal(back["data"]["design"]["K"], np.ones((2, 3)))
    # stored as the design file encodes it, with its result schema, in the store's envelope
    doc = json.loads(path.read_text(encoding="utf-8"))
    assert doc["schema"] == DESIGNS_SCHEMA == 2 and doc["checksum"] == fingerprint(from_tree(doc["designs"]))
    entry = doc["designs"]["OF"]
    assert set(entry) == {"spec", "result"} and entry["result"]["schema"] == RESULT_SCHEMA
    assert entry["result"]["fields"] == json.loads(json.dumps(to_tree(encode_result(result))))
    assert decode_result(from_tree(entry["result"]["fields"]), "here").gamma == result.gamma


def _break_fields(doc):
    del doc["designs"]["OF"]["result"]["fields"]["certificate"]


def _future_schema(doc):
    doc["designs"]["OF"]["result"]["schema"] = 99


def _object_array(doc):
    doc["designs"]["OF"]["result"]["fields"]["K"] = {"__array__": "object", "shape": [1],
                                                      "data": ["os.system"]}


def _older_store(doc):
    doc["schema"] = 1


@pytest.mark.parametrize("edit, fix, message", [
    (lambda doc: doc["designs"]["OF"]["result"]["fields"].update(gamma=0.5), False,
     r"designs\.json: its content does not match its checksum"),
    (_break_fields, True, r"designs\.json: design 'OF': a result needs exactly the fields"),
    (_future_schema, True, r"designs\.json: design 'OF': result schema 99, this version reads schemas \[1, 2\]"),
    (_object_array, False, r"designs\.json.*array"),    # refused before any checksum
    (_older_store, True, r"designs\.json: schema 1, this version reads schema 2 \(pinned before "
                         r"synthesis results were stored as results\); restore the file, or choose another --out"),
    (lambda doc: doc["designs"]["OF"].update(result=[1, 2]), True,
     r"designs\.json: design 'OF' is not a pinned synthesis result"),
])
def test_a_damaged_pinned_result_is_refused_naming_the_file(pinned, edit, fix, message):
    store, path = pinned
    _edit(path, edit, fix)
    with pytest.raises(CampaignFolderError, match=message):
        store.load_designs("c", SPECS)


def test_the_check_sees_the_decoded_result(pinned):
    store, _ = pinned
    seen = {}

    def check(label, design):
        seen[label] = type(design).__name__
        if label == "OF" and design.controller.nk > 0:
            raise ValueError("a static controller was expected")

    with pytest.raises(CampaignFolderError, match=r"design 'OF' is not what the synthesis produces "
                                                  r"\(a static controller was expected\)"):
        store.load_designs("c", SPECS, check=check)
    assert seen["OF"] == "SynthesisResult"
