"""Does the foreground show legs, or only low things (a walker's wheels and frame, a bag)?

A leg belongs to a body above it, so in the image it rises above knee height or leaves the view through the
border that is "up" for the camera.  A walker's wheel, in view while its user is away, does neither: it is
0.3 m high at most, and its frame's tubes are 1-2 cm wide where they leave the image.  A user close to the walker
(the walker lagging behind, a user leaning on it) has legs nearer than the sensor's range above the shins: the legs
leave the view through pixels without depth before they reach the border (``no_depth``), which counts as reaching it;
a wheel has the floor and the room above it, which have depth.  The tracker ends a
track on foreground that shows no legs (:meth:`walker_gait.core.tracker.LegTracker.legs_in_view`), and the
segmentation's static-structure mask learns what it sees in such frames as the walker's own structure.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from walker_gait.core.types import CameraIntrinsics


_THROUGH_KNOWN = 0.1
"""A foreground pixel leaves the view through pixels without depth (:func:`border_width`) when at most this share of
the pixels between it and the border have depth (a sensor's speckle, flying pixels at the leg's edge)."""


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


def _up_first(image: NDArray[Any], *, up: NDArray[np.floating], intrinsics: CameraIntrinsics
              ) -> tuple[NDArray[Any], float]:
    """``image`` ``(H, W)`` turned so that its row 0 is the border that is "up" (the floor normal ``up``, camera frame,
    projected into the image at the optical axis) and its columns run along that border; and the focal length (px)
    along the border."""
    p0 = np.array([0.0, 0.0, 1.0])
    uv = intrinsics.project(np.stack([p0, p0 + 0.1 * np.asarray(up, dtype=np.float64)]))
    du, dv = uv[1] - uv[0]
    if abs(dv) >= abs(du):
        return (image if dv <= 0 else image[::-1]), intrinsics.fx
    return (image.T if du <= 0 else image[:, ::-1].T), intrinsics.fy


def border_width(depth_fg: NDArray[np.floating], *, up: NDArray[np.floating], intrinsics: CameraIntrinsics,
                 band: float, no_depth: NDArray[np.bool_] | None = None) -> float:
    """Width (m) of the widest foreground part in the band (``band`` of the image) along the image border that is
    "up": the floor normal ``up`` (camera frame) projected into the image at the optical axis.  ``depth_fg``:
    ``(H, W)`` foreground depth (m), NaN or 0 elsewhere.  With ``no_depth`` ``(H, W)`` (pixels without a depth
    measurement that are not background: nearer than the sensor's range, say) a foreground pixel with (nearly) nothing
    but such pixels between it and that border (at most ``_THROUGH_KNOWN`` of them with depth) also leaves the view
    there: a leg nearer than the sensor's range above its shin."""
    oriented, focal = _up_first(np.asarray(depth_fg), up=up, intrinsics=intrinsics)
    b = max(1, int(round(band * oriented.shape[0])))
    strip = oriented[:b]
    with np.errstate(invalid="ignore"):
        z = np.where(np.isfinite(strip) & (strip > 0), strip, np.inf).min(axis=0)
    if no_depth is not None:
        unknown = _up_first(np.asarray(no_depth, dtype=bool), up=up, intrinsics=intrinsics)[0]
        if unknown.shape != oriented.shape:
            raise ValueError(f"no_depth shape {unknown.shape} does not match depth_fg {oriented.shape}")
        with np.errstate(invalid="ignore"):
            fg = np.isfinite(oriented) & (oriented > 0)  # the whole image only here: the band settles most frames
        first = np.argmax(fg, axis=0)  # per column, the first foreground pixel from the border
        cols = np.arange(oriented.shape[1])
        # ... with (nearly) nothing but pixels without depth before it (the sensor's speckle aside)
        known = np.cumsum(~unknown, axis=0, dtype=np.int32)[np.maximum(first - 1, 0), cols]
        through = fg[first, cols] & (first > 0) & (known <= _THROUGH_KNOWN * first)
        z = np.where(np.isfinite(z) | ~through, z, oriented[first, cols])
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
                 intrinsics: CameraIntrinsics, test: PresenceTest = PresenceTest(),
                 no_depth: NDArray[np.bool_] | None = None) -> bool:
    """Whether the foreground shows legs: at least ``test.share`` of its points (and 10) higher than
    ``test.height`` above the floor (``heights``: ``(N,)``, one per foreground point), or a part at least
    ``test.width`` wide (metres, at its depth) in the ``test.band`` of the image along the border that is "up"
    (:func:`border_width`: the top rows for an upright camera, the bottom rows for one mounted upside down), or
    reaching it through pixels without depth (``no_depth``, see :func:`border_width`)."""
    if legs_above(heights, test) or border_width(depth_fg, up=up, intrinsics=intrinsics, band=test.band) >= test.width:
        return True
    # the way out through pixels without depth only where the border alone does not settle it (a close user): it
    # reads the whole image
    return no_depth is not None and border_width(depth_fg, up=up, intrinsics=intrinsics, band=test.band,
                                                 no_depth=no_depth) >= test.width
