"""What the running kiosk tells the world about once a second: the systemd STATUS line
(`systemctl status exhibit`) and the health file (exhibit.operations.health's schema), which
`exhibit status`, the Prometheus textfile and the watchdog's humans read: besides the frames,
devices and problems, when the last frame was drawn, which version and release run, and the
state folder (full, read-only, not writable) with the errno of each write there that failed
(exhibit.operations.storage), named among the problems too."""

from __future__ import annotations

import logging
import os
import resource
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from exhibit.kiosk.frame_errors import FrameErrors, FrameStats
from exhibit.operations import journal, storage
from exhibit.operations.notify import Notifier

if TYPE_CHECKING:
    from exhibit.kiosk.governor import Governor
    from exhibit.preparing.held import OnScreen
    from exhibit.operations.sessions import SessionLog
    from exhibit.kiosk.state import KioskState

log = logging.getLogger("exhibit.kiosk")


def rss_kb() -> int:
    """The process's resident memory now (kB), else its peak where /proc is not there."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * (os.sysconf("SC_PAGE_SIZE") // 1024)
    except OSError:
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss


def fd_count() -> int:
    """Open file descriptors (-1 where /proc is not there): a leak shows here first."""
    try:
        return len(os.listdir("/proc/self/fd"))
    except OSError:
        return -1


def _round(seconds: float | None) -> float | None:
    return None if seconds is None else round(seconds, 1)


class Reporter:
    """Writes the reports; ``notifier`` (systemd) and ``health_path`` may each be None."""

    def __init__(self, notifier: Notifier | None, health_path: Path | None, started: float):
        self.notifier = notifier
        self.health_path = health_path
        self.started = started
        self._since = started
        #: Resolved now, at the start: an update switches /opt/exhibit before the restart.
        self.build = storage.build_info()
        #: Frames counted at the last report, and when (unix seconds) a report last saw more.
        self._frames_seen = 0
        self.last_frame: float | None = None

    def report(
        self,
        now: float,
        *,
        stats: FrameStats,
        frames: int,
        errors: FrameErrors,
        devices: list[dict],
        state: KioskState | None,
        problems: list[str],
        scenes_failed: list[dict],
        language: str,
        sessions: SessionLog | None,
        governor: Governor,
        narration: dict | None = None,
        frame_passes: dict | None = None,
        screen: OnScreen | None = None,
    ) -> None:
        """The frame times since the last report (``stats`` is emptied), the devices' states
        and seconds missing, what is on screen (``screen``; None: the state's scene) and being
        prepared, and every problem, the frames' failing too."""
        count = len(stats.times)
        elapsed = now - self._since
        fps = count / elapsed if elapsed > 0 else 0.0
        p95 = float(np.percentile(stats.times, 95)) * 1000 if stats.times else 0.0
        stats.times.clear()
        self._since = now
        # Per device: its state, seconds in it, and seconds it has been missing (null when
        # connected), for `exhibit status --max-lost` and the metrics (exhibit.operations.health).
        rows = [
            {
                "name": s.get("name", ""),
                "url": s.get("url", ""),
                "state": s.get("state", ""),
                "state_s": _round(s.get("state_s")),
                "missing_s": _round(s.get("missing_s")),
            }
            for s in devices
        ]
        mode = scene = preparing = waiting_s = None
        if state is not None:
            mode, scene = state.mode, state.frame.scene
            if screen is not None:
                scene, preparing, waiting_s = screen.scene, screen.preparing, screen.waiting_s
        wall = time.time()
        if frames > self._frames_seen:
            self._frames_seen, self.last_frame = frames, wall
        problems = list(problems)
        disk = self._storage(sessions)  # its own key, not a line in "problems"
        if errors.failing_since is not None:
            problems.append(
                f"frames failing for {now - errors.failing_since:.0f} s (see the journal)"
            )
        if self.notifier is not None:
            states = ", ".join(f"{d['url']} {d['state']}" for d in rows)
            what = f"{mode}, {scene}" if state is not None else "notice (no scene)"
            what += f", preparing {preparing}" if preparing is not None else ""
            self.notifier.status(
                f"{fps:.0f} fps, {what}; {states}"
                + (f"; {len(problems)} problems" if problems else "")
            )
        if self.health_path is None:
            return
        from exhibit.operations.health import process_uptime, report, write_health

        # Since the process started (imports, window, first meshes included), not since the
        # kiosk was built: that missed the whole start-up.
        uptime = process_uptime()
        try:
            write_health(
                self.health_path,
                report(
                    **{
                        "time": wall,
                        "pid": os.getpid(),
                        "last_frame": self.last_frame,
                        **self.build,
                        "storage": disk,
                        "fps": round(fps, 1),
                        "frame_ms_p95": round(p95, 2),
                        "mode": mode,
                        "scene": scene,
                        "preparing": preparing,
                        "waiting_s": _round(waiting_s),
                        "devices": rows,
                        "uptime_s": round(now - self.started if uptime is None else uptime, 1),
                        "gl_errors": stats.gl_errors,
                        "rss_kb": rss_kb(),
                        "fds": fd_count(),
                        "frames": frames,
                        "frame_errors": errors.total,
                        "problems": problems,
                        "scenes_failed": scenes_failed,
                        "language": language,
                        **(sessions.health() if sessions is not None else {}),
                        **governor.health(),  # quality level, frame_ms, target_ms
                        **({"narration": narration} if narration is not None else {}),
                        **({"frame_passes": frame_passes} if frame_passes is not None else {}),
                    }
                ),
            )
        except (OSError, TypeError) as exc:
            log.warning("cannot write the health file %s: %s", self.health_path, exc)

    def _storage(self, sessions: SessionLog | None) -> dict | None:
        """The state folder (the health file's) now, with the errno of each other writer's
        last failed write: the session log's and the journal's."""
        if self.health_path is None:
            return None
        out = storage.check_folder(self.health_path.parent)
        failed = {}
        if sessions is not None:
            state = sessions.health().get("sessions")
            if isinstance(state, dict) and state.get("errno"):
                failed["sessions"] = str(state["errno"])
        sent = journal.last_errno()
        if sent is not None:
            failed["journal"] = sent
        out["errors"] = failed
        return out
