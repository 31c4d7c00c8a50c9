"""One kiosk frame as one value: what the kiosk asks a target to draw, built once a frame and
carried unchanged to the passes (exhibit.render.frame turns it into its list of passes).

The drawable's own facts (the framebuffer, its size) are the target's, not the request's: the
same request drawn on a window and offscreen is the same frame."""

from __future__ import annotations

from dataclasses import dataclass

from exhibit.geometry.view import ViewState
from exhibit.render.gpu import GpuMesh
from exhibit.render.hud_info import HudInfo
from exhibit.render.options import RenderOptions
from exhibit.render.quality import Quality


@dataclass(frozen=True)
class Inset:
    """The time-slice inset for one frame: a small scene (exhibit.render.inset), its view, where
    it goes (x, y, width, height in pixels from the top-left) and its label."""

    gpu: GpuMesh
    view: ViewState
    rect: tuple[float, float, float, float]
    label: str = ""


@dataclass(frozen=True)
class FrameRequest:
    """A frame: the mesh in a view with its options (``options.quality`` set: a whole kiosk
    frame at that level; None: a plain picture), the HUD's words (None: none), the opacity of
    the captured outgoing picture laid over it (``fade``, a crossfade) and the time-slice
    ``inset``."""

    gpu: GpuMesh
    view: ViewState
    options: RenderOptions = RenderOptions()
    hud: HudInfo | None = None
    fade: float = 0.0
    inset: Inset | None = None

    @property
    def quality(self) -> Quality | None:
        """The quality level a kiosk frame is drawn at (None: a plain picture)."""
        return self.options.quality

    @property
    def has_words(self) -> bool:
        """Whether the frame shows its HUD."""
        return self.options.hud and self.hud is not None
