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


def test_a_part_running_into_pixels_without_depth_up_to_the_top_leaves_the_view() -> None:
    """A user close to the walker has legs nearer than the sensor's range above the shins: the legs end, seen from
    the image's top, below rows without depth, not at the border.  With those rows known to lack depth
    (``no_depth``) the legs leave the view through them; with depth there (the floor, the room behind a wheel) they
    do not.  A few pixels with depth among them (speckle) do not break the way out."""
    img = _image()
    img[20:60, 40:50] = 0.5  # 10 px at 0.5 m = 5 cm wide, its top 20 rows below the image's top
    low = np.full(100, 0.1)
    assert border_width(img, up=UP, intrinsics=CAM, band=0.04) == 0.0
    assert not legs_in_view(low, img, up=UP, intrinsics=CAM)
    above = np.zeros(img.shape, bool)
    above[:20, 35:55] = True  # no depth above the part, up to the top border
    assert border_width(img, up=UP, intrinsics=CAM, band=0.04, no_depth=above) == pytest.approx(0.05)
    assert legs_in_view(low, img, up=UP, intrinsics=CAM, no_depth=above)
    speckled = above.copy()
    speckled[3, 35:55:7] = False  # a pixel with depth here and there in the way
    assert legs_in_view(low, img, up=UP, intrinsics=CAM, no_depth=speckled)
    # pixels without depth that stop short of the border (the floor or the room between): not a way out
    short = above.copy()
    short[:10] = False
    assert not legs_in_view(low, img, up=UP, intrinsics=CAM, no_depth=short)
    # a narrow part (a walker's tube) stays too narrow whichever way it leaves
    tube = _image()
    tube[20:60, 40:43] = 0.5
    assert not legs_in_view(low, tube, up=UP, intrinsics=CAM, no_depth=above)
    # "up" is the floor's: for a camera mounted upside down the way out is through the bottom rows
    assert not legs_in_view(low, img, up=-UP, intrinsics=CAM, no_depth=above)
    assert legs_in_view(low, img[::-1].copy(), up=-UP, intrinsics=CAM, no_depth=above[::-1].copy())
    # ... and through the left columns for one rolled a quarter turn
    left = np.array([-0.9, 0.0, -0.44])
    side = np.full((CAM.height, CAM.width), np.nan, np.float32)
    side[40:50, 20:60] = 0.5
    beside = np.zeros(side.shape, bool)
    beside[35:55, :20] = True
    assert border_width(side, up=left, intrinsics=CAM, band=0.04, no_depth=beside) == pytest.approx(0.05)
    assert not legs_in_view(low, side, up=left, intrinsics=CAM)
    with pytest.raises(ValueError, match="no_depth shape"):
        border_width(img, up=UP, intrinsics=CAM, band=0.04, no_depth=above[:, :10])
