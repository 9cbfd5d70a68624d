"""The live session (:mod:`~mimucap.session.live.live_session`) and the parts it is composed of,
each with its own events: the source and its sensors, the processing, the calibrations, the
recording, the evaluation against the simulator's truth, the plot history and the status."""
