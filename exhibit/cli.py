"""The `exhibit` command: one subcommand per module in exhibit.commands, each with its own help.

A command module provides HELP (one line), add_arguments(parser) and run(args) -> exit code.
ExhibitError becomes a one-line message and exit code 2; nothing else reaches the user as a
traceback
unless EXHIBIT_DEBUG=1.
"""

from __future__ import annotations

import argparse
import errno
import importlib
import os
import sys

from exhibit import __version__
from exhibit.errors import ExhibitError

# name -> module under exhibit.commands; the order is the order of `exhibit --help`.
COMMANDS = {
    "run": "run",
    "check-config": "check_config",
    "sweep": "sweep",
    "scenes": "scenes",
    "inspect": "inspect",
    "collide": "collide",
    "silhouette": "silhouette",
    "slice": "slice",
    "bench": "bench",
    "render": "render",
    "decode": "decode",
    "devices": "devices",
    "monitor": "monitor",
    "simulate": "simulate",
    "record": "record",
    "status": "status",
    "stats": "stats",
    "install": "install",
    "prepare": "prepare",
    "update": "update",
    "rollback": "rollback",
}


class _Parser(argparse.ArgumentParser):
    """Bad arguments get one line (``exhibit CMD: error: argument --x: reason``) and exit 2,
    like every other error a person can fix; --help still shows the usage."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The parser; with ``only``, just that subcommand's module is imported (command modules pull
    in numpy, GL and sympy, so importing all of them would slow every command down)."""
    parser = _Parser(
        prog="exhibit",
        description="Surfaces living in four-dimensional space: a museum exhibit after "
        "Hoffmann & Zhou, 'Visualization of Surfaces in Four-Dimensional Space'.",
    )
    parser.add_argument("--version", action="version", version=f"exhibit {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", title="commands")
    for name, module_name in COMMANDS.items():
        if only is not None and name != only:
            continue
        module = importlib.import_module(f"exhibit.commands.{module_name}")
        cmd = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(cmd)
        cmd.set_defaults(_run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(argv[0] if argv and argv[0] in COMMANDS else None)
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    try:
        code = int(args._run(args) or 0)
        sys.stdout.flush()  # a full disk or a closed pipe shows here, not at exit
        return code
    except ExhibitError as exc:
        print(f"exhibit {args.command}: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # `exhibit decode ... | head`: the reader is gone; stop quietly
        _drop_stdout()
        return 141  # 128 + SIGPIPE, what a shell reports for a Unix tool in this case
    except OSError as exc:
        if exc.errno not in (errno.ENOSPC, errno.EDQUOT):
            return _internal(args, exc)
        _drop_stdout()
        print(f"exhibit {args.command}: error: {exc.strerror}", file=sys.stderr)
        return 1
    except Exception as exc:  # noqa: BLE001 - the last line of defence: one line for people
        return _internal(args, exc)


def _internal(args, exc: Exception) -> int:
    if os.environ.get("EXHIBIT_DEBUG") == "1":
        raise exc
    print(
        f"exhibit {args.command}: internal error: {type(exc).__name__}: {exc} "
        "(set EXHIBIT_DEBUG=1 for a traceback)",
        file=sys.stderr,
    )
    return 1


def _drop_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's final flush cannot fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):
        pass


if __name__ == "__main__":
    raise SystemExit(main())
