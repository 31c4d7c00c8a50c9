"""The HUD's words for a frame: title, caption, axis and key labels and the object tags, in the
language on screen (or one asked for: the warm-up lays out every language's panels)."""

from __future__ import annotations

from exhibit import scenes
from exhibit.kiosk.language import Translator
from exhibit.render.renderer import HudInfo


class HudWords:
    """``words(title, caption, scene, language, tags)`` -> the HudInfo the renderer draws."""

    def __init__(self, translate: Translator) -> None:
        self.translate = translate

    def __call__(
        self,
        title: str,
        caption: str,
        scene: str,
        language: str | None = None,
        tags: tuple[tuple[str, str], ...] = (),
    ) -> HudInfo:
        tr = self.translate
        return HudInfo(
            title=tr(title, language),
            caption=tr(caption, language),
            axes=scenes.get(scene).axes,
            axes_label=tr("4D axes", language),
            words=tr.hud_words(language),
            tags=tuple((name, tr(words, language)) for name, words in tags),
        )
