"""Where things sit on the kiosk's screen (layer 6, above the renderer's Framer, below what
prepares and runs the kiosk): attract timelines framed clear of the text (timeline_framing.py),
the framing that follows a visitor's picture (follow.py), the views a scene starts from
(start_views.py) and the text panels' slow drift (panel_drift.py)."""
