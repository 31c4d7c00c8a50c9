"""Scene start views framed for the screen: KioskState's framer (a scene's start view, "home",
the pose a visitor takes over), fitted into the area the scene's own panels leave free."""

from __future__ import annotations

import logging
from collections import OrderedDict

from exhibit import scenes
from exhibit.geometry.framing import Sample, mesh_sample
from exhibit.geometry.view import ViewState
from exhibit.timelines.model import Params
from exhibit.framing.follow import MeshLookup
from exhibit.framing.timeline_framing import FILL_LIMIT
from exhibit.render.framer import Framer

log = logging.getLogger("exhibit.kiosk")

#: Framed views kept: every scene's start view and the poses visitors took over at lately.
FRAMED_CACHE = 64


class StartViews:
    """``views(name, params, view)`` -> the view framed by ``framer`` around ``content``'s mesh
    of the scene. A pose whose picture fills the world on purpose (the sensor inside the
    object: it would need FILL_LIMIT times the zoom to fit) keeps its zoom, as a framed
    timeline does. A scene not prepared yet is left as it is (KioskState.reframe frames it on
    arrival). Cached: the same few start views come back at every "home" and scene change."""

    def __init__(self, framer: Framer, content: MeshLookup) -> None:
        self.framer = framer
        self.content = content
        self._framed: OrderedDict[tuple, ViewState] = OrderedDict()
        self._samples: dict[tuple, Sample] = {}  # (scene, params) -> its mesh_sample

    def __call__(self, name: str, params: Params, view: ViewState) -> ViewState:
        key = (name, tuple(params), view)
        framed = self._framed.get(key)
        if framed is None:
            mesh = self.content.mesh(name, params)
            if mesh is None:
                return view
            framed = view
            try:
                points = self._samples.get(key[:2])
                if points is None:
                    points = self._samples[key[:2]] = mesh_sample(mesh)
                fitted = self.framer.scene_view(scenes.get(name), mesh, view, points=points)
                if fitted.half_height <= FILL_LIMIT * view.half_height:
                    framed = fitted
            except Exception as exc:  # noqa: BLE001 - the scene's own view will do
                log.warning("scene %s not framed: %s", name, exc)
            while len(self._framed) >= FRAMED_CACHE:
                self._framed.popitem(last=False)
            self._framed[key] = framed
        self._framed.move_to_end(key)
        return framed
