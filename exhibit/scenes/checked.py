"""Formula checks that passed, remembered beside the mesh cache, so a warm kiosk start needs no
sympy (half a second) yet every formula is still checked on its box the first time it is seen.

A verdict is keyed by the formula, its variables, parameters and box, and the code version, so a
change to any of them (or to the checker) checks again. Only passes are remembered; a missing,
unreadable or tampered file only costs the checks again (a false "passed" would at worst let a
build fail, and the kiosk skips a scene whose build fails).
"""

from __future__ import annotations

import hashlib
import json
import logging
from collections.abc import Mapping, Sequence

from exhibit.errors import ConfigError
from exhibit.scenes.cache import cache_dir, code_version, store
from exhibit.schema import read_text
from exhibit.surfaces.expressions import check_expression

log = logging.getLogger(__name__)
FILE = "checked-formulas.txt"
MAX_ENTRIES = 10_000

_passed: set[str] | None = None
_new: set[str] = set()


def _key(text: str, variables: Sequence[str], parameters: Mapping[str, float], box) -> str:
    description = json.dumps(
        [text, list(variables), sorted(parameters.items()), [list(b) for b in box], code_version()]
    )
    return hashlib.sha256(description.encode()).hexdigest()


def _load() -> set[str]:
    global _passed
    if _passed is None:
        try:
            lines = read_text(cache_dir() / FILE).split()
            _passed = {line for line in lines if len(line) == 64}
        except ConfigError:
            _passed = set()
    return _passed


def check(
    text: str,
    variables: Sequence[str],
    parameters: Mapping[str, float],
    box: Sequence[tuple[float, float]],
) -> None:
    """check_expression on the box, unless this exact check has passed before."""
    key = _key(text, variables, parameters, box)
    passed = _load()
    if key in passed:
        return
    check_expression(text, variables, parameters, box=box)
    passed.add(key)
    _new.add(key)


def save() -> None:
    """Remember the new passes (best effort: a read-only disk only costs the checks again)."""
    if not _new:
        return
    kept = sorted(_load())[-MAX_ENTRIES:]
    try:
        folder = cache_dir()
        store(folder, folder / FILE, ("\n".join(kept) + "\n").encode())
        _new.clear()
    except (OSError, ValueError) as exc:
        log.warning("could not remember checked formulas: %s", exc)
