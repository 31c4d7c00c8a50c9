"""`exhibit update RELEASE [--prefix DIR] [--keep N]`: switch a deployed kiosk to a new release
(docs/DEPLOYMENT.md, "8. Updating"); `./bootstrap.sh update` makes RELEASE and then runs this.

Releases live side by side in PREFIX-releases/ (/opt/exhibit-releases/VERSION-DATE/), each with
its own .venv; PREFIX (/opt/exhibit) is a symbolic link to the current one, so the units, which
run PREFIX/.venv/bin/exhibit, never change. The site configuration is in /etc/exhibit, outside
every release, and is never touched.

An update is a transaction, one at a time (a lock, PREFIX-releases/.exhibit-lock: a second one
says who holds it and stops). Every check comes before the switch, and every external step has a
time limit (:data:`TIMEOUTS`). In order, stopping at the first failure:

0. finishes what an update or rollback that stopped half-way (kill -9, SIGHUP, Ctrl-C, a
   power cut) still owes, as its journal (PREFIX-releases/.exhibit-journal.json, written before
   each of steps 4 and 5) says: the switch, install, restart, or the switch back; when that was
   this same update, the update is done;
1. checks what is there: the release (a folder in PREFIX-releases/ with its venv, whose
   `exhibit --version` prints its own version), PREFIX (a
   link to a release, or the plain checkout of the first deployment), PREFIX-releases/previous
   (a link, or nothing); anything else is refused by name, and what a killed switch left behind
   (its temporary links) is removed;
2. checks the site configuration with the new release (`exhibit check-config`, as the service's
   user with the service's environment): a file the new version refuses stops the update here;
3. builds the mesh cache with the new release (`exhibit prepare`, the same way), while the old
   release still runs: the restart draws at once;
4. switches PREFIX to the new release in one rename (a checkout that is a plain folder at PREFIX,
   as step 2 of the deployment makes it, first moves into PREFIX-releases/ as a release itself),
   and remembers the old one as PREFIX-releases/previous;
5. runs the new release's `exhibit install` (units, udev, systemd reload) and restarts
   exhibit.service if it runs; when either fails, the links are switched back, the old
   release's install and restart run again, and the update fails saying so;
6. removes the oldest releases beyond --keep, counting only releases that run, never the
   current or the previous one nor one ./bootstrap.sh update is making (one a killed bootstrap
   left half-made goes); a release that cannot be removed (a mount point, a busy file) is kept
   and said so: the update is done.

A kill -9 at any moment leaves PREFIX a working release (the old one or the new one), and the
lock goes with the process. `exhibit rollback` (exhibit/commands/rollback.py) switches back the
same way.

The transaction itself, shared with `exhibit rollback`, is exhibit/commands/_releases.py; this
module is the command line.
"""

from __future__ import annotations

import argparse
import os

from exhibit.commands import install as inst
from exhibit.commands._releases import KEEP, LOCK, PREVIOUS, RESTART, TIMEOUTS, Releases, StepFailed
from exhibit.errors import ExhibitError

#: Releases and the constants are here too, where `exhibit rollback` and the tests import them.
__all__ = [
    "HELP",
    "KEEP",
    "LOCK",
    "PREVIOUS",
    "RESTART",
    "TIMEOUTS",
    "Releases",
    "StepFailed",
    "add_arguments",
    "add_prefix",
    "need_root",
    "run",
]

HELP = (
    "switch a deployed kiosk to a release made by ./bootstrap.sh update: check the site "
    "config, build the cache, switch, restart"
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "release",
        metavar="RELEASE",
        help="the new release's folder, in PREFIX-releases/, with its .venv "
        "(./bootstrap.sh update makes it)",
    )
    add_prefix(parser)
    parser.add_argument(
        "--keep",
        type=int,
        default=KEEP,
        metavar="N",
        help="releases to keep, the current and the previous one included "
        f"(default {KEEP}, at least 2)",
    )


def add_prefix(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--prefix",
        default=inst.DEFAULT_PREFIX,
        metavar="DIR",
        help=f"the path the units run the exhibit from (default "
        f"{inst.DEFAULT_PREFIX}); the releases are in DIR-releases/",
    )


def run(args: argparse.Namespace) -> int:
    prefix = inst.check_prefix(args.prefix)
    if args.keep < 2:
        raise ExhibitError(
            f"--keep {args.keep}: keep at least 2 (the current and the previous release)"
        )
    need_root("update", prefix)
    release = os.path.normpath(os.path.abspath(args.release))
    return Releases(prefix).update(release, keep=args.keep)


def need_root(what: str, prefix: str) -> None:
    if os.geteuid() != 0:
        raise ExhibitError(f"{what} needs root (it switches {prefix} and restarts the kiosk)")
