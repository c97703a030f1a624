"""Does the foreground show legs, or only low things (a walker's wheels and frame, a bag)?

A leg belongs to a body above it, so in the image it rises above knee height or leaves the view through the
border that is "up" for the camera.  A walker's wheel, in view while its user is away, does neither: it is
0.3 m high at most, and its frame's tubes are 1-2 cm wide where they leave the image.  The tracker ends a
track on foreground that shows no legs (:meth:`walker_gait.core.tracker.LegTracker.legs_in_view`), and the
segmentation's static-structure mask learns what it sees in such frames as the walker's own structure.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from walker_gait.core.types import CameraIntrinsics


@dataclass(frozen=True, kw_only=True)
class PresenceTest:
    """Thresholds of :func:`legs_in_view` (the ``default`` tracker preset's)."""

    height: float = 0.40  # m: points higher than this above the floor show legs ...
    share: float = 0.02  # ... when they are at least this fraction of the foreground (and 10 points)
    band: float = 0.04  # width of the image border band (fraction of the image) through which legs leave the view
    width: float = 0.04  # m: a foreground part at least this wide in that band shows a leg

    def __post_init__(self) -> None:
        if not (self.height >= 0 and 0 <= self.share <= 1 and 0 < self.band <= 0.5 and self.width >= 0):
            raise ValueError("presence height and width must be >= 0, share in [0, 1] and band in (0, 0.5], got "
                             f"{self.height}, {self.width}, {self.share}, {self.band}")


def border_width(depth_fg: NDArray[np.floating], *, up: NDArray[np.floating], intrinsics: CameraIntrinsics,
                 band: float) -> float:
    """Width (m) of the widest foreground part in the band (``band`` of the image) along the image border that is
    "up": the floor normal ``up`` (camera frame) projected into the image at the optical axis.  ``depth_fg``:
    ``(H, W)`` foreground depth (m), NaN or 0 elsewhere."""
    p0 = np.array([0.0, 0.0, 1.0])
    uv = intrinsics.project(np.stack([p0, p0 + 0.1 * np.asarray(up, dtype=np.float64)]))
    du, dv = uv[1] - uv[0]
    h, w = depth_fg.shape
    if abs(dv) >= abs(du):
        b = max(1, int(round(band * h)))
        strip, focal = (depth_fg[:b] if dv <= 0 else depth_fg[h - b :]), intrinsics.fx
        axis = 0
    else:
        b = max(1, int(round(band * w)))
        strip, focal = (depth_fg[:, :b] if du <= 0 else depth_fg[:, w - b :]), intrinsics.fy
        axis = 1
    with np.errstate(invalid="ignore"):
        z = np.where(np.isfinite(strip) & (strip > 0), strip, np.inf).min(axis=axis)
    occupied = np.isfinite(z)
    if not occupied.any():
        return 0.0
    edges = np.flatnonzero(np.diff(np.concatenate([[0], occupied.view(np.int8), [0]])))
    return max(float((stop - start) * np.median(z[start:stop]) / focal)
               for start, stop in zip(edges[::2], edges[1::2], strict=True))


def legs_above(heights: NDArray[np.floating], test: PresenceTest = PresenceTest()) -> bool:
    """The height half of :func:`legs_in_view`: at least ``test.share`` of the points (and 10) higher than
    ``test.height`` above the floor."""
    h = np.asarray(heights)
    return bool(np.count_nonzero(h > test.height) >= max(10.0, test.share * h.shape[0]))


def legs_in_view(heights: NDArray[np.floating], depth_fg: NDArray[np.floating], *, up: NDArray[np.floating],
                 intrinsics: CameraIntrinsics, test: PresenceTest = PresenceTest()) -> bool:
    """Whether the foreground shows legs: at least ``test.share`` of its points (and 10) higher than
    ``test.height`` above the floor (``heights``: ``(N,)``, one per foreground point), or a part at least
    ``test.width`` wide (metres, at its depth) in the ``test.band`` of the image along the border that is "up"
    (:func:`border_width`: the top rows for an upright camera, the bottom rows for one mounted upside down)."""
    if legs_above(heights, test):
        return True
    return border_width(depth_fg, up=up, intrinsics=intrinsics, band=test.band) >= test.width
