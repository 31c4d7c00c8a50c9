"""Layered configuration: a site file holds only the keys it changes over the shipped defaults.

Tables merge key by key (``content.resolution`` too, so a site can change one scene's resolution);
any other value, lists included, is replaced whole. Every leaf remembers which file it came from,
so a problem is reported against the file that holds it and ``check-config --show`` can say where
each value was set.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

Key = tuple[str, ...]


def merge(layers: list[tuple[Path, dict]]) -> tuple[dict, dict[Key, Path]]:
    """The documents merged in order (later wins) and, for every key path, the file that set it."""
    merged: dict = {}
    origin: dict[Key, Path] = {}

    def walk(into: dict, doc: dict, path: Path, prefix: Key) -> None:
        for key, value in doc.items():
            where = prefix + (key,)
            if isinstance(value, dict) and isinstance(into.get(key, {}), dict):
                into.setdefault(key, {})
                origin.setdefault(where, path)
                walk(into[key], value, path, where)
            else:
                into[key] = value
                origin[where] = path
                for stale in [k for k in origin if k[: len(where)] == where and k != where]:
                    del origin[stale]  # a table replaced by a value

    for path, doc in layers:
        walk(merged, doc, path, ())
    return merged, origin


def source_of(origin: dict[Key, Path], loc: tuple, default: Path) -> Path:
    """The file behind the longest known prefix of ``loc`` (a new key: the last file given)."""
    keys = tuple(str(part) for part in loc)
    for n in range(len(keys), 0, -1):
        if keys[:n] in origin:
            return origin[keys[:n]]
    return default


def leaves(doc: dict, prefix: Key = ()) -> list[tuple[Key, Any]]:
    """(key path, value) for every non-table value, in file order."""
    out: list[tuple[Key, Any]] = []
    for key, value in doc.items():
        if isinstance(value, dict) and value:
            out += leaves(value, prefix + (key,))
        else:
            out.append((prefix + (key,), value))
    return out
