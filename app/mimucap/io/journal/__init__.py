"""The recorder's journal: how a recording in progress is kept on disk, crash-safe.

* :mod:`.file` — the append-only file of length-prefixed, CRC-checked records, and its reader,
  which steps over damage and says what it could not read;
* :mod:`.arrays` — the payload layout of records that hold named arrays;
* :mod:`.records` — the record kinds (start, sample block, marker, status, end, truth), their
  payloads, and the journal's file names beside the session;
* :mod:`.to_session` — a journal read back as a session (at the end of a recording, and after
  a crash).

The recorder itself (when to write what) is :mod:`mimucap.session.live.recorder`.
"""
