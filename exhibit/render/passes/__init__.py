"""Render passes as units: each owns its programs, binds its vertex arrays, sets its own GL
state and says what it reads and writes (docs/RENDERING.md, "Passes"). exhibit.render.renderer
orders the picture's passes; exhibit.render.frame adds the composite passes of kiosk frames.
The modules are imported where they are used (the object-id pass only by reviews and tests)."""
