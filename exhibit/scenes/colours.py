"""Colours every visitor can tell apart: each pair of a scene's colours that carries meaning
(surfaces, curves, markers, wires: "the green doughnut" against the red one, the red offset curve
on the blue pipe) must stay at least LIMIT apart in CAM02-UCS ΔE under protanopia, deuteranopia
and tritanopia at full severity (Machado et al. 2009), as well as under normal vision. One man
in twelve sees colour differently; a ΔE of 5 is barely a difference, categorical palettes aim at
15-20 and more.

Surfaces are held to it as lit on screen, not only as their base colour: at full light and at
the mid-tone of lighting.glsl (base x (0.22 + 0.78 x 1/2)); a curve or marker lying on a surface
must stand out from both. Every pair of parts is compared, however close their colours: two
shades a little apart ([0.55, 0.4, 0.85] and [0.56, 0.4, 0.85]) are two objects no visitor tells
apart, a clash. Only exactly equal colours are one colour on purpose, and no pair: parts_of
makes them one part per kind, and clashes() skips a line and a surface of one colour. The shipped
scenes use that for the 4D axes, drawn in the gizmo's colours, two of which belong to objects of
another kind in Figures 6-8 (the x axis is the red doughnut's vermillion, the w axis the blue
fibre's blue): a straight thin line against a lit doughnut or a circle, named by its letter in
the gizmo and never by its colour, where the captions name the doughnuts and circles in words.

The simulation and the colour difference are colorspacious', not written here. Pure: the kiosk's
check-config and `exhibit scenes --check-colours` call it on a scene's mesh, and the tests on every
shipped scene and on the HUD's axis colours. Text contrast (WCAG's luminance and ratio) is read
with the same library here, for the HUD and its checks.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from collections.abc import Iterable, Sequence

import numpy as np
from numpy.typing import ArrayLike
from colorspacious import cspace_convert

from exhibit.scenes.base import Scene
from exhibit.surfaces.mesh import Mesh4D


#: The least ΔE (CAM02-UCS) between two parts of different colours, in every vision.
LIMIT = 15.0
#: How a lit surface looks at half light (lighting.glsl: 0.22 + 0.78 x diffuse).
MID_TONE = 0.22 + 0.78 * 0.5
#: The visions checked, with colorspacious' name for each deficiency (None: normal vision).
VISIONS = {
    "normal vision": None,
    "protanopia": "protanomaly",
    "deuteranopia": "deuteranomaly",
    "tritanopia": "tritanomaly",
}
#: Resolution at which a scene is built to read its colours (its materials, not its shape).
PROBE_RESOLUTION = 6


@dataclass(frozen=True)
class Part:
    """A coloured part of a scene: its name, "surface" (lit) or "line" (curves, wires,
    markers: drawn in their flat colour), and its RGB in [0, 1]."""

    name: str
    kind: str
    color: tuple[float, float, float]

    def tones(self) -> list[np.ndarray]:
        base = np.asarray(self.color, dtype=float)
        return [base, base * MID_TONE] if self.kind == "surface" else [base]


@dataclass(frozen=True)
class Clash:
    """Two parts whose colours fall under LIMIT for some vision."""

    a: Part
    b: Part
    delta_e: float
    vision: str

    def describe(self) -> str:
        def show(p: Part) -> str:
            return f"{p.name!r} {[round(c, 3) for c in p.color]}"

        return (
            f"{show(self.a)} and {show(self.b)} are ΔE {self.delta_e:.1f} apart under "
            f"{self.vision} (at least {LIMIT:g} is needed to tell them apart)"
        )


def luminance(rgb: ArrayLike) -> float | np.ndarray:
    """Relative luminance (WCAG 2.x) of sRGB colours (..., 3) in 0..1: CIE Y, as colorspacious
    computes it; a float for one colour."""
    rgb = np.clip(np.asarray(rgb, dtype=float)[..., :3], 0.0, 1.0)
    y = cspace_convert(rgb, "sRGB1", "XYZ1")[..., 1]
    return float(y) if np.ndim(y) == 0 else y


def contrast_ratio(a: ArrayLike, b: ArrayLike) -> float | np.ndarray:
    """WCAG contrast ratio between sRGB colours (either order, broadcast), 1..21."""
    la, lb = luminance(a), luminance(b)
    return (np.maximum(la, lb) + 0.05) / (np.minimum(la, lb) + 0.05)


def parts_of(mesh: Mesh4D) -> list[Part]:
    """The parts of a Mesh4D with a colour of their own: one per distinct colour and kind, in
    mesh order (the first part names it)."""
    found: dict[tuple, Part] = {}
    for s in mesh.surfaces:
        kind = "surface" if s.material.style == "solid" else "line"
        found.setdefault((kind, s.material.color), Part(s.name, kind, s.material.color))
    for c in mesh.curves:
        found.setdefault(("line", c.material.color), Part(c.name, "line", c.material.color))
    for m in mesh.markers:
        name = m.label.split(",")[0] if m.label else "marker"
        found.setdefault(("line", m.material.color), Part(name, "line", m.material.color))
    return list(found.values())


def _ucs(colors: np.ndarray, deficiency: str | None) -> np.ndarray:
    rgb = np.clip(colors, 0.0, 1.0)
    if deficiency is not None:
        cvd = {"name": "sRGB1+CVD", "cvd_type": deficiency, "severity": 100}
        rgb = np.clip(cspace_convert(rgb, cvd, "sRGB1"), 0.0, 1.0)
    return cspace_convert(rgb, "sRGB1", "CAM02-UCS")


def delta_e(a: Part, b: Part, vision: str = "normal vision") -> float:
    """The least ΔE between the two parts as seen with ``vision``: two surfaces compared at the
    same light, a line against a surface at every light."""
    deficiency = VISIONS[vision]
    ta, tb = a.tones(), b.tones()
    pairs = list(zip(ta, tb)) if a.kind == b.kind == "surface" else list(itertools.product(ta, tb))
    ua = _ucs(np.array([p for p, _ in pairs]), deficiency)
    ub = _ucs(np.array([q for _, q in pairs]), deficiency)
    return float(np.min(np.linalg.norm(ua - ub, axis=-1)))


def clashes(parts: Sequence[Part]) -> list[Clash]:
    """Every pair of parts of different colours (exactly equal ones are one colour on purpose)
    that some vision sees closer than LIMIT, at its worst vision."""
    out = []
    for a, b in itertools.combinations(parts, 2):
        if a.color == b.color:
            continue
        worst = min((delta_e(a, b, v), v) for v in VISIONS)
        if worst[0] < LIMIT:
            out.append(Clash(a, b, worst[0], worst[1]))
    return out


def least_delta_e(parts: Iterable[Part]) -> tuple[float, str]:
    """The smallest ΔE over every pair of different colours and every vision, with the vision:
    a palette's margin, for the docs and the tests."""
    best = (float("inf"), "")
    for a, b in itertools.combinations(list(parts), 2):
        if a.color != b.color:
            best = min(best, min((delta_e(a, b, v), v) for v in VISIONS))
    return best


def scene_parts(scene: Scene) -> list[Part]:
    """A scene's coloured parts, read from its mesh at PROBE_RESOLUTION at its default
    parameters."""
    return parts_of(scene.build(scene.resolve(), PROBE_RESOLUTION))


def scene_clashes(scene: Scene) -> list[Clash]:
    """The clashes of a scene's colours."""
    return clashes(scene_parts(scene))


def colour_problems(scene: Scene, parts: Sequence[Part] | None = None) -> list[str]:
    """The clashes of a scene (of ``parts``, when the caller has them) as ``where: colours:
    ...`` lines, where is the scene's file (a curator's TOML scene) or its name; a scene that
    cannot be built says so once."""
    where = str(scene.source) if scene.source is not None else f"scene {scene.name}"
    try:
        found = clashes(scene_parts(scene) if parts is None else parts)
    except Exception as exc:  # noqa: BLE001 - its build is reported where it is built
        return [f"{where}: colours: not checked, the scene cannot be built ({exc})"]
    return [f"{where}: colours: {c.describe()}" for c in found]
