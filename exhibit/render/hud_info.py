"""The words a frame's HUD shows, handed in with each frame (the kiosk's scenes and captions in
the language on screen); exhibit.render.hud lays them out and draws them."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class HudInfo:
    """Words for visitors; the numbers (angles, sensor distance) come from the ViewState."""

    title: str = ""
    caption: str = ""
    axes: tuple[str, str, str, str] = ("x", "y", "z", "w")
    #: Labels of the mesh's markers are drawn too; this is an extra line under the caption.
    note: str = ""
    #: The gizmo's label, in the language on screen (exhibit.kiosk.language).
    axes_label: str = "4D axes"
    #: The HUD's other words in the language on screen, (English, shown) pairs: the numbers
    #: panel's "sensor", "eye", "fov" and the words of marker labels ("first contact").
    #: A tuple, not a dict, so the HUD can key its caches by it.
    words: tuple[tuple[str, str], ...] = ()
    #: Objects the caption names, each tagged on screen with words in the language on screen
    #: (exhibit.render.object_tags): (object name or the start of names, words).
    tags: tuple[tuple[str, str], ...] = ()

    def word(self, english: str) -> str:
        """``english`` in the language on screen (itself when there is no translation)."""
        return dict(self.words).get(english, english)
