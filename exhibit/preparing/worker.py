"""What runs in a worker process (spawned: it imports this module and what it needs, never the
window): jobs in through a pipe, their results out, at a lower priority than the frame loop."""

from __future__ import annotations

import dataclasses
import os
from multiprocessing.connection import Connection

from exhibit import scenes
from exhibit.preparing.jobs import Framers, Prepared, run_job
from exhibit.surfaces.mesh import Mesh4D


def portable(prepared: Prepared) -> Prepared:
    """``prepared`` as the kiosk gets it from the cache: without a fresh build's exact
    surfaces (sympy functions, which do not pickle; the kiosk's frames never use them)."""
    plain: dict[int, Mesh4D] = {}
    for level, mesh in prepared.meshes.items():
        same = next((plain[other] for other in plain if prepared.meshes[other] is mesh), None)
        plain[level] = same or dataclasses.replace(
            mesh, surfaces=[dataclasses.replace(s, exact=None) for s in mesh.surfaces]
        )
    return dataclasses.replace(prepared, meshes=plain)


def serve(connection: Connection, framers: Framers, nice: int) -> None:
    """The worker process: jobs in, Prepared out, until a None job or the end of the pipe.
    ``nice``: how much it yields to the frame loop (0: the urgent worker, for the scene a
    visitor waits for)."""
    try:
        if nice:
            os.nice(nice)
    except OSError:  # a system call filter without setpriority: the same priority, then
        pass
    from exhibit.operations import journal

    journal.install()
    scenes.load()
    while True:
        try:
            job = connection.recv()
        except (EOFError, OSError):
            return
        if job is None:
            return
        try:
            connection.send(portable(run_job(job, framers)))
        except OSError:  # the kiosk is gone or stopping
            return
