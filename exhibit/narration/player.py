"""Playing narration without ever holding up a frame or stopping the kiosk.

miniaudio (a C library with a Python binding and manylinux wheels) runs the device's own thread
and calls :func:`~exhibit.narration.feed.stream` for samples; the frame loop only swaps the
sound in the :class:`~exhibit.narration.feed.Feed`. The device is opened once and runs
continuously (silence when nothing plays), so play() starts a sound at once.

A kiosk may have no sound card, a USB speaker that is unplugged and plugged back in, or an ALSA
that fails: none of it raises into the caller. Opening fails -> status "absent" (no such device)
or "error" (one that would not work), play() does nothing and playing is False; the next play()
at least RETRY_S later tries again, in a thread of its own (opening ALSA takes tens of ms). A
device that stops asking for samples for STALL_S is taken as gone and reopened the same way.
"""

from __future__ import annotations

import atexit
import logging
import threading
import time
import weakref
from typing import Any

from exhibit.narration.feed import DEFAULT_VOLUME, MAX_VOLUME, Feed, clamp_volume, stream
from exhibit.narration.sound import RATE, Sound

__all__ = ["MAX_VOLUME", "Player", "RETRY_S", "STALL_S"]

log = logging.getLogger(__name__)

#: Every player not closed yet. miniaudio closes a device it is garbage-collecting by stopping
#: its thread, which then waits for the interpreter that is shutting down: the process hangs
#: at exit (a review's `exhibit render` did, 0 % CPU). So the players left open are closed at
#: exit, while the interpreter still runs threads.
_OPEN: weakref.WeakSet = weakref.WeakSet()


@atexit.register
def _close_all() -> None:
    for player in list(_OPEN):
        player.close()


#: Least time between two attempts to open the device.
RETRY_S = 3.0
#: A running device that has not asked for samples this long is taken as gone.
STALL_S = 2.0
#: The device's period: how much it asks for at a time (latency of a start or a stop).
PERIOD_MS = 20


#: ALSA's own error printer, replaced once (_quiet_alsa); kept so the callback lives.
_ALSA_HANDLER: list[Any] = []


def _quiet_alsa() -> None:
    """On a machine with no sound card every open attempt made libasound print about 35
    "ALSA lib ... cannot find card '0'" lines to stderr (the journal, each retry). The player
    says why it has no device in one line of its own (status()), so ALSA's printer is replaced
    by one that says nothing. Once a process; nothing where libasound is not installed."""
    if _ALSA_HANDLER:
        return
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("asound")
    if name is None:
        _ALSA_HANDLER.append(None)
        return
    try:
        library = ctypes.CDLL(name)
        kind = ctypes.CFUNCTYPE(
            None, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p
        )
        handler = kind(lambda *args: None)
        library.snd_lib_error_set_handler(handler)
    except (OSError, AttributeError) as exc:
        log.debug("ALSA's error printer stays: %s", exc)
        _ALSA_HANDLER.append(None)
        return
    _ALSA_HANDLER.append(handler)


def _backends(name: str | None) -> list[Any]:
    """miniaudio backends to try: ``name`` alone ("null", "alsa", "pulseaudio"...), else every
    real one (never the null backend, which would "play" into nothing on a kiosk with no card).
    ValueError for an unknown name."""
    import miniaudio

    if name is not None:
        try:
            return [miniaudio.Backend[name.strip().upper()]]
        except KeyError:
            have = ", ".join(b.name.lower() for b in miniaudio.Backend)
            raise ValueError(f"unknown audio backend {name!r} (miniaudio has: {have})") from None
    fake = {miniaudio.Backend.NULL, miniaudio.Backend.CUSTOM}
    return [b for b in miniaudio.Backend if b not in fake]


class Player:
    """One output device and what plays on it. Never raises from its methods (errors show in
    :meth:`status`); play(), stop() and playing take no more than a lock held for a slice."""

    def __init__(
        self, device: str | None = None, volume: float = DEFAULT_VOLUME, backend: str | None = None
    ):
        self._feed = Feed(clamp_volume(volume))
        self._wanted = device
        self._backend = backend
        self._lock = threading.Lock()
        self._device: Any = None
        self._name: str | None = None
        self._state = "absent"
        self._error: str | None = None
        self._attempt = float("-inf")
        self._opener: threading.Thread | None = None
        self._closed = False
        _OPEN.add(self)
        self._open()  # here, once, in the caller's thread: the kiosk is starting, not drawing

    # ------------------------------------------------------------------ the caller's side

    def play(self, sound: Sound) -> None:
        """Start ``sound`` now, replacing what plays. Without a working device: nothing, and
        a reopen in the background when the last attempt is RETRY_S old."""
        try:
            if self._closed:
                return
            if self._check() != "ok":
                self._feed.clear()
                self._retry()
                return
            self._feed.load(sound)
        except Exception as exc:  # noqa: BLE001 - narration must never stop the kiosk
            self._fail("error", f"play: {exc}")

    def stop(self) -> None:
        try:
            self._feed.clear()
        except Exception as exc:  # noqa: BLE001 - as in play()
            self._fail("error", f"stop: {exc}")

    @property
    def playing(self) -> bool:
        """True until the sound's last sample has gone to the device (False without one)."""
        try:
            return self._check() == "ok" and self._feed.playing
        except Exception:  # noqa: BLE001 - as in play()
            return False

    @property
    def volume(self) -> float:
        return self._feed.volume

    def status(self) -> dict:
        """{"state": "ok" | "absent" | "error", "device": its name or None, "error": why or
        None, "sounds_begun": how many sounds the device began, "played_s": seconds of sound
        it took}, for the health file and `exhibit status`."""
        state = self._check()
        return {
            "state": state,
            "device": self._name,
            "error": self._error,
            "sounds_begun": self._feed.sounds_begun,
            "played_s": round(self._feed.frames_played / RATE, 3),
        }

    def close(self) -> None:
        """Stop and let the device go (the kiosk is quitting). Idempotent."""
        self._closed = True
        _OPEN.discard(self)
        self._feed.clear()
        with self._lock:
            device, self._device = self._device, None
        self._release(device)
        if self._state == "ok":
            self._state, self._error = "absent", "closed"

    def __enter__(self) -> Player:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ the device

    def _check(self) -> str:
        """The state, after noticing a device that stopped asking for samples."""
        if self._state == "ok" and time.monotonic() - self._feed.last_request > STALL_S:
            self._fail("error", f"the device stopped taking samples for over {STALL_S:g} s")
        return self._state

    def _fail(self, state: str, why: str) -> None:
        log.warning("narration audio %s: %s", state, why)
        self._feed.clear()
        with self._lock:
            device, self._device = self._device, None
            self._state, self._error = state, why
        if device is not None:  # uninit waits for the device's thread: not in the frame's
            threading.Thread(target=self._release, args=(device,), daemon=True).start()

    def _retry(self) -> None:
        now = time.monotonic()
        with self._lock:
            busy = self._opener is not None and self._opener.is_alive()
            if busy or self._closed or now - self._attempt < RETRY_S:
                return
            self._attempt = now
            self._opener = threading.Thread(target=self._open, name="narration-open", daemon=True)
            self._opener.start()

    def _open(self) -> None:
        """Open and start the device; sets the state either way, never raises."""
        self._attempt = time.monotonic()
        try:
            state, why, device, name = self._start()
        except Exception as exc:  # noqa: BLE001 - whatever miniaudio or ALSA throws
            state, why, device, name = "error", f"{type(exc).__name__}: {exc}", None, None
        with self._lock:
            if self._closed:
                state, why, keep = "absent", "closed", None
            else:
                keep, self._device = device, device
            self._state, self._error = state, why
            if name is not None:
                self._name = name
        if keep is None:
            self._release(device)
        if state != "ok":
            log.warning("narration audio %s: %s", state, why)

    def _start(self) -> tuple[str, str | None, Any, str | None]:
        import miniaudio

        _quiet_alsa()

        try:
            backends = _backends(self._backend)
        except ValueError as exc:
            return "error", str(exc), None, None
        device_id, name = None, None
        if self._wanted is not None:
            try:
                playbacks = miniaudio.Devices(backends).get_playbacks()
            except miniaudio.MiniaudioError as exc:
                return (
                    "absent",
                    f"no audio backend to look for {self._wanted!r} in: {exc}",
                    None,
                    None,
                )
            found = _find(playbacks, self._wanted)
            if found is None:
                names = ", ".join(repr(p["name"]) for p in playbacks) or "none"
                return (
                    "absent",
                    f"no output device {self._wanted!r} (there are: {names})",
                    None,
                    None,
                )
            device_id, name = found["id"], found["name"]
        try:
            device = miniaudio.PlaybackDevice(
                output_format=miniaudio.SampleFormat.SIGNED16,
                nchannels=1,
                sample_rate=RATE,
                buffersize_msec=PERIOD_MS,
                device_id=device_id,
                backends=backends,
                app_name="exhibit",
            )
        except miniaudio.MiniaudioError as exc:
            what = f"output device {name!r}" if name else "the default output device"
            return "absent", f"cannot open {what}: {exc}", None, name
        try:
            generator = stream(self._feed)
            next(generator)
            self._feed.last_request = time.monotonic()
            device.start(generator)
        except Exception as exc:  # noqa: BLE001 - a device that opened but will not start
            self._release(device)
            return "error", f"cannot start {name or 'the default output'}: {exc}", None, name
        return "ok", None, device, name or f"default ({device.backend})"

    @staticmethod
    def _release(device: Any) -> None:
        if device is None:
            return
        try:
            device.close()
        except Exception as exc:  # noqa: BLE001 - closing a device that is gone
            log.debug("closing the narration device: %s", exc)


def _find(playbacks: list[dict], wanted: str) -> dict | None:
    """The device named ``wanted``: exactly, else the one whose name holds it (any case)."""
    for info in playbacks:
        if info["name"] == wanted:
            return info
    matches = [p for p in playbacks if wanted.casefold() in p["name"].casefold()]
    return matches[0] if len(matches) == 1 else None
