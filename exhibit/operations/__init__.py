"""Running the exhibit, for staff rather than visitors: the health file, its Prometheus metrics,
the journal, sd_notify and the visitor-session log. Beside the frame loop (exhibit.kiosk), below
it: the kiosk reports through these modules, and `exhibit status`, `exhibit stats` and `exhibit
run` read and start them without a window."""
