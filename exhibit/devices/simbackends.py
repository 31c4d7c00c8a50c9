"""``sim://`` backends: the real host code connected to a simulated device.

``sim://controller`` is a :class:`SerialController` reading the pty of a :class:`SimController`
it owns; ``sim://controller?firmware=ELF`` reads the controller firmware itself, running in
simavr (:class:`~exhibit.devices.simavr.FirmwareController`); ``sim://LAYOUT`` is a
:class:`HidBackend` reading a scripted fake HID device. Nothing is
short-circuited: the controller's bytes cross a real pty, the fake HID device hands over the same
report bytes hidapi would.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from exhibit.devices.controller import SerialController
from exhibit.devices.sim import SimController, Step

if TYPE_CHECKING:
    from exhibit.devices.base import Clock
    from exhibit.devices.hid import HidBackend, Layout

    from exhibit.devices.simavr import FirmwareController

__all__ = ["SimulatedController", "SimulatedFirmware", "simulated_hid"]


@dataclass
class SimulatedController(SerialController):
    """A controller simulator in a thread and the serial backend on its pty."""

    script: list[Step] | None = None
    seed: int | None = None
    sim: SimController | FirmwareController | None = field(default=None, init=False)

    def _simulator(self) -> SimController | FirmwareController:
        """The simulated device to start (it offers ``link``, the pty, and ``stop()``)."""
        return SimController(script=self.script, seed=self.seed)

    def _open(self) -> None:
        sim = self.sim = self._simulator().start()
        self.path = str(sim.link)
        super()._open()

    def _close(self) -> None:
        super()._close()
        if self.sim is not None:
            self.sim.stop()
            self.sim = None


@dataclass
class SimulatedFirmware(SimulatedController):
    """The controller firmware in simavr, started on open, and the serial backend on its pty.
    The firmware runs in real time, so this backend needs the real clock (no simulated time)."""

    firmware: str = ""

    def _simulator(self) -> SimController | FirmwareController:
        from exhibit.devices.simavr import FirmwareController

        return FirmwareController(Path(self.firmware), script=self.script, seed=self.seed)


def simulated_hid(
    name: str,
    clock: Clock,
    layout: Layout,
    script: list[tuple] | None = None,
    seed: int | None = None,
) -> HidBackend:
    from exhibit.devices.fakehid import FakeHidBus, FakeHidDevice
    from exhibit.devices.hid import HidBackend

    vid, pid = layout.match[0] if layout.match else (0xF00D, 0x0001)
    device = FakeHidDevice(
        vid,
        pid,
        product=layout.description or layout.name,
        serial="SIM1",
        usage_page=layout.usage_page or 0,
        script=script,
        clock=clock,
        seed=seed,
        layout=layout,
    )
    bus = FakeHidBus([device])
    # The real HidBackend, on a bus where only the fake device is plugged in (its ``api``).
    return HidBackend(
        name=name,
        clock=clock,
        layout=layout,
        backend=layout.backend,
        vid=vid,
        pid=pid,
        serial=None,
        path=None,
        api=bus,
    )
