"""Errors meant for people, not tracebacks: the CLI prints their message on one line and exits 2."""


class ExhibitError(Exception):
    """A problem the user can fix (bad argument, bad file, bad value); the message says what
    and where."""

    exit_code = 2


class ConfigError(ExhibitError):
    """One or more problems in files, each ``file: key: reason`` on its own line.

    Loaders collect every problem they can find before raising, so an installer fixes a file in
    one pass instead of one error per restart.
    """

    def __init__(self, problems: list[str] | str):
        self.problems = [problems] if isinstance(problems, str) else list(problems)
        super().__init__("\n".join(self.problems))
