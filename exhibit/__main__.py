from exhibit.cli import main

# Guarded: the kiosk's worker process (multiprocessing "spawn") imports this module again.
if __name__ == "__main__":
    raise SystemExit(main())
