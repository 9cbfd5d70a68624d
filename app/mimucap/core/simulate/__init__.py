"""The simulated sensor suit with ground truth: a skeleton moved through scripted activities
in a magnetic field, measured by units with a realistic error model.

Modules, from the settings down to the numbers:

* :mod:`.config`: :class:`~.config.SimulationConfig` (scenario, duration, sensors, rate,
  seed, error model, field, subject) and :data:`~.config.SENSOR_PLACEMENTS`;
* :mod:`.suit`: :class:`~.suit.SuitSimulator` (streaming) and :func:`~.suit.simulate_session`
  (a whole scenario at once, :class:`~.suit.SimulationResult`);
* :mod:`.truth`: what an interval gives (samples, ground truth, markers);
* :mod:`.scenarios`: the activities of each scenario, the demo, the magnetometer turns;
* :mod:`.schedule`: activities on a timeline, blended;
* :mod:`.activities`, :mod:`.walking`: what the subject does; :mod:`.body_pose` its pose;
* :mod:`.sensor_errors`: what a unit reports for a true motion;
* :mod:`.magnetic_field`: the earth field and local disturbances;
* :mod:`.hand_held`: magnetometer-calibration motions of a sensor held in the hand;
* :mod:`.minimum_jerk`: the smooth step every movement uses;
* :mod:`.names`: scenario and preset names, importable without numpy (the command line's help).

This package module imports nothing, so that :mod:`.names` stays cheap to import.
"""
