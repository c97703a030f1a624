"""Tests of walker_gait.core.presence (the tracker's use of it: test_tracker's presence tests)."""

from __future__ import annotations

import numpy as np
import pytest

from walker_gait.core.presence import PresenceTest, border_width, legs_in_view
from walker_gait.core.types import CameraIntrinsics

CAM = CameraIntrinsics(width=160, height=120, fx=100.0, fy=100.0, cx=80.0, cy=60.0)
UP = np.array([0.0, -0.9, -0.44])  # an upright camera pitched down: "up" is towards the image's top rows


def _image() -> np.ndarray:
    return np.full((CAM.height, CAM.width), np.nan, np.float32)


def test_points_above_knee_height_show_legs() -> None:
    low = np.full(1000, 0.2)
    assert not legs_in_view(low, _image(), up=UP, intrinsics=CAM)
    some = low.copy()
    some[:19] = 0.6  # under 2 % of the points
    assert not legs_in_view(some, _image(), up=UP, intrinsics=CAM)
    some[:20] = 0.6
    assert legs_in_view(some, _image(), up=UP, intrinsics=CAM)
    # and never fewer than 10 points, however small the foreground
    assert not legs_in_view(np.full(9, 0.6), _image(), up=UP, intrinsics=CAM)


def test_a_wide_part_leaving_the_image_at_the_top_shows_a_leg() -> None:
    img = _image()
    img[0:3, 40:50] = 1.0  # 10 px at 1 m = 10 cm wide, in the top 4 % band (5 rows)
    assert border_width(img, up=UP, intrinsics=CAM, band=0.04) == pytest.approx(0.10)
    low = np.full(100, 0.1)
    assert legs_in_view(low, img, up=UP, intrinsics=CAM)
    thin = _image()
    thin[0:3, 40:43] = 1.0  # a walker tube: 3 cm
    assert not legs_in_view(low, thin, up=UP, intrinsics=CAM)
    # the band is the border that is "up": for a camera mounted upside down, the bottom rows
    assert not legs_in_view(low, img, up=-UP, intrinsics=CAM)
    flipped = img[::-1].copy()
    assert legs_in_view(low, flipped, up=-UP, intrinsics=CAM)


def test_presence_thresholds_are_validated() -> None:
    for bad in ({"height": -0.1}, {"share": 1.5}, {"band": 0.0}, {"band": 0.6}, {"width": -1.0}):
        with pytest.raises(ValueError, match="presence"):
            PresenceTest(**bad)
