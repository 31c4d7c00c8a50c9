"""Render passes as units: each owns its programs, vertex arrays and GL state and says what it
reads and writes (docs/RENDERING.md). The object-id pass is the first; the picture's own passes
still live in exhibit.render.renderer."""

from exhibit.render.passes.ids import ObjectCoverage, ObjectIdPass

__all__ = ["ObjectCoverage", "ObjectIdPass"]
