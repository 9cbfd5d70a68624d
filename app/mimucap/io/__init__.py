"""Files: session files, calibrations, exports and third-party imports. May import ``core`` only."""
