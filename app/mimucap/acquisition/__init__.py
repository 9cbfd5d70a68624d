"""Wire protocols (pure parsers), device drivers, worker processes, supervisor and time sync.

May import ``core`` only (never ``io``, ``session`` or ``gui``). Modules, one concept each:

* ``samples`` (Sample, its validation, packed blocks of them), ``rejections`` (named, counted refusals)
* ``protocol_udp``, ``protocol_serial`` (total parsers and encoders), ``block_codec`` (journal records)
* ``timesync`` (node clock offset and drift), ``intake`` (per-sample session checks and mapping)
* ``udp``, ``serial_port``, ``simulated``, ``replay`` (drivers), ``worker`` (process entry point),
  ``outbox``/``messages`` (worker → supervisor), ``supervisor``, ``stats``
* ``source_spec`` (spec strings)
* ``emulate_common``, ``emulate_udp``, ``emulate_serial``, ``emulate_motion`` (device emulators)

See ``docs/protocols.md``.
"""
