"""A calibration feed whose one sensor's orientation is said to be settling for a while."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from mimucap.core.pipeline.doubt_reasons import DOUBT_DTYPE, SETTLING
from mimucap.session.sources.calibration_feed import DOUBT_EXTRA


class SettlingFeed:
    """The simulated feed, with one sensor's orientation said to be settling (as the pipeline says
    for seconds after a new magnetometer calibration) until ``until_s`` of the feed's clock."""

    def __init__(self, feed, sensor_id: str, until_s: float):
        self._feed, self.settling_sensor, self.until_s = feed, sensor_id, until_s

    def __getattr__(self, name):
        return getattr(self._feed, name)

    def read(self):
        blocks = self._feed.read()
        block = blocks.get(self.settling_sensor)
        if block is not None and block.t_s.shape[0]:
            reasons = np.where(block.t_s < self.until_s, SETTLING, 0).astype(DOUBT_DTYPE)
            blocks[self.settling_sensor] = replace(block, extra={**(block.extra or {}), DOUBT_EXTRA: reasons})
        return blocks
