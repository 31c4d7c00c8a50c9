"""How a name a curator writes (a label's object, a claim's object) stands for objects of the
scene: the one rule, used by the tags on screen (exhibit.render.object_tags), the claims
(exhibit.timelines.claims.base.matching) and check-config.

A name stands for the object of exactly that name, and for its pieces: a traced curve drawn in
pieces is named "NAME", "NAME 2", "NAME 3", ... (a space and a whole number written in 0-9,
e.g. "silhouette along x and y 7"; the wire cylinder's "wire pipe 2" .. "wire pipe 19" are
pieces of "wire pipe"). Nothing else: "torus" is no torus, so a name that is a mistake
finds nothing rather than the wrong objects, and check-config says so.

A scene lists its objects' names (exhibit.scenes.base.Scene.objects, with the marks the
renderer draws live, MARKS) and the short names a curator may write for them (Scene.aliases:
"offset curve" for "offset curve (silhouette along u, v)"). Aliases are resolved when a
timeline or a scene is loaded (:func:`resolve`), so at run time a name is only ever matched
exactly or as pieces (:func:`matching`). Pure: no files, no GL.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence

#: The marks the renderer finds live and draws after the mesh's own objects (the Lemma 3
#: outlines, the Lemma 2 points' discs, the glowing slice): every scene has them. The same as
#: exhibit.render.passes.ids.MARKS (a test holds them together; this layer cannot import it).
MARKS = ("outline", "pinch points", "slice")

#: "NAME N": a piece of NAME (N in ASCII digits: "x²" is no piece number).
_PIECE = re.compile(r"^(.+) ([0-9]+)$")


def object_of(drawn: str, objects: Sequence[str]) -> str | None:
    """The object of ``objects`` that the drawn object ``drawn`` is (its own name) or a piece
    of; None when it is none of them."""
    if drawn in objects:
        return drawn
    found = _PIECE.match(drawn)
    return found.group(1) if found and found.group(1) in objects else None


def stands_for(name: str, drawn: str) -> bool:
    """Whether ``name`` stands for the drawn object ``drawn``: the same name, or ``drawn`` is
    one of its pieces ("NAME 2", "NAME 3", ...)."""
    if drawn == name:
        return True
    found = _PIECE.match(drawn)
    return found is not None and found.group(1) == name


def matching(name: str, objects: Iterable[str]) -> list[str]:
    """The objects ``name`` stands for, each once, in their order."""
    return [o for o in dict.fromkeys(objects) if stands_for(name, o)]


def resolve(name: str, aliases: Mapping[str, str]) -> str:
    """The object's name for what a curator wrote: an alias's object, else the name as
    written."""
    return aliases.get(name, name)


def known(name: str, objects: Sequence[str]) -> bool:
    """Whether ``name`` (aliases resolved) names one of a scene's ``objects`` (base names)."""
    return name in objects


def listing(objects: Sequence[str], aliases: Mapping[str, str]) -> str:
    """The names a curator may write, for a problem line: the objects, then the aliases."""
    out = ", ".join(f'"{o}"' for o in objects) or "none"
    if aliases:
        out += "; aliases " + ", ".join(f'"{a}" ({o})' for a, o in aliases.items())
    return out


def unknown_line(head: str, name: str, objects: Sequence[str], aliases: Mapping[str, str]) -> str:
    """check-config's line for a name that is no object: ``head: no object "NAME"; objects
    are ...``."""
    return f'{head}: no object "{name}"; objects are {listing(objects, aliases)}'
