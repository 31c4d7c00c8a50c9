"""Attract timelines (layer 3, below the narration that speaks them and the kiosk that plays
them): the model (:mod:`.model`: Timeline, Keyframe, what a caption says in ``while``), the file
curators write (:mod:`.file`: its format, read and checked; the scene it names is looked up by
the caller), the playlist (:mod:`.playlist`), check-config's caption checks (:mod:`.captions`)
and the kinds of claim a caption makes in ``while``, one module each (:mod:`.claims`)."""
