"""Measured data shipped with the package (see PROVENANCE.md for where each file comes from)."""

from __future__ import annotations

import json
from functools import lru_cache
from importlib import resources


__all__ = ["load"]


@lru_cache(maxsize=None)
def load(name: str) -> dict:
    """Load ``sobolev_drake/data/<name>.json`` (e.g. ``load("propeller_coefficients")``)."""
    path = resources.files(__name__) / f"{name}.json"
    if not path.is_file():
        available = sorted(p.name[:-5] for p in resources.files(__name__).iterdir() if p.name.endswith(".json"))
        raise FileNotFoundError(f"no data file {name!r}; available: {available}")
    return json.loads(path.read_text())
