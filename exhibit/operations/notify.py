"""sd_notify without libsystemd: tell systemd the kiosk is READY, what it is doing (STATUS), and
that its frame loop is alive (WATCHDOG), so a hung loop is restarted by `WatchdogSec=`.

The protocol is one datagram of newline-separated ``KEY=VALUE`` lines to the AF_UNIX socket named
by $NOTIFY_SOCKET (a path, or ``@name`` for the abstract namespace); systemd learns the sender's
PID from the kernel, which is how ``NotifyAccess=main`` knows the message is ours. Outside
systemd (no $NOTIFY_SOCKET) every method is a cheap no-op, so the app calls them unconditionally.

A notification must never take the exhibit down or stall a frame: sends are non-blocking, errors
are counted and logged once per kind, never raised. ``watchdog()`` is meant to be called every
frame: when no ping is due it does one clock read (vDSO, no system call) and returns.
"""

from __future__ import annotations

import errno
import logging
import math
import os
import socket
import time
from collections.abc import Callable, Mapping

__all__ = ["Notifier"]

log = logging.getLogger("exhibit.operations.notify")


class Notifier:
    """A client of one notify socket. Build it with :meth:`from_env` in the service's main process.

    ``address`` is the socket as in $NOTIFY_SOCKET (``/run/systemd/notify`` or ``@name``), or None
    for a disabled notifier. ``watchdog_usec`` is $WATCHDOG_USEC (None: no watchdog). ``clock``
    is a monotonic clock in seconds, replaceable for tests.
    """

    def __init__(
        self,
        address: str | None,
        watchdog_usec: int | None = None,
        clock: Callable[[], float] = time.monotonic,
    ):
        self._address = _socket_address(address) if address else None
        self._address_text = address
        if watchdog_usec is not None and (
            isinstance(watchdog_usec, bool)
            or not isinstance(watchdog_usec, int)
            or watchdog_usec <= 0
        ):
            raise ValueError(
                f"watchdog_usec must be a positive whole number, got {watchdog_usec!r}"
            )
        self._watchdog_usec = watchdog_usec if self._address is not None else None
        # Ping at half the timeout (as sd_watchdog_enabled(3) advises), so one late frame or a
        # lost datagram does not cost the service its life.
        self._period = self._watchdog_usec / 2e6 if self._watchdog_usec else None
        self._clock = clock
        self._next_ping = -math.inf
        self._sock: socket.socket | None = None
        self._last_status: str | None = None
        self._logged: set[int] = set()
        self.sent = 0  #: datagrams delivered to the socket
        self.send_errors = 0  #: datagrams that could not be sent (see the log for why)

    @classmethod
    def from_env(
        cls, environ: Mapping[str, str] | None = None, clock: Callable[[], float] = time.monotonic
    ) -> Notifier:
        """A notifier for $NOTIFY_SOCKET, with the watchdog of $WATCHDOG_USEC when $WATCHDOG_PID is
        unset or this process (a child that inherited the variables must not ping for its
        parent). Malformed values are logged and ignored: a bad unit file must not stop the
        exhibit, and systemd then restarts it for the missing READY or pings anyway."""
        env = os.environ if environ is None else environ
        address = env.get("NOTIFY_SOCKET") or None
        if address is not None and not (address.startswith("/") or address.startswith("@")):
            log.warning(
                "NOTIFY_SOCKET=%r is neither an absolute path nor '@abstract': "
                "systemd notifications are off",
                address,
            )
            address = None
        usec = None
        raw = env.get("WATCHDOG_USEC")
        if raw:
            try:
                usec = int(raw)
                if usec <= 0:
                    raise ValueError
            except ValueError:
                log.warning("WATCHDOG_USEC=%r is not a positive whole number: watchdog off", raw)
                usec = None
        pid = env.get("WATCHDOG_PID")
        if usec is not None and pid:
            try:
                for_us = int(pid) == os.getpid()
            except ValueError:
                log.warning("WATCHDOG_PID=%r is not a process id: watchdog off", pid)
                for_us = False
            if not for_us:
                usec = None
        try:
            return cls(address, usec, clock=clock)
        except ValueError as exc:
            log.warning("%s: systemd notifications are off", exc)
            return cls(None, clock=clock)

    # ------------------------------------------------------------------ state

    @property
    def enabled(self) -> bool:
        """True when there is a notify socket to talk to (running under systemd's Type=notify)."""
        return self._address is not None

    @property
    def watchdog_interval(self) -> float | None:
        """The watchdog timeout systemd enforces ($WATCHDOG_USEC in seconds), or None when there is
        no watchdog. ``watchdog()`` pings every half of it."""
        return self._watchdog_usec / 1e6 if self._watchdog_usec else None

    @property
    def ping_period(self) -> float | None:
        """Seconds between watchdog pings (half the timeout), or None."""
        return self._period

    def __repr__(self) -> str:
        return (
            f"Notifier({self._address_text!r}, watchdog_interval={self.watchdog_interval}, "
            f"sent={self.sent}, send_errors={self.send_errors})"
        )

    # ------------------------------------------------------------------ messages

    def ready(self, status: str | None = None) -> bool:
        """READY=1: start-up is finished (the first frame is on screen); systemd's start job
        completes and the watchdog starts counting. An optional STATUS goes in the same datagram."""
        fields = ["READY=1"]
        if status is not None:
            fields.append(f"STATUS={_one_line(status)}")
            self._last_status = _one_line(status)
        return self.send(*fields)

    def status(self, text: str) -> bool:
        """STATUS=text, shown by systemctl status; repeating the last text sends nothing."""
        text = _one_line(text)
        if text == self._last_status or not self.enabled:
            return False
        if self.send(f"STATUS={text}"):
            self._last_status = text
            return True
        return False

    def watchdog(self) -> bool:
        """WATCHDOG=1 when a ping is due (every ``ping_period``); else nothing. True when sent.

        Call it from the frame loop, after the frame is drawn: if the loop hangs, the pings stop
        and systemd restarts the service after WatchdogSec. A failed send is retried after a
        tenth of the period rather than a whole one, so one lost datagram cannot add up to a
        missed deadline.
        """
        if self._period is None:
            return False
        now = self._clock()
        if now < self._next_ping:
            return False
        if self.send("WATCHDOG=1"):
            self._next_ping = now + self._period
            return True
        self._next_ping = now + self._period / 10
        return False

    def extend_timeout(self, seconds: float) -> bool:
        """EXTEND_TIMEOUT_USEC: ask for ``seconds`` more to finish start-up (or stopping) beyond
        TimeoutStartSec=, e.g. once per scene while a cold mesh cache is being built."""
        if not (seconds > 0 and math.isfinite(seconds)):
            raise ValueError(f"seconds must be positive and finite, got {seconds!r}")
        return self.send(f"EXTEND_TIMEOUT_USEC={int(seconds * 1e6)}")

    def stopping(self) -> bool:
        """STOPPING=1: the kiosk is shutting down on purpose (maintenance keys, SIGTERM)."""
        return self.send("STOPPING=1")

    def send(self, *fields: str) -> bool:
        """Send ``KEY=VALUE`` fields as one datagram; True when the socket took it.

        Never raises for a delivery problem (no socket, systemd gone, buffer full): the error is
        counted in ``send_errors`` and logged the first time each kind occurs.
        """
        if self._address is None:
            return False
        for field in fields:
            if "\n" in field or "=" not in field:
                raise ValueError(f"notify field must be one KEY=VALUE line, got {field!r}")
        payload = "\n".join(fields).encode("utf-8", "replace")
        try:
            if self._sock is None:
                self._sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM | socket.SOCK_CLOEXEC)
            # MSG_DONTWAIT: a full receive queue (systemd busy) costs one message, not a frame.
            self._sock.sendto(payload, socket.MSG_DONTWAIT | socket.MSG_NOSIGNAL, self._address)
        except OSError as exc:
            self.send_errors += 1
            code = exc.errno or -1
            if code not in self._logged:
                self._logged.add(code)
                log.warning(
                    "cannot notify systemd at %s (%s): %s; the kiosk carries on, and "
                    "further errors of this kind are not logged",
                    self._address_text,
                    errno.errorcode.get(code, code),
                    exc.strerror or exc,
                )
            return False
        self.sent += 1
        return True

    def close(self) -> None:
        """Close the socket (a later send opens a new one)."""
        if self._sock is not None:
            self._sock.close()
            self._sock = None

    def __enter__(self) -> Notifier:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _socket_address(address: str) -> bytes:
    """$NOTIFY_SOCKET as a sockaddr_un path: '@name' is the abstract name '\\0name'."""
    raw = os.fsencode(address)
    if raw.startswith(b"@"):
        raw = b"\0" + raw[1:]
    if len(raw) > 107:  # sun_path holds 108 bytes, the last one for a path's terminating NUL
        raise ValueError(f"notify socket address is too long ({len(raw)} bytes): {address!r}")
    return raw


def _one_line(text: str) -> str:
    """STATUS must be one line: a newline would start a new KEY=VALUE assignment."""
    return " ".join(str(text).split("\n")).strip()
