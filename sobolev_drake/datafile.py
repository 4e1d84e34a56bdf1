"""Readable, non-executable data files: JSON with typed arrays, atomic writes, clear errors.

Everything the library writes for a later run to read back (pinned campaign designs, campaign
definitions) goes through this module, never through ``pickle``: a JSON file can only ever
produce numbers, strings, lists and dicts, so a file planted in a results folder cannot run
code.  Arrays keep their exact values (floats are written with ``repr``'s shortest round-trip
form), dtype and shape.

The encoding of a value (:func:`to_tree` / :func:`from_tree`):

* ``None``, ``bool``, ``int``, ``float`` (NaN and ±inf as JSON's common ``NaN``/``Infinity``
  extension), ``str`` — themselves;
* ``list``/``tuple`` — a JSON list (a tuple reads back as a list);
* ``dict`` with string keys — a JSON object (keys starting with ``"__"`` are reserved);
* ``numpy.ndarray`` of bool, integer, float or complex dtype, and numpy scalars — ``{"__array__":
  dtype, "shape": [...], "data": [...]}`` (complex entries as ``[re, im]`` pairs).

Examples
--------
>>> import numpy as np
>>> tree = to_tree({"K": np.array([[1.0, -0.5]]), "gamma": 2.5})
>>> back = from_tree(tree)
>>> back["K"].shape, float(back["gamma"])
((1, 2), 2.5)
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from sobolev_drake.errors import SobolevDrakeError

__all__ = ["DataFileError", "to_tree", "from_tree", "fingerprint", "write_json_atomic",
           "write_text_atomic", "write_bytes_atomic", "read_json", "fsync_directory"]

_ARRAY = "__array__"
_DTYPES = {"bool": np.bool_, "int64": np.int64, "float64": np.float64, "complex128": np.complex128}


class DataFileError(SobolevDrakeError, ValueError):
    """A data file that cannot be used: unreadable, not JSON, or not of the expected structure.

    The message starts with the file's path (and ``:line:column`` for a JSON syntax error).
    """


def _array_tree(arr: np.ndarray) -> dict:
    kind = arr.dtype.kind
    if kind == "b":
        dtype, data = "bool", arr.astype(bool).ravel().tolist()
    elif kind in "iu":
        if arr.size and (arr.max() > np.iinfo(np.int64).max):
            raise TypeError(f"cannot store unsigned integers above 2**63 - 1 (got {arr.max()})")
        dtype, data = "int64", arr.astype(np.int64).ravel().tolist()
    elif kind == "f":
        dtype, data = "float64", arr.astype(np.float64).ravel().tolist()
    elif kind == "c":
        flat = arr.astype(np.complex128).ravel()
        dtype, data = "complex128", [[z.real, z.imag] for z in flat.tolist()]
    else:
        raise TypeError(f"cannot store an array of dtype {arr.dtype} (bool, integer, float or "
                        "complex arrays only)")
    return {_ARRAY: dtype, "shape": list(arr.shape), "data": data}


def to_tree(value: Any) -> Any:
    """``value`` as a JSON-serializable tree (see the module docstring for the encoding).

    Parameters
    ----------
    value : object
        None, bool, int, float, str, list, tuple, dict with str keys, numpy arrays and scalars,
        nested.

    Returns
    -------
    object
        Made of dicts, lists, str, int, float, bool and None only.

    Raises
    ------
    TypeError
        For anything else (objects, functions, Drake systems), naming the type and where in the
        value it sits.
    """
    return _to_tree(value, "value")


def _to_tree(value, where):
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, (int, np.integer)) and not isinstance(value, np.bool_):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    if isinstance(value, (np.ndarray, np.generic)):
        try:
            return _array_tree(np.asarray(value))
        except TypeError as exc:
            raise TypeError(f"{where}: {exc}") from None
    if isinstance(value, (list, tuple)):
        return [_to_tree(v, f"{where}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str) or k.startswith("__"):
                raise TypeError(f"{where}: dict keys must be strings not starting with '__', got {k!r}")
            out[k] = _to_tree(v, f"{where}[{k!r}]")
        return out
    raise TypeError(f"{where}: cannot store an object of type {type(value).__name__} in a data "
                    "file (numbers, strings, lists, dicts and numpy arrays only)")


def from_tree(tree: Any, where: str = "value") -> Any:
    """The value :func:`to_tree` encoded as ``tree`` (arrays rebuilt with dtype and shape).

    Parameters
    ----------
    tree : object
        Parsed JSON.
    where : str
        How to name the value in error messages (e.g. the file).

    Returns
    -------
    object

    Raises
    ------
    DataFileError
        A malformed array entry or a reserved key, naming where it sits.
    """
    if isinstance(tree, list):
        return [from_tree(v, f"{where}[{i}]") for i, v in enumerate(tree)]
    if not isinstance(tree, dict):
        if tree is None or isinstance(tree, (bool, int, float, str)):
            return tree
        raise DataFileError(f"{where}: unexpected {type(tree).__name__}")
    if _ARRAY in tree:
        return _array_from_tree(tree, where)
    bad = [k for k in tree if k.startswith("__")]
    if bad:
        raise DataFileError(f"{where}: unknown reserved key {bad[0]!r}")
    return {k: from_tree(v, f"{where}[{k!r}]") for k, v in tree.items()}


def _array_from_tree(tree, where):
    dtype, shape, data = tree.get(_ARRAY), tree.get("shape"), tree.get("data")
    if set(tree) != {_ARRAY, "shape", "data"} or dtype not in _DTYPES:
        raise DataFileError(f"{where}: an array needs exactly '__array__' (one of "
                            f"{sorted(_DTYPES)}), 'shape' and 'data', got keys {sorted(tree)} "
                            f"with dtype {dtype!r}")
    if not (isinstance(shape, list) and all(isinstance(n, int) and not isinstance(n, bool)
                                            and 0 <= n for n in shape)):
        raise DataFileError(f"{where}: array shape must be a list of non-negative integers, got {shape!r}")
    size = math.prod(shape)
    if not isinstance(data, list) or len(data) != size:
        raise DataFileError(f"{where}: array of shape {tuple(shape)} needs {size} entries, got "
                            f"{len(data) if isinstance(data, list) else type(data).__name__}")
    scalar = {"bool": (bool,), "int64": (int,), "float64": (int, float),
              "complex128": (list,)}[dtype]
    for i, v in enumerate(data):
        if not isinstance(v, scalar) or (dtype != "bool" and isinstance(v, bool)) or (
                dtype == "complex128" and not (len(v) == 2 and all(
                    isinstance(p, (int, float)) and not isinstance(p, bool) for p in v))):
            raise DataFileError(f"{where}: entry {i} of a {dtype} array is {v!r}")
    if dtype == "complex128":
        data = [complex(re, im) for re, im in data]
    return np.array(data, dtype=_DTYPES[dtype]).reshape(shape)


def _canonical(value, where):
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        fields = {f.name: _canonical(getattr(value, f.name), f"{where}.{f.name}")
                  for f in dataclasses.fields(value)}
        return {"dataclass": f"{type(value).__module__}.{type(value).__qualname__}", "fields": fields}
    if isinstance(value, dict):
        return {"dict": [[_canonical(k, where), _canonical(v, f"{where}[{k!r}]")]
                         for k, v in sorted(value.items(), key=lambda kv: repr(kv[0]))]}
    if isinstance(value, (list, tuple)):
        return [_canonical(v, f"{where}[{i}]") for i, v in enumerate(value)]
    return _to_tree(value, where)


def fingerprint(value: Any) -> str:
    """SHA-256 of a value's exact content (hex): equal values give equal fingerprints.

    Frozen dataclasses (design specifications) are fingerprinted field by field with their
    qualified class name; dicts in key order; floats exactly; arrays with dtype and shape.

    Parameters
    ----------
    value : object
        What :func:`to_tree` accepts, plus dataclass instances.

    Returns
    -------
    str
        64 hexadecimal digits.

    Examples
    --------
    >>> fingerprint({"a": 1.0, "b": [1, 2]}) == fingerprint({"b": [1, 2], "a": 1.0})
    True
    """
    text = json.dumps(_canonical(value, "value"), sort_keys=True, separators=(",", ":"),
                      ensure_ascii=True, allow_nan=True)
    return hashlib.sha256(text.encode("ascii")).hexdigest()


def fsync_directory(path: str | os.PathLike) -> None:
    """Make a rename or a new file in folder ``path`` durable (POSIX; a no-op where folders
    cannot be opened, e.g. Windows).

    Parameters
    ----------
    path : str or Path
    """
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def write_json_atomic(path: str | os.PathLike, value: Any) -> Path:
    """Write ``value`` (a :func:`to_tree`-able value) as JSON to ``path`` atomically.

    The text goes to a temporary file in the same folder, is flushed and synced, then renamed
    over ``path`` and the folder synced: a reader sees the old file or the new one, never a
    mixture, whatever kills the process (a full disk leaves the old file in place).

    Parameters
    ----------
    path : str or Path
    value : object

    Returns
    -------
    Path

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from sobolev_drake.datafile import read_json, write_json_atomic
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = write_json_atomic(Path(folder) / "design.json", {"K": np.array([[-1.0, -2.0]])})
    ...     back = read_json(path, "the design")
    >>> back["K"], back["K"].dtype
    (array([[-1., -2.]]), dtype('float64'))
    """
    text = json.dumps(to_tree(value), indent=1, ensure_ascii=False, allow_nan=True) + "\n"
    return write_text_atomic(path, text)


def write_text_atomic(path: str | os.PathLike, text: str) -> Path:
    """Replace ``path`` by ``text`` (UTF-8) atomically (:func:`write_bytes_atomic`).

    Parameters
    ----------
    path : str or Path
    text : str

    Returns
    -------
    Path
    """
    return write_bytes_atomic(path, text.encode("utf-8"))


def write_bytes_atomic(path: str | os.PathLike, data: bytes) -> Path:
    """Replace ``path`` by ``data`` atomically: temporary file in the same folder, flush, fsync,
    rename, folder fsync.  On any failure (a full disk) the old file stays.

    Parameters
    ----------
    path : str or Path
    data : bytes

    Returns
    -------
    Path
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    fsync_directory(path.parent)
    return path


def read_json(path: str | os.PathLike, what: str = "data file") -> Any:
    """Parse the JSON file ``path`` (:func:`from_tree` applied).

    Parameters
    ----------
    path : str or Path
    what : str
        What the file is, for messages ("the campaign definition").

    Returns
    -------
    object

    Raises
    ------
    DataFileError
        Unreadable, not UTF-8, NUL bytes, not JSON (with ``path:line:column``), or a malformed
        array; the message names the file and what it should be.
    FileNotFoundError
        No such file.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from sobolev_drake.datafile import DataFileError, read_json
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = Path(folder) / "records.json"
    ...     _ = path.write_text('{"gamma": 2.5, "ok": true}')
    ...     print(read_json(path))
    ...     _ = path.write_text('{"gamma": 2.5,')
    ...     try:
    ...         read_json(path, "the records")
    ...     except DataFileError as error:
    ...         print(str(error).split(": ", 1)[1])
    {'gamma': 2.5, 'ok': True}
    the records is not valid JSON (...; truncated or edited?)
    """
    path = Path(path)
    raw = path.read_bytes()
    nul = raw.find(b"\x00")
    if nul >= 0:
        raise DataFileError(f"{path}: {what} holds NUL bytes from offset {nul} (damaged on disk)")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise DataFileError(f"{path}: {what} is not UTF-8 text (byte {exc.start})") from None
    if not text.strip():
        raise DataFileError(f"{path}: {what} is empty (damaged, or written by a process that died)")
    try:
        tree = json.loads(text)
    except json.JSONDecodeError as exc:
        raise DataFileError(f"{path}:{exc.lineno}:{exc.colno}: {what} is not valid JSON "
                            f"({exc.msg}; truncated or edited?)") from None
    return from_tree(tree, str(path))
