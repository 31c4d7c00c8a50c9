"""The time-slice inset of a running kiosk: while a timeline slices a scene that has a 3D world
at each moment (the collision's pipe and ball, with their touching curve in closed form), that
world drawn in the corner the timeline's framing keeps free (exhibit.render.inset)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from exhibit import scenes
from exhibit.geometry.framing import mesh_points
from exhibit.render.frame import Inset
from exhibit.render.inset import inset_label, inset_view
from exhibit.kiosk.state import Frame
from exhibit.render.layout import Rect
from exhibit.surfaces.mesh import Mesh4D


class SliceInset:
    """The inset's world, rebuilt and uploaded (``upload``) whenever the moment changes (about
    1 ms), and its view, framed once per camera."""

    def __init__(self, rect: Rect, upload: Callable):
        self.rect = rect
        self.upload = upload
        self._mesh: tuple | None = None  # (key, gpu mesh)
        self._view: tuple | None = None  # (key, view)

    def for_frame(self, frame: Frame, mesh: Mesh4D | None) -> Inset | None:
        """The inset for ``frame`` (``mesh``: the 4D scene's, for its extent in time), or None
        when the frame does not slice such a scene."""
        view = frame.view
        scene = scenes.get(frame.scene)
        if view.slice_axis is None or scene.world_at is None or scene.slice_axis != view.slice_axis:
            return None
        # The exact moment: next to a tangency the world changes within 1e-6 (Figure 15 at
        # t = 0 touches all round the pipe, at t = 1e-6 only below its axis).
        key = (frame.scene, frame.params, view.slice_at)
        if self._mesh is None or self._mesh[0] != key:
            world = scene.world_at(dict(frame.params), view.slice_at)
            if self._mesh is not None:
                self._mesh[1].release()
            self._mesh = (key, self.upload(world))
        r = self.rect
        size = (int(r.width), int(r.height))
        label = inset_label(scene.axes[view.slice_axis], view.slice_at)
        return Inset(
            self._mesh[1],
            self._framed(frame, scene, mesh, size),
            (r.x0, r.y0, r.width, r.height),
            label,
        )

    def _framed(self, frame, scene, mesh, size):
        """Framed once for the worlds of the moments at the ends and middle of the scene's
        extent along its time axis, so the frame holds still as time moves."""
        view = frame.view
        key = (
            frame.scene,
            frame.params,
            view.eye_azimuth,
            view.eye_incidence,
            view.twist,
            view.eye_r,
        )
        if self._view is None or self._view[0] != key:
            low, high = mesh.bounds() if mesh is not None else (np.full(4, -1.0), np.full(4, 1.0))
            axis = view.slice_axis
            moments = (low[axis], 0.5 * (low[axis] + high[axis]), high[axis])
            points = np.concatenate(
                [mesh_points(scene.world_at(dict(frame.params), c)) for c in moments]
            )
            self._view = (key, inset_view(view, points, size))
        return self._view[1]

    def release(self) -> None:
        if self._mesh is not None:
            self._mesh[1].release()
        self._mesh = None
