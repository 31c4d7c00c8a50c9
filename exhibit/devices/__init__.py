"""Input devices: one backend interface (base.py), chosen by URL (url.py), polled without
blocking by the render loop, and the mapping from their events to the exhibit's seven
parameters (mapping.py). docs/DEVICES.md is the guide.

- protocol.py: the pure codec of the 6-axis controller's serial protocol (firmware/PROTOCOL.md)
- controller.py: the controller over a serial line (handshake, heartbeat watch, reconnect)
- hid.py: HID devices through hidapi (libusb or hidraw) with report layouts from configs/devices
- keyboard.py, replay.py: keys and mouse from the window; recorded sessions
- sim.py, simbackends.py, fakehid.py: the simulated controller on a pty, fake HID devices
- config.py, hub.py: the device config and all configured devices at once
"""
