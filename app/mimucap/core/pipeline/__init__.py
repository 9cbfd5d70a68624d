"""One processing path, from raw samples to joint angles (no I/O, no Qt).

Every consumer (the live view, both calibration wizards, review, export, the analysis and the
commands ``fuse``, ``bench orientation``, ``bodycal``, ``angles``, ``export``, ``gait``,
``report``) runs its data through these modules, which follow the data:

* :mod:`.settings` — what the path is run with (:class:`~.settings.PipelineSettings`, the filter
  states a recording stores) and its two results (*as seen live*, *reprocessed*);
* :mod:`.chain` — steps 1-2 per sensor: magnetometer calibration, the on-board-orientation
  rule, the orientation filter (:class:`~.chain.SensorChain`, live blocks and whole recordings),
  with :mod:`.sensor_doubt`, why each orientation may be wrong;
* :mod:`.instants` — step 3: every sensor at the same instants;
* :mod:`.segments` — step 4: segments from sensors, the body-calibration step, where a
  coupling of the sensors of a joint acts (:class:`~.segments.SegmentStage`);
* :mod:`.joint_angles` — step 5: the joint angles of the measured joints and why each may be
  wrong; :mod:`.doubt_reasons` names the reasons;
* :mod:`.recording` — the batch form over a whole recording (:func:`~.recording.process_recording`);
* :mod:`.live` — the live form, block by block (:class:`~.live.LivePipeline`).

This package imports nothing itself: a command imports the module it uses.
"""
