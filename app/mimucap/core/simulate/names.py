"""Names of the simulator's activities, scenarios and sensor error presets, importable
without numpy (the command line lists them in ``--help``)."""

#: Activities the simulated subject can perform (:func:`mimucap.core.simulate.scenarios.make_activity`).
ACTIVITY_NAMES = ("npose", "tpose", "walk", "turn", "arm_raise", "squat", "rom", "mag_single_axis", "mag_figure8",
                  "mag_tumble")
#: Scenarios of :class:`mimucap.core.simulate.config.SimulationConfig`: every activity, ``demo``, ``bodycal`` and
#: the clinical tests.
#: The clinical tests the subject performs (:mod:`mimucap.core.simulate.clinical_tests`).
CLINICAL_TEST_SCENARIOS = ("tug", "walk10m", "walk2min", "walk6min", "chair_stand")
SCENARIOS = ACTIVITY_NAMES + ("demo", "bodycal") + CLINICAL_TEST_SCENARIOS
#: Presets of :func:`mimucap.core.simulate.sensor_errors.error_model` (the keys of ``ERROR_PRESETS``).
ERROR_PRESET_NAMES = ("default", "ideal", "mpu9250", "bno055")
#: Rooms of :data:`mimucap.core.simulate.rooms.ROOMS` (``clean``: the earth field alone).
ROOM_NAMES = ("clean", "clinic", "treadmill")
