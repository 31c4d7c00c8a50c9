"""Quality levels of a kiosk frame: what the frame governor (exhibit.kiosk.governor) steps down
and back up to hold its frame time, and what kiosk.toml's [quality] section can pin.

A level sets four things (antialiasing, mesh, effects, render scale), and the ladder gives them
up in this order, cheapest loss first (the antialiasing twice: MSAA for FXAA, later the FXAA pass
itself):

1. antialiasing: "msaa" (multisampling; cheap on real GPUs, costly on software GL), "fxaa" (one
   post-process pass, exhibit/render/shaders/composite.glsl), or "none";
2. mesh: the mesh resolution per scene, as a factor of the configured one (MESH_FACTORS);
3. effects: "full", or "lean" (no intersection curves, whose sheet buffer and passes are the
   costly effect on software GL; everything else stays, as dropping it saved nothing);
4. the antialiasing pass: "direct" draws the lean picture straight to the screen (the live
   silhouettes' antialiased lines ink every outline, so it hardly shows);
5. scale: the render scale of the 3D picture, upscaled bilinearly (the HUD stays at full
   resolution). On software GL the upscaling costs about what the smaller picture saves, so the
   kiosk leaves these levels out there (exhibit.kiosk.governor.kiosk_levels).

What each level costs and shows, measured: docs/PERFORMANCE.md, "Kiosk frames".
"""

from __future__ import annotations

from dataclasses import dataclass, replace

ANTIALIASING = ("msaa", "fxaa", "none")
EFFECTS = ("full", "lean")
#: Mesh levels: factors on each scene's configured resolution (level 0 = as configured).
MESH_FACTORS = (1.0, 0.75, 0.5)
#: Render scales the ladder uses (any value in [SCALE_MIN, 1] can be pinned).
SCALES = (1.0, 0.75, 0.5)
SCALE_MIN = 0.25


@dataclass(frozen=True)
class Quality:
    name: str
    antialiasing: str = "fxaa"
    mesh: int = 0
    effects: str = "full"
    scale: float = 1.0

    def __post_init__(self) -> None:
        if self.antialiasing not in ANTIALIASING:
            raise ValueError(f"antialiasing must be one of {ANTIALIASING}")
        if self.effects not in EFFECTS:
            raise ValueError(f"effects must be one of {EFFECTS}")
        if not 0 <= self.mesh < len(MESH_FACTORS):
            raise ValueError(f"mesh must be a level in [0, {len(MESH_FACTORS) - 1}]")
        if not SCALE_MIN <= self.scale <= 1.0:
            raise ValueError(f"scale must lie in [{SCALE_MIN}, 1]")

    @property
    def settings(self) -> tuple:
        return (self.antialiasing, self.mesh, self.effects, self.scale)

    @property
    def intersections(self) -> bool:
        """Whether this level draws the intersection curves (RenderOptions.at_quality)."""
        return self.effects == "full"

    def describe(self) -> str:
        return (
            f"{self.name}: {self.antialiasing}, mesh x{MESH_FACTORS[self.mesh]:g}, "
            f"{self.effects} effects, scale {self.scale:g}"
        )


#: The governor's ladder, best first. Each step gives up one thing, in the module's order.
LADDER = (
    Quality("msaa", "msaa", 0, "full", 1.0),
    Quality("fxaa", "fxaa", 0, "full", 1.0),
    Quality("mesh-75", "fxaa", 1, "full", 1.0),
    Quality("mesh-50", "fxaa", 2, "full", 1.0),
    Quality("lean", "fxaa", 2, "lean", 1.0),
    Quality("direct", "none", 2, "lean", 1.0),
    Quality("scale-75", "none", 2, "lean", 0.75),
    Quality("scale-50", "none", 2, "lean", 0.5),
)
LEVEL_NAMES = tuple(q.name for q in LADDER)


def ladder(
    antialiasing: str | None = None,
    mesh: int | None = None,
    effects: str | None = None,
    scale: float | None = None,
    levels: tuple[Quality, ...] = LADDER,
) -> tuple[Quality, ...]:
    """The ladder with some settings pinned (None: the governor's choice): every level takes
    the pinned values, and levels that became the same as the one before are dropped."""
    out: list[Quality] = []
    for q in levels:
        pinned = replace(
            q,
            antialiasing=antialiasing or q.antialiasing,
            mesh=q.mesh if mesh is None else mesh,
            effects=effects or q.effects,
            scale=q.scale if scale is None else scale,
        )
        if not out or out[-1].settings != pinned.settings:
            out.append(pinned)
    return tuple(out)


def mesh_resolution(resolution: int, level: int, minimum: int = 4) -> int:
    """A scene's mesh resolution at a mesh level (never below the schema's minimum)."""
    return max(minimum, int(round(resolution * MESH_FACTORS[level])))


def software_renderer(renderer: str) -> bool:
    """Whether a GL_RENDERER string names a software rasteriser (Mesa's llvmpipe, softpipe,
    swrast, SwiftShader, Microsoft's GDI/WARP): there, multisampling costs a full-screen resolve
    and the post-process antialiasing is the better deal."""
    text = renderer.lower()
    return any(
        word in text
        for word in (
            "llvmpipe",
            "softpipe",
            "swrast",
            "swiftshader",
            "software",
            "gdi generic",
            "basic render",
        )
    )
