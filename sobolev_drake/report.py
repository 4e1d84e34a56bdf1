"""Tables (markdown + JSON) and the REPRODUCTION.md summary of experiment results.

Numbers are printed with 4 significant digits (``fmt``): 845.8, 0.2545, 1.23e-05; integers
and values in [10⁴, 10⁶) without exponent; NaN/None as "—".  The JSON keeps full precision
(NaN/inf become null).
"""

from __future__ import annotations

import json
import math
import os
import re
from datetime import datetime, timezone
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

__all__ = ["Claim", "ExperimentResult", "fmt", "percent_of", "percent_rows", "reading_claim", "markdown_table", "write_table", "write_reproduction",
           "save_result", "load_result", "GENERATED_MARKER", "check_replaceable"]

DASH = "—"

#: First line of every report :func:`write_reproduction` writes; a file without it (or the
#: "Generated ... by `sobolev-drake`." line of reports written before the marker existed) is
#: never replaced.
GENERATED_MARKER = ("<!-- written by sobolev-drake (rerun it to update this file; "
                    "it replaces a file only while this line is at its top) -->")
_LEGACY_STAMP = re.compile(r"Generated \d{4}-\d{2}-\d{2} \d{2}:\d{2} UTC by `sobolev-drake`\. ")


@dataclass
class Claim:
    """One checkable statement of the thesis and whether it held in our run.

    Attributes
    ----------
    text : str
        The statement, as the thesis makes it.
    held : bool
        Whether our run confirmed it.
    detail : str, default ""
        Supporting numbers or explanation (shown in parentheses in REPRODUCTION.md).
    """

    text: str
    held: bool
    detail: str = ""


@dataclass
class ExperimentResult:
    """What an experiment produced: files, headline numbers and thesis claims.

    Attributes
    ----------
    name : str
        Experiment name (section title and anchor in REPRODUCTION.md).
    outputs : dict of str to Path
        Label -> produced file (png/html/md/json).
    metrics : dict
        Headline numbers (scalars are listed in REPRODUCTION.md; everything is saved as JSON).
    claims : list of Claim
        The thesis statements checked and whether they held.
    table_markdown : str
        Markdown table of our numbers beside the thesis'.
    """

    name: str
    outputs: dict[str, Path] = field(default_factory=dict)  # label -> file (png/html/md/json)
    metrics: dict = field(default_factory=dict)
    claims: list[Claim] = field(default_factory=list)
    table_markdown: str = ""  # our numbers beside the thesis'



def percent_of(value: float | None, base: float | None) -> str:
    """A table cell "value (percentage of base)", e.g. ``"0.369 (65%)"``; the value alone when
    ``base`` is 0.

    Parameters
    ----------
    value : float
    base : float

    Returns
    -------
    str
    """
    return f"{value:.4g} ({100 * value / base:.0f}%)" if base else f"{value:.4g}"


def percent_rows(values: dict, base: str | dict, columns: Sequence[str]) -> list:
    """Table rows "label, value (percentage of the base row's value), ..." per labelled row.

    Parameters
    ----------
    values : dict
        {row label: {column: float}}, in row order.
    base : str or dict
        The label of the row every column is a percentage of, or that row's values
        ({column: float}, e.g. a thesis row that is not among ``values``).
    columns : sequence of str
        The columns, in order.

    Returns
    -------
    list of list
        ``[label, percent_of(values[label][c], base_row[c]) for c in columns]`` per row.
    """
    base_row = values[base] if isinstance(base, str) else base
    return [[label, *(percent_of(v[c], base_row[c]) for c in columns)] for label, v in values.items()]


def reading_claim(text: str, values: dict, thesis_row: dict, columns: Sequence[str], tolerance: float, *,
                  digits: int = 1, extra: str = "") -> Claim:
    """The claim "a reading reproduces a thesis row": every column within ``tolerance``.

    Parameters
    ----------
    text : str
        The claim's statement, e.g. "W2/W∞ with the thesis-printed M reproduces the thesis'
        W2/W∞ row within 1 %".
    values : dict
        {column: float} of the reading.
    thesis_row : dict
        {column: float} of the thesis' row (non-zero).
    columns : sequence of str
        The columns compared.
    tolerance : float
        Largest relative deviation allowed (0.01 for 1 %).
    digits : int, default 1
        Decimals of the percentages in the detail.
    extra : str, default ""
        Appended to the detail ("; " first).

    Returns
    -------
    Claim
        Held when every |value / thesis − 1| < tolerance; the detail lists each value and its
        signed deviation.
    """
    if not (math.isfinite(tolerance) and tolerance > 0):
        raise ValueError(f"tolerance must be a finite fraction > 0, got {tolerance!r}")
    off = {c: values[c] / thesis_row[c] - 1 for c in columns}
    detail = ", ".join(f"{c} {values[c]:.4g} ({100 * v:+.{digits}f} %)" for c, v in off.items())
    return Claim(text, all(abs(v) < tolerance for v in off.values()),
                 detail + (f"; {extra}" if extra else ""))


def fmt(x: Any) -> str:
    """Human formatting of one table cell.

    Parameters
    ----------
    x : object
        The cell value: None, bool, integer, float (numpy scalars included) or anything else
        (formatted with ``str``).

    Returns
    -------
    str
        "—" for None/NaN, "yes"/"no" for booleans, integers as is, floats with 4 significant
        digits (no exponent in [10⁴, 10⁶), "∞"/"−∞" for infinities), other values with
        ``|`` escaped and newlines removed (safe inside a markdown table).
    """
    if x is None:
        return DASH
    if isinstance(x, (bool, np.bool_)):
        return "yes" if x else "no"
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    if isinstance(x, (float, np.floating)):
        x = float(x)
        if not math.isfinite(x):
            return DASH if math.isnan(x) else ("∞" if x > 0 else "−∞")
        if x == 0.0:
            return "0"
        if 1e4 <= abs(x) < 1e6:
            return f"{x:.0f}"
        return f"{x:.4g}"
    return str(x).replace("|", "\\|").replace("\n", " ")


def _jsonable(x):
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(float(x)) else None
    if x is None:
        return None
    if isinstance(x, (list, tuple, np.ndarray)):
        return [_jsonable(v) for v in x]
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    return str(x)


def markdown_table(columns: Sequence[str], rows: Sequence[Sequence]) -> str:
    """A markdown table with every cell (headers too) formatted by :func:`fmt`.

    Parameters
    ----------
    columns : sequence of str
        Column headers.
    rows : sequence of sequence
        Table rows, each with one cell per column (``ValueError`` otherwise).

    Returns
    -------
    str
        The table (header, separator and body lines), without a trailing newline.
    """
    for i, r in enumerate(rows):
        if len(r) != len(columns):
            raise ValueError(f"markdown_table: row {i} has {len(r)} cells, expected {len(columns)} "
                             f"(columns {list(columns)})")
    head = "| " + " | ".join(fmt(c) for c in columns) + " |"
    sep = "|" + "|".join("---" for _ in columns) + "|"
    body = ["| " + " | ".join(fmt(c) for c in r) + " |" for r in rows]
    return "\n".join([head, sep, *body])


def write_table(out_dir: str | os.PathLike, stem: str, columns: Sequence[str], rows: Sequence[Sequence], *,
                thesis_rows: Sequence[Sequence | None] | None = None,
                title: str = "") -> tuple[Path, Path, str]:
    """Write ``<out_dir>/<stem>.md`` and ``<stem>.json``; return (md_path, json_path, markdown).

    ``thesis_rows`` (optional) is aligned with ``rows`` (``None`` where the thesis has no
    number); each of our rows is then followed by the thesis row and a "source" column
    (ours / thesis) is inserted after the first column.

    Parameters
    ----------
    out_dir : str or Path
        Output directory (created if missing).
    stem : str
        File name without extension (no folders).
    columns : sequence of str
        Column headers.
    rows : sequence of sequence
        Our rows, one cell per column.
    thesis_rows : sequence of (sequence or None), optional
        The thesis' rows, aligned with ``rows``.
    title : str, optional
        Heading of the markdown table and ``title`` of the JSON.

    Returns
    -------
    md_path : Path
        ``<out_dir>/<stem>.md``.
    json_path : Path
        ``<out_dir>/<stem>.json`` (full precision; NaN/inf as null).
    markdown : str
        The markdown text written.
    """
    columns = list(columns)
    rows = [list(r) for r in rows]
    for k, r in enumerate(rows):
        if len(r) != len(columns):
            raise ValueError(f"row {k} has {len(r)} cells, expected {len(columns)} (columns {columns})")
    if thesis_rows is not None:
        thesis_rows = [None if r is None else list(r) for r in thesis_rows]
        if len(thesis_rows) != len(rows):
            raise ValueError(f"thesis_rows must align with rows: {len(thesis_rows)} != {len(rows)}")
        for k, r in enumerate(thesis_rows):
            if r is not None and len(r) != len(columns):
                raise ValueError(f"thesis_rows[{k}] has {len(r)} cells, expected {len(columns)}")
        cols = [columns[0], "source", *columns[1:]]
        shown = []
        for r, th in zip(rows, thesis_rows):
            shown.append([r[0], "ours", *r[1:]])
            if th is not None:
                shown.append([th[0], "thesis", *th[1:]])
    else:
        cols, shown = columns, rows
    if not stem or "/" in stem or os.sep in stem:
        raise ValueError(f"stem must be a plain file name without folders, got {stem!r}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    md = (f"### {title}\n\n" if title else "") + markdown_table(cols, shown) + "\n"
    md_path = out_dir / f"{stem}.md"
    json_path = out_dir / f"{stem}.json"
    md_path.write_text(md, encoding="utf-8")
    json_path.write_text(json.dumps({"title": title, "columns": columns, "rows": _jsonable(rows),
                                     "thesis_rows": _jsonable(thesis_rows)}, indent=1, ensure_ascii=False),
                         encoding="utf-8")
    return md_path, json_path, md


def _rel(p, base: Path) -> str:
    try:
        return os.path.relpath(Path(p).resolve(), base.resolve())
    except ValueError:  # different drive (Windows)
        return Path(p).name


def write_reproduction(results: Sequence, path: str | os.PathLike, *, title: str = "Reproduction of the thesis experiments",
                       campaigns: Sequence = (), differences: str = "") -> Path:
    """Write a REPRODUCTION.md from ``ExperimentResult`` objects: per experiment its table, its
    claims marked held / NOT held, headline metrics and links (relative to ``path``) to outputs.

    The file starts with :data:`GENERATED_MARKER`; an existing file without it is not
    replaced (:func:`check_replaceable`).

    Parameters
    ----------
    results : sequence of ExperimentResult
        The experiments to summarize, in order.
    path : str or Path
        The markdown file to write (its folder is created if missing).
    title : str, optional
        Top-level heading.
    campaigns : sequence of str, optional
        Markdown sections of campaign summaries (``summary.md`` of each campaign), appended
        under "Campaigns".
    differences : str, optional
        Markdown paragraphs on why the thesis' numbers differ from ours (one per table),
        appended under "Why the thesis' numbers differ".

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    FileExistsError
        If ``path`` exists and was not written by this function.
    """
    for i, r in enumerate(results):
        _require_result(f"results[{i}]", r)
    path = check_replaceable(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    base = path.parent
    n_claims = sum(len(r.claims) for r in results)
    n_held = sum(c.held for r in results for c in r.claims)
    lines = [GENERATED_MARKER, f"# {title}", "",
             f"Generated {datetime.now(timezone.utc).strftime('%Y-%m-%d %H:%M UTC')} by `sobolev-drake`. "
             f"{len(results)} experiment(s); claims held: {n_held}/{n_claims}.", "",
             "| experiment | claims held |", "|---|---|"]
    for r in results:
        lines.append(f"| [{r.name}](#{r.name}) | {sum(c.held for c in r.claims)}/{len(r.claims)} |")
    for r in results:
        lines += ["", f"## {r.name}", ""]
        if r.table_markdown:
            lines += [r.table_markdown.strip(), ""]
        if r.claims:
            lines.append("Claims:")
            lines.append("")
            for c in r.claims:
                mark = "✅ held" if c.held else "❌ NOT held"
                lines.append(f"- {mark} — {c.text}" + (f" ({c.detail})" if c.detail else ""))
            lines.append("")
        scalars = {k: v for k, v in (r.metrics or {}).items()
                   if isinstance(v, (int, float, np.integer, np.floating, str, bool))}
        if scalars:
            lines.append("Metrics: " + ", ".join(f"{k} = {fmt(v)}" for k, v in list(scalars.items())[:16]))
            lines.append("")
        if r.outputs:
            lines.append("Outputs: " + ", ".join(f"[{label}]({_rel(p, base)})" for label, p in r.outputs.items()))
    if campaigns:
        lines += ["", "# Campaigns", "",
                  "The thesis compares designs on one disturbance realization and one parameter set; "
                  "here each comparison is repeated over many seeds (`sobolev-drake campaign`).", ""]
        lines += [str(c).strip() + "\n" for c in campaigns]
    if differences.strip():
        lines += ["", "# Why the thesis' numbers differ", "", differences.strip(), ""]
    path.write_text("\n".join(lines).rstrip() + "\n", encoding="utf-8")
    return path


def check_replaceable(path: str | os.PathLike) -> Path:
    """``path`` as a Path if a report may be written there: absent, or a file that
    :func:`write_reproduction` wrote (its first line is :data:`GENERATED_MARKER`).

    Parameters
    ----------
    path : str or Path
        The report file about to be written.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    FileExistsError
        If ``path`` exists and is not a file written by sobolev-drake (someone's own
        REPRODUCTION.md, a folder); the message names it and says how to proceed.
    """
    path = Path(path)
    if not path.exists():
        return path
    if not path.is_file():
        raise FileExistsError(f"{path} exists and is not a file; remove it or write the report "
                              "elsewhere")
    try:
        with path.open(encoding="utf-8", errors="replace") as f:
            head = [f.readline().rstrip("\n") for _ in range(3)]
    except OSError as err:
        raise FileExistsError(f"{path} exists and cannot be read ({err.strerror or err}); "
                              "refusing to replace it") from None
    if head[0] == GENERATED_MARKER or (head[0].startswith("# ") and _LEGACY_STAMP.match(head[2])):
        return path
    raise FileExistsError(f"refusing to replace {path}: it was not written by sobolev-drake "
                          f"(its first line is not the marker '{GENERATED_MARKER[:29]}...'); move "
                          "or delete it, or write the report elsewhere")


def _require_result(name, value):

    if not isinstance(value, ExperimentResult):
        raise TypeError(f"{name} must be an ExperimentResult, got {type(value).__name__}")


def save_result(result: ExperimentResult, out_dir: str | os.PathLike) -> Path:
    """Write ``<out_dir>/result.json`` (paths relative to ``out_dir``) so that reports can be
    rebuilt later without rerunning (``sobolev-drake report``).

    Parameters
    ----------
    result : ExperimentResult
        The result to save.
    out_dir : str or Path
        Directory of ``result.json`` (created if missing).

    Returns
    -------
    Path
        ``<out_dir>/result.json``.
    """
    _require_result("result", result)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    data = {"name": result.name,
            "outputs": {k: _rel(v, out_dir) for k, v in result.outputs.items()},
            "metrics": _jsonable(result.metrics),
            "claims": [{"text": c.text, "held": bool(c.held), "detail": c.detail} for c in result.claims],
            "table_markdown": result.table_markdown}
    path = out_dir / "result.json"
    path.write_text(json.dumps(data, indent=1, ensure_ascii=False), encoding="utf-8")
    return path


def _json_bool(value, path, i):
    if not isinstance(value, bool):   # bool("false") is True: never coerce
        raise ValueError(f"{path}: claims[{i}].held must be a JSON boolean, got {value!r}")
    return value


def load_result(path: str | os.PathLike) -> ExperimentResult:
    """Inverse of :func:`save_result` (output paths made relative to the current directory).

    Parameters
    ----------
    path : str or Path
        A ``result.json`` written by :func:`save_result`.

    Returns
    -------
    ExperimentResult
        The saved result; its output paths are joined to ``path``'s folder.

    Raises
    ------
    ValueError
        If the file is not valid JSON (the message gives its line and column) or not the
        object :func:`save_result` writes (the message names the offending key).
    OSError
        If the file cannot be read.
    """

    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as err:
        raise ValueError(f"{path}: not valid JSON at line {err.lineno}, column {err.colno} "
                         f"({err.msg})") from None
    except UnicodeDecodeError as err:
        raise ValueError(f"{path}: not UTF-8 text (byte {err.start}: {err.reason})") from None
    what = f"{path} is not a result.json written by save_result"
    if not isinstance(data, dict):
        raise ValueError(f"{what}: expected a JSON object, got a JSON {_JSON_KIND.get(type(data))}")
    if "name" not in data:
        raise ValueError(f"{what}: the key 'name' is missing")
    data = {"outputs": {}, "metrics": {}, "claims": [], "table_markdown": "", **data}
    for key, kind in (("name", str), ("outputs", dict), ("metrics", dict), ("claims", list),
                      ("table_markdown", str)):
        if not isinstance(data[key], kind):
            raise ValueError(f"{what}: {key!r} must be a JSON {_JSON_KIND[kind]}, got "
                             f"{_JSON_KIND.get(type(data[key]))} {data[key]!r:.60}")
    for i, c in enumerate(data["claims"]):
        if not isinstance(c, dict) or "text" not in c or "held" not in c:
            raise ValueError(f"{what}: claims[{i}] must be an object with 'text' and 'held', "
                             f"got {c!r:.60}")
    try:
        outputs = {k: path.parent / v for k, v in data["outputs"].items()}
    except TypeError:
        raise ValueError(f"{what}: every outputs value must be a file name (a JSON string), got "
                         f"{data['outputs']!r:.60}") from None
    return ExperimentResult(name=data["name"], outputs=outputs, metrics=data["metrics"],
                            claims=[Claim(c["text"], _json_bool(c["held"], path, i), c.get("detail", ""))
                                    for i, c in enumerate(data["claims"])],
                            table_markdown=data["table_markdown"])


_JSON_KIND = {dict: "object", list: "array", str: "string", int: "number", float: "number",
              bool: "boolean", type(None): "null"}
