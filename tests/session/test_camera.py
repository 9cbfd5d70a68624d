"""The camera presets stand far enough back for a T pose in any view shape, and refuse
impossible views."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mimucap.session.views.camera import (CAMERA_PRESETS, FIT_HEIGHT_HEIGHTS, FIT_MARGIN, FIT_WIDTH_HEIGHTS,
                                    VIEW_ANGLE_DEG, camera_preset, fit_distance)


def _half_extent_seen(distance: float, aspect: float) -> tuple[float, float]:
    """Half the width and half the height (m) a camera sees at ``distance``."""
    half_height = distance * math.tan(math.radians(VIEW_ANGLE_DEG) / 2.0)
    return half_height * aspect, half_height


@pytest.mark.parametrize("aspect", [0.5, 0.88, 1.0, 1.6, 3.0])
def test_the_fit_distance_shows_the_whole_box_and_no_more_than_needed(aspect):
    height = 1.75
    distance = fit_distance(height, aspect)
    half_width, half_height = _half_extent_seen(distance, aspect)
    need_width = 0.5 * FIT_WIDTH_HEIGHTS * height * (1.0 + FIT_MARGIN)
    need_height = 0.5 * FIT_HEIGHT_HEIGHTS * height * (1.0 + FIT_MARGIN)
    assert half_width >= need_width - 1e-9 and half_height >= need_height - 1e-9
    # One of the two is tight: the camera is no farther than it must be.
    assert min(half_width - need_width, half_height - need_height) == pytest.approx(0.0, abs=1e-9)


def test_a_narrow_view_puts_the_camera_farther_back_and_a_wide_one_does_not():
    assert fit_distance(1.75, 0.6) > fit_distance(1.75, 1.0)
    assert fit_distance(1.75, 2.0) == pytest.approx(fit_distance(1.75, 3.0))  # the height limits
    assert fit_distance(2.0, 1.0) == pytest.approx(fit_distance(1.0, 1.0) * 2.0)


@pytest.mark.parametrize("height, aspect", [(0.0, 1.0), (-1.0, 1.0), (1.75, 0.0), (1.75, float("nan"))])
def test_impossible_views_are_refused(height, aspect):
    with pytest.raises(ValueError, match="must be positive"):
        fit_distance(height, aspect)


def test_every_preset_looks_at_the_root_from_the_fit_distance_at_least():
    root = np.array([4.0, 0.93, -7.0])
    for name in CAMERA_PRESETS:
        pose = camera_preset(name, root, 1.75, aspect=0.8)
        np.testing.assert_allclose(pose.focal_point[[0, 2]], root[[0, 2]])
        assert np.linalg.norm(pose.position - pose.focal_point) >= fit_distance(1.75, 0.8) - 1e-9
