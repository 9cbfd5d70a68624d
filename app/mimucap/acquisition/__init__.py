"""Wire protocols (pure parsers), device drivers, worker processes, supervisor and time sync.

May import ``core`` only (never ``io``, ``session`` or ``gui``). Modules, one concept each:

* ``wire_sample`` (one decoded Sample, its validation, its sequence number unwrapped),
  ``packed_blocks`` (accepted samples of many sensors in one set of columns), ``rejections``
  (named, counted refusals)
* ``protocol_udp``, ``protocol_serial``, ``slimevr_protocol`` (total parsers and encoders),
  ``hello`` (which device a node is)
* ``timesync`` (node clock offset and drift), ``intake`` (per-sample session checks and mapping)
* ``udp``, ``serial_port``, ``slimevr``, ``simulated``, ``replay`` (drivers; ``datagram_socket`` the
  UDP reading they share), ``worker`` (process entry point),
  ``outbox``/``messages`` (worker → supervisor), ``supervisor``, ``stats``
* ``source_spec`` (spec strings)
* ``emulate_common``, ``emulate_udp``, ``emulate_serial``, ``emulate_motion`` (device emulators)

See ``docs/protocols.md``.
"""
