"""`python -I -m exhibit.narration.make_cache_key [FILE]`: make the speech cache's secret key
(exhibit.narration.cache_secret; default: in the state folder) if there is none, as `exhibit
install` does as the service's user; keep one that is there; exit 1, saying why, when the file
there is refused (a link, a FIFO, readable by others, ...). A module of its own so that running
it does not import it twice (the package imports cache_secret)."""

from __future__ import annotations

import sys
from pathlib import Path

from exhibit.narration.cache_secret import key_path, make_key, read_key


def main(argv: list[str] | None = None) -> int:
    """Make or keep the key in ``argv[0]`` (default: the state folder's); the exit code."""
    args = sys.argv[1:] if argv is None else argv
    path = Path(args[0]) if args else key_path()
    try:
        try:
            read_key(path)
            print(f"speech cache key: {path} (kept)")
        except FileNotFoundError:
            make_key(path)
            print(f"speech cache key: {path} (made, mode 0600)")
    except (OSError, ValueError) as exc:
        why = getattr(exc, "strerror", None) or str(exc)
        print(
            f"speech cache key {path} is refused: {why}; remove it and run this again",
            file=sys.stderr,
        )
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
