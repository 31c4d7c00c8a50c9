"""Errors meant for people, not tracebacks: the CLI prints their message on one line and exits 2."""


class ExhibitError(Exception):
    """A problem the user can fix (bad argument, bad file, bad value); the message says what and where."""

    exit_code = 2
