"""The kiosk's health as Prometheus metrics, for node_exporter's textfile collector.

`exhibit status --prometheus FILE` renders the health file (exhibit.operations.health.Health) in the
Prometheus text exposition format (version 0.0.4) with prometheus_client, in a registry of its
own, and writes it atomically (exhibit.schema.files.write_atomic), so a museum that already
runs node_exporter on its machines watches every kiosk with the Prometheus it has: no new
server, no open port on the kiosk. Run every 15 s by exhibit-metrics.timer.

The file is written whatever the health file says, because an alert needs a value to fire on:
``exhibit_up`` is 1 only while the kiosk draws frames (a fresh file whose "last_frame" is
recent: exhibit.operations.assessment), and ``exhibit_health`` says which status holds
(``{status="missing"} 1``; "not_drawing": fresh but no frame drawn; "unwritable": the file is
old but its process runs and its state folder is full or read-only), with no free-text reason
(a label whose value changes with every message would make a new time series each time). The
kiosk's own numbers (frame rate, mode, devices...) are only written from a fresh file: a dead
kiosk's last frame rate is not a current one. ``exhibit_build_info{version,release}`` names the
code the kiosk runs (while its process does), and ``exhibit_state_folder_problem{problem}`` and
``exhibit_state_folder_free_bytes`` its state folder (from the kiosk's file, else as
`exhibit status` sees the folder).

Label values come from the health file (device names and URLs from the config, scene names) and
are made safe: control and invisible characters are removed and the value is cut to
MAX_LABEL_CHARS; prometheus_client escapes backslash, double quote and line feed as the format
requires.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from typing import TypeGuard

from prometheus_client import CollectorRegistry, generate_latest
from prometheus_client.core import CounterMetricFamily, GaugeMetricFamily

from exhibit.devices.base import State
from exhibit.operations.health import MODES, Health, as_health, device_label
from exhibit.operations.storage import PROBLEMS
from exhibit.schema.files import check_target, write_atomic

__all__ = ["HEALTH_STATUSES", "FAMILIES", "registry", "render", "write_metrics", "escape_label"]

#: exhibit_health's status label: fresh and drawing, too old (or its process gone), no file,
#: unreadable, fresh but no frame drawn, old while its process runs on a full or read-only disk.
HEALTH_STATUSES = ("ok", "stale", "missing", "broken", "not_drawing", "unwritable")
#: exhibit_state_folder_problem's label.
FOLDER_PROBLEMS = tuple(dict.fromkeys(PROBLEMS.values()))
#: The statuses in which the kiosk's process is known to run.
ALIVE = ("ok", "not_drawing", "unwritable")
#: exhibit_mode's label: the two modes, and "notice" when no scene could be prepared.
MODE_LABELS = (*MODES, "notice")
MAX_LABEL_CHARS = 200
#: At most this many devices are written (a config has a handful; a corrupt file could have more).
MAX_DEVICES = 64
#: At most this many render passes become series (a damaged file may list thousands).
MAX_PASSES = 16

#: name -> (type, help), in the order they are written.
FAMILIES = {
    "exhibit_up": (
        "gauge",
        "1 while the kiosk draws frames (a fresh health file with a recent last frame), else 0",
    ),
    "exhibit_health": (
        "gauge",
        "The health file's status: 1 for the one that holds (ok, stale, missing, broken, "
        "not_drawing, unwritable)",
    ),
    "exhibit_build_info": ("gauge", "The version and release the kiosk runs, as labels"),
    "exhibit_state_folder_problem": (
        "gauge",
        "1 for the kiosk state folder's problem that holds (full, read-only, not writable)",
    ),
    "exhibit_state_folder_free_bytes": (
        "gauge",
        "Free space in the kiosk's state folder for its user",
    ),
    "exhibit_last_frame_timestamp_seconds": (
        "gauge",
        "When the kiosk last drew a frame (unix time)",
    ),
    "exhibit_health_age_seconds": ("gauge", "Seconds since the kiosk last wrote its health file"),
    "exhibit_last_update_timestamp_seconds": (
        "gauge",
        "When the kiosk last wrote its health file (unix time)",
    ),
    "exhibit_fps": ("gauge", "Frames drawn per second over the last second"),
    "exhibit_frame_time_p95_seconds": (
        "gauge",
        "95th percentile of the frame time over the last second",
    ),
    "exhibit_mode": (
        "gauge",
        "1 for the kiosk's mode (attract, visitor; notice: no scene could be prepared)",
    ),
    "exhibit_scene_info": ("gauge", "The scene on screen, as its label"),
    "exhibit_device_state": (
        "gauge",
        "1 for each configured device's state (waiting: never "
        "connected since the start; lost: connected, then gone)",
    ),
    "exhibit_device_state_seconds": ("gauge", "Seconds each device has been in its state"),
    "exhibit_device_missing_seconds": (
        "gauge",
        "Seconds since each device was last connected "
        "(since the start if never); 0 while connected",
    ),
    "exhibit_uptime_seconds": ("gauge", "Seconds since the kiosk process started"),
    "exhibit_frames_total": ("counter", "Frames drawn since the kiosk started"),
    "exhibit_frame_errors_total": (
        "counter",
        "Frames that raised an error since the kiosk started",
    ),
    "exhibit_gl_errors_total": ("counter", "OpenGL errors since the kiosk started"),
    "exhibit_scenes_failed": ("gauge", "Scenes skipped because they could not be prepared"),
    "exhibit_problems": ("gauge", "Problems the kiosk reports for people (see exhibit status)"),
    "exhibit_resident_memory_bytes": ("gauge", "Resident memory of the kiosk process"),
    "exhibit_open_fds": ("gauge", "Open file descriptors of the kiosk process"),
    "exhibit_frame_pass_seconds": (
        "gauge",
        "One measured kiosk frame's time per render pass (the health file's frame_passes)",
    ),
}


def registry(
    data: Health | Mapping | None,
    status: str,
    age: float | None = None,
    folder: Mapping | None = None,
) -> CollectorRegistry:
    """A registry of its own holding the metrics for health ``data`` (read with read_health;
    None when there is none), its ``status`` (one of HEALTH_STATUSES), ``age`` in seconds
    (None if unknown) and the state ``folder``'s {"problem", "free_bytes"} (None: not known)."""
    if status not in HEALTH_STATUSES:
        raise ValueError(f"status must be one of {HEALTH_STATUSES}, got {status!r}")
    health = None if data is None else as_health(data)
    samples: dict[str, list[tuple[dict, float]]] = {name: [] for name in FAMILIES}

    def add(name, value, **labels):
        if _is_number(value):
            samples[name].append((labels, value))

    add("exhibit_up", int(status == "ok"))
    for s in HEALTH_STATUSES:
        add("exhibit_health", int(s == status), status=s)
    if health is not None:
        if age is not None:
            add("exhibit_health_age_seconds", round(max(age, 0.0), 3))
        add("exhibit_last_update_timestamp_seconds", health.time)
    if health is not None and status in ALIVE:
        if health.version is not None or health.release is not None:
            add(
                "exhibit_build_info",
                1,
                version=str(health.version or ""),
                release=str(health.release or ""),
            )
        add("exhibit_last_frame_timestamp_seconds", health.last_frame)
    if folder is not None:
        problem = folder.get("problem")
        for p in FOLDER_PROBLEMS:
            add("exhibit_state_folder_problem", int(p == problem), problem=p)
        add("exhibit_state_folder_free_bytes", folder.get("free_bytes"))
    if health is not None and status in ("ok", "not_drawing"):
        _kiosk(health, add)
    out = CollectorRegistry(auto_describe=False)
    out.register(_Samples(samples))
    return out


class _Samples:
    """A prometheus_client collector of fixed samples: the families that have any, in the order
    of FAMILIES."""

    def __init__(self, samples: dict[str, list[tuple[dict, float]]]):
        self.samples = samples

    def collect(self):
        for name, (kind, text) in FAMILIES.items():
            rows = self.samples[name]
            if not rows:
                continue
            labels = list(rows[0][0])
            family = (CounterMetricFamily if kind == "counter" else GaugeMetricFamily)(
                name, text, labels=labels
            )
            for row_labels, value in rows:
                family.add_metric([_clean(row_labels[k]) for k in labels], value)
            yield family


def render(
    data: Health | Mapping | None,
    status: str,
    age: float | None = None,
    folder: Mapping | None = None,
) -> str:
    """The metrics text (registry(), as prometheus_client writes it)."""
    return generate_latest(registry(data, status, age, folder)).decode("utf-8")


def _kiosk(data: Health, add) -> None:
    add("exhibit_fps", data.fps)
    p95 = data.frame_ms_p95
    if _is_number(p95):
        add("exhibit_frame_time_p95_seconds", round(p95 / 1000.0, 6))
    mode = data.mode if data.mode in MODES else "notice"
    for m in MODE_LABELS:
        add("exhibit_mode", int(m == mode), mode=m)
    if isinstance(data.scene, str):
        add("exhibit_scene_info", 1, scene=data.scene)
    seen: set[tuple[str, str]] = set()
    for device in (data.devices or [])[:MAX_DEVICES]:
        labels = {"device": _clean(device_label(device)), "url": _clean(device.url)}
        key = (labels["device"], labels["url"])
        n = 2
        while key in seen:  # two devices that clean up to one name: keep both series apart
            key = (f"{labels['device']}#{n}", labels["url"])
            n += 1
        seen.add(key)
        labels["device"] = key[0]
        state = _clean(device.state)
        states = [s.value for s in State]
        for s in states + ([state] if state not in states else []):
            add("exhibit_device_state", int(s == state), **labels, state=s)
        add("exhibit_device_state_seconds", device.state_s, **labels)
        missing = device.missing_s
        if (
            state == State.CONNECTED.value
            and missing is None
            and "state_s" in device.model_fields_set
        ):
            missing = 0  # a current kiosk writes null while connected; an old one knows nothing
        add("exhibit_device_missing_seconds", missing, **labels)
    add("exhibit_uptime_seconds", data.uptime_s)
    add("exhibit_frames_total", data.frames)
    add("exhibit_frame_errors_total", data.frame_errors)
    add("exhibit_gl_errors_total", data.gl_errors)
    for name, value in (
        ("exhibit_scenes_failed", data.scenes_failed),
        ("exhibit_problems", data.problems),
    ):
        if isinstance(value, list):
            add(name, len(value))
    rss = data.rss_kb
    if _is_number(rss) and rss >= 0:
        add("exhibit_resident_memory_bytes", rss * 1024)
    fds = data.fds
    if _is_number(fds) and fds >= 0:  # -1: could not be counted
        add("exhibit_open_fds", fds)
    passes = data.frame_passes
    times = passes.get("passes_ms") if isinstance(passes, dict) else None
    if isinstance(times, dict):
        for name, ms in list(times.items())[:MAX_PASSES]:
            if _is_number(ms) and ms >= 0:
                add("exhibit_frame_pass_seconds", round(ms / 1000.0, 6), **{"pass": _clean(name)})


def write_metrics(
    path: str | os.PathLike,
    data: Health | Mapping | None,
    status: str,
    age: float | None = None,
    folder: Mapping | None = None,
) -> None:
    """Replace the metrics file at ``path`` atomically with the metrics of registry(), as
    prometheus_client writes them, world-readable (node_exporter runs as another user), through
    the one safe writer (exhibit.schema.files.write_atomic: its temporary name does not end in
    .prom, so the collector never reads it half written).

    Its folder must exist: node_exporter's package creates it, and a missing one means the
    collector is not installed. A folder, FIFO or device at ``path`` is refused (UnsafePath); a
    symlink there is replaced, not followed. Raises OSError."""
    check_target(path)
    text = generate_latest(registry(data, status, age, folder))
    write_atomic(path, text, mode=0o644, sync=False)  # rewritten every 15 s: spare the flash


def _clean(value: object) -> str:
    """A label value without control or invisible characters (C0, DEL, C1, bidi overrides,
    lone surrogates), whitespace runs as they are but line breaks and tabs as spaces, at most
    MAX_LABEL_CHARS long."""
    text = str(value)
    out = "".join(c if c.isprintable() else " " if c.isspace() else "" for c in text)
    return out[:MAX_LABEL_CHARS]


def escape_label(value: object) -> str:
    """A label value for the text format: cleaned (_clean), then backslash, double quote and
    line feed escaped."""
    return _clean(value).replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")


def _is_number(value: object) -> TypeGuard[float]:
    """A finite int or float (not a bool): a health file's value fit to be a sample."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
