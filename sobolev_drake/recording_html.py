"""Reading saved Meshcat recordings (the standalone HTML of ``Meshcat.StaticHtml()``).

The page embeds the viewer's commands as base64 msgpack blobs; :func:`meshcat_commands` decodes
them, :func:`animation_keyframes` lists what the recorded animation moves and
:func:`animates_path` asks about one object.  :func:`external_script_sources` lists any tag that
would load a script or stylesheet from the network (a recording must open offline).  Used by
the tests and by :func:`sobolev_drake.viz.save_recording_html`.
"""

from __future__ import annotations

import base64
import re
import struct
from pathlib import Path

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


def _unpack(b: bytes, i: int = 0):
    """Minimal msgpack decoder (the subset Meshcat emits); returns (value, next index)."""
    c = b[i]
    if c <= 0x7F or c >= 0xE0:
        return (c if c <= 0x7F else c - 256), i + 1
    if 0x80 <= c <= 0x9F:
        n, i, is_map = c & 0x0F, i + 1, c <= 0x8F
    elif c in (0xDC, 0xDD, 0xDE, 0xDF):
        f = ">H" if c in (0xDC, 0xDE) else ">I"
        n, i, is_map = struct.unpack_from(f, b, i + 1)[0], i + 1 + struct.calcsize(f), c >= 0xDE
    elif 0xA0 <= c <= 0xBF:
        n = c & 0x1F
        return b[i + 1:i + 1 + n].decode(), i + 1 + n
    elif c in (0xC0, 0xC2, 0xC3):
        return {0xC0: None, 0xC2: False, 0xC3: True}[c], i + 1
    else:
        num = {0xCA: ">f", 0xCB: ">d", 0xCC: ">B", 0xCD: ">H", 0xCE: ">I", 0xCF: ">Q",
               0xD0: ">b", 0xD1: ">h", 0xD2: ">i", 0xD3: ">q"}
        if c in num:
            return struct.unpack_from(num[c], b, i + 1)[0], i + 1 + struct.calcsize(num[c])
        lens = {0xC4: ">B", 0xC5: ">H", 0xC6: ">I", 0xD9: ">B", 0xDA: ">H", 0xDB: ">I",
                0xC7: ">B", 0xC8: ">H", 0xC9: ">I"}
        fixext = {0xD4: 1, 0xD5: 2, 0xD6: 4, 0xD7: 8, 0xD8: 16}
        if c in fixext:
            n, j = fixext[c], i + 1
        elif c in lens:
            n = struct.unpack_from(lens[c], b, i + 1)[0]
            j = i + 1 + struct.calcsize(lens[c])
        else:
            raise ValueError(f"unsupported msgpack byte 0x{c:02x} at {i}")
        if c in fixext or c >= 0xC7 and c <= 0xC9:  # ext: (type, raw bytes)
            return ("ext", b[j], bytes(b[j + 1:j + 1 + n])), j + 1 + n
        raw = bytes(b[j:j + n])
        return (raw.decode() if c >= 0xD9 else raw), j + n
    out = {} if is_map else []
    for _ in range(n):
        if is_map:
            k, i = _unpack(b, i)
            out[k], i = _unpack(b, i)
        else:
            v, i = _unpack(b, i)
            out.append(v)
    return out, i


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
            v, _ = _unpack(raw)
        except (ValueError, IndexError, UnicodeDecodeError, KeyError):
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
