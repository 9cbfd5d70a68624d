"""The guided procedures (magnetometer calibration, body calibration, range of motion), what
they ask of the subject, and a whole guided session run without a window; each procedure tells
what changed through its events."""
