"""Magnetometer calibration (Choe, Zhao, Qiu, So, "Study of calibration method of low-cost MEMS
magnetometer"), one concept per module:

* :mod:`.model` — :class:`~.model.MagCalibration`, the hard- and soft-iron correction of one
  sensor and its application ``mag_cal = soft_iron @ (mag_raw − offset_uT)``;
* :mod:`.fit` — the ellipsoid fit (Li & Griffiths, and the general quadric), robust to outliers;
* :mod:`.quality` — the fit's quality figures and its good / warn / fail verdict;
* :mod:`.calibrate` — fit and quality in one call, giving the calibration record;
* :mod:`.gyro_scale` — the gyroscope's scale and cross-axis correction from the same turns;
* :mod:`.guidance` — the one-turn-per-axis protocol, followed sample by sample;
* :mod:`.standing` — how a calibration stands for a sensor now (device, local field, age);
* :mod:`.study` — the comparison of calibration protocols on simulated sensors.

Fields in µT, rates rad/s, sensor frame.
"""
