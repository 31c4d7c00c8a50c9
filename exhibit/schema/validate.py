"""pydantic models in, ``file: key: reason`` lines out: every problem of a file at once."""

from __future__ import annotations

import os
import typing
from collections.abc import Callable

from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

from exhibit.errors import ConfigError
from exhibit.schema.types import shorten

#: Where a problem is said to be: a file name, or a function from an error's location to the
#: file that holds that key (layered configs).
Source = str | os.PathLike[str] | Callable[[tuple[int | str, ...]], str | os.PathLike[str]]

M = TypeVar("M", bound=BaseModel)

_PLAIN = {
    "missing": "missing",
    "bool_type": "must be true or false",
    "string_type": "must be a string",
    "list_type": "must be a list",
    "dict_type": "must be a table",
    "model_type": "must be a table",
    "model_attributes_type": "must be a table",
    "int_type": "must be a whole number",
    "float_type": "must be a number",
}


def where(loc: tuple) -> str:
    """('mapping', 'bind', 3, 'param') -> 'mapping.bind[3].param'."""
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def _allowed(model: type[BaseModel], loc: tuple) -> list[str] | None:
    """The keys a table at ``loc`` may have, found by walking the model's annotations."""
    current: Any = model
    for part in loc:
        if isinstance(current, type) and issubclass(current, BaseModel):
            field = _fields(current).get(str(part))
            if field is None:
                return None
            current = field.annotation
            continue
        args = [a for a in typing.get_args(current) if a is not type(None)]
        if not args:
            return None
        current = args[-1]  # list[X], dict[str, X], X | None -> X
        if isinstance(current, type) and issubclass(current, BaseModel):
            continue
    while not (isinstance(current, type) and issubclass(current, BaseModel)):
        args = [a for a in typing.get_args(current) if a is not type(None)]
        if not args:
            return None
        current = args[-1]
    return sorted(_fields(current))


def _fields(model: type[BaseModel]) -> dict:
    """A model's fields by the key written in the file (a field named ``while_`` is written
    ``while``, a Python keyword)."""
    return {field.alias or name: field for name, field in model.model_fields.items()}


def problems(exc: ValidationError, source: Source, model: type[BaseModel]) -> list[str]:
    """One ``file: key: reason`` line per error; ``source`` is a file name, or a function from
    an error's location to the file that holds that key (layered configs)."""
    out = []
    for error in exc.errors(include_url=False):
        loc, kind = tuple(error["loc"]), error["type"]
        if kind == "extra_forbidden":
            allowed = _allowed(model, loc[:-1])
            reason = "unknown key" + (f" (allowed: {', '.join(allowed)})" if allowed else "")
        elif kind in _PLAIN:
            reason = _PLAIN[kind] + (
                "" if kind == "missing" else f", got {shorten(error['input'])}"
            )
        elif kind in ("too_short", "too_long"):
            reason = (
                f"must have {error['ctx'].get('min_length', error['ctx'].get('max_length'))}"
                f" items, got {error['ctx'].get('actual_length')}"
            )
        elif kind == "literal_error":
            reason = f"must be {error['ctx']['expected']}, got {shorten(error['input'])}"
        elif kind == "value_error":
            reason = str(error["ctx"]["error"])
        else:
            reason = error["msg"]
        key = where(loc)
        file = source(loc) if callable(source) else source
        out.append(f"{file}: {key}: {reason}" if key else f"{file}: {reason}")
    return out


def validate(model: type[M], data: Any, source: Source, context: dict | None = None) -> M:
    """``model`` from parsed data; ConfigError lists every problem as ``source: key: reason``
    (``source`` as for :func:`problems`)."""
    try:
        return model.model_validate(data, context=context)
    except ValidationError as exc:
        raise ConfigError(
            problems(exc, source if callable(source) else str(source), model)
        ) from None
