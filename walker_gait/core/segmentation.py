"""Floor estimation, region of interest and foreground (leg) segmentation.

Pure numpy (no rclpy).  Units are SI (metres).  Inputs are the depth image
(``(H, W)`` float32 metres, NaN invalid, see :func:`walker_gait.core.depth.decode_depth`)
and its back-projection (``(H, W, 3)`` float32 points in the **camera optical
frame**, see :class:`walker_gait.core.depth.DepthProjector`).

Pipeline of :meth:`Segmenter.process` (seed paper 000 §4.2, plus robustness):

1. floor plane: automatic RANSAC (:func:`fit_floor_ransac`), tracked over time by
   :class:`FloorTracker` (cheap residual check each frame, re-fit when needed);
2. floor removal: either points less than ``RoiConfig.min_height`` above the plane
   (``floor_method="plane"``), or the seed's background-frame subtraction
   (``floor_method="background"``, :class:`BackgroundModel`);
3. region of interest: a box in the floor-aligned **walker frame** (x forward from
   the camera towards the user, y = the camera's left, z up; :class:`RoiConfig`);
4. removal of the walker's own parts: parts thinner than a leg (:func:`thin_parts`), structure that
   keeps its pixels and depth while the user moves (:class:`StaticStructureMask`, on by default) and,
   optionally, what the 3-state occupancy-grid HMM of paper 003 §III-A calls static (:class:`OccupancyHMM`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from os import PathLike
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from walker_gait.core import kernels
from walker_gait.core.presence import legs_above, legs_in_view
from walker_gait.core.types import CameraIntrinsics, FloorPlane

F32 = NDArray[np.float32]
F64 = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

__all__ = [
    "BackgroundModel",
    "BackgroundModelError",
    "FloorConfig",
    "FloorTracker",
    "HmmConfig",
    "OccupancyHMM",
    "RoiConfig",
    "Segmentation",
    "Segmenter",
    "SegmenterConfig",
    "StaticMaskConfig",
    "StaticStructureMask",
    "fit_floor_ransac",
    "invalid_floor",
]


# =========================================================================== floor


@dataclass(kw_only=True)
class FloorConfig:
    """Floor-plane estimation parameters (RANSAC + tracking).

    Distances in metres, angles in degrees, ``z`` = optical-axis depth of a point.
    The plausible-orientation prior is expressed relative to ``up_hint`` (the
    approximate "up" direction in the camera optical frame, default ``-y`` =
    image up), so no particular camera pitch is hard-coded.
    """

    sample_stride: int = 4
    """Pixel stride of the grid subsample of the points image used by RANSAC (px)."""
    check_stride: int = 8
    """Pixel stride of the (cheaper) subsample used for the per-frame check and refinement (px)."""
    max_fit_range: float = 5.0
    """Points farther than this (optical z, m) are not used for the floor (noise grows with z²)."""
    ransac_iterations: int = 200
    """Number of 3-point plane hypotheses per RANSAC run."""
    ransac_max_points: int = 2500
    """Points used to score the hypotheses (random subset of the subsample)."""
    inlier_threshold: float = 0.012
    """Inlier band half-width at zero range (m)."""
    inlier_threshold_per_m2: float = 0.005
    """Growth of the inlier band with squared range (m per m²), applied along the viewing ray and
    projected on the plane normal; Kinect depth noise ~0.0014 z² plus eq. (1) quantisation 0.003 z² steps."""
    up_hint: tuple[float, float, float] = (0.0, -1.0, 0.0)
    """Approximate up direction in the camera optical frame (need not be unit length)."""
    max_tilt_deg: float = 70.0
    """Max angle between a candidate floor normal and ``up_hint`` (deg); walls (~90°) are rejected."""
    auto_flip: bool = True
    """Until a floor was ever found, also search around ``up_hint`` turned half a turn about the optical axis (a
    camera mounted upside down); that orientation is taken, for good, once it alone finds a floor in
    ``FLIP_CONFIRM_ATTEMPTS`` attempts in a row (``FloorTracker.flipped``)."""
    min_camera_height: float = 0.1
    """Plausible camera heights above the floor (m), lower bound."""
    max_camera_height: float = 3.0
    """Plausible camera heights above the floor (m), upper bound."""
    min_inliers: int = 100
    """Minimum number of inliers (at ``sample_stride``; scaled for ``check_stride``) for a floor to be accepted."""
    min_inlier_fraction: float = 0.03
    """Minimum inliers / usable subsample points for a floor to be accepted."""
    lower_plane_support: float = 0.3
    """A plausible plane lying below the best-supported one wins if it has at least this fraction of its support."""
    max_below_fraction: float = 0.05
    """Max fraction of usable points clearly (3 bands) below an accepted floor."""
    refine_iterations: int = 3
    """Least-squares re-fits on the inliers after RANSAC."""
    smoothing: float = 1.0
    """Weight of each new measurement in the exponential smoothing of the tracked plane (0..1]; 1 = none, the
    frame's own least-squares fit.  A walker rocks on its wheels as it rolls (a degree or two of pitch and roll,
    up to ~10 Hz), which moves the floor in the camera frame from frame to frame: smoothed at 0.2 the plane
    lagged it by 0.8-1.3 deg (1-2 cm of height at the feet) at 1 deg RMS of rocking, while the fit of one frame's
    thousands of floor points is within 0.01 deg on a still floor (``make bench``'s floor rows)."""
    refit_interval: int = 90
    """Re-run RANSAC at least every this many frames (frames)."""
    retry_interval: int = 3
    """After a failed RANSAC (no floor visible), wait this many frames before the next attempt (frames)."""
    min_support_ratio: float = 0.5
    """Re-run RANSAC when the near-plane fraction drops below this times its value at the last RANSAC."""
    max_rms_growth: float = 2.0
    """Re-run RANSAC when the residual RMS exceeds this times its value at the last RANSAC."""
    max_jump_deg: float = 8.0
    """A re-fit within this angle (deg) of the tracked plane is smoothed in; larger changes are
    adopted only if the tracked plane lost support."""
    max_jump_m: float = 0.08
    """Same for the plane offset (camera height, m)."""
    reference_frames: int = 60
    """The still walker's floor: the tracked plane averaged over about this many frames (exponentially), to which
    the walker frame's origin and heading are fixed (``FloorPlane.anchor`` / ``heading``), so that a walker rocking
    on its wheels does not shake the walker frame with its camera; restarted when the floor jumps (a re-mounted
    camera, a ramp).  0 = off: the walker frame hangs from the camera (its foot point, its optical axis)."""

    def validate(self) -> None:
        """Raise ``ValueError`` naming the first invalid field."""
        if self.sample_stride < 1 or self.check_stride < 1:
            raise ValueError(
                "floor.sample_stride and floor.check_stride must be >= 1, "
                f"got {self.sample_stride}, {self.check_stride}"
            )
        if self.ransac_iterations < 1 or self.ransac_max_points < 3:
            raise ValueError("floor.ransac_iterations must be >= 1 and floor.ransac_max_points >= 3")
        if not (self.inlier_threshold > 0) or self.inlier_threshold_per_m2 < 0:
            raise ValueError("floor.inlier_threshold must be > 0 and floor.inlier_threshold_per_m2 >= 0")
        up = np.asarray(self.up_hint, dtype=np.float64)
        if up.shape != (3,) or not np.all(np.isfinite(up)) or np.linalg.norm(up) < 1e-9:
            raise ValueError(f"floor.up_hint must be a finite non-zero 3-vector, got {self.up_hint}")
        if not (0 < self.max_tilt_deg <= 90):
            raise ValueError(f"floor.max_tilt_deg must be in (0, 90], got {self.max_tilt_deg}")
        if not (0 <= self.min_camera_height < self.max_camera_height):
            raise ValueError("floor.min_camera_height must be >= 0 and < floor.max_camera_height")
        if not (0 < self.smoothing <= 1):
            raise ValueError(f"floor.smoothing must be in (0, 1], got {self.smoothing}")
        if self.reference_frames < 0:
            raise ValueError(f"floor.reference_frames must be >= 0, got {self.reference_frames}")
        if self.refit_interval < 1 or self.retry_interval < 1:
            raise ValueError(
                "floor.refit_interval and floor.retry_interval must be >= 1, "
                f"got {self.refit_interval}, {self.retry_interval}"
            )


def invalid_floor(config: FloorConfig | None = None) -> FloorPlane:
    """Placeholder plane for "no floor found yet": ``valid=False``, normal = ``up_hint``, offset NaN."""
    up = np.asarray((config or FloorConfig()).up_hint, dtype=np.float64)
    return FloorPlane(
        normal=up / np.linalg.norm(up), offset=float("nan"), rms=float("nan"), inlier_ratio=0.0, valid=False
    )


def _noise_gain(pts: F64, cfg: FloorConfig) -> F64:
    """``k z² / |p|`` per point: times ``|n·p|`` it is the depth noise projected on a plane normal (m)."""
    z = pts[:, 2]
    return cfg.inlier_threshold_per_m2 * z * z / np.maximum(np.linalg.norm(pts, axis=1), 1e-9)


def _band(pts: F64, gain: F64, n: F64, d: float, cfg: FloorConfig) -> F64:
    """Inlier band half-width (m) of each point for plane ``(n, d)``.

    Depth noise acts along the viewing ray, so its component along the plane
    normal is ``k z² |n·p̂|``; for the floor seen at a grazing angle this is much
    smaller than the depth noise itself.
    """
    return cfg.inlier_threshold + gain * np.abs(pts @ n)


def _usable(points: NDArray[np.floating], cfg: FloorConfig) -> F64:
    """Finite points with 0 < z <= max_fit_range, as float64 ``(N, 3)``."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    z = pts[:, 2]
    ok = np.isfinite(pts).all(axis=1) & (z > 0) & (z <= cfg.max_fit_range)
    return pts[ok]


def _lsq_plane(pts: F64) -> tuple[F64, float] | None:
    """Total-least-squares plane ``n·p + d = 0`` (unit n) through ``pts``; None if degenerate."""
    if pts.shape[0] < 3:
        return None
    centroid = pts.mean(axis=0)
    q = pts - centroid
    cov = q.T @ q
    if not np.all(np.isfinite(cov)):
        return None
    w, v = np.linalg.eigh(cov)
    if w[1] <= 1e-12:  # points (nearly) collinear
        return None
    n = v[:, 0]
    return n, float(-n @ centroid)


def _orient_up(n: F64, d: float) -> tuple[F64, float]:
    """Flip the plane so that the camera (origin) is on its positive side (offset >= 0)."""
    return (-n, -d) if d < 0 else (n, d)


def _plausible(n: F64, d: float, cfg: FloorConfig, up: F64) -> bool:
    cos_tilt = math.cos(math.radians(cfg.max_tilt_deg))
    return bool(n @ up >= cos_tilt and cfg.min_camera_height <= d <= cfg.max_camera_height)


def _refine(
    pts: F64, gain: F64, n: F64, d: float, cfg: FloorConfig, up: F64
) -> tuple[F64, float, BoolArray, F64] | None:
    """Iterated least-squares refinement on the inliers of ``(n, d)``; None if it degenerates.

    Returns the plane, the inlier mask and the per-point band of the final plane.
    """
    band = _band(pts, gain, n, d, cfg)
    inl = np.abs(pts @ n + d) < band
    for _ in range(max(1, cfg.refine_iterations)):
        fit = _lsq_plane(pts[inl])
        if fit is None:
            return None
        n_new, d_new = _orient_up(*fit)
        if not _plausible(n_new, d_new, cfg, up):
            return None
        n, d = n_new, d_new
        band = _band(pts, gain, n, d, cfg)
        inl = np.abs(pts @ n + d) < band
    return n, d, inl, band


def fit_floor_ransac(
    points: NDArray[np.floating],
    *,
    rng: np.random.Generator,
    config: FloorConfig | None = None,
) -> FloorPlane:
    """Robustly fit the floor plane to camera-frame points (metres) with RANSAC + least squares.

    ``points`` is ``(N, 3)`` (or any ``(..., 3)``; non-finite rows are ignored),
    camera optical frame.  Candidate planes must be *plausible*: normal within
    ``max_tilt_deg`` of ``up_hint`` and camera height within
    ``[min_camera_height, max_camera_height]``.  Among plausible candidates the
    best-supported one is taken, unless another plausible candidate with at
    least ``lower_plane_support`` of that support lies *below* it (its inliers
    are above the candidate) — the floor is the lowest large horizontal
    surface, so a big box, a seat or the walker's frame cannot win over it.
    The winner is refined by least squares on its inliers.

    Returns a :class:`FloorPlane` with the normal pointing up, ``offset`` = camera
    height (m), ``rms`` of the inlier residuals (m) and ``inlier_ratio`` =
    inliers / usable points; ``valid=False`` (offset NaN) if no plausible floor
    has enough support.  Never raises on degenerate input.
    """
    cfg = config or FloorConfig()
    up = np.asarray(cfg.up_hint, dtype=np.float64)
    up = up / np.linalg.norm(up)
    pts = _usable(points, cfg)
    n_pts = pts.shape[0]
    if n_pts < max(3, cfg.min_inliers):
        return invalid_floor(cfg)
    gain_all = _noise_gain(pts, cfg)

    # scoring subset
    if n_pts > cfg.ransac_max_points:
        sel = rng.choice(n_pts, size=cfg.ransac_max_points, replace=False)
        spts, sgain = pts[sel], gain_all[sel]
    else:
        spts, sgain = pts, gain_all
    m = spts.shape[0]

    # vectorised hypotheses
    tri = rng.integers(0, m, size=(cfg.ransac_iterations, 3))
    a, b, c = spts[tri[:, 0]], spts[tri[:, 1]], spts[tri[:, 2]]
    normals = np.cross(b - a, c - a)
    norms = np.linalg.norm(normals, axis=1)
    good = norms > 1e-9
    if not np.any(good):
        return invalid_floor(cfg)
    normals, a = normals[good] / norms[good, None], a[good]
    offs = -np.einsum("ij,ij->i", normals, a)
    flip = offs < 0
    normals[flip] *= -1.0
    offs[flip] *= -1.0
    cos_tilt = math.cos(math.radians(cfg.max_tilt_deg))
    plaus = (normals @ up >= cos_tilt) & (offs >= cfg.min_camera_height) & (offs <= cfg.max_camera_height)
    if not np.any(plaus):
        return invalid_floor(cfg)
    normals, offs = normals[plaus], offs[plaus]

    proj = spts @ normals.T  # (m, k) n·p
    heights = proj + offs  # signed heights of the scoring points above each candidate
    band = cfg.inlier_threshold + sgain[:, None] * np.abs(proj)
    inlier = np.abs(heights) < band
    support = inlier.sum(axis=0)
    below = (heights < -3.0 * band).sum(axis=0)
    min_support = max(3, int(math.ceil(max(cfg.min_inliers * m / n_pts, cfg.min_inlier_fraction * m))))
    cand = (support >= min_support) & (below <= cfg.max_below_fraction * m)
    if not np.any(cand):
        return invalid_floor(cfg)
    best = int(np.argmax(np.where(cand, support, -1)))
    # prefer a sufficiently supported plausible plane lying below the current choice
    for _ in range(4):
        ref_inl = inlier[:, best]
        if ref_inl.sum() < 3:
            break
        med_h = np.median(heights[ref_inl], axis=0)  # height of best's inliers above each candidate
        lower = (
            cand
            & (support >= cfg.lower_plane_support * support[best])
            & (med_h > 2.0 * np.median(band[ref_inl], axis=0))
        )
        if not np.any(lower):
            break
        best = int(np.argmax(np.where(lower, support, -1)))

    refined = _refine(pts, gain_all, normals[best], float(offs[best]), cfg, up)
    if refined is None:
        return invalid_floor(cfg)
    n, d, inl, band_all = refined
    n_inl = int(inl.sum())
    h = pts @ n + d
    n_below = int((h < -3.0 * band_all).sum())
    if n_inl < max(3, cfg.min_inliers) or n_inl < cfg.min_inlier_fraction * n_pts:
        return invalid_floor(cfg)
    if n_below > cfg.max_below_fraction * n_pts:
        return invalid_floor(cfg)
    rms = float(np.sqrt(np.mean(h[inl] ** 2)))
    return FloorPlane(normal=n, offset=d, rms=rms, inlier_ratio=n_inl / n_pts, valid=True)


def _angle_deg(n1: F64, n2: F64) -> float:
    return math.degrees(math.acos(float(np.clip(n1 @ n2, -1.0, 1.0))))


FLIP_CONFIRM_ATTEMPTS = 3
"""RANSAC attempts in a row in which only the half-turned ``up_hint`` finds a floor before :class:`FloorTracker`
takes it (``FloorConfig.auto_flip``): one frame's plane could be a ceiling or a table top seen from below."""


def _child_rng(rng: np.random.Generator) -> np.random.Generator:
    """An independent Generator derived from ``rng`` without drawing from it (``Generator.spawn``); ``rng`` itself
    where its bit generator cannot spawn (no seed sequence)."""
    try:
        return rng.spawn(1)[0]
    except TypeError:
        return rng


def flipped_up_hint(up_hint: tuple[float, float, float]) -> tuple[float, float, float]:
    """``up_hint`` turned half a turn about the optical axis (+z): the up direction of the camera mounted upside
    down."""
    x, y, z = (float(v) for v in up_hint)
    return (0.0 - x, 0.0 - y, z)  # 0.0 - 0.0 is 0.0, where -0.0 would be written "-0.0"


_FOLLOW_WIDEN = 3.0
"""Band factor of the first least-squares pass with which :class:`FloorTracker` follows a moving floor."""


class FloorTracker:
    """Floor plane of a camera mounted on the walker, followed from frame to frame.

    Each :meth:`update` takes a grid subsample (``check_stride``) of the points, moves the
    tracked plane to this frame's floor (least squares on the points near it, a wider band
    first: the walker rocks as it rolls), measures the near-plane support, the fraction of
    points below the plane and the residual RMS, refines the plane by least squares on the
    near-plane points and blends it in with ``smoothing`` (default 1: none).  RANSAC (:func:`fit_floor_ransac`) runs
    only when no plane is known, when the support drops / the RMS grows / too many
    points lie below the plane, or every ``refit_interval`` frames.  When no floor
    is visible the last plane is kept (``floor_visible`` False); before a floor was
    ever found the plane is :func:`invalid_floor`.

    Counters: ``frames``, ``ransac_runs``, ``ransac_failures``, ``resets``.
    """

    def __init__(self, config: FloorConfig | None = None, *, rng: np.random.Generator) -> None:
        self.config = config or FloorConfig()
        self.config.validate()
        self._rng = rng
        up = np.asarray(self.config.up_hint, dtype=np.float64)
        self._up = up / np.linalg.norm(up)
        self.plane: FloorPlane = invalid_floor(self.config)
        self.frames = 0
        self.ransac_runs = 0
        self.ransac_failures = 0
        self.resets = 0
        self.floor_visible = False
        self.refit_this_frame = False
        self._since_ransac = 0
        self._since_failure = 10**9
        self._ref_support = 0.0
        self._ref_rms = 0.0
        self._still: tuple[F64, float] | None = None  # the still walker's floor (normal, offset), see reference_frames
        self.flipped = False  # the floor was found around the half-turned up_hint (auto_flip), which is used since
        self._ever_found = False
        self._flip_run = 0  # attempts in a row in which only the half-turned up_hint found a floor
        # the half-turned search draws from a child stream (spawning leaves rng's own stream as it is), so a camera
        # mounted upright sees the same random numbers with auto_flip on or off
        self._flip_rng = _child_rng(rng)
        self.last: FloorPlane = self.plane  # the plane :meth:`update` returned last (with anchor and heading)

    def reset(self) -> None:
        """Forget the plane (e.g. after the camera was re-mounted)."""
        self.plane = invalid_floor(self.config)
        self._since_ransac = 0
        self._still = None
        self.resets += 1

    def _subsample(self, points: NDArray[np.floating], s: int) -> F64:
        if points.ndim == 3:
            sub = points[::s, ::s]
        else:
            sub = points.reshape(-1, 3)[::s]
        return _usable(sub, self.config)

    def _check_set(self, points: NDArray[np.floating]) -> tuple[F64, F64]:
        pts = self._subsample(points, self.config.check_stride)
        return pts, _noise_gain(pts, self.config)

    def _band(self, pts: F64, gain: F64, n: F64) -> tuple[F64, F64]:
        """``(pts @ n, inlier band half-width)`` per point for a plane of normal ``n`` (the band grows with range)."""
        proj = pts @ n
        return proj, self.config.inlier_threshold + gain * np.abs(proj)

    def _stats(self, pts: F64, gain: F64, n: F64, d: float) -> tuple[float, float, float, BoolArray]:
        proj, band = self._band(pts, gain, n)
        h = proj + d
        near = np.abs(h) < band
        cnt = int(near.sum())
        support = cnt / max(1, pts.shape[0])
        below = float((h < -3.0 * band).sum()) / max(1, pts.shape[0])
        rms = float(np.sqrt(np.mean(h[near] ** 2))) if cnt else float("inf")
        return support, below, rms, near

    def _run_ransac(self, pts: F64) -> FloorPlane:
        self.ransac_runs += 1
        self._since_ransac = 0
        plane = fit_floor_ransac(pts, rng=self._rng, config=self.config)
        if not plane.valid:
            self.ransac_failures += 1
            self._since_failure = 0
        return plane

    def _try_flipped(self, pts: F64) -> FloorPlane:
        """After a failed attempt before any floor was found: the floor around the half-turned ``up_hint``, taken
        (and the tracker's ``up_hint`` with it) once it has been found in ``FLIP_CONFIRM_ATTEMPTS`` attempts in a
        row; otherwise an invalid plane."""
        flipped = replace(self.config, up_hint=flipped_up_hint(self.config.up_hint))
        plane = fit_floor_ransac(pts, rng=self._flip_rng, config=flipped)
        self._flip_run = self._flip_run + 1 if plane.valid else 0
        if self._flip_run < FLIP_CONFIRM_ATTEMPTS:
            return invalid_floor(self.config)
        self.config = flipped
        up = np.asarray(flipped.up_hint, dtype=np.float64)
        self._up = up / np.linalg.norm(up)
        self.flipped = True
        return plane

    def _may_retry(self) -> bool:
        return self._since_failure >= self.config.retry_interval

    def _adopt(self, plane: FloorPlane, pts: F64, gain: F64) -> None:
        self.plane = plane
        support, _, rms, _ = self._stats(pts, gain, plane.normal, plane.offset)
        self._ref_support = support
        self._ref_rms = max(rms, 1e-4)

    def _blend(self, n_meas: F64, d_meas: float, rms: float, ratio: float) -> None:
        a = self.config.smoothing
        n = (1.0 - a) * self.plane.normal + a * n_meas
        n = n / np.linalg.norm(n)
        d = (1.0 - a) * self.plane.offset + a * d_meas
        self.plane = FloorPlane(normal=n, offset=float(d), rms=rms, inlier_ratio=ratio, valid=True)

    def _follow(self, pts: F64, gain: F64) -> tuple[F64, float]:
        """The tracked plane moved to this frame's floor: least squares on the points near it, first in a band
        ``_FOLLOW_WIDEN`` times wider, then in the usual one.  A walker rocks on its wheels as it rolls (a degree
        or two of pitch and roll, up to ~10 Hz), so the floor moves in the camera frame from one frame to the
        next; measured against the last frame's plane, its far part leaves the inlier band and the support
        test would call the floor lost (a RANSAC every frame).  Falls back to the tracked plane when a fit is
        implausible or jumps more than ``max_jump_deg``."""
        cfg = self.config
        n0, d0 = self.plane.normal, self.plane.offset
        n, d = n0, d0
        for widen in (_FOLLOW_WIDEN, 1.0):
            proj, band = self._band(pts, gain, n)
            near = np.abs(proj + d) < widen * band
            if int(near.sum()) < 3:
                break
            fit = _lsq_plane(pts[near])
            if fit is None:
                break
            n1, d1 = _orient_up(*fit)
            if not _plausible(n1, d1, cfg, self._up) or _angle_deg(n1, n0) > cfg.max_jump_deg:
                break
            n, d = n1, d1
        return n, d

    def update(self, points: NDArray[np.floating]) -> FloorPlane:
        """Update with one frame's camera-frame points (``(H, W, 3)`` image or ``(N, 3)``); return the plane, with
        the still walker's anchor and heading (``reference_frames``) once one is known."""
        resets = self.resets
        plane = self._update(points)
        self.last = self._anchored(plane, resets=resets)
        return self.last

    def _anchored(self, plane: FloorPlane, *, resets: int) -> FloorPlane:
        """``plane`` with the still walker's anchor and heading (``resets``: the reset count before this frame)."""
        cfg = self.config
        if not plane.valid or cfg.reference_frames <= 0:
            return plane
        n, d = np.asarray(plane.normal, dtype=np.float64), float(plane.offset)
        if self.floor_visible:
            still = self._still
            if still is None or self.resets != resets or _angle_deg(still[0], n) > cfg.max_jump_deg:
                self._still = (n.copy(), d)
            else:
                a = 1.0 / cfg.reference_frames
                n_s = (1.0 - a) * still[0] + a * n
                self._still = (n_s / np.linalg.norm(n_s), (1.0 - a) * still[1] + a * d)
        if self._still is None:
            return plane
        n_s, d_s = self._still
        optical = np.array([0.0, 0.0, 1.0])
        heading = optical - (optical @ n_s) * n_s
        if np.linalg.norm(heading) < 1e-6:  # looking straight down: the walker frame's own fallback
            return plane
        return replace(plane, anchor=-d_s * n_s, heading=heading / np.linalg.norm(heading))

    def _update(self, points: NDArray[np.floating]) -> FloorPlane:
        cfg = self.config
        self.frames += 1
        self._since_ransac += 1
        self._since_failure += 1
        self.refit_this_frame = False
        if points.ndim == 3:
            rows, cols = points.shape[0], points.shape[1]
            n_ransac = -(-rows // cfg.sample_stride) * -(-cols // cfg.sample_stride)  # ceil divisions
            n_check = -(-rows // cfg.check_stride) * -(-cols // cfg.check_stride)
        else:
            n = points.reshape(-1, 3).shape[0]
            n_ransac, n_check = -(-n // cfg.sample_stride), -(-n // cfg.check_stride)
        # inlier count needed in the check subsample (min_inliers is given at sample_stride)
        min_check = max(3, int(cfg.min_inliers * n_check / max(1, n_ransac)))

        if not self.plane.valid:
            if not self._may_retry():
                self.floor_visible = False
                return self.plane
            self.refit_this_frame = True
            pts_r = self._subsample(points, cfg.sample_stride)
            plane = self._run_ransac(pts_r)
            if not plane.valid and cfg.auto_flip and not self._ever_found:
                plane = self._try_flipped(pts_r)
            self.floor_visible = plane.valid
            if plane.valid:
                self._ever_found = True
                self._adopt(plane, *self._check_set(points))
            return self.plane

        pts, gain = self._check_set(points)
        if pts.shape[0] < 3:
            self.floor_visible = False
            return self.plane
        n0, d0 = self._follow(pts, gain)
        support, below, rms, near = self._stats(pts, gain, n0, d0)
        lost = (
            support < cfg.min_support_ratio * self._ref_support
            or below > cfg.max_below_fraction
            or int(near.sum()) < min_check
            or rms > max(cfg.max_rms_growth * self._ref_rms, 0.5 * cfg.inlier_threshold)
        )
        if (lost and self._may_retry()) or self._since_ransac >= cfg.refit_interval:
            self.refit_this_frame = True
            plane = self._run_ransac(self._subsample(points, cfg.sample_stride))
            if plane.valid:
                close = (
                    _angle_deg(plane.normal, n0) <= cfg.max_jump_deg and abs(plane.offset - d0) <= cfg.max_jump_m
                )
                if close:
                    self._blend(plane.normal, plane.offset, plane.rms, plane.inlier_ratio)
                    self._ref_support = self._stats(pts, gain, self.plane.normal, self.plane.offset)[0]
                    self._ref_rms = max(plane.rms, 1e-4)
                    self.floor_visible = True
                    return self.plane
                if lost:  # the tracked plane is gone and a different plausible floor is there: jump
                    self._adopt(plane, pts, gain)
                    self.resets += 1
                    self.floor_visible = True
                    return self.plane
                # periodic re-fit disagrees while the tracked plane still holds: keep tracking
            elif lost:
                self.floor_visible = False
                return self.plane
        elif lost:  # waiting for the next RANSAC attempt: keep the plane untouched
            self.floor_visible = False
            return self.plane
        # cheap path: least-squares refinement on the near-plane points, smoothed in
        if int(near.sum()) < min_check:
            self.floor_visible = False
            return self.plane
        fit = _lsq_plane(pts[near])
        if fit is None:
            self.floor_visible = False
            return self.plane
        n1, d1 = _orient_up(*fit)
        if not _plausible(n1, d1, cfg, self._up) or _angle_deg(n1, n0) > cfg.max_jump_deg:
            self.floor_visible = False
            return self.plane
        h = pts[near] @ n1 + d1
        self._blend(n1, d1, float(np.sqrt(np.mean(h * h))), support)
        self.floor_visible = True
        return self.plane


# =========================================================================== ROI


@dataclass(kw_only=True)
class RoiConfig:
    """Region of interest in the floor-aligned walker frame (metres).

    Walker frame (see :mod:`walker_gait.core.types`): origin on the floor below
    the camera, +x = optical axis projected on the floor (from the camera towards
    the user), +y = the **camera's** left (= the image's left, optical -x),
    +z = up.  Seed 000 §4.2: a box 1500 mm forward, 245 mm to the (camera's) left
    and 175 mm to the (camera's) right, no height limit.  Note the seed measures
    the box along the optical axes; here it is floor-aligned (same thing for an
    unpitched camera).  The user's *anatomical* right leg is on the camera's left.
    """

    forward: float = 1.5
    """Max distance forward (walker +x, towards the user) from the camera (m)."""
    left: float = 0.245
    """Max lateral offset to the camera's left (walker +y, image left) (m)."""
    right: float = 0.175
    """Max lateral offset to the camera's right (walker -y, image right) (m)."""
    near: float = 0.0
    """Min forward distance (walker x) (m); excludes the walker's own parts right below the camera."""
    min_height: float = 0.025
    """Points less than this above the floor plane are floor (m); ~3-5 sigma of Kinect noise at 1.5 m."""
    min_height_per_m2: float = 0.002
    """Extra floor band growing with the squared optical depth (m per m²)."""
    max_height: float | None = None
    """Optional max height above the floor (m); None = no limit (seed)."""
    center_max_shift: float = 0.15
    """Auto-centring: the box follows the user's legs sideways by up to this (m), so that a camera
    mounted off the walker's centre line does not cut a leg (the box is kept where the legs' lateral
    centre would be for a centred camera; that centre is measured over the whole band the box can reach,
    so a leg the box cuts does not pull it further off).  0 = a fixed box (seed)."""
    center_deadband: float = 0.05
    """Auto-centring: the box only moves once the legs' lateral centre is more than this (m) off the
    walker's centre line (a user walking a little to one side of a centred camera keeps the fixed box)."""
    center_gain: float = 0.05
    """Auto-centring: fraction of the remaining lateral offset corrected per frame (0.05 at 30 Hz:
    time constant ~0.7 s, so a leg briefly hidden behind the other barely moves the box)."""
    join_edge_parts: bool = False
    """True: foreground beyond the box's sides, within the band the auto-centred box can reach (``center_max_shift``
    either way), is kept where it is one part (8-connected in the image) with foreground inside the box: a leg that
    crosses the box's side is not cut.  The box follows the legs' centre slowly and is 0.42 m wide: a user coming in
    from the side, the box still shifted that way, lands the far foot beyond its other side, and the box took that leg
    away for half a second (synthetic ``absent_start``).  Parts are split where the depth jumps by more than
    ``join_max_jump``, so what stands behind a leg or beside it at another depth does not join it.  Needs
    ``center_max_shift`` > 0.  Off by default: on four synthetic sweeps it put the heels 0.01-0.13 cm nearer and the
    frames over 10 cm at the walker 0.65/0.55/0.37/0.45 -> 0.09/0.12/0.25/0.32 %, but a user walking in was then
    reported from the backward pass 21 cm off for 8 frames (``test_an_arriving_user_is_not_reported_before_...``)
    and set A's step width was worse (eighty-third session, DEVELOPERS.md).  With the backward pass waiting for both
    feet seen at once over three frames (``smoothing.wait_for_both_feet(frames=3, at_once=True)``) the arrival is
    clean, but the step width stays worse where the box stands centred (sets A / C, ``slow_elderly`` 1.02 / 1.30 ->
    1.43 / 1.66 cm, ``normal`` 0.81 / 0.54 -> 0.91 / 0.62; eighty-fourth session): see ``join_centred_only``.  The
    pipeline's backward pass waits for both feet at once with this on (``pipeline.strict_backward_wait``).  False:
    the box cuts (seed)."""
    join_max_jump: float = 0.05
    """Depth step (m) between neighbouring pixels at which ``join_edge_parts`` splits two parts."""
    join_centred_only: bool = False
    """With ``join_edge_parts``: join only foreground the box would hold centred on the walker (no shift) that the
    shifted box has left out: nothing while the box stands centred, where the joined band beyond both sides moved the
    measured feet outwards (step width, eighty-fourth session), and the band the box uncovered as it moved towards one
    side (the far leg of a user walking in from that side, a camera mounted off the centre line).  Not the default:
    on sets C / A, tracker seeds 0 / 1, the heels 2.64 / 2.52 / 2.43 / 2.47 -> 2.60 / 2.51 / 2.38 / 2.56 cm, the
    frames over 10 cm at the walker 0.65 / 0.55 / 0.37 / 0.45 -> 0.25 / 0.25 / 0.41 / 0.73 %, the width unchanged
    where the box stayed centred, but set A seed 1 swapped legs in two runs (0.28 % of its frames; none before) and
    ``baggy_trousers:123`` went 20 frames off (DEVELOPERS.md, eighty-fourth session).  False: the whole band the
    auto-centred box can reach either way."""

    def validate(self) -> None:
        """Raise ``ValueError`` naming the first invalid field."""
        if not (math.isfinite(self.center_max_shift) and self.center_max_shift >= 0):
            raise ValueError(f"roi.center_max_shift must be finite and >= 0, got {self.center_max_shift}")
        if not (math.isfinite(self.join_max_jump) and self.join_max_jump > 0):
            raise ValueError(f"roi.join_max_jump must be finite and > 0, got {self.join_max_jump}")
        if not (math.isfinite(self.center_deadband) and self.center_deadband >= 0):
            raise ValueError(f"roi.center_deadband must be finite and >= 0, got {self.center_deadband}")
        if not (0 <= self.center_gain <= 1):
            raise ValueError(f"roi.center_gain must be in [0, 1], got {self.center_gain}")
        for name in ("forward", "left", "right", "min_height_per_m2"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"roi.{name} must be finite and >= 0, got {v}")
        if not (math.isfinite(self.near) and 0 <= self.near < self.forward):
            raise ValueError(f"roi.near must be in [0, forward), got {self.near}")
        if not math.isfinite(self.min_height):
            raise ValueError(f"roi.min_height must be finite, got {self.min_height}")
        if self.max_height is not None and not (self.max_height > self.min_height):
            raise ValueError(f"roi.max_height must be > min_height or None, got {self.max_height}")


# =========================================================================== background (seed)


class BackgroundModelError(ValueError):
    """A background model file or frame is unusable."""


class BackgroundModel:
    """Per-pixel background depth learned from frames of the empty scene (seed 000 §4.2).

    ``depth`` is ``(H, W)`` float32 metres, NaN where the background had no
    reliable reading.  A pixel is foreground when it is valid and nearer than
    the background by more than ``threshold + threshold_per_m2 * z_bg²`` — a
    constant threshold in raw Kinect disparity units corresponds to
    ``0.00307 * z² * units`` metres (eq. (1)); pixels farther than (behind) the
    background are background.
    """

    FILE_VERSION = 1

    def __init__(self, depth_m: NDArray[np.floating], *, n_frames: int = 1) -> None:
        arr = np.asarray(depth_m, dtype=np.float32)
        if arr.ndim != 2 or arr.size == 0:
            raise BackgroundModelError(f"background depth must be a non-empty 2-D image, got shape {arr.shape}")
        self.depth: F32 = np.where(np.isfinite(arr) & (arr > 0), arr, np.float32(np.nan)).astype(np.float32)
        self.n_frames = int(n_frames)

    @property
    def shape(self) -> tuple[int, int]:
        """``(H, W)`` of the images this model applies to."""
        return (int(self.depth.shape[0]), int(self.depth.shape[1]))

    @classmethod
    def from_frames(cls, frames: Iterable[NDArray[np.floating]], *, min_valid_fraction: float = 0.5) -> BackgroundModel:
        """Per-pixel median of valid depths over ``frames``; pixels valid in fewer than
        ``min_valid_fraction`` of the frames get NaN."""
        stack = [np.asarray(f, dtype=np.float32) for f in frames]
        if not stack:
            raise BackgroundModelError("no frames to learn the background from")
        shape = stack[0].shape
        if any(f.shape != shape for f in stack):
            raise BackgroundModelError("background frames have different shapes")
        cube = np.stack(stack)
        cube[~(np.isfinite(cube) & (cube > 0))] = np.nan
        n_valid = np.isfinite(cube).sum(axis=0)
        # per-pixel median of the valid values (np.nanmedian is very slow on mostly-NaN stacks):
        # NaN sorts last, so the valid values are the first n_valid entries of each column
        cube.sort(axis=0)
        lo = np.maximum(n_valid - 1, 0) // 2
        hi = np.maximum(n_valid, 1) // 2
        a = np.take_along_axis(cube, lo[None], axis=0)[0]
        b = np.take_along_axis(cube, np.minimum(hi, len(stack) - 1)[None], axis=0)[0]
        med = np.where(n_valid % 2 == 1, a, 0.5 * (a + b)).astype(np.float32)
        med[n_valid < max(1, math.ceil(min_valid_fraction * len(stack)))] = np.nan
        return cls(med, n_frames=len(stack))

    def save(self, path: str | PathLike[str]) -> None:
        """Write the model to a ``.npz`` file (``depth`` float32 metres, ``n_frames``, ``version``)."""
        with Path(path).open("wb") as fh:
            np.savez_compressed(
                fh, depth=self.depth, n_frames=np.int64(self.n_frames), version=np.int64(self.FILE_VERSION)
            )

    @classmethod
    def load(cls, path: str | PathLike[str]) -> BackgroundModel:
        """Read a model written by :meth:`save`; raises :class:`BackgroundModelError` if unusable."""
        try:
            with np.load(Path(path), allow_pickle=False) as data:
                if "depth" not in data.files:
                    raise BackgroundModelError(f"{path}: not a background model (no 'depth' array)")
                version = int(data["version"]) if "version" in data.files else cls.FILE_VERSION
                if version != cls.FILE_VERSION:
                    raise BackgroundModelError(f"{path}: unsupported background model version {version}")
                depth = np.asarray(data["depth"])
                n_frames = int(data["n_frames"]) if "n_frames" in data.files else 1
        except (OSError, ValueError) as exc:
            if isinstance(exc, BackgroundModelError):
                raise
            raise BackgroundModelError(f"{path}: cannot read background model ({exc})") from exc
        return cls(depth, n_frames=n_frames)

    def foreground_mask(
        self, depth_m: NDArray[np.floating], *, threshold: float = 0.02, threshold_per_m2: float = 0.0092
    ) -> BoolArray:
        """``(H, W)`` bool: valid pixels nearer than the background by more than the threshold (m).

        Pixels without background reading count as foreground when valid.
        """
        if depth_m.shape != self.depth.shape:
            raise BackgroundModelError(
                f"depth image shape {depth_m.shape} does not match background model shape {self.depth.shape}"
            )
        bg = self.depth
        thr = threshold + threshold_per_m2 * bg * bg
        closer = depth_m < bg - thr  # False where either is NaN
        no_bg = np.isnan(bg) & (depth_m > 0)  # NaN depth compares False
        return closer | no_bg


# =========================================================================== thin structures


def _run_lengths(mask: BoolArray) -> NDArray[np.int32]:
    """Length (px) of the horizontal run of True pixels each pixel of ``mask`` belongs to (0 if False)."""
    h, w = mask.shape
    padded = np.zeros((h, w + 1), dtype=bool)
    padded[:, :w] = mask
    flat = padded.ravel()
    starts = flat.copy()
    starts[1:] &= ~flat[:-1]
    run_id = np.cumsum(starts, dtype=np.int32)
    run_id *= flat
    counts = np.bincount(run_id).astype(np.int32)
    counts[0] = 0
    return counts[run_id].reshape(h, w + 1)[:, :w]


def thin_parts(mask: BoolArray, depth: NDArray[np.floating], *, fx: float, fy: float, min_width: float,
               close_px: int = 7, stride: int = 2) -> BoolArray:
    """Pixels of ``mask`` on structures thinner than ``min_width`` metres across or along the rows.

    The width of each pixel's horizontal (vertical) run of foreground, in pixels, times its depth
    over ``fx`` (``fy``) is the structure's metric width there.  Runs are measured on the mask
    closed by ``close_px`` so that depth dropouts inside a leg (fabric, noise) do not split it.
    A back leg's visible sliver is contiguous with the front leg in the mask, so it is kept.
    Works on the mask's bounding box sub-sampled by ``stride`` (a 2 cm tube at 2 m is still
    ~2-3 px wide there).
    """
    import cv2

    out = np.zeros(mask.shape, dtype=bool)
    rows = np.flatnonzero(mask.any(axis=1))
    if rows.size == 0:
        return out
    cols = np.flatnonzero(mask.any(axis=0))
    r0, r1, c0, c1 = int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
    m = mask[r0:r1:stride, c0:c1:stride]
    z = depth[r0:r1:stride, c0:c1:stride].astype(np.float32)  # read only where m (True = valid depth)
    closed = m
    k = max(1, close_px // stride)
    if k > 1:
        closed = cv2.morphologyEx(m.astype(np.uint8), cv2.MORPH_CLOSE, np.ones((k, k), np.uint8)).astype(bool) | m
    jit = kernels.compiled()
    if jit is not None:  # the runs, widths and verdicts in one compiled pass, bit for bit as below (tested)
        jit.thin_parts(np.ascontiguousarray(closed), np.ascontiguousarray(m), np.ascontiguousarray(z),
                       float(np.float32(stride / fx)), float(np.float32(stride / fy)), float(min_width),
                       np.ascontiguousarray(mask, dtype=bool), r0, c0, stride, out)
        return out
    across = _run_lengths(closed) * z * np.float32(stride / fx)
    along = _run_lengths(np.ascontiguousarray(closed.T)).T * z * np.float32(stride / fy)
    thin = m & ((across < min_width) | (along < min_width))
    # back to full resolution: each full-res pixel takes its sub-sampled cell's verdict
    if stride > 1:
        thin = np.repeat(np.repeat(thin, stride, axis=0)[: r1 - r0], stride, axis=1)[:, : c1 - c0]
    out[r0:r1, c0:c1] = thin
    out &= mask
    return out


# =========================================================================== occupancy HMM (paper 003)


@dataclass(kw_only=True)
class HmmConfig:
    """Three-state occupancy-grid HMM of paper 003 §III-A (states O static, M moving, E empty).

    Transitions per frame: O→E ``alpha``, E→M ``beta``, M→E ``gamma``, M→O ``psi``
    (003: α=0.01, β=0.1, γ=0.4, ψ=e^-38, 5 cm cells).  Observation f(ε), ε = d − l
    (measured depth minus voxel depth, m): see :meth:`OccupancyHMM.observation`.
    """

    cell_size: float = 0.05
    """Voxel edge (m)."""
    alpha: float = 0.01
    """Transition probability O → E per frame (static structure disappears)."""
    beta: float = 0.1
    """Transition probability E → M per frame (something appears)."""
    gamma: float = 0.4
    """Transition probability M → E per frame (a moving object leaves)."""
    psi: float = math.exp(-38.0)
    """Transition probability M → O per frame (a moved object settles; 003: e^-38)."""
    p_hit: float = 0.9
    """f(ε≈0): likelihood of an occupied state when the voxel holds foreground points."""
    p_free: float = 0.1
    """f(ε>0): likelihood of an occupied state when the camera sees through the voxel."""
    p_unknown: float = 0.5
    """f(ε<0) (voxel hidden behind a surface) and missing depth: no information."""
    free_margin: float = 0.03
    """ε must exceed this (m) for a voxel to be seen through (absorbs depth noise)."""
    min_points: int = 3
    """Foreground points needed in a voxel to observe it as occupied."""
    max_height: float = 1.2
    """Top of the grid above the floor (m)."""
    init_occupied_static: bool = False
    """Initialise cells occupied in the first frame as static (003's "static scene at start"): removes
    the walker's frame at once, but feet/legs in view at start are static until they move away and
    low cells whose free space is hard to observe stay static.  False: every cell starts empty and
    static structure is recognised after ~76 frames (ψ = e^-38)."""

    def validate(self) -> None:
        if not (self.cell_size > 0):
            raise ValueError(f"hmm.cell_size must be > 0, got {self.cell_size}")
        for name in ("alpha", "beta", "gamma", "psi", "p_hit", "p_free", "p_unknown"):
            v = getattr(self, name)
            if not (0 <= v <= 1):
                raise ValueError(f"hmm.{name} must be a probability, got {v}")
        if self.gamma + self.psi > 1:
            raise ValueError("hmm.gamma + hmm.psi must be <= 1")
        if not (self.max_height > 0):
            raise ValueError(f"hmm.max_height must be > 0, got {self.max_height}")


STATE_STATIC, STATE_MOVING, STATE_EMPTY = 0, 1, 2


class OccupancyHMM:
    """Voxel grid over the ROI box (walker frame) whose cells follow 003's three-state HMM.

    Rows/cols of the state distribution are ordered (O, M, E).  Per frame:
    ``Q_t ∝ (Q_{t-1}ᵀ A) ⊙ [f, f, 1−f]`` (003), then MAP classification.  Foreground
    points in cells whose MAP state is O (static in the camera frame, e.g. the
    walker's own frame) are dropped; moving legs stay M.  All cells start empty
    (see ``HmmConfig.init_occupied_static`` for 003's static-scene initialisation), so
    static structure is recognised after ~76 frames.  Note: a leg that stays
    completely still for ~2-3 s (≈ 38 / ln((1−α)/(1−γ)) ≈ 76 frames) also becomes
    static — this is 003's design (moved furniture settles), hence off by default.
    """

    def __init__(self, config: HmmConfig, roi: RoiConfig) -> None:
        config.validate()
        self.config = config
        cs = config.cell_size
        self.origin = np.array([roi.near, -roi.right, 0.0])
        self.dims = (
            max(1, math.ceil((roi.forward - roi.near) / cs)),
            max(1, math.ceil((roi.left + roi.right) / cs)),
            max(1, math.ceil(config.max_height / cs)),
        )
        n = int(np.prod(self.dims))
        self.q: F64 = np.full((n, 3), 1.0 / 3.0)
        a, b, g, p = config.alpha, config.beta, config.gamma, config.psi
        self.transition: F64 = np.array([[1 - a, 0.0, a], [p, 1 - g - p, g], [0.0, b, 1 - b]])
        ix, iy, iz = np.meshgrid(*(np.arange(k) for k in self.dims), indexing="ij")
        self._centres: F64 = self.origin + (np.stack([ix, iy, iz], axis=-1).reshape(-1, 3) + 0.5) * cs
        self.states: NDArray[np.int8] = np.full(n, STATE_EMPTY, dtype=np.int8)
        self.updates = 0

    def observation(self, eps: F64, hit: BoolArray) -> F64:
        """f(ε): likelihood of the occupied states (O, M) per voxel; E gets 1 − f.

        Shape of 003 Fig. 3 (reproduced qualitatively; the paper gives no numbers):
        ``p_hit`` when the voxel holds foreground points (ε ≈ 0), ``p_free`` when the
        measured surface is behind the voxel (ε > ``free_margin``: seen through),
        ``p_unknown`` when the voxel is hidden (ε < 0), unobserved or the depth is missing.
        """
        cfg = self.config
        f = np.full(eps.shape, cfg.p_unknown)
        f[eps > cfg.free_margin] = cfg.p_free  # NaN compares False -> unknown
        f[hit] = cfg.p_hit
        return f

    def cell_index_xyz(
        self, x: NDArray[np.floating], y: NDArray[np.floating], z: NDArray[np.floating]
    ) -> NDArray[np.intp]:
        """Flat cell index of walker-frame coordinates given as 1-D arrays (m); -1 outside the grid."""
        inv = 1.0 / self.config.cell_size
        nx, ny, nz = self.dims
        with np.errstate(invalid="ignore", over="ignore"):
            fx = (np.asarray(x, dtype=np.float32) - np.float32(self.origin[0])) * np.float32(inv)
            fy = (np.asarray(y, dtype=np.float32) - np.float32(self.origin[1])) * np.float32(inv)
            fz = (np.asarray(z, dtype=np.float32) - np.float32(self.origin[2])) * np.float32(inv)
            inside = fx >= 0  # NaN -> False
            inside &= fx < nx
            inside &= fy >= 0
            inside &= fy < ny
            inside &= fz >= 0
            inside &= fz < nz
        flat = np.full(inside.shape, -1, dtype=np.intp)
        # non-negative, so truncation == floor
        flat[inside] = (fx[inside].astype(np.intp) * ny + fy[inside].astype(np.intp)) * nz + fz[inside].astype(np.intp)
        return flat

    def cell_index(self, points_walker: NDArray[np.floating]) -> NDArray[np.intp]:
        """Flat cell index of ``(N, 3)`` walker-frame points (m); -1 outside the grid."""
        p = np.asarray(points_walker, dtype=np.float64).reshape(-1, 3)
        return self.cell_index_xyz(p[:, 0], p[:, 1], p[:, 2])

    def update(
        self,
        *,
        points_walker: NDArray[np.floating] | None = None,
        floor: FloorPlane,
        depth_m: NDArray[np.floating] | None = None,
        intrinsics: CameraIntrinsics | None = None,
        cells: NDArray[np.intp] | None = None,
    ) -> NDArray[np.int8]:
        """One HMM step from this frame's candidate foreground points (walker frame, ``(N, 3)``, m).

        ``cells`` may replace ``points_walker`` with precomputed :meth:`cell_index` values.
        Free-space evidence needs ``depth_m`` and ``intrinsics`` (voxel centres are
        projected into the depth image); without them only hits are used.
        Returns the MAP state per cell (0 = O, 1 = M, 2 = E).
        """
        n_cells = self.q.shape[0]
        if cells is None:
            cells = self.cell_index(np.empty((0, 3)) if points_walker is None else points_walker)
        counts = np.bincount(cells[cells >= 0], minlength=n_cells)
        hit = counts >= self.config.min_points
        eps = np.full(n_cells, np.nan)
        if depth_m is not None and intrinsics is not None and floor.valid and depth_m.ndim == 2:
            rot, t = floor.walker_transform()
            cam = (self._centres - t) @ rot  # p_cam = Rᵀ (p_walker − t)
            uv = intrinsics.project(cam)
            with np.errstate(invalid="ignore"):
                u = np.rint(uv[:, 0])
                v = np.rint(uv[:, 1])
                ok = (u >= 0) & (u < depth_m.shape[1]) & (v >= 0) & (v < depth_m.shape[0])
            ui, vi = u[ok].astype(np.intp), v[ok].astype(np.intp)
            eps[ok] = depth_m[vi, ui] - cam[ok, 2]
        f = self.observation(eps, hit)
        if self.updates == 0:
            self.q = np.zeros_like(self.q)
            if self.config.init_occupied_static:
                # 003 assumes a static scene at initialisation: what is occupied now is background
                self.q[hit, STATE_STATIC] = 1.0
                self.q[~hit, STATE_EMPTY] = 1.0
                self.states = np.argmax(self.q, axis=1).astype(np.int8)
                self.updates += 1
                return self.states
            self.q[:, STATE_EMPTY] = 1.0  # then the regular step below
        pred = self.q @ self.transition
        pred[:, 0] *= f
        pred[:, 1] *= f
        pred[:, 2] *= 1.0 - f
        total = pred.sum(axis=1, keepdims=True)
        bad = ~(total[:, 0] > 0)
        pred[bad] = 1.0 / 3.0
        total[bad] = 1.0
        self.q = pred / total
        self.states = np.argmax(self.q, axis=1).astype(np.int8)
        self.updates += 1
        return self.states

    def static_cells(self, cells: NDArray[np.intp]) -> BoolArray:
        """Bool per cell index (-1 = outside): the cell's MAP state is static (O)."""
        out = np.zeros(cells.shape[0], dtype=bool)
        inside = cells >= 0
        out[inside] = self.states[cells[inside]] == STATE_STATIC
        return out

    def static_points(self, points_walker: NDArray[np.floating]) -> BoolArray:
        """Bool per ``(N, 3)`` walker-frame point: it lies in a cell whose MAP state is static (O)."""
        return self.static_cells(self.cell_index(points_walker))


# =========================================================================== static structure (camera frame)


@dataclass(kw_only=True)
class StaticMaskConfig:
    """Removal of structure that stays put in the camera frame while the scene moves (:class:`StaticStructureMask`)."""

    enabled: bool = True
    """Learn and remove static structure (the walker's own wheels and frame, an object carried on it)."""
    frames: int = 60
    """Moving frames (see ``motion_fraction``) a pixel's depth must stay unchanged before it counts as
    structure (60 = 2 s of the user moving at 30 Hz)."""
    tolerance: float = 0.03
    """Depth change (m, at zero range) still counted as "unchanged"."""
    tolerance_per_m2: float = 0.0092
    """Growth of the tolerance with the squared depth (m per m²; Kinect disparity noise)."""
    motion_fraction: float = 0.03
    """A frame counts as moving when at least this fraction of the candidate cells changed depth
    (something moved: the user).  Frames in which nothing moves (a user standing still, an empty
    view) teach nothing, so legs standing still are never learned as structure (but see ``still_weight``
    for a view that has not changed since it began)."""
    grid_stride: int = 4
    """Image pixels per model cell along each axis (the model runs on a sub-sampled grid)."""
    still_weight: float = 0.2
    """Until the first moving frame in view (a scene unchanged since the camera started: the walker waiting
    for its user, its wheels in the region of interest), each still frame counts this much of a moving frame
    for the cells that keep their depth (0 = still frames teach nothing)."""
    still_share: float = 0.67
    """Those still frames may make up at most this share of ``frames``: structure always needs some moving
    frames as well, so a user who stood still from the start is not learned before walking off."""
    learn_without_legs: bool = True
    """Frames whose foreground (where the box can reach) shows no legs count as moving frames: nothing rises
    above knee height or leaves the image through its top border, directly or through pixels without depth (a
    close user's legs nearer than the sensor's range; the tracker's presence test,
    :func:`walker_gait.core.presence.legs_in_view`), so what is there is not a user but the walker's own structure
    (a rear wheel waiting with the walker for its user), learned in ``frames`` frames instead of being taken for a
    pair of legs when the user walks in."""

    def validate(self) -> None:
        if not (math.isfinite(self.still_weight) and self.still_weight >= 0):
            raise ValueError(f"static_mask.still_weight must be >= 0 and finite, got {self.still_weight}")
        if not 0 <= self.still_share < 1:
            raise ValueError(f"static_mask.still_share must be in [0, 1), got {self.still_share}")
        if self.frames < 1:
            raise ValueError(f"static_mask.frames must be >= 1, got {self.frames}")
        if not (self.tolerance >= 0 and self.tolerance_per_m2 >= 0):
            raise ValueError("static_mask tolerances must be >= 0")
        if not (0 < self.motion_fraction <= 1):
            raise ValueError(f"static_mask.motion_fraction must be in (0, 1], got {self.motion_fraction}")
        if self.grid_stride < 1:
            raise ValueError(f"static_mask.grid_stride must be >= 1, got {self.grid_stride}")


_MIN_MOVING_CELLS = 8  # fewer changed cells than this never make a moving frame (edge flicker)


class StaticStructureMask:
    """Per-pixel model of foreground that does not move in the camera frame while the user does.

    The camera rides on the walker, so the walker's own parts (rear wheels seen face-on, frame, a
    basket) sit at the same pixels and depths in every frame, and a region of interest that follows
    the user sideways can take them in.  Per cell of a sub-sampled grid the model keeps a reference
    depth and counts the *moving* frames in which the cell still shows it: frames in which a
    noticeable part of the candidate foreground changed depth, i.e. the user moved.  A cell counted
    ``frames`` times is structure; its pixels are removed wherever they still show the reference
    depth, so a leg passing in front of a wheel stays foreground.  A cell through which the camera
    sees farther than the reference (the structure has gone) or, before it is learned, something
    nearer is re-learned from scratch.  A user standing still makes no moving frames, so still legs
    are not learned; one leg held still for ``frames`` moving frames of the other one (the walker
    stopped) would be, until it moves.  Until the first moving frame, still frames count too, at
    ``still_weight`` each and up to ``still_share`` of ``frames``: a walker whose user is still out of
    view shows nothing but its own structure, which is then learned after the first ``frames x (1 -
    still_share)`` moving frames (20 instead of 60) instead of being taken for a pair of legs while the user
    walks in; and frames whose candidates show no legs at all (``learn_without_legs``: nothing above knee height,
    nothing leaving the image through its top border) count in full, moving or not, so structure in view while
    the user is away is learned before the user arrives.
    """

    def __init__(self, config: StaticMaskConfig | None = None) -> None:
        self.config = config or StaticMaskConfig()
        self.config.validate()
        self._ref: F32 = np.empty((0, 0), dtype=np.float32)
        self._count: NDArray[np.float32] = np.empty((0, 0), dtype=np.float32)
        self._shape: tuple[int, int] = (0, 0)
        self._seeded = False  # the next frame starts a view whose structure was given (:meth:`seed`)
        self.moving_frames = 0
        """Moving frames seen so far."""

    def structure(self) -> F32 | None:
        """The learned structure: ``(h, w)`` reference depths (m) of the learned cells, NaN elsewhere (sub-sampled
        grid); None before any frame or with nothing learned."""
        learned = self.learned
        if not learned.any():
            return None
        return np.where(learned, self._ref, np.float32(np.nan)).astype(np.float32)

    def seed(self, structure: F32, shape: tuple[int, int]) -> None:
        """Start from ``structure`` (:meth:`structure` of a mask that has seen the same camera's ``(H, W)`` images,
        e.g. a pass over the whole recording): its cells count as learned from the first frame on, everything
        else is learned as usual.  The first frame then still counts as the view's first (no motion in it)."""
        s = self.config.grid_stride
        grid = ((shape[0] + s - 1) // s, (shape[1] + s - 1) // s)
        if structure.shape != grid:
            raise ValueError(f"structure grid {structure.shape} does not fit {shape} images at stride {s} ({grid})")
        self._shape = (int(shape[0]), int(shape[1]))
        self._ref = structure.astype(np.float32, copy=True)
        self._count = np.where(np.isfinite(self._ref), self.config.frames, 0).astype(np.float32)
        self.moving_frames = 0
        self._seeded = True

    @property
    def image_shape(self) -> tuple[int, int]:
        """``(H, W)`` of the images the model has learned from ((0, 0) before any)."""
        return self._shape

    @property
    def learned(self) -> BoolArray:
        """``(h, w)`` cells currently counted as static structure (sub-sampled grid)."""
        return self._count >= self.config.frames

    def _tol(self, z: F32) -> F32:
        c = self.config
        return (np.float32(c.tolerance) + np.float32(c.tolerance_per_m2) * z * z).astype(np.float32, copy=False)

    def update(self, depth_m: F32, candidates: BoolArray, *, no_legs: bool = False) -> bool:
        """Learn from one frame: ``depth_m`` ``(H, W)`` float32 m (NaN invalid), ``candidates`` ``(H, W)`` the
        pixels that could be foreground (above the floor, in the reach of the region of interest); ``no_legs``:
        the candidates show no legs, so whatever keeps its depth is structure (counts as in a moving frame, with
        ``learn_without_legs``).  Returns whether the frame counted as moving."""
        s = self.config.grid_stride
        z = depth_m[::s, ::s]
        cand = candidates[::s, ::s]
        reset = self._shape != depth_m.shape
        first = reset or self._seeded  # a view's first frame: everything in it is new, which is no motion
        self._seeded = False
        if reset:
            self._shape = (int(depth_m.shape[0]), int(depth_m.shape[1]))
            self._ref = np.full(z.shape, np.nan, dtype=np.float32)
            self._count = np.zeros(z.shape, dtype=np.float32)
            self.moving_frames = 0
        ref, count = self._ref, self._count
        with np.errstate(invalid="ignore"):
            valid = z > 0  # NaN -> False
            has = np.isfinite(ref)
            tol = self._tol(np.where(has, ref, z))
            diff = z - ref
            same = has & valid & (np.abs(diff) <= tol)
            farther = has & valid & (diff > tol)
            nearer = has & valid & (diff < -tol) & (count < self.config.frames)
        new = ~has & valid & cand
        changed = farther | nearer | new
        n_changed = int(np.count_nonzero(changed))
        moving = not first and n_changed >= max(_MIN_MOVING_CELLS,
                                                self.config.motion_fraction * int(np.count_nonzero(cand)))
        keep = same & cand
        ref[keep] += np.float32(0.1) * diff[keep]  # follow slow drift (temperature, noise)
        if moving:
            count[keep] += 1
            self.moving_frames += 1
        elif no_legs and self.config.learn_without_legs and not first:
            count[keep] += 1
        elif self.moving_frames == 0 and not first and self.config.still_weight > 0:
            # nothing has moved since the view began: what stays put counts, partly (see still_weight)
            cap = np.float32(self.config.still_share * self.config.frames)
            ck = count[keep]
            count[keep] = np.maximum(ck, np.minimum(ck + np.float32(self.config.still_weight), cap))
        relearn = changed & cand
        ref[relearn] = z[relearn]
        count[changed] = 0
        gone = farther & ~cand
        ref[gone] = np.nan
        return moving

    def static_pixels(self, depth_m: F32, mask: BoolArray) -> BoolArray:
        """``(H, W)`` pixels of ``mask`` that show learned structure (at its reference depth, within the
        tolerance).  Each learned cell also claims its 8 neighbours' pixels, so the edges of a part are
        removed with it."""
        out = np.zeros(mask.shape, dtype=bool)
        if self._shape != mask.shape:
            return out
        learned = self.learned
        if not learned.any():
            return out
        import cv2

        s = self.config.grid_stride
        ref = np.where(learned, self._ref, np.float32(0.0))
        grown = cv2.dilate(ref, np.ones((3, 3), np.uint8))  # the farthest learned reference around each cell
        grown = np.where(learned, ref, grown)  # a learned cell keeps its own reference
        jit = kernels.compiled()
        if jit is not None:  # one pass, bit for bit as the numpy code below (tested)
            c = self.config
            jit.static_pixels(np.ascontiguousarray(grown, dtype=np.float32), np.ascontiguousarray(depth_m,
                              dtype=np.float32), np.ascontiguousarray(mask, dtype=bool), s, np.float32(c.tolerance),
                              np.float32(c.tolerance_per_m2), out)
            return out
        h, w = mask.shape
        full = np.repeat(np.repeat(grown, s, axis=0), s, axis=1)[:h, :w]
        with np.errstate(invalid="ignore"):
            out = mask & (full > 0) & (np.abs(depth_m - full) <= self._tol(full))
        return out


# =========================================================================== segmenter


FLOOR_METHODS: tuple[str, ...] = ("plane", "background")


@dataclass(kw_only=True)
class SegmenterConfig:
    """Foreground segmentation parameters (become ROS parameters; nested names like ``roi.forward``)."""

    floor_method: str = "plane"
    """``"plane"``: points below ``roi.min_height`` above the fitted floor are floor;
    ``"background"``: the seed's per-pixel background-frame subtraction."""
    roi: RoiConfig = field(default_factory=RoiConfig)
    floor: FloorConfig = field(default_factory=FloorConfig)
    min_range: float = 0.2
    """Depths nearer than this (m) are ignored."""
    max_range: float = 8.0
    """Depths farther than this (m) are ignored."""
    no_depth_frames: int = 30
    """Pixels without depth in most of about this many recent frames (an exponential average, see
    ``no_depth_persistent``) are background, not unknown, in ``Segmentation.no_depth``: the walker's own
    parts nearer than the sensor reaches, a dead image border; a leg passing in front of the lens leaves a hole
    for a fraction of a second (0 = every pixel without depth is unknown)."""
    no_depth_persistent: float = 0.9
    """Average share of recent frames without depth over which a pixel's missing depth is persistent."""
    background_threshold: float = 0.02
    """Background subtraction threshold at zero range (m)."""
    background_threshold_per_m2: float = 0.0092
    """Growth of the background threshold with the squared background depth (m per m²);
    0.0092 = 3 raw Kinect disparity units via eq. (1)."""
    background_frames: int = 30
    """Frames of the empty scene learned as background when no model is given (frames)."""
    background_path: str = ""
    """``.npz`` background model to load at start ("" = learn from the first ``background_frames``)."""
    require_floor: bool = True
    """With no floor plane ever found, output an empty foreground (True) or — background method
    only — fall back to a camera-frame box (False)."""
    min_part_width: float = 0.045
    """Foreground thinner than this (m), across or along the image rows, is dropped: a walker's own
    tubes (posts, side bars, wheels seen edge-on: 2-4 cm) that reach into the ROI on other mounts;
    legs, trousers and shoes are wider (≥ ~7 cm).  0 = keep everything (seed)."""
    static_mask: StaticMaskConfig = field(default_factory=StaticMaskConfig)
    """Removal of structure that stays put in the camera frame while the user moves (:class:`StaticStructureMask`)."""
    use_occupancy_hmm: bool = False
    """Remove structure static in the camera frame with :class:`OccupancyHMM`."""
    hmm: HmmConfig = field(default_factory=HmmConfig)

    def validate(self) -> None:
        """Raise ``ValueError`` naming the first invalid field."""
        if self.floor_method not in FLOOR_METHODS:
            raise ValueError(f"floor_method must be one of {FLOOR_METHODS}, got {self.floor_method!r}")
        if not (0 <= self.min_range < self.max_range):
            raise ValueError(f"need 0 <= min_range < max_range, got {self.min_range}, {self.max_range}")
        if self.no_depth_frames < 0:
            raise ValueError(f"no_depth_frames must be >= 0, got {self.no_depth_frames}")
        if not (0.0 < self.no_depth_persistent <= 1.0):
            raise ValueError(f"no_depth_persistent must be in (0, 1], got {self.no_depth_persistent}")
        if self.background_threshold < 0 or self.background_threshold_per_m2 < 0:
            raise ValueError("background thresholds must be >= 0")
        if self.background_frames < 1:
            raise ValueError(f"background_frames must be >= 1, got {self.background_frames}")
        if not (self.min_part_width >= 0):
            raise ValueError(f"min_part_width must be >= 0, got {self.min_part_width}")
        self.roi.validate()
        self.floor.validate()
        self.static_mask.validate()
        self.hmm.validate()


def joined_parts(inside: BoolArray, beyond: BoolArray, depth: NDArray[np.floating], *, max_jump: float) -> BoolArray:
    """``(H, W)`` the pixels of ``beyond`` that are one part with pixels of ``inside``: 8-connected in the image
    through ``inside | beyond``, no step between two neighbouring pixels of more than ``max_jump`` (m) in ``depth``
    (both pixels of such a step are left out of the parts, which splits them there)."""
    import cv2

    out = np.zeros_like(beyond)
    if not beyond.any() or not inside.any():
        return out
    full = inside | beyond
    rows, cols = np.flatnonzero(full.any(axis=1)), np.flatnonzero(full.any(axis=0))
    win = (slice(int(rows[0]), int(rows[-1]) + 1), slice(int(cols[0]), int(cols[-1]) + 1))  # the parts' bounding box
    inside, beyond, part = inside[win], beyond[win], full[win]
    z = np.asarray(depth[win], dtype=np.float32)
    step = np.zeros_like(part)
    with np.errstate(invalid="ignore"):
        across = np.abs(z[:, 1:] - z[:, :-1]) > max_jump
        down = np.abs(z[1:, :] - z[:-1, :]) > max_jump
    across &= part[:, 1:] & part[:, :-1]
    down &= part[1:, :] & part[:-1, :]
    step[:, 1:] |= across
    step[:, :-1] |= across
    step[1:, :] |= down
    step[:-1, :] |= down
    n, labels = cv2.connectedComponents(np.ascontiguousarray(part & ~step).view(np.uint8), connectivity=8)
    touching = np.zeros(n, dtype=bool)
    touching[labels[inside]] = True
    touching[0] = False
    out[win] = beyond & touching[labels]
    return out


@dataclass(kw_only=True)
class Segmentation:
    """Result of :meth:`Segmenter.process` for one frame."""

    mask: BoolArray
    """``(H, W)`` bool, True = foreground (leg) pixel, aligned with the depth image."""
    points: F32
    """``(N, 3)`` float32 foreground points, camera optical frame (m), finite, row-major pixel order."""
    floor: FloorPlane
    """Current floor plane (``valid=False`` if never found)."""
    status: str = "ok"
    """``ok``, ``no_floor`` (never found), ``learning_background``, ``background_mismatch``
    (model size differs from the image), ``empty`` (no valid depth)."""
    floor_visible: bool = False
    """The floor was measured in this frame (else the last plane was kept)."""
    floor_refit: bool = False
    """RANSAC ran in this frame."""
    n_valid: int = 0
    """Valid depth pixels within ``[min_range, max_range]``."""
    n_floor: int = 0
    """Valid pixels removed as floor/background."""
    n_outside_roi: int = 0
    """Valid non-floor pixels outside the ROI box."""
    n_static: int = 0
    """Pixels removed as structure static in the camera frame (static mask and occupancy HMM)."""
    n_thin: int = 0
    """Pixels removed as parts thinner than ``min_part_width``."""
    n_foreground: int = 0
    """Foreground pixels (= ``len(points)``)."""
    roi_shift: float = 0.0
    """Lateral shift (m, walker +y) of the ROI box used for this frame's successor (auto-centring)."""
    no_depth: BoolArray | None = None
    """``(H, W)`` bool, True = no depth measured in ``[min_range, max_range]`` in this frame (a leg nearer than
    the sensor's near limit, IR shadow, dropouts) and not persistently missing (``no_depth_frames``: the walker's
    own parts in front of the lens are background): unknown, neither foreground nor background (None in the
    empty results: no depth at all, no floor, background still being learned)."""

    def foreground_depth(self, depth_m: NDArray[np.floating]) -> F32:
        """Copy of ``depth_m`` (float32, m) with NaN outside the foreground mask."""
        return np.where(self.mask, depth_m, np.float32(np.nan)).astype(np.float32, copy=False)


def _select_rows(pts: F32, mask: BoolArray) -> F32:
    """``pts[mask]`` for ``(N, 3)`` float32 rows, several times faster via a 12-byte void view."""
    if pts.flags.c_contiguous and pts.dtype == np.float32:
        rows = pts.view(np.dtype((np.void, 12))).reshape(-1)
        return np.ascontiguousarray(rows[mask]).view(np.float32).reshape(-1, 3)
    return np.ascontiguousarray(pts[mask], dtype=np.float32)


class Segmenter:
    """Per-frame floor removal + ROI (+ optional static-structure removal).

    ``intrinsics`` (optional) must be those the points were back-projected with
    (:class:`walker_gait.core.depth.DepthProjector`, stride 1).  When given and
    matching the image size, walker-frame coordinates are computed from the depth
    and cached per-column/per-row rays (faster than transforming the points); they
    also enable the occupancy HMM's free-space evidence.
    Counters: ``frames``, ``empty_frames``, and the floor tracker's.
    """

    def __init__(
        self,
        config: SegmenterConfig | None = None,
        *,
        rng: np.random.Generator,
        intrinsics: CameraIntrinsics | None = None,
        background: BackgroundModel | None = None,
    ) -> None:
        self.config = config or SegmenterConfig()
        self.config.validate()
        self.floor_tracker = FloorTracker(self.config.floor, rng=rng)
        self.intrinsics = intrinsics
        self._rays_for: CameraIntrinsics | None = None
        self._rx: F32 = np.empty(0, dtype=np.float32)
        self._ry: F32 = np.empty(0, dtype=np.float32)
        self.background = background
        if background is None and self.config.background_path:
            self.background = BackgroundModel.load(self.config.background_path)
        self._bg_frames: list[F32] = []
        roi = self.config.roi
        # the HMM grid covers every position the auto-centred box can take
        grid_roi = replace(roi, left=roi.left + roi.center_max_shift, right=roi.right + roi.center_max_shift)
        self.hmm: OccupancyHMM | None = (
            OccupancyHMM(self.config.hmm, grid_roi) if self.config.use_occupancy_hmm else None
        )
        self.static: StaticStructureMask | None = (
            StaticStructureMask(self.config.static_mask) if self.config.static_mask.enabled else None
        )
        self.roi_shift = 0.0
        """Current lateral shift (m, walker +y) of the ROI box (auto-centring)."""
        self._no_legs = False  # the last frame's foreground showed no legs (`StaticMaskConfig.learn_without_legs`)
        self._no_depth_rate: F32 | None = None  # per pixel, the recent share of frames without depth
        self.frames = 0
        self.empty_frames = 0

    def _walker_coords(self, pts: F32, z: F32, floor: FloorPlane) -> tuple[F32, F32, F32]:
        """Flat walker-frame x, y and height above the floor (float32, m) of every pixel."""
        rot, _ = floor.walker_transform()
        rot32 = rot.astype(np.float32)
        off = np.float32(floor.offset)
        intr = self.intrinsics
        if intr is not None and (intr.height, intr.width) == z.shape:
            rx, ry = self._ray_coefficients(intr)
            out = []
            for k in range(3):
                # coefficient image c(v, u) = R_k · (x/z, y/z, 1); walker coordinate = z * c
                coef = np.add.outer(rot32[k, 1] * ry + rot32[k, 2], rot32[k, 0] * rx)
                np.multiply(coef, z, out=coef)
                out.append(coef.reshape(-1))
            out[2] += off
            return out[0], out[1], out[2]
        xw = pts @ rot32[0]
        yw = pts @ rot32[1]
        h = pts @ rot32[2]
        h += off
        return xw, yw, h

    @property
    def _uses_reach(self) -> bool:
        """Whether anything reads the band the auto-centred box can reach (the static mask learns there, the centring
        measures there)."""
        return self.static is not None or self.config.roi.center_max_shift > 0

    def _ray_coefficients(self, intr: CameraIntrinsics) -> tuple[F32, F32]:
        """Per column ``x/z`` and per row ``y/z`` of ``intr``'s pixels (float32), cached for the intrinsics."""
        if self._rays_for != intr:
            self._rx = ((np.arange(intr.width) - intr.cx) / intr.fx).astype(np.float32)
            self._ry = ((np.arange(intr.height) - intr.cy) / intr.fy).astype(np.float32)
            self._rays_for = intr
        return self._rx, self._ry

    def _walker_box(self, z: F32, valid: BoolArray, floor: FloorPlane
                    ) -> tuple[F32, F32, F32, BoolArray, BoolArray | None, int] | None:
        """The floor-plane branch of :meth:`_process`'s pixel pass compiled (:func:`walker_gait.core._jit.walker_box`):
        walker x, y, height, the box's mask, the reach band's (None where nothing uses it) and the count of valid
        pixels above the floor's threshold, bit for bit as the numpy code; None without the kernels or where the
        intrinsics do not match the image (the numpy code's slow path)."""
        jit = kernels.compiled()
        intr = self.intrinsics
        if jit is None or intr is None or (intr.height, intr.width) != z.shape:
            return None
        rx, ry = self._ray_coefficients(intr)
        roi = self.config.roi
        rot, _ = floor.walker_transform()
        n = z.size
        xw, yw, h = np.empty(n, np.float32), np.empty(n, np.float32), np.empty(n, np.float32)
        mask = np.empty(n, dtype=bool)
        want_reach = self._uses_reach
        reach = np.empty(n, dtype=bool)
        f32 = np.float32
        # branch-free: a plain height threshold is k z² + min_height with k = 0, no height limit an infinite one
        # (the same decisions for every valid pixel, whose depth is finite)
        k_m2 = f32(roi.min_height_per_m2) if roi.min_height_per_m2 > 0 else f32(0.0)
        max_height = f32(roi.max_height) if roi.max_height is not None else f32(np.inf)
        n_not_floor = jit.walker_box(
            np.ascontiguousarray(z, dtype=np.float32), np.ascontiguousarray(valid).reshape(-1), rx, ry,
            np.ascontiguousarray(rot, dtype=np.float32), f32(floor.offset), f32(roi.forward), f32(roi.near),
            max_height, f32(roi.left + roi.center_max_shift), f32(-roi.right - roi.center_max_shift),
            f32(roi.left + self.roi_shift), f32(self.roi_shift - roi.right), k_m2, f32(roi.min_height),
            xw, yw, h, mask, reach)
        return xw, yw, h, mask, (reach if want_reach else None), int(n_not_floor)

    def set_intrinsics(self, intrinsics: CameraIntrinsics | None) -> None:
        """Intrinsics the points are back-projected with (enables the fast path and HMM free space)."""
        self.intrinsics = intrinsics

    def set_background(self, model: BackgroundModel | None) -> None:
        """Use ``model`` (None = learn again from the next ``background_frames`` frames)."""
        self.background = model
        self._bg_frames = []

    @property
    def floor(self) -> FloorPlane:
        """Current tracked floor plane (with the still walker's anchor and heading)."""
        return self.floor_tracker.last

    def _empty(self, shape: tuple[int, int], status: str, **counts: int) -> Segmentation:
        self.empty_frames += 1
        return Segmentation(
            mask=np.zeros(shape, dtype=bool),
            points=np.empty((0, 3), dtype=np.float32),
            floor=self.floor_tracker.last,
            status=status,
            floor_visible=self.floor_tracker.floor_visible,
            floor_refit=self.floor_tracker.refit_this_frame,
            **counts,
        )

    def process(self, depth_m: NDArray[np.floating], points: NDArray[np.floating]) -> Segmentation:
        """Segment one frame.

        ``depth_m``: ``(H, W)`` float32 metres (NaN invalid); ``points``: its ``(H, W, 3)``
        camera-frame back-projection.  Never raises on decoded frames (all-NaN,
        no floor, tiny images...): such frames give an empty foreground.

        Raises:
            ValueError: ``depth_m``/``points`` shapes are inconsistent (a programming error).
        """
        with np.errstate(all="ignore"):  # NaN/huge values are expected in depth data
            return self._process(depth_m, points)

    def _process(self, depth_m: NDArray[np.floating], points: NDArray[np.floating]) -> Segmentation:
        cfg = self.config
        roi = cfg.roi
        self.frames += 1
        no_legs_before, self._no_legs = self._no_legs, False  # a frame that returns early shows no foreground
        if depth_m.ndim != 2 or points.shape != (*depth_m.shape, 3):
            raise ValueError(f"points shape {points.shape} does not match depth shape {depth_m.shape} + (3,)")
        shape = (int(depth_m.shape[0]), int(depth_m.shape[1]))
        z = depth_m if depth_m.dtype == np.float32 else depth_m.astype(np.float32)
        valid = z >= cfg.min_range  # NaN -> False
        valid &= z <= cfg.max_range
        n_valid = int(np.count_nonzero(valid))
        # (a frame without any depth, a blank start-up frame or the lens covered, says nothing of which pixels never
        # have depth, and has no foreground to go with it)
        no_depth = self._transient_no_depth(valid) if n_valid else None

        floor = self.floor_tracker.update(points)

        if cfg.floor_method == "background" and self.background is None:
            self._bg_frames.append(np.array(z, dtype=np.float32))
            if len(self._bg_frames) >= cfg.background_frames:
                self.background = BackgroundModel.from_frames(self._bg_frames)
                self._bg_frames = []
            return self._empty(shape, "learning_background", n_valid=n_valid)
        if n_valid == 0:
            return self._empty(shape, "empty")

        pts = points.reshape(-1, 3)
        if pts.dtype != np.float32:
            pts = pts.astype(np.float32)
        zf = z.reshape(-1)
        xw: NDArray[np.float32] | None = None
        yw: NDArray[np.float32] | None = None
        h: NDArray[np.float32] | None = None
        # where the auto-centred box can reach: the static mask learns there and the centring measures there
        in_reach: BoolArray | None = None
        box = self._walker_box(z, valid, floor) if floor.valid and cfg.floor_method == "plane" else None
        if box is not None:  # compiled: the same arrays, one pass (tested against the numpy code below)
            xw, yw, h, mask, reach, n_not_floor = box
        else:
            if floor.valid:
                xw, yw, h = self._walker_coords(pts, z, floor)
                in_roi = xw <= roi.forward  # in-place &= avoids temporaries (speed)
                in_roi &= xw >= roi.near
                if roi.max_height is not None:
                    in_roi &= h <= roi.max_height
                if self._uses_reach:
                    in_reach = in_roi & (yw <= roi.left + roi.center_max_shift)
                    in_reach &= yw >= -roi.right - roi.center_max_shift
                in_roi &= yw <= roi.left + self.roi_shift
                in_roi &= yw >= self.roi_shift - roi.right
            elif cfg.floor_method == "background" and not cfg.require_floor:
                # seed's camera-frame box: optical z forward, camera's left = optical -x
                x = pts[:, 0]
                in_roi = (zf <= roi.forward) & (zf >= roi.near) & (x >= -roi.left) & (x <= roi.right)
            else:
                return self._empty(shape, "no_floor", n_valid=n_valid)

            valid_f = valid.reshape(-1)
            if cfg.floor_method == "plane":
                assert h is not None
                if roi.min_height_per_m2 > 0:
                    thr = zf * zf
                    thr *= np.float32(roi.min_height_per_m2)
                    thr += np.float32(roi.min_height)
                    not_floor = h > thr
                else:
                    not_floor = h > roi.min_height
            else:
                assert self.background is not None
                if self.background.shape != shape:
                    return self._empty(shape, "background_mismatch", n_valid=n_valid)
                not_floor = self.background.foreground_mask(
                    z, threshold=cfg.background_threshold, threshold_per_m2=cfg.background_threshold_per_m2
                ).reshape(-1)
            cand_nf = not_floor
            cand_nf &= valid_f
            n_not_floor = int(np.count_nonzero(cand_nf))
            mask = cand_nf & in_roi
            # the wider band the auto-centred box can reach gets the same structure filters as the box; the
            # centring measures the legs there, so a leg the box cuts does not pull the box further off it
            reach = None if in_reach is None else cand_nf & in_reach
        join = roi.join_edge_parts and reach is not None and roi.center_max_shift > 0
        in_box = mask.copy() if join else None  # the box's pixels before the structure filters take theirs
        n_static = 0
        if self.static is not None and reach is not None:
            # the previous frame's foreground (what the tracker got) showed no legs: see learn_without_legs
            self.static.update(z, reach.reshape(shape), no_legs=no_legs_before)
            static_px = self.static.static_pixels(z, reach.reshape(shape)).reshape(-1)
            n_static = int(np.count_nonzero(static_px & mask))  # the box's share (the counters add up)
            mask &= ~static_px
            reach &= ~static_px
        n_thin = 0
        if cfg.min_part_width > 0 and self.intrinsics is not None:
            fx, fy = self.intrinsics.fx, self.intrinsics.fy
            thin = thin_parts(mask.reshape(shape), z, fx=fx, fy=fy, min_width=cfg.min_part_width).reshape(-1)
            n_thin = int(np.count_nonzero(thin))
            mask &= ~thin
            if reach is not None and roi.center_max_shift > 0:
                # coarser (a quarter of the work): this band only feeds the centring's percentiles
                reach &= ~thin_parts(reach.reshape(shape), z, fx=fx, fy=fy, min_width=cfg.min_part_width,
                                     stride=4).reshape(-1)
        if join:
            assert reach is not None and in_box is not None
            beyond = reach & ~in_box
            if roi.join_centred_only:  # what the centred box holds: nothing more while the box stands centred
                assert yw is not None
                beyond &= (yw >= -roi.right) & (yw <= roi.left)
            if beyond.any():
                mask |= joined_parts(mask.reshape(shape), beyond.reshape(shape), z,
                                     max_jump=roi.join_max_jump).reshape(-1)
        if self.hmm is not None and floor.valid and xw is not None and yw is not None and h is not None:
            idx = np.flatnonzero(mask)
            cells = self.hmm.cell_index_xyz(xw[idx], yw[idx], h[idx])
            self.hmm.update(cells=cells, floor=floor, depth_m=z, intrinsics=self.intrinsics)
            static = self.hmm.static_cells(cells)
            n_static += int(np.count_nonzero(static))
            mask[idx[static]] = False
        if roi.center_max_shift > 0 and yw is not None and h is not None and reach is not None:
            self._follow_legs(reach, yw, h, zf)
        fg = _select_rows(pts, mask)
        n_fg = int(fg.shape[0])
        if self.static is not None and cfg.static_mask.learn_without_legs and self.intrinsics is not None \
                and h is not None and floor.valid:
            heights = h[mask]  # the height test first: it settles most frames without the foreground image
            self._no_legs = not (legs_above(heights) or legs_in_view(
                heights, np.where(mask.reshape(shape), z, np.float32(np.nan)), up=floor.normal,
                intrinsics=self.intrinsics, no_depth=no_depth))
        return Segmentation(
            mask=mask.reshape(shape),
            points=fg,
            floor=floor,
            status="ok",
            floor_visible=self.floor_tracker.floor_visible,
            floor_refit=self.floor_tracker.refit_this_frame,
            n_valid=n_valid,
            n_floor=n_valid - n_not_floor,
            n_outside_roi=n_not_floor - n_fg - n_static - n_thin,
            n_static=n_static,
            n_thin=n_thin,
            n_foreground=n_fg,
            roi_shift=self.roi_shift,
            no_depth=no_depth,
        )

    def _transient_no_depth(self, valid: BoolArray) -> BoolArray:
        """Pixels without depth in this frame whose depth is not persistently missing (``no_depth_frames``); the
        first frame with depth starts the average."""
        cfg = self.config
        missing = ~valid
        if cfg.no_depth_frames <= 0:
            return missing
        rate = self._no_depth_rate
        if rate is None or rate.shape != missing.shape:
            self._no_depth_rate = rate = missing.astype(np.float32)
        else:
            gain = np.float32(1.0 / cfg.no_depth_frames)
            jit = kernels.compiled()
            if jit is not None and rate.flags.c_contiguous and valid.flags.c_contiguous:
                out = np.empty(valid.shape, dtype=bool)  # one pass, bit for bit as the numpy code below (tested)
                jit.transient_no_depth(valid.reshape(-1), rate.reshape(-1), np.float32(1.0) - gain, gain,
                                       np.float32(cfg.no_depth_persistent), out.reshape(-1))
                return out
            rate *= np.float32(1.0) - gain
            rate += gain * missing
        return missing & (rate < np.float32(cfg.no_depth_persistent))

    def _follow_legs(self, mask: BoolArray, yw: F32, h: F32, z: F32) -> None:
        """Auto-centring: move the box sideways towards the lateral centre of the legs, measured on ``mask``
        (the foreground of the whole band the box can reach, so a leg the box cuts does not pull it further
        off): the midpoint of the 15th and 85th area-weighted percentiles of walker y over the foreground
        0.2-0.6 m up (shins and knees, above a walker's wheels; 0.05-0.6 m when that holds < 300 pixels).
        A pixel covers z² of surface, so the leg nearer the camera does not outvote the other; percentiles,
        not the pixels' span, so a walker part or clutter at the edge is not chased; not the median, which
        falls on the inner edge of one leg when two legs of about equal area stand apart.  Needs >= 300 pixels."""
        roi = self.config.roi
        idx = np.flatnonzero(mask)
        hh = h[idx]
        sel = idx[(hh > 0.2) & (hh < 0.6)]
        if sel.size < 300:
            sel = idx[(hh > 0.05) & (hh < 0.6)]
        if sel.size < 300:
            return
        sel = sel[:: sel.size // 5000 + 1]  # a few thousand pixels give the percentiles to a millimetre
        ys = yw[sel]
        order = np.argsort(ys)
        y = ys[order]
        cw = np.cumsum(np.square(z[sel][order], dtype=np.float64))
        lo, hi = np.searchsorted(cw, np.array([0.15, 0.85]) * cw[-1])
        centre = 0.5 * float(y[min(int(lo), y.size - 1)] + y[min(int(hi), y.size - 1)])
        target = 0.0 if abs(centre) <= roi.center_deadband else centre
        target = float(np.clip(target, -roi.center_max_shift, roi.center_max_shift))
        self.roi_shift += roi.center_gain * (target - self.roi_shift)
