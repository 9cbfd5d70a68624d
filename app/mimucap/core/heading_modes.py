"""Where the sensors' headings come from: the modes a user chooses (no imports: the command
line offers them without loading the processing path; :mod:`mimucap.core.heading_sources`
applies them)."""

MODE_COUPLED = "coupled"
MODE_MAGNETOMETER = "magnetometer"
MODE_NO_MAGNETOMETER = "no-magnetometer"
MODES = (MODE_COUPLED, MODE_MAGNETOMETER, MODE_NO_MAGNETOMETER)
MODE_LABELS = {
    MODE_COUPLED: "relative headings from the field the body shares and the knees' axes, "
                  "the body's from the magnetometers",
    MODE_MAGNETOMETER: "each sensor's heading from its own magnetometer",
    MODE_NO_MAGNETOMETER: "no magnetometer: relative headings from the knees' axes, the others from the gyroscopes",
}

def check_mode(mode: str) -> str:
    """``mode`` when it is one of :data:`MODES`, else ``ValueError`` naming them."""
    if mode not in MODES:
        raise ValueError(f"unknown heading mode {mode!r}; use one of {', '.join(MODES)}")
    return mode
