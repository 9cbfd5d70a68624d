"""Where live samples come from: the feeds (the simulated suit in process, acquisition workers),
the worker configurations of a source spec, and the calibration procedures' view of a live session."""
