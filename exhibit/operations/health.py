"""The kiosk's health file: what the running exhibit is doing, rewritten about once a second.

Its schema is one pydantic model, Health (with DeviceHealth per device): the kiosk builds one
(Kiosk.report, through report()) and writes it, and every reader gets one back from
read_health (`exhibit status`, the Prometheus metrics in exhibit.operations.prometheus). The fields'
comments say what each holds. "frames" drawn and "frame_errors" (frames that raised) count since
the start, "uptime_s" is the seconds since the kiosk process started (process_uptime),
"problems" has one line each for people (scenes skipped, frames failing), and "mode" and "scene"
are null when no scene could be prepared (the screen shows a notice). Per device, "state" is one
of exhibit.devices.base.State's values ("waiting": never connected since the start, "lost":
connected once, then gone), "state_s" the seconds it has been in that state and "missing_s" the
seconds since it was last connected (or since the start, if never), null while connected; all
as of "time". Files from kiosks older than these three device keys have only "url" and "state",
and are read as before (durations unknown). "last_frame" is when the kiosk last drew a frame
(unix seconds; readers call a kiosk up by it, not by the file's freshness alone), "version" and
"release" say which code runs (exhibit.operations.storage.build_info), and "storage" is the
state folder as the kiosk sees it: free space, a problem ("full", "read-only", "not writable")
and the errno of each of its writes that failed ("sessions", "journal").

Writes go into the file in place (exhibit.operations.health_file: blocks allocated once, a
checksum that a reader checks, reading again when it caught a write half done), so the file
stays current on a full disk; the file is made (and remade, when it must grow) by an atomic
replace (exhibit.schema.files.write_atomic: never over a device, FIFO, folder or symlink), and
is world-readable (0644) so staff can read it without sudo: nothing in it is secret.

Where the kiosk writes it: $EXHIBIT_STATE_DIR/health.json, else
$XDG_STATE_HOME/exhibit/health.json, else ~/.local/state/exhibit/health.json. The systemd unit
sets EXHIBIT_STATE_DIR=/var/lib/exhibit. Where readers look: candidate_paths().

Why one module of this size: the health file's schema, its writer, its reader and the problems
`exhibit status` reports from it."""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    PlainValidator,
    ValidationError,
    model_validator,
)
from pydantic_core import PydanticCustomError

from exhibit.errors import ExhibitError
from exhibit.operations import health_file, storage
from exhibit.schema import files

__all__ = [
    "HEALTH_FILE",
    "SERVICE_STATE_DIR",
    "MAX_HEALTH_BYTES",
    "Health",
    "DeviceHealth",
    "HealthError",
    "state_dir",
    "default_path",
    "candidate_paths",
    "report",
    "write_health",
    "read_health",
    "freshness",
    "drawing",
    "pid_alive",
    "storage_problem",
    "missing_devices",
    "device_label",
    "format_duration",
    "process_uptime",
]

HEALTH_FILE = "health.json"
#: Where the service's StateDirectory=exhibit puts the file (exhibit.service).
SERVICE_STATE_DIR = Path("/var/lib/exhibit")
MODES = ("attract", "visitor")
#: Largest health file read (1 MiB; the kiosk writes about 400 bytes): a reader is never flooded.
MAX_HEALTH_BYTES = 1 << 20
#: Largest magnitude of a known number (2**53, exact as a float): anything beyond is corrupt,
#: and would overflow the float arithmetic of a reader (an int of 400 digits has no float).
MAX_NUMBER = 2**53


def _fail(message: str):
    # The whole message in the context: a template would read the braces of a repr as fields.
    return PydanticCustomError("health", "{message}", {"message": message})


def _number(wanted: str, *, nullable: bool = True, seconds: bool = False):
    """A JSON number (int or float, never a bool), finite and within ±2**53; seconds: in
    [0, 2**53]. Kept as it was read (an int stays an int)."""

    def check(value):
        if value is None and nullable:
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise _fail(f"expected {wanted}, got {value!r}")
        if seconds and not 0 <= value <= MAX_NUMBER:
            raise _fail(f"expected seconds in [0, 2**53], got {value!r}")
        if isinstance(value, float) and not math.isfinite(value):
            raise _fail(f"expected a finite number, got {value!r}")
        if abs(value) > MAX_NUMBER:
            raise _fail("out of range (beyond ±2**53)")
        return value

    return PlainValidator(check)


def _whole(value):
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int):
        raise _fail(f"expected a whole number, got {value!r}")
    if abs(value) > MAX_NUMBER:
        raise _fail("out of range (beyond ±2**53)")
    return value


def _text(value):
    if value is not None and not isinstance(value, str):
        raise _fail(f"expected a string, got {value!r}")
    return value


def _mode(value):
    _text(value)
    if value is not None and value not in MODES:
        raise _fail(f"expected one of {', '.join(MODES)}, got {value!r}")
    return value


def _a_list(value):
    if value is not None and not isinstance(value, list):
        raise _fail(f"expected a list, got {value!r}")
    return value


def _as_read(value):
    return value


Number = Annotated[int | float | None, _number("a number")]
Seconds = Annotated[int | float | None, _number("a number", seconds=True)]
Whole = Annotated[int | None, PlainValidator(_whole)]
Text = Annotated[str | None, PlainValidator(_text)]
#: Written by the kiosk, not checked on read (as before the model): a reader shows an odd value
#: as "?" (exhibit.commands.status) rather than calling the whole file broken.
Unchecked = PlainValidator(_as_read)


class DeviceHealth(BaseModel):
    """One configured device: "state" is one of exhibit.devices.base.State's values, "state_s"
    the seconds in it, "missing_s" the seconds since it was last connected (null while
    connected). Files from kiosks older than the three optional keys have only url and state."""

    model_config = ConfigDict(extra="allow")

    url: str
    state: str
    name: Text = None
    state_s: Seconds = None
    missing_s: Seconds = None

    @model_validator(mode="before")
    @classmethod
    def _an_entry(cls, value):
        if (
            not isinstance(value, (dict, DeviceHealth))
            or isinstance(value, dict)
            and not all(isinstance(value.get(k), str) for k in ("url", "state"))
        ):
            raise _fail(f'expected {{"url": str, "state": str}}, got {value!r}')
        return value


class Health(BaseModel):
    """The health file, as the kiosk writes it (Kiosk.report, through report()) and every
    reader reads it (read_health: `exhibit status`, the metrics). "time" is the only required
    key; null is "not known yet" (fps before the first second); unknown keys are kept (a newer
    kiosk may add some) and so is which keys the file had (as_dict)."""

    model_config = ConfigDict(extra="allow")

    time: Annotated[int | float, _number("a number (unix seconds)", nullable=False)]
    pid: Whole = None
    fps: Number = None
    frame_ms_p95: Number = None
    mode: Annotated[str | None, PlainValidator(_mode)] = None
    scene: Text = None
    #: The scene being prepared: the one a visitor chose, waiting "waiting_s" (null: nobody
    #: waits) while "scene" is still shown, else the preparer's next (null: none).
    preparing: Text = None
    waiting_s: Seconds = None
    devices: Annotated[list[DeviceHealth] | None, BeforeValidator(_a_list)] = None
    #: Seconds since the kiosk process started (process_uptime).
    uptime_s: Number = None
    gl_errors: Whole = None
    rss_kb: Whole = None
    fds: Whole = None
    frames: Whole = None
    frame_errors: Whole = None
    #: One line each for people: scenes skipped, frames failing.
    problems: Annotated[list[str] | None, Unchecked] = None
    #: [{"scene", "reason"}]
    scenes_failed: Annotated[list[dict[str, Any]] | None, Unchecked] = None
    language: Annotated[str | None, Unchecked] = None
    #: The visitor-session recorder (exhibit.operations.sessions.SessionLog.health).
    sessions: Annotated[dict[str, Any] | None, Unchecked] = None
    #: The frame governor (exhibit.kiosk.governor.Governor.health).
    quality: Annotated[str | None, Unchecked] = None
    quality_detail: Annotated[dict[str, Any] | None, Unchecked] = None
    frame_ms: Annotated[float | None, Unchecked] = None
    frame_ms_max: Annotated[float | None, Unchecked] = None
    frame_ms_max_at_s: Annotated[float | None, Unchecked] = None
    target_ms: Annotated[float | None, Unchecked] = None
    #: "Listen" (exhibit.kiosk.narrator.Narrator.status): on, speaking, the player's device.
    narration: Annotated[dict[str, Any] | None, Unchecked] = None
    #: One frame measured pass by pass (exhibit.kiosk.frame_passes): its level, its age, the
    #: frame's total and each pass's milliseconds.
    frame_passes: Annotated[dict[str, Any] | None, Unchecked] = None
    #: When the kiosk last drew a frame (unix seconds); null before the first.
    last_frame: Number = None
    #: Which code runs (exhibit.operations.storage.build_info): exhibit.__version__, and the
    #: release folder (PREFIX-releases/NAME) or the checkout's path.
    version: Text = None
    release: Text = None
    #: The state folder (exhibit.operations.storage.check_folder): "folder", "free_bytes",
    #: "free_inodes", "problem" (full, read-only, not writable, or null) and "errors": the
    #: errno name of the last failed write of each writer ({"sessions": "ENOSPC"}).
    storage: Annotated[dict[str, Any] | None, Unchecked] = None

    def as_dict(self) -> dict[str, Any]:
        """The keys the file had (or the writer set), unknown ones included, as JSON values."""
        return self.model_dump(mode="python", exclude_unset=True, warnings=False)

    def get(self, key: str, default: Any = None) -> Any:
        """A key of the file, known or not, None when absent (as dict.get)."""
        return self.as_dict().get(key, default)

    def has(self, key: str) -> bool:
        return key in self.model_fields_set or key in (self.model_extra or {})


def _validation_problems(exc: ValidationError) -> list[str]:
    problems = []
    for error in exc.errors():
        key = ""
        for part in error["loc"]:
            key += f"[{part}]" if isinstance(part, int) else f".{part}" if key else str(part)
        if error["type"] == "missing":
            problems.append(f"key {key!r}: missing")
        elif error["type"] == "health":
            problems.append(f"key {key!r}: {error['msg']}")
        else:
            problems.append(f"key {key!r}: {error['msg']} (got {error.get('input')!r})")
    return problems


def as_health(data: Health | Mapping) -> Health:
    """``data`` as a Health (a Mapping is checked: HealthError names what is wrong)."""
    if isinstance(data, Health):
        return data
    try:
        return Health.model_validate(dict(data))
    except ValidationError as exc:
        raise HealthError("; ".join(_validation_problems(exc))) from None


#: States in which a device delivers nothing (exhibit.devices.base.MISSING, without importing
#: the device layer into every reader); "lost" is counted in files written before "waiting".
MISSING_STATES = ("waiting", "connecting", "lost", "reconnecting")


class HealthError(ExhibitError):
    """The health file is missing, unreadable or malformed; the message names the file and why.
    ``missing`` is True when there is no file at all (the kiosk never ran, or not here)."""

    def __init__(self, message: str, missing: bool = False):
        super().__init__(message)
        self.missing = missing


class _Unparsed(HealthError):
    """Not JSON (or not UTF-8): what a read caught in the middle of a write looks like too."""


def state_dir(environ: Mapping[str, str] | None = None) -> Path:
    """$EXHIBIT_STATE_DIR, else $XDG_STATE_HOME/exhibit, else ~/.local/state/exhibit."""
    env = os.environ if environ is None else environ
    if env.get("EXHIBIT_STATE_DIR"):
        return Path(env["EXHIBIT_STATE_DIR"])
    if env.get("XDG_STATE_HOME"):
        return Path(env["XDG_STATE_HOME"]) / "exhibit"
    home = env.get("HOME") or str(Path.home())
    return Path(home) / ".local" / "state" / "exhibit"


def default_path(environ: Mapping[str, str] | None = None) -> Path:
    """The health file this process would write: state_dir() / health.json."""
    return state_dir(environ) / HEALTH_FILE


def candidate_paths(environ: Mapping[str, str] | None = None) -> list[Path]:
    """Where a reader looks, in order; it reads the first that exists. $EXHIBIT_STATE_DIR
    names the one place. Without it, the service's /var/lib/exhibit/health.json comes first:
    on a kiosk machine the service is the kiosk staff ask about, whoever asks (root's own
    ~/.local/state holds at most a file from a kiosk someone once ran by hand, and must not
    hide the service's), then this user's own default_path(), for a kiosk run by hand where
    no service runs."""
    env = os.environ if environ is None else environ
    if env.get("EXHIBIT_STATE_DIR"):
        return [default_path(env)]
    paths = [SERVICE_STATE_DIR / HEALTH_FILE]
    own = default_path(env)
    return paths if own in paths else [*paths, own]


def report(**fields: Any) -> Health:
    """The Health the kiosk writes, from its numbers: non-finite floats (an fps before the first
    second) become null, as JSON has no NaN. Raises TypeError for a value of the wrong type."""
    try:
        return Health.model_validate(_finite(fields))
    except ValidationError as exc:
        raise TypeError("health file: " + "; ".join(_validation_problems(exc))) from None


def write_health(path: str | os.PathLike, data: Health | Mapping) -> None:
    """Write ``data`` (a Health, or a mapping checked as one by report()) as the health file at
    ``path`` atomically, creating its folder if needed.

    Raises OSError when the disk refuses (the app logs it and carries on), TypeError for values
    of the wrong type. No fsync: the file is rewritten every second, and losing the last one to
    a power cut is harmless, while syncing 86,400 times a day wears the kiosk's flash for nothing.
    """
    health = data if isinstance(data, Health) else report(**dict(data))
    fields = _finite(health.as_dict())
    fields.pop(health_file.CHECK_KEY, None)  # the writer's own: a read file written back

    def shorter() -> bytes:  # what still fits on a full disk: the numbers, not the lists
        return health_file.encode(
            {k: v for k, v in fields.items() if k not in _BULKY}
            | {"problems": [str(p)[:200] for p in fields.get("problems") or []][:5]}
        )

    health_file.write(path, health_file.encode(fields), shorter)


#: What a health file written on a full disk that has outgrown its file leaves out.
_BULKY = ("scenes_failed", "quality_detail", "narration", "frame_passes", "devices", "problems")


def read_health(path: str | os.PathLike) -> Health:
    """The health file at ``path``; HealthError names the file and what is wrong.

    "time" is required (a reader needs the age); the other known keys are checked for type and
    range when present, and unknown keys are kept (a newer kiosk may add some). Only a regular
    file of at most MAX_HEALTH_BYTES is read, opened non-blocking so that a FIFO or device in its
    place is refused instead of hanging the reader; NaN, Infinity and numbers too large for a
    float (1e400) are refused too, as JSON has none and they would make --json output invalid.
    """
    path = Path(path)
    for attempt in range(READ_TRIES):
        raw = _read_raw(path)
        try:
            health_file.verify(raw)
            return _parse(path, raw)
        except (health_file.Torn, _Unparsed) as exc:
            # A write in place caught half done reads as a bad checksum or broken JSON: the
            # kiosk writes once a second, so a read a moment later gets a whole one.
            if attempt == READ_TRIES - 1:
                if isinstance(exc, health_file.Torn):
                    raise HealthError(
                        f"{path}: {exc} (read {READ_TRIES} times): the file is damaged"
                    ) from None
                raise
            time.sleep(0.005 * (attempt + 1))
    raise AssertionError("unreachable")


#: Reads of a health file before one that does not parse, or fails its checksum, is broken.
READ_TRIES = 5


def _read_raw(path: Path) -> bytes:
    try:
        return files.read_regular(path, MAX_HEALTH_BYTES)
    except files.NotAFile as exc:
        if exc.kind == "a folder":
            raise HealthError(f"{path} is a folder, not a health file") from None
        raise HealthError(f"cannot read {path}: not a regular file ({exc.kind})") from None
    except files.TooLarge:
        raise HealthError(
            f"cannot read {path}: more than the {MAX_HEALTH_BYTES} bytes a health file may have"
        ) from None
    except FileNotFoundError:
        raise HealthError(
            f"no health file at {path}: the kiosk is not running or has not "
            "drawn its first second yet",
            missing=True,
        ) from None
    except IsADirectoryError:
        raise HealthError(f"{path} is a folder, not a health file") from None
    except (OSError, ValueError) as exc:
        raise HealthError(f"cannot read {path}: {getattr(exc, 'strerror', None) or exc}") from None


def _parse(path: Path, raw: bytes) -> Health:
    try:
        data = json.loads(
            raw.decode("utf-8"), parse_constant=_no_constant, parse_float=_finite_float
        )
    except UnicodeDecodeError:
        raise _Unparsed(f"{path}: not UTF-8 text") from None
    except json.JSONDecodeError as exc:
        raise _Unparsed(
            f"{path}: not valid JSON (line {exc.lineno} column {exc.colno}: {exc.msg})"
        ) from None
    except ValueError as exc:  # NaN, 1e400, a 5000-digit int
        raise _Unparsed(f"{path}: not valid JSON ({str(exc)[:80]})") from None
    except RecursionError:
        raise _Unparsed(f"{path}: not valid JSON (nested too deep)") from None
    if not isinstance(data, dict):
        raise HealthError(f"{path}: expected a JSON object, got {type(data).__name__}")
    data.pop(health_file.CHECK_KEY, None)
    try:
        return Health.model_validate(data)
    except ValidationError as exc:
        raise HealthError(f"{path}: " + "; ".join(_validation_problems(exc))) from None


def _no_constant(name: str):
    raise ValueError(f"{name} is not a JSON number")


def _finite_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"{text[:20]} is too large")
    return value


def freshness(
    data: Health | Mapping, max_age: float, now: float | None = None, check_pid: bool = True
) -> tuple[bool, float, str | None]:
    """(fresh, age in seconds, reason when not fresh) of health data read with read_health.

    Stale when older than ``max_age``, when its time lies more than ``max_age`` ahead (the clock
    was set back, or the writer's clock is wrong), or when its pid no longer exists on this
    machine (a crashed kiosk is stale at once, not ``max_age`` later).
    """
    data = as_health(data)
    now = time.time() if now is None else now
    age = now - float(data.time)
    if age > max_age:
        return False, age, f"last update {format_duration(age)} ago (more than {max_age:g} s)"
    if age < -max_age:
        return (
            False,
            age,
            (f"last update is stamped {format_duration(-age)} in the future (clock changed?)"),
        )
    pid = data.pid
    if check_pid and isinstance(pid, int) and pid > 0 and not _pid_alive(pid):
        return (
            False,
            age,
            (f"the kiosk process {pid} is not running (last update {format_duration(age)} ago)"),
        )
    return True, age, None


def drawing(
    data: Health | Mapping, max_age: float, now: float | None = None
) -> tuple[bool | None, str | None]:
    """(whether the kiosk draws, reason when not) by its "last_frame": False when it drew no
    frame for more than ``max_age`` seconds by ``now`` (every frame failing), or none since it
    started; None when the file does not say (a kiosk older than "last_frame")."""
    data = as_health(data)
    if not data.has("last_frame"):
        return None, None
    if data.last_frame is None:
        return False, "no frame drawn since the kiosk started (see the journal)"
    now = time.time() if now is None else now
    since = now - float(data.last_frame)
    if since > max_age:
        return False, (
            f"no frame drawn for {format_duration(since)} (more than {max_age:g} s): "
            "frames are failing (see the journal)"
        )
    return True, None


def storage_problem(data: Health | Mapping) -> tuple[str, str] | None:
    """(problem, reason) when the kiosk's state folder is full, read-only or not writable, by
    its "storage" (exhibit.operations.storage.problem_in); None when it has none."""
    info = as_health(data).storage
    return storage.problem_in(info) if isinstance(info, dict) else None


def device_label(device: DeviceHealth) -> str:
    """What to call a device from the health file: its config name, else its URL."""
    return device.name or device.url


def missing_devices(data: Health | Mapping, max_lost: float, age: float = 0.0) -> list[dict]:
    """The devices of health data (read with read_health) missing for longer than ``max_lost``
    seconds by now, ``age`` seconds after the file's "time": [{"device", "url", "state",
    "missing_s"}]. A device in a missing state without "missing_s" (a file from an older kiosk)
    is not counted: how long it has been gone is unknown."""
    out = []
    for device in as_health(data).devices or []:
        missing = device.missing_s
        if device.state not in MISSING_STATES or missing is None:
            continue
        missing = float(missing) + max(0.0, age)
        if missing > max_lost:
            out.append(
                {
                    "device": device_label(device),
                    "url": device.url,
                    "state": device.state,
                    "missing_s": round(missing, 1),
                }
            )
    return out


def process_uptime(pid: int | None = None) -> float | None:
    """Seconds since the process ``pid`` (this one by default) started, from the kernel: its
    start time in /proc/PID/stat (clock ticks after boot) against CLOCK_BOOTTIME. So start-up
    counts too (imports, the window, the first meshes), which a clock started in the kiosk's
    own code misses. None where /proc cannot tell (not Linux)."""
    try:
        with open(f"/proc/{pid or 'self'}/stat", "rb") as f:
            stat_line = f.read().decode("ascii", "replace")
        # After the command name, which is in parentheses and may hold spaces or ")".
        fields = stat_line[stat_line.rindex(")") + 2 :].split()
        started = int(fields[19]) / os.sysconf("SC_CLK_TCK")  # field 22, starttime
        return max(0.0, time.clock_gettime(time.CLOCK_BOOTTIME) - started)
    except (OSError, ValueError, IndexError, AttributeError):
        return None


def _finite(value):
    """Replace NaN and infinities (anywhere in dicts and lists) by None."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def pid_alive(pid: int) -> bool:
    """Whether process ``pid`` exists (on this machine, in this process's view)."""
    return _pid_alive(pid)


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except (ProcessLookupError, OverflowError):  # OverflowError: beyond any pid
        return False
    except PermissionError:
        return True  # exists, owned by another user (the service's)
    except OSError:
        return True  # cannot tell: do not call a running kiosk dead
    return True


def format_duration(seconds: float) -> str:
    """3.2 s, 4 min 10 s, 2 h 5 min, 3 d 4 h: how staff read durations."""
    seconds = abs(seconds)
    if seconds < 60:
        return f"{seconds:.1f} s"
    minutes, s = divmod(int(seconds), 60)
    hours, m = divmod(minutes, 60)
    days, h = divmod(hours, 24)
    if days:
        return f"{days} d {h} h"
    if hours:
        return f"{hours} h {m} min"
    return f"{m} min {s} s"
