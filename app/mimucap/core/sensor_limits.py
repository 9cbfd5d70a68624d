"""Physical limits of the MEMS motion sensors MimuCap works with, shared by the live intake
(which refuses a sample beyond them as ``out_of_range``) and the file readers (which refuse a
file whose values are beyond them: most likely stored in another unit).

The limits are about twice the full scale of the sensors used for human motion (BNO055,
MPU-9250, BMI160, LSM6DS3: ±16 g, ±2000 °/s = 34.9 rad/s, ±4900 µT), per axis, so that a
sensor at full scale with scale and bias errors is still inside them.
"""

from __future__ import annotations

#: Largest acceleration (m/s², per axis, ≈ 32 g).
ACC_MAX_M_S2 = 320.0
#: Largest angular rate (rad/s, per axis, ≈ 4000 °/s). A gyroscope "rate" beyond it is not in
#: rad/s: most likely °/s, 57.3 times too large.
GYR_MAX_RAD_S = 70.0
#: Largest magnetic field (µT, per axis).
MAG_MAX_UT = 5000.0
