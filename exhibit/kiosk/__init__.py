"""The kiosk: configuration, attract mode, the frame loop, and deployment helpers."""
