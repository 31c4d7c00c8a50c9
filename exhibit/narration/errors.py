"""The one error narration raises, in its own module so every other module can import it without
importing the package (whose __init__ imports them all)."""

from __future__ import annotations

from exhibit.errors import ExhibitError


class NarrationError(ExhibitError):
    """Narration that cannot be made: a recording refused, a text that cannot be spoken, no
    speech engine. The message names the file or text and what was wrong, on one line."""
