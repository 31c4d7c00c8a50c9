"""Input devices. ``exhibit.devices.protocol`` is the pure codec of the 6-axis controller's
serial protocol (firmware/PROTOCOL.md); the backends that open ports build on it."""
