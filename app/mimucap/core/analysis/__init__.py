"""Clinical analysis of a recording, as pure functions on arrays (no Qt, no files).

One concept per module:

* :mod:`.signals` uniform resampling, zero-phase low-pass filtering, sub-sample event times;
* :mod:`.sagittal` the sagittal axes of a shank or foot sensor (from the body calibration, or
  found in its samples), its angular velocity about the flexion axis and its acceleration in
  the sagittal plane;
* :mod:`.heel_strike` the heel strike's impact in that acceleration;
* :mod:`.gait_events` initial and final contact of each foot from that angular velocity and
  the impact;
* :mod:`.zupt` stride length and heading change of a foot sensor by zero-velocity-update
  integration;
* :mod:`.leg_model` stride length from thigh and shank orientations (double-pendulum leg model);
* :mod:`.turns` turns from a continuous heading, found before the strides are judged;
* :mod:`.strides` strides (initial contact to initial contact), turns, walking bouts and the
  reason every refused stride was refused;
* :mod:`.gait_parameters` temporal and spatial gait parameters per side and for both, their
  variability and left/right symmetry;
* :mod:`.gait_cycle` joint angles time-normalised to 0-100 % of the stride, mean ± SD, and
  normative bands;
* :mod:`.rom` range of motion of the standard clinical movements, with reference values.

Units: seconds, metres, rad/s, m/s² inside; degrees only where a name says ``_deg``.
Frames: ISB segment frames (x anterior, y superior, z right), world ENU (z up);
quaternions scalar first ``[w, x, y, z]``.
"""
