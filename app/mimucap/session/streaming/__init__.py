"""The live session streamed to other programs through the Lab Streaming Layer: its outlets and
the markers that come in (:mod:`~mimucap.session.streaming.lsl_streamer`), and the LSL clock
beside the session's (:mod:`~mimucap.session.streaming.lsl_clock`)."""
