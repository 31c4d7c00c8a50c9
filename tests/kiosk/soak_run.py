"""The soak's kiosk process (tests/kiosk/test_soak.py runs it under Xvfb): a real window, the
simulated controller unplugging and replugging, an accelerated clock; it prints the memory and
file descriptors after warm-up and at the end, GL errors and the devices' states as JSON.

    python -m tests.kiosk.soak_run KIOSK.TOML FRAMES STEP_S
"""

import itertools
import json
import sys

from exhibit.kiosk.app import Kiosk, open_window
from exhibit.kiosk.reporting import fd_count as _fd_count, rss_kb as _rss_kb
from exhibit.kiosk.config import load_kiosk_config


def main() -> None:
    config = load_kiosk_config(sys.argv[1])
    frames, step = int(sys.argv[2]), float(sys.argv[3])
    ticks = itertools.count()

    def clock() -> float:
        return next(ticks) * step / 4  # the loop reads the clock about 4 times a frame

    window = open_window(config, windowed=True)
    kiosk = Kiosk(config, window, clock=clock)
    kiosk.run(max_frames=frames // 5)
    warm = {"rss_kb": _rss_kb(), "fds": _fd_count()}
    kiosk.run(max_frames=frames - frames // 5)
    end = {"rss_kb": _rss_kb(), "fds": _fd_count()}
    print(
        json.dumps(
            {
                "warm": warm,
                "end": end,
                "gl_errors": kiosk.stats.gl_errors,
                "simulated_s": clock(),
                "devices": kiosk.devices.statuses(),
            }
        )
    )
    window.close()


if __name__ == "__main__":
    main()
