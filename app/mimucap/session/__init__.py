"""The application without Qt, by kind: :mod:`~mimucap.session.live.live_session` (the live session and its
parts), :mod:`~mimucap.session.sources.source_configs` (where live samples come from),
:mod:`~mimucap.session.procedures` (the guided calibrations and assessments),
:mod:`~mimucap.session.recorded` (a recording reviewed, analysed, exported),
:mod:`~mimucap.session.streaming` (the live session's Lab Streaming Layer streams) and
:mod:`~mimucap.session.views` (view models the windows draw); :mod:`~mimucap.session.events`
is how every model tells what changed."""
