"""Synthesis results saved to and loaded from readable files: JSON or npz, never pickle.

A file holds one :class:`~sobolev_drake.synthesis.problem.SynthesisResult` with every field
(controller or gain, γ, Lyapunov matrices, certificates, region, warnings, what was tried; for
a discrete-time result its period and its :class:`~sobolev_drake.synthesis.problem.
DiscreteDesign`, with the continuous design inside), a format name, a schema version and a
checksum (``datafile.fingerprint``) of the content:

* ``.json`` -- ``datafile``'s typed-array JSON (exact floats, dtype and shape kept), readable in
  any editor;
* ``.npz`` -- numpy's archive: each array stored in binary as ``a0``, ``a1``, ...; the rest of
  the document as JSON text in ``document`` (where each array sits as ``{"__npz__": "a0"}``).
  It is read with ``np.load(allow_pickle=False)``.

Schema 2 added ``dt`` and ``discrete`` (and the controller's ``dt``); a schema-1 file (before
them) still loads, as the continuous-time result it holds.  A file of another format or
schema, an edited or damaged file, or a result of the wrong structure is refused with a :class:`~sobolev_drake.datafile.DataFileError` naming the file and
the problem.  The loaded result is the saved one; it is not re-certified (call
``certificates.certify_closed_loop`` on ``result.closed_loop(plant)`` to check it again).
"""

from __future__ import annotations

import dataclasses
import io
import json
import os
import zipfile
from pathlib import Path

import numpy as np

from sobolev_drake.datafile import (DataFileError, fingerprint, from_tree, read_json, to_tree,
                                    write_bytes_atomic, write_json_atomic)

from .certificates import Certificate
from .controller import DynamicController
from .problem import DiscreteDesign, SynthesisResult
from .regions import LMIRegion

__all__ = ["RESULT_FORMAT", "RESULT_SCHEMA", "save_result", "load_result", "encode_result",
           "decode_result"]

RESULT_FORMAT = "sobolev_drake synthesis result"
RESULT_SCHEMA = 2
#: schemas this version reads: 1 had no ``dt`` / ``discrete`` (continuous time only)
_READABLE = {1: {"dt": 0.0, "discrete": None}, 2: {}}
_SUFFIXES = (".json", ".npz")
_NPZ = "__npz__"


def encode_result(result: SynthesisResult) -> dict:
    """The design-file encoding of ``result``: a dict of plain values and arrays, one entry per
    field (what :func:`save_result` writes, before ``datafile.to_tree`` types the arrays).

    For containers that carry results inside their own envelope (a campaign's pinned designs);
    :func:`decode_result` inverts it.

    Parameters
    ----------
    result : SynthesisResult

    Returns
    -------
    dict
        {field name: value}; nested records (controller, certificates, region, discrete
        design) as dicts.

    Examples
    --------
    >>> import numpy as np
    >>> from sobolev_drake import SynthesisResult
    >>> from sobolev_drake.datafile import from_tree, to_tree
    >>> from sobolev_drake.synthesis.design_file import RESULT_SCHEMA, decode_result, encode_result
    >>> res = SynthesisResult("state_feedback", 2.0, K=np.array([[-1.0, -2.0]]))
    >>> tree = to_tree(encode_result(res))                  # JSON-ready, arrays typed
    >>> back = decode_result(from_tree(tree), "example", RESULT_SCHEMA)
    >>> back.kind, back.gamma, back.K.tolist(), back.controller.nk
    ('state_feedback', 2.0, [[-1.0, -2.0]], 0)
    """
    res = result
    out = {}
    for f in dataclasses.fields(SynthesisResult):
        v = getattr(res, f.name)
        if isinstance(v, DynamicController):
            v = {"AK": v.AK, "BK": v.BK, "CK": v.CK, "DK": v.DK, "dt": v.dt}
        elif isinstance(v, DiscreteDesign):
            v = {**{g.name: getattr(v, g.name) for g in dataclasses.fields(DiscreteDesign)},
                 "closed_loop": list(v.closed_loop), "continuous": encode_result(v.continuous)}
        elif isinstance(v, Certificate):
            v = dataclasses.asdict(v)
        elif isinstance(v, LMIRegion):
            v = {"L": v.L, "M": v.M, "label": v.label}
        elif f.name == "certificates":
            v = [dataclasses.asdict(c) for c in v]
        out[f.name] = v
    return out


def decode_result(fields: dict, where: str, schema: int = RESULT_SCHEMA) -> SynthesisResult:
    """The :class:`SynthesisResult` of :func:`encode_result`'s ``fields`` (arrays decoded).

    Parameters
    ----------
    fields : dict
        {field name: value} as :func:`encode_result` gave it (after ``datafile.from_tree``).
    where : str
        Where the fields come from, for the error message (a file, a campaign's design).
    schema : int, default RESULT_SCHEMA
        The design-file schema the fields were written with; an older readable schema gets
        the fields it did not have (schema 1: continuous time).

    Returns
    -------
    SynthesisResult
        As encoded (not re-certified).

    Raises
    ------
    DataFileError
        ``schema`` is not readable, or the fields are not a result's; the message names
        ``where``.
    """
    if isinstance(schema, bool) or schema not in _READABLE:
        raise DataFileError(f"{where}: result schema {schema!r}, this version reads schemas "
                            f"{sorted(_READABLE)}")
    if isinstance(fields, dict) and _READABLE[schema]:
        fields = {**_READABLE[schema], **fields}    # the fields an older schema had not
    names = {f.name for f in dataclasses.fields(SynthesisResult)}
    if not isinstance(fields, dict) or set(fields) != names:
        got = sorted(fields) if isinstance(fields, dict) else type(fields).__name__
        raise DataFileError(f"{where}: a result needs exactly the fields {sorted(names)}, got {got}")
    try:
        f = dict(fields)
        if f["controller"] is not None:
            f["controller"] = DynamicController(**f["controller"])
        if f["certificate"] is not None:
            f["certificate"] = Certificate(**f["certificate"])
        f["certificates"] = [Certificate(**c) for c in f["certificates"]]
        if f["region"] is not None:
            f["region"] = LMIRegion(**f["region"])
        if f["discrete"] is not None:
            d = dict(f["discrete"])
            d["closed_loop"] = tuple(d["closed_loop"])
            d["continuous"] = decode_result(d["continuous"], f"{where} (its continuous design)", schema)
            f["discrete"] = DiscreteDesign(**d)
        if f["kind"] not in ("state_feedback", "output_feedback"):
            raise ValueError(f"kind {f['kind']!r} is not 'state_feedback' or 'output_feedback'")
        gain = f["K"] if f["kind"] == "state_feedback" else f["controller"]
        # an uncertified thesis-literal (6.22) result has gamma only; a certified one has a gain
        if gain is None and f["certificate"] is not None:
            raise ValueError(f"a {f['kind']} result without its "
                             f"{'gain K' if f['kind'] == 'state_feedback' else 'controller'}")
        return SynthesisResult(**f)
    except (TypeError, ValueError, KeyError) as exc:
        raise DataFileError(f"{where}: not a synthesis result ({exc})") from None


def _suffix(path):
    path = Path(path)
    if path.suffix not in _SUFFIXES:
        raise ValueError(f"path must end in .json or .npz, got {str(path)!r}")
    return path, path.suffix


def save_result(result: SynthesisResult, path: str | os.PathLike[str]) -> Path:
    """Write ``result`` to ``path`` (``.json`` or ``.npz``) atomically.

    Parameters
    ----------
    result : SynthesisResult
        The result to save.
    path : str or Path
        Ends in ``.json`` (readable text) or ``.npz`` (binary arrays).

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    TypeError
        ``result`` is not a SynthesisResult.
    ValueError
        ``path`` ends in neither ``.json`` nor ``.npz``.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import sobolev_drake as sd
    >>> from sobolev_drake.synthesis.design_file import load_result, save_result
    >>> P = sd.GeneralizedPlant.make([[0, 1], [-1, -0.5]], B1=[[0], [1]], B2=[[0], [1]],
    ...                              C1=[[1, 0], [0, 0]], D12=[[0], [1]])
    >>> res = sd.hinf_state_feedback(P)
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     back = load_result(save_result(res, Path(folder) / "design.json"))
    >>> bool((back.K == res.K).all()), back.gamma == res.gamma, back.certificate.ok
    (True, True, True)
    """
    if not isinstance(result, SynthesisResult):
        raise TypeError(f"result must be a SynthesisResult, got {type(result).__name__}")
    path, suffix = _suffix(path)
    fields = encode_result(result)
    tree = to_tree(fields)
    doc = {"format": RESULT_FORMAT, "schema": RESULT_SCHEMA, "checksum": fingerprint(tree)}
    if suffix == ".json":
        return write_json_atomic(path, {**doc, "result": fields})
    arrays = {}

    def extract(node):  # array nodes -> references to the archive's entries
        if isinstance(node, list):
            return [extract(v) for v in node]
        if isinstance(node, dict):
            if "__array__" in node:
                key = f"a{len(arrays)}"
                arrays[key] = from_tree(node)
                return {_NPZ: key}
            return {k: extract(v) for k, v in node.items()}
        return node
    doc["result"] = extract(tree)
    buffer = io.BytesIO()
    np.savez(buffer, document=np.array(json.dumps(doc, allow_nan=True)), **arrays)
    return write_bytes_atomic(path, buffer.getvalue())


def load_result(path: str | os.PathLike[str]) -> SynthesisResult:
    """The :class:`SynthesisResult` saved in ``path`` by :func:`save_result`.

    Parameters
    ----------
    path : str or Path
        A ``.json`` or ``.npz`` file.

    Returns
    -------
    SynthesisResult
        As saved (not re-certified).

    Raises
    ------
    DataFileError
        Not such a file, another schema, damaged or edited (checksum), or not a result; the
        message names the file.
    FileNotFoundError
        No such file.
    ValueError
        ``path`` ends in neither ``.json`` nor ``.npz``.
    """
    path, suffix = _suffix(path)
    if suffix == ".json":
        doc = read_json(path, "a synthesis result")
        tree = to_tree(doc.get("result")) if isinstance(doc, dict) else None
    else:
        doc, tree = _read_npz(path)
    if not isinstance(doc, dict) or doc.get("format") != RESULT_FORMAT:
        raise DataFileError(f"{path}: not a synthesis result file (no format {RESULT_FORMAT!r})")
    schema = doc.get("schema")
    if isinstance(schema, bool) or schema not in _READABLE:
        raise DataFileError(f"{path}: schema {schema!r}, this version reads schemas "
                            f"{sorted(_READABLE)}")
    if doc.get("checksum") != fingerprint(tree):
        raise DataFileError(f"{path}: its content does not match its checksum (edited or "
                            "damaged after it was written)")
    return decode_result(from_tree(tree, str(path)), str(path), schema)


def _read_npz(path):
    """(document, result tree with the arrays put back) of an npz result file."""
    try:
        with np.load(path, allow_pickle=False) as archive:
            entries = {k: archive[k] for k in archive.files}
        doc = json.loads(str(entries.pop("document")))
    except FileNotFoundError:
        raise
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
        # truncated or not a zip, an object array (pickle refused), bad JSON, no document
        raise DataFileError(f"{path}: not a readable synthesis result archive ({exc})") from None

    def restore(node):
        if isinstance(node, list):
            return [restore(v) for v in node]
        if isinstance(node, dict):
            if set(node) == {_NPZ}:
                if node[_NPZ] not in entries:
                    raise DataFileError(f"{path}: refers to array {node[_NPZ]!r}, not in the file")
                return to_tree(entries[node[_NPZ]])
            return {k: restore(v) for k, v in node.items()}
        return node
    return doc, restore(doc.get("result")) if isinstance(doc, dict) else None
