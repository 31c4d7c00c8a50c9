"""What every recent health file carries besides its numbers: the last frame drawn, the
version and release, and a state folder with room (exhibit.operations.storage)."""

from __future__ import annotations

import time


def fresh_fields() -> dict:
    return {
        "last_frame": time.time(),
        "version": "0.1.0",
        "release": "0.1.0-20250601T120000Z",
        "storage": {
            "folder": "/var/lib/exhibit",
            "free_bytes": 5 << 30,
            "free_inodes": 1000,
            "problem": None,
            "errors": {},
        },
    }
