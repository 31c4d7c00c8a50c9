"""Reviewing attract mode off the exhibit (layer 9, above the kiosk it plays): the player that
runs the real kiosk headlessly on a clock it sets (:mod:`.player`), what it plays checked first
(:mod:`.setup`), `exhibit render --timeline --verify`'s claims measured on the frames
(:mod:`.claims`) and the narrated review (:mod:`.narrated`). Never imported by the running kiosk:
the commands (exhibit.commands._review, `exhibit bench`) and the tests use it."""
