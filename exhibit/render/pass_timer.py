"""Per-pass times of a frame, on frames asked to be measured (PassTimer.measure_next_frame):
what each pass of the picture, the composites and the HUD cost, for `exhibit bench kiosk
--breakdown`, the governor and a technician.

Two ways to measure, chosen once per context:

* "gpu": a GL_TIME_ELAPSED query around each pass (``ctx.query(time=True)``), read LATENCY
  frames later, when it is long done, so reading never stalls the pipeline.
* "wall": on software GL, where the "GPU" is the same CPU cores (llvmpipe accepts timer queries
  but they time only the command submission, not the rasterisation it defers to its threads: a
  pass of many full-screen triangles reads a small fraction of its wall time), and where a
  query cannot be made: ctx.finish() at each pass boundary and the wall time between them. The
  finishes cost the measured frame some overlap, so only measured frames pay them.

Frames not asked to be measured pay one attribute check per pass. Sections nest by being
ignored: while one is open (e.g. the time-slice inset, itself a whole small frame) the passes
inside it are part of it, and a frame begun inside a frame is part of that frame.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager, nullcontext
from dataclasses import dataclass, field

import moderngl

from exhibit.render.quality import software_renderer


@dataclass(frozen=True)
class PassTimes:
    """One measured frame: milliseconds per pass in the order they ran (a pass that ran twice,
    e.g. FXAA then the upscale composite, adds up), and the frame's total (wall mode: from the
    frame's start to its finish, so it includes the CPU work between passes; gpu mode: the sum
    of the passes)."""

    passes: dict[str, float] = field(default_factory=dict)
    total_ms: float = 0.0
    mode: str = "wall"

    @property
    def other_ms(self) -> float:
        """What the frame cost outside its passes (wall mode: the CPU work between them)."""
        return max(0.0, self.total_ms - sum(self.passes.values()))

    def share(self, name: str) -> float:
        """The pass's share of the frame (0..1)."""
        return self.passes.get(name, 0.0) / self.total_ms if self.total_ms > 0 else 0.0


class PassTimer:
    """Times the sections (passes) of measured frames; ``latest`` is the newest result."""

    LATENCY = 2

    def __init__(
        self,
        ctx: moderngl.Context,
        clock: Callable[[], float] = time.perf_counter,
        wall: bool | None = None,
    ) -> None:
        self.ctx = ctx
        self.clock = clock
        if wall is None:
            wall = software_renderer(ctx.info.get("GL_RENDERER", ""))
        self.mode = "wall" if wall else "gpu"
        #: The newest measured frame's times (None before the first is read).
        self.latest: PassTimes | None = None
        self._asked = False
        self._depth = 0  # frames begun and not ended (a frame inside a frame is part of it)
        self._measuring = False
        self._open = False  # a section is open: sections inside it are part of it
        self._frame = 0
        self._start = 0.0
        self._walls: dict[str, float] = {}
        self._queries: list[tuple[str, moderngl.Query]] = []
        self._pending: deque[tuple[int, list[tuple[str, moderngl.Query]]]] = deque()
        self._free: list[moderngl.Query] = []

    def measure_next_frame(self) -> None:
        """Time the passes of the next frame begun."""
        self._asked = True

    @property
    def measuring(self) -> bool:
        return self._measuring

    def begin_frame(self) -> None:
        self._depth += 1
        if self._depth > 1:
            return
        self._frame += 1
        if self._pending and self._pending[0][0] <= self._frame - self.LATENCY:
            self._read(self._pending.popleft()[1])
        if not self._asked:
            return
        self._asked, self._measuring = False, True
        self._walls, self._queries = {}, []
        if self.mode == "wall":
            self.ctx.finish()
            self._start = self.clock()

    def end_frame(self) -> None:
        self._depth = max(0, self._depth - 1)
        if self._depth or not self._measuring:
            return
        self._measuring = False
        if self.mode == "wall":
            self.ctx.finish()
            total = (self.clock() - self._start) * 1000.0
            self.latest = PassTimes(dict(self._walls), total, "wall")
        else:
            self._pending.append((self._frame, self._queries))

    def section(self, name: str) -> AbstractContextManager[None]:
        """Time what runs inside as the pass ``name`` (nothing on an unmeasured frame)."""
        if not self._measuring or self._open:
            return nullcontext()
        return self._timed(name)

    @contextmanager
    def _timed(self, name: str) -> Iterator[None]:
        self._open = True
        try:
            if self.mode == "gpu":
                try:
                    query = self._free.pop() if self._free else self.ctx.query(time=True)
                except Exception:  # noqa: BLE001 - no timer queries here: measure wall time
                    self.mode = "wall"
                    self._start = self.clock()
                else:
                    with query:
                        yield
                    self._queries.append((name, query))
                    return
            self.ctx.finish()
            start = self.clock()
            yield
            self.ctx.finish()
            self._walls[name] = self._walls.get(name, 0.0) + (self.clock() - start) * 1000.0
        finally:
            self._open = False

    def flush(self) -> PassTimes | None:
        """Read every measured frame's queries now (waits for the GPU; benchmarks and tests)."""
        while self._pending:
            self._read(self._pending.popleft()[1])
        return self.latest

    def _read(self, queries: list[tuple[str, moderngl.Query]]) -> None:
        passes: dict[str, float] = {}
        for name, query in queries:
            passes[name] = passes.get(name, 0.0) + query.elapsed / 1e6
            self._free.append(query)
        self.latest = PassTimes(passes, sum(passes.values()), "gpu")

    def release(self) -> None:
        # moderngl queries have no release(); they go with their context.
        self._pending.clear()
        self._free.clear()
