"""`exhibit rollback [--prefix DIR]`: switch a deployed kiosk back to the release before the
current one (docs/DEPLOYMENT.md, "8. Updating"): the site config checked with it, its mesh cache
built as the service's user, PREFIX switched in one rename, its `exhibit install` run and
exhibit.service restarted, as a transaction like an update's (the same lock, time limits and
switch back when install or restart fails). A `previous` that names the running release, or
anything but a release in PREFIX-releases/, is refused in one line, changing nothing. The
release rolled back from becomes the previous one, so a second rollback undoes the first.
The releases are made by `./bootstrap.sh update`
(exhibit/commands/update.py)."""

from __future__ import annotations

import argparse

from exhibit.commands import install as inst
from exhibit.commands.update import Releases, add_prefix, need_root

HELP = "switch a deployed kiosk back to its previous release (made by ./bootstrap.sh update)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_prefix(parser)


def run(args: argparse.Namespace) -> int:
    prefix = inst.check_prefix(args.prefix)
    need_root("rollback", prefix)
    return Releases(prefix).rollback()
