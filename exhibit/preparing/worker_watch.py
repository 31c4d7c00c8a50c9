"""The kiosk's side of a worker process: its results read whole on a thread of their own (off the
frame loop), and its job under way watched for progress, so a stopped or stuck worker is found
and replaced (exhibit.preparing.process_preparer.ProcessPreparer)."""

from __future__ import annotations

import contextlib
import math
import os
import queue
from dataclasses import dataclass
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess

#: A worker with a job under way is stalled when it has used no CPU time for STALL_S (stopped by
#: SIGSTOP, blocked on a disk that does not answer; a niced worker on a busy machine still gets
#: some) or has spent JOB_DEADLINE_S on one job (a cold build takes seconds to minutes): it is
#: killed and replaced, and named in the health file. Looked at every CHECK_EVERY_S.
STALL_S = 120.0
JOB_DEADLINE_S = 1800.0
CHECK_EVERY_S = 1.0

#: What the reader thread puts in the inbox when the worker's end of the pipe has closed.
ENDED = object()


def read_results(connection: Connection, inbox: queue.SimpleQueue) -> None:
    """The kiosk's reader thread: a result is read whole here, off the frame loop (a worker
    at a lower priority may take its time writing megabytes), and handed over whole. At the
    end of the pipe it closes the kiosk's end itself: a worker stopped or replaced is left to
    it, since closing a pipe under a thread blocked reading it could hand its file descriptor
    number to the next worker's pipe while this thread still reads it."""
    while True:
        try:
            inbox.put(connection.recv())
        except Exception:  # noqa: BLE001 - the end, or the kiosk closed this end (TypeError)
            with contextlib.suppress(OSError):
                connection.close()
            inbox.put(ENDED)
            return


def worker_progress(pid: int | None) -> tuple[str, float] | None:
    """A process's state letter ("T": stopped) and the CPU seconds it has used, from /proc;
    None where that cannot be read (not Linux, gone): then only JOB_DEADLINE_S applies."""
    if not pid:
        return None
    try:
        with open(f"/proc/{int(pid)}/stat", "rb") as file:
            text = file.read(4096).decode("ascii", "replace")
        fields = text[text.rindex(")") + 2 :].split()
        return fields[0], (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return None


@dataclass
class Watch:
    """A worker's job under way, watched for progress: when it was sent, when the worker's CPU
    time last moved, that CPU time, and when it was last looked at."""

    sent_at: float
    progress_at: float
    cpu: float | None = None
    checked_at: float = -math.inf

    def stalled(self, process: BaseProcess, now: float) -> str | None:
        """Why the worker counts as stalled now, or None."""
        if now - self.checked_at < CHECK_EVERY_S:
            return None
        self.checked_at = now
        seen = worker_progress(process.pid)
        if seen is not None:
            state, cpu = seen
            if self.cpu is not None and cpu > self.cpu:
                self.progress_at = now
            self.cpu = cpu
            if now - self.progress_at >= STALL_S:
                stopped = " (stopped)" if state in ("T", "t") else ""
                return f"no progress for {now - self.progress_at:.0f} s{stopped}"
        if now - self.sent_at >= JOB_DEADLINE_S:
            return f"still on one job after {now - self.sent_at:.0f} s"
        return None
