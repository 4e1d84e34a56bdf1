"""Reading saved Meshcat recordings (the standalone HTML of ``Meshcat.StaticHtml()``).

The page embeds the viewer's commands as base64 msgpack blobs; :func:`meshcat_commands` decodes
them (with the msgpack package), :func:`animation_keyframes` lists what the recorded animation
moves and :func:`animates_path` asks about one object.  :func:`external_script_sources` lists any tag that
would load a script or stylesheet from the network (a recording must open offline).  Used by
the tests and by :func:`sobolev_drake.viz.save_recording_html`.
"""

from __future__ import annotations

import base64
import re
from pathlib import Path

import msgpack

__all__ = ["external_script_sources", "meshcat_commands", "animation_keyframes", "animates_path"]


def _text(name: str, value) -> str:
    """``value`` if it is a ``str``, else a TypeError naming ``name`` (the page's text, not a
    path or bytes)."""
    if not isinstance(value, str):
        hint = " (pass the page's text, e.g. Path(file).read_text())" if isinstance(
            value, (bytes, Path)) else ""
        raise TypeError(f"{name} must be a str, got {type(value).__name__}{hint}")
    return value


_SCRIPT_SRC = re.compile(r"<script[^>]*\bsrc\s*=\s*[\"']?(https?:)?//", re.IGNORECASE)
_LINK_HREF = re.compile(r"<link[^>]*\bhref\s*=\s*[\"']?(https?:)?//", re.IGNORECASE)


def external_script_sources(html: str) -> list[str]:
    """The ``<script src=…>`` / ``<link href=…>`` tags of ``html`` pointing at http(s) or //.

    Parameters
    ----------
    html : str
        An HTML page.

    Returns
    -------
    list of str
        The offending tags (empty for a self-contained page).
    """
    html = _text("html", html)
    tags = []
    for pattern in (_SCRIPT_SRC, _LINK_HREF):
        for m in pattern.finditer(html):
            end = html.find(">", m.start())
            tags.append(html[m.start(): end + 1])
    return tags


def _unpack(raw: bytes):
    """The first msgpack object of ``raw`` (msgpack's decoder; an ext value as ``("ext", type,
    bytes)``, map keys of any type, trailing bytes ignored)."""
    try:
        return msgpack.unpackb(raw, raw=False, strict_map_key=False,
                               ext_hook=lambda code, data: ("ext", code, bytes(data)))
    except msgpack.ExtraData as extra:
        return extra.unpacked


_BLOB = re.compile(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)")


def meshcat_commands(html: str) -> list[dict]:
    """The Meshcat commands embedded in a ``StaticHtml()`` page, decoded.

    Parameters
    ----------
    html : str
        A page from ``Meshcat.StaticHtml()``.

    Returns
    -------
    list of dict
        The commands (dicts with ``type``, ``path``, …); assets that are not commands are
        skipped.
    """
    html = _text("html", html)
    out = []
    for m in _BLOB.finditer(html):
        raw = base64.b64decode(m.group(1))
        try:
            v = _unpack(raw)
        except (ValueError, msgpack.UnpackException):   # an asset that is not msgpack
            continue
        if isinstance(v, dict) and "type" in v:
            out.append(v)
    return out


def animation_keyframes(html: str) -> dict[str, dict[str, int]]:
    """{scene path: {track name: number of keyframes}} of the animation in a StaticHtml page.

    Parameters
    ----------
    html : str
        A page from ``Meshcat.StaticHtml()``.

    Returns
    -------
    dict
        {scene path: {track name: number of keyframes}} (empty without an animation).
    """
    out: dict[str, dict[str, int]] = {}
    for cmd in meshcat_commands(html):
        if cmd.get("type") != "set_animation":
            continue
        for a in cmd.get("animations", []):
            tracks = out.setdefault(a.get("path"), {})
            for tr in a.get("clip", {}).get("tracks", []):
                tracks[tr.get("name")] = len(tr.get("keys", []))
    return out


def animates_path(html: str, path: str) -> bool:
    """Whether a saved Meshcat recording animates the object at ``path``.

    Parameters
    ----------
    html : str
        A page written by ``Meshcat.StaticHtml()``.
    path : str
        A Meshcat path, e.g. ``"/Cameras/default"``.

    Returns
    -------
    bool
    """
    html, key = _text("html", html), _text("path", path).encode()
    return any(b"set_animation" in raw and key in raw
               for raw in (base64.b64decode(m.group(1)) for m in _BLOB.finditer(html)))
