"""Tests of walker_gait.core.segmentation: floor RANSAC/tracking, ROI, background model, occupancy HMM."""

from __future__ import annotations

import functools
from dataclasses import replace
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from walker_gait.bench.segmentation import (
    KINECT_INTRINSICS,
    LABEL_BAR,
    LABEL_FLOOR,
    LABEL_LEG,
    LABEL_POST,
    SyntheticScene,
    add_kinect_noise,
    camera_floor,
    make_synthetic_scene,
    run_segmentation_bench,
)
from walker_gait.core.depth import DepthProjector, decode_depth, kinect_raw_to_metres
from walker_gait.core.segmentation import (
    STATE_EMPTY,
    STATE_MOVING,
    STATE_STATIC,
    BackgroundModel,
    BackgroundModelError,
    FloorConfig,
    FloorTracker,
    HmmConfig,
    OccupancyHMM,
    RoiConfig,
    Segmenter,
    SegmenterConfig,
    StaticMaskConfig,
    StaticStructureMask,
    FLIP_CONFIRM_ATTEMPTS,
    fit_floor_ransac,
    flipped_up_hint,
    joined_parts,
    thin_parts,
)
from walker_gait.core.types import CameraIntrinsics, FloorPlane

PROJ = DepthProjector(KINECT_INTRINSICS)
QVGA = KINECT_INTRINSICS.scaled(0.5)


@functools.lru_cache(maxsize=64)
def scene_cached(legs: tuple[tuple[float, float], ...] | None = None, intrinsics: CameraIntrinsics = KINECT_INTRINSICS,
                 **kw: float) -> SyntheticScene:
    """Noise-free scenes repeat along the periodic gait: generate each once per test session."""
    extra = {} if legs is None else {"legs": legs}
    return make_synthetic_scene(intrinsics=intrinsics, **extra, **kw)  # type: ignore[arg-type]


def noisy_depth(scene: SyntheticScene, rng: np.random.Generator, **noise: float) -> np.ndarray:
    """Kinect-like noisy depth (m) of a scene, through the real 16UC1 kinect_raw decoder."""
    raw = add_kinect_noise(scene.depth, rng=rng, **noise)
    h, w = raw.shape
    return decode_depth(raw.astype("<u2").tobytes(), encoding="16UC1", width=w, height=h, step=2 * w,
                        is_bigendian=False, depth_format="kinect_raw")


def angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    return math.degrees(math.acos(float(np.clip(a @ b / np.linalg.norm(a) / np.linalg.norm(b), -1, 1))))


def gait_legs(i: int) -> tuple[tuple[float, float], tuple[float, float]]:
    s = math.sin(2 * math.pi * i / 30.0)
    return ((0.85 + 0.2 * s, 0.09), (0.85 - 0.2 * s, -0.07))


def to_camera(points_walker: np.ndarray, floor: FloorPlane) -> np.ndarray:
    rot, t = floor.walker_transform()
    return (points_walker - t) @ rot


# --------------------------------------------------------------------------- floor RANSAC


@pytest.mark.parametrize(("height", "pitch", "roll"), [(0.5, 30.0, 0.0), (0.4, 45.0, 3.0), (0.6, 22.0, -5.0)])
def test_fit_floor_ransac_recovers_plane_with_legs_and_walker_in_view(height: float, pitch: float, roll: float) -> None:
    rng = np.random.default_rng(1)
    scene = make_synthetic_scene(camera_height=height, pitch_deg=pitch, roll_deg=roll)
    assert (scene.labels == LABEL_LEG).sum() > 5000
    assert pitch < 25 or (scene.labels == LABEL_BAR).sum() > 500  # walker bar in view (out of view at 22°)
    pts = PROJ.points(noisy_depth(scene, rng))
    plane = fit_floor_ransac(pts[::4, ::4].reshape(-1, 3), rng=rng)
    assert plane.valid
    assert angle_deg(plane.normal, scene.floor.normal) < 0.5
    assert abs(plane.offset - height) < 0.005
    assert plane.normal @ np.array([0.0, -1.0, 0.0]) > 0  # points up
    assert 0 < plane.rms < 0.01 and 0.3 < plane.inlier_ratio <= 1.0


def _patch(rng: np.random.Generator, n: int, x: tuple[float, float], y: tuple[float, float], z: float) -> np.ndarray:
    return np.stack([rng.uniform(*x, n), rng.uniform(*y, n), np.full(n, z) + rng.normal(0, 0.003, n)], axis=1)


@pytest.mark.parametrize("max_below", [0.05, 1.0])
def test_floor_is_the_lowest_well_supported_plane(max_below: float) -> None:
    """A large raised platform (more points than the visible floor) must not win over the floor."""
    rng = np.random.default_rng(2)
    floor = camera_floor(camera_height=0.5, pitch_deg=30.0)
    platform = _patch(rng, 6000, (0.4, 1.2), (-0.8, 0.8), 0.30)  # e.g. a seat / box top 30 cm up
    ground = _patch(rng, 3000, (1.2, 3.0), (-1.0, 1.0), 0.0)
    pts = to_camera(np.concatenate([platform, ground]), floor)
    cfg = FloorConfig(max_below_fraction=max_below)  # 1.0 disables the "points below" test: lower-plane rule only
    plane = fit_floor_ransac(pts, rng=rng, config=cfg)
    assert plane.valid
    assert abs(plane.offset - 0.5) < 0.01 and angle_deg(plane.normal, floor.normal) < 1.0


def _upside_down(points: np.ndarray) -> np.ndarray:
    """Camera-frame points of the same view from the camera turned half a turn about its optical axis."""
    return points * np.array([-1.0, -1.0, 1.0], dtype=points.dtype)


def test_floor_tracker_finds_the_floor_of_a_camera_mounted_upside_down() -> None:
    """``auto_flip``: until a floor was ever found, the half-turned ``up_hint`` is tried too and taken, for good, once
    it alone has found a floor in FLIP_CONFIRM_ATTEMPTS attempts in a row; the plane is the true one (normal up).
    Off, the tracker never finds that floor (the old behaviour, which needed ``up_hint`` set by hand)."""
    scene = scene_cached(gait_legs(0), camera_height=0.5, pitch_deg=30.0)
    pts = _upside_down(PROJ.points(scene.depth))
    true_up = scene.floor.normal * np.array([-1.0, -1.0, 1.0])
    cfg = FloorConfig()
    tracker = FloorTracker(cfg, rng=np.random.default_rng(1))
    frames_to_floor = None
    for i in range(20):
        plane = tracker.update(pts)
        if plane.valid and frames_to_floor is None:
            frames_to_floor = i + 1
    assert tracker.flipped and tracker.config.up_hint == (0.0, 1.0, 0.0)
    # attempts at frames 1, 1 + retry_interval, ...: the third finds it
    assert frames_to_floor == 1 + (FLIP_CONFIRM_ATTEMPTS - 1) * cfg.retry_interval
    assert angle_deg(plane.normal, true_up) < 0.3 and abs(plane.offset - 0.5) < 0.005
    off = FloorTracker(FloorConfig(auto_flip=False), rng=np.random.default_rng(1))
    assert not any(off.update(pts).valid for _ in range(20)) and not off.flipped
    assert flipped_up_hint((0.1, -1.0, 0.2)) == (-0.1, 1.0, 0.2)


def test_floor_tracker_does_not_flip_once_it_has_found_the_floor_nor_for_a_passing_plane() -> None:
    """A camera mounted upright: the half-turned search never changes a plane or the random stream (same planes
    with ``auto_flip`` on and off); once a floor was found, frames that show only an upside-down floor do not turn
    the tracker over; a half-turned floor seen in fewer than FLIP_CONFIRM_ATTEMPTS attempts in a row (a table top
    from below, one frame) is not taken."""
    rng = np.random.default_rng(6)
    frames = [PROJ.points(noisy_depth(scene_cached(gait_legs(i), camera_height=0.5, pitch_deg=30.0), rng))
              for i in range(12)]
    planes = {}
    for flip in (True, False):
        tracker = FloorTracker(FloorConfig(auto_flip=flip), rng=np.random.default_rng(2))
        planes[flip] = [tracker.update(p) for p in frames + [_upside_down(f) for f in frames]]
        assert not tracker.flipped
    for a, b in zip(planes[True], planes[False]):
        assert a.valid == b.valid and np.array_equal(a.normal, b.normal) and a.offset == b.offset
    nan_pts = np.full_like(frames[0], np.nan)
    cfg = FloorConfig()
    tracker = FloorTracker(cfg, rng=np.random.default_rng(3))
    pattern = ([_upside_down(frames[0])] + [nan_pts] * (cfg.retry_interval - 1)) * (FLIP_CONFIRM_ATTEMPTS - 1)
    pattern += [nan_pts] * cfg.retry_interval  # an attempt without any floor ends the run
    for p in pattern * 3:
        assert not tracker.update(p).valid
    assert not tracker.flipped


def test_wall_only_is_not_a_floor_and_garbage_is_safe() -> None:
    rng = np.random.default_rng(3)
    wall = np.stack([rng.uniform(-1, 1, 3000), rng.uniform(-1, 1, 3000), np.full(3000, 2.0)], axis=1)
    assert not fit_floor_ransac(wall, rng=rng).valid
    assert math.isnan(fit_floor_ransac(wall, rng=rng).offset)
    for pts in (np.empty((0, 3)), np.full((500, 3), np.nan), np.zeros((500, 3)), np.ones((500, 3)),
                np.full((10, 3), np.inf)):
        assert not fit_floor_ransac(pts, rng=rng).valid
    # collinear points (a thin bar) are not a plane
    line = np.stack([np.linspace(-1, 1, 1000), np.full(1000, 0.4), np.linspace(1, 2, 1000)], axis=1)
    assert not fit_floor_ransac(line, rng=rng).valid


# --------------------------------------------------------------------------- floor tracking


def test_floor_tracker_smooths_refits_rarely_and_follows_a_bump() -> None:
    rng = np.random.default_rng(4)
    tracker = FloorTracker(FloorConfig(), rng=rng)
    for i in range(30):
        scene = scene_cached(gait_legs(i), camera_height=0.5, pitch_deg=30.0)
        plane = tracker.update(PROJ.points(noisy_depth(scene, rng)))
        assert plane.valid and tracker.floor_visible
    assert tracker.ransac_runs <= 2  # not every frame
    assert angle_deg(plane.normal, scene.floor.normal) < 0.3 and abs(plane.offset - 0.5) < 0.003
    assert plane.rms < 0.01 and plane.inlier_ratio > 0.3
    # the walker hits a bump: camera pitch changes by 12 degrees, height by 3 cm
    runs = tracker.ransac_runs
    for i in range(6):
        scene = scene_cached(gait_legs(i), camera_height=0.53, pitch_deg=42.0)
        plane = tracker.update(PROJ.points(noisy_depth(scene, rng)))
    assert tracker.ransac_runs > runs
    assert angle_deg(plane.normal, scene.floor.normal) < 0.5 and abs(plane.offset - 0.53) < 0.005
    # a jump restarts the still walker's floor: the walker origin is the new floor's point below the camera
    assert plane.anchor is not None and np.linalg.norm(plane.anchor + plane.offset * plane.normal) < 0.01
    # no floor visible (all invalid): keep the last plane
    nan_pts = np.full((480, 640, 3), np.nan, np.float32)
    kept = tracker.update(nan_pts)
    assert kept.valid and not tracker.floor_visible and kept.offset == plane.offset
    # a tracker that never saw a floor reports an invalid plane
    fresh = FloorTracker(rng=rng)
    assert not fresh.update(nan_pts).valid


def test_floor_tracker_follows_a_rocking_walker_frame_by_frame() -> None:
    """A walker rocks on its wheels as it rolls (pitch and roll by a degree or two, up to ~10 Hz): the camera's
    floor changes from one frame to the next, and a floor smoothed over frames lags it (with the old default
    smoothing of 0.2 the error here was ~1 deg, which is 1.7 cm of height at 1 m)."""
    rng = np.random.default_rng(7)
    tracker = FloorTracker(FloorConfig(), rng=rng)
    errs = []
    for i in range(24):
        pitch = 30.0 + 1.5 * math.sin(2 * math.pi * i / 5.0)
        roll = 1.5 * math.cos(2 * math.pi * i / 4.0)
        scene = make_synthetic_scene(legs=gait_legs(i), camera_height=0.5, pitch_deg=pitch, roll_deg=roll)
        plane = tracker.update(PROJ.points(noisy_depth(scene, rng)))
        assert plane.valid and tracker.floor_visible
        errs.append(angle_deg(plane.normal, scene.floor.normal))
    assert max(errs[1:]) < 0.15, errs
    assert tracker.ransac_runs <= 2  # followed by the cheap refit, not by RANSAC


def _rocked(pitch_deg: float, roll_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """World-from-camera rotation and centre of a camera 0.5 m up, pitched down 30 deg, facing -X, on a walker
    tipped by ``pitch_deg`` onto its front wheels (0.12 m ahead) and by ``roll_deg`` onto its -Y wheels (0.28 m out)."""
    th = math.radians(30.0)
    r0 = np.stack([[0.0, 1.0, 0.0], [math.sin(th), 0.0, -math.cos(th)], [-math.cos(th), 0.0, -math.sin(th)]], axis=1)
    p, r = math.radians(pitch_deg), math.radians(roll_deg)
    ry = np.array([[math.cos(p), 0.0, math.sin(p)], [0.0, 1.0, 0.0], [-math.sin(p), 0.0, math.cos(p)]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(r), -math.sin(r)], [0.0, math.sin(r), math.cos(r)]])
    j = rx @ ry
    pivot = np.array([0.12, -0.28, 0.0])
    return j @ r0, pivot + j @ (np.array([0.0, 0.0, 0.5]) - pivot)


def test_an_anchored_walker_frame_stays_put_while_the_camera_rocks() -> None:
    """The camera's foot point moves ~9 mm per degree of rocking; a walker point at floor level does not."""
    r0, c0 = _rocked(0.0, 0.0)
    still = FloorPlane(normal=r0.T @ np.array([0.0, 0.0, 1.0]), offset=0.5)
    anchor = -still.offset * still.normal  # the still floor's point below the camera, camera frame (walker-fixed)
    heading = np.array([0.0, 0.0, 1.0]) - still.normal[2] * still.normal
    feet = np.array([[-0.6, 0.08, 0.0], [-1.1, -0.1, 0.0], [-0.9, 0.0, 0.05]])  # world points behind the walker
    ref = still.to_walker((feet - c0) @ r0)
    for pitch, roll in ((1.5, 0.0), (-1.5, 1.0), (0.7, -2.0)):
        r1, c1 = _rocked(pitch, roll)
        cam = (feet - c1) @ r1
        n1 = r1.T @ np.array([0.0, 0.0, 1.0])
        hanging = FloorPlane(normal=n1, offset=float(c1[2])).to_walker(cam)
        anchored = FloorPlane(normal=n1, offset=float(c1[2]), anchor=anchor, heading=heading).to_walker(cam)
        np.testing.assert_allclose(anchored[:, 2], ref[:, 2], atol=1e-9)  # heights come from the plane, both right
        np.testing.assert_allclose(hanging[:, 2], ref[:, 2], atol=1e-9)
        assert np.abs(anchored[:, :2] - ref[:, :2]).max() < 0.001
        assert np.abs(hanging[:, :2] - ref[:, :2]).max() > 0.006
    # without rocking both are the camera's walker frame
    cam0 = (feet - c0) @ r0
    np.testing.assert_allclose(FloorPlane(normal=still.normal, offset=0.5, anchor=anchor, heading=heading).to_walker(cam0),
                               ref, atol=1e-12)


def test_floor_tracker_anchors_the_walker_frame_to_the_still_walkers_floor() -> None:
    rng = np.random.default_rng(9)
    tracker = FloorTracker(FloorConfig(), rng=rng)
    still = None
    for i in range(40):
        rocking = i >= 10  # the walker stands, then rolls off rocking
        pitch = 30.0 + (1.5 * math.sin(2 * math.pi * i / 5.0) if rocking else 0.0)
        roll = 1.5 * math.cos(2 * math.pi * i / 4.0) if rocking else 0.0
        scene = make_synthetic_scene(legs=gait_legs(i), camera_height=0.5, pitch_deg=pitch, roll_deg=roll)
        plane = tracker.update(PROJ.points(noisy_depth(scene, rng)))
        assert plane.anchor is not None and plane.heading is not None
        if i == 9:
            still = plane
        if rocking:
            assert still is not None
            assert np.linalg.norm(plane.anchor - (-0.5 * still.normal)) < 0.003
            assert angle_deg(plane.heading, still.heading) < 0.3
            assert angle_deg(plane.normal, scene.floor.normal) < 0.15  # the plane itself rocks
    assert tracker.last is plane
    # off: the walker frame hangs from the camera
    plain = FloorTracker(FloorConfig(reference_frames=0), rng=np.random.default_rng(9))
    assert plain.update(PROJ.points(noisy_depth(scene, rng))).anchor is None


# --------------------------------------------------------------------------- segmenter (plane)


def _quality(seg: Segmenter, n_frames: int, rng: np.random.Generator, *, start: int = 0,
             intrinsics: CameraIntrinsics = KINECT_INTRINSICS, **scene_kw: float) -> dict[str, float]:
    roi = seg.config.roi
    proj = DepthProjector(intrinsics)
    tot = dict.fromkeys(("leg", "leg_kept", "floor", "floor_leak", "post", "post_kept", "bar", "bar_kept"), 0)
    res = None
    for i in range(start, start + n_frames):
        scene = scene_cached(gait_legs(i), intrinsics, **scene_kw)
        depth = noisy_depth(scene, rng)
        res = seg.process(depth, proj.points(depth))
        wk = scene.walker
        in_roi = (wk[..., 0] <= roi.forward) & (wk[..., 1] <= roi.left) & (wk[..., 1] >= -roi.right)
        valid = np.isfinite(depth)
        leg = (scene.labels == LABEL_LEG) & valid & in_roi & (scene.height >= roi.min_height + 0.02)
        floor = (scene.labels == LABEL_FLOOR) & valid & in_roi
        for name, sel in (("leg", leg), ("floor", floor), ("post", (scene.labels == LABEL_POST) & valid),
                          ("bar", (scene.labels == LABEL_BAR) & valid)):
            tot[name] += int(sel.sum())
        tot["leg_kept"] += int((leg & res.mask).sum())
        tot["floor_leak"] += int((floor & res.mask).sum())
        tot["post_kept"] += int(((scene.labels == LABEL_POST) & res.mask).sum())
        tot["bar_kept"] += int(((scene.labels == LABEL_BAR) & res.mask).sum())
    assert res is not None
    return {
        "leg_kept": tot["leg_kept"] / tot["leg"],
        "floor_leak": tot["floor_leak"] / tot["floor"],
        "post_kept": tot["post_kept"] / max(1, tot["post"]),
        "bar_kept": tot["bar_kept"] / max(1, tot["bar"]),
        "n_post": tot["post"],
    }


@pytest.mark.parametrize("with_intrinsics", [True, False])
def test_segmenter_keeps_legs_and_removes_floor(with_intrinsics: bool) -> None:
    rng = np.random.default_rng(5)
    seg = Segmenter(SegmenterConfig(), rng=rng, intrinsics=KINECT_INTRINSICS if with_intrinsics else None)
    q = _quality(seg, 4, rng)
    assert q["leg_kept"] >= 0.98
    assert q["floor_leak"] <= 0.01
    assert q["n_post"] > 100 and q["post_kept"] == 0.0  # walker posts are outside the ROI laterally


def test_segmentation_output_contract() -> None:
    rng = np.random.default_rng(6)
    scene = make_synthetic_scene()
    depth = noisy_depth(scene, rng)
    pts = PROJ.points(depth)
    # (the thin-part filter needs intrinsics; off for the comparison of the two coordinate paths)
    cfg = SegmenterConfig(min_part_width=0.0)
    a = Segmenter(cfg, rng=np.random.default_rng(0), intrinsics=KINECT_INTRINSICS).process(depth, pts)
    b = Segmenter(cfg, rng=np.random.default_rng(0)).process(depth, pts)
    assert a.status == "ok" and a.floor.valid and a.floor_refit
    # the floor it reports carries the still walker's anchor (its first floor, here) for the walker frame
    assert a.floor.anchor is not None and np.linalg.norm(a.floor.anchor + a.floor.offset * a.floor.normal) < 1e-9
    assert Segmenter(cfg, rng=np.random.default_rng(0)).floor.anchor is None  # no floor yet
    assert a.mask.shape == depth.shape and a.mask.dtype == bool
    assert a.points.dtype == np.float32 and a.points.shape == (a.n_foreground, 3) and a.points.flags.c_contiguous
    np.testing.assert_array_equal(a.points, pts[a.mask])
    assert np.all(np.isfinite(a.points))
    assert a.n_valid == a.n_floor + a.n_outside_roi + a.n_static + a.n_thin + a.n_foreground
    c = Segmenter(rng=np.random.default_rng(0), intrinsics=KINECT_INTRINSICS).process(depth, pts)
    assert c.n_thin > 0 and c.n_valid == c.n_floor + c.n_outside_roi + c.n_static + c.n_thin + c.n_foreground
    # the two coordinate paths (rays from intrinsics / transforming points) agree
    assert np.count_nonzero(a.mask != b.mask) <= 5
    fg = a.foreground_depth(depth)
    assert np.all(np.isnan(fg[~a.mask])) and np.array_equal(fg[a.mask], depth[a.mask])
    # pixels without a measurement in the configured range are unknown, never foreground (every one of them, with
    # no memory of earlier frames)
    near = depth.copy()
    near[:40] = 0.1  # nearer than min_range (0.2 m)
    d = Segmenter(replace(cfg, no_depth_frames=0), rng=np.random.default_rng(0),
                  intrinsics=KINECT_INTRINSICS).process(near, PROJ.points(near))
    assert d.no_depth is not None and d.no_depth.shape == depth.shape and d.no_depth.dtype == bool
    np.testing.assert_array_equal(d.no_depth, ~np.isfinite(near) | (near < cfg.min_range) | (near > cfg.max_range))
    assert d.no_depth[:40].all() and np.isnan(depth).any() and d.no_depth[np.isnan(depth)].all()
    assert not (d.no_depth & d.mask).any()


def test_depth_missing_for_a_moment_is_unknown_missing_for_long_is_background() -> None:
    """A leg passing in front of the lens leaves a hole for a fraction of a second: unknown.  The walker's own parts
    nearer than the sensor reaches never have depth: background, as pixels showing nothing of interest."""
    rng = np.random.default_rng(6)
    depth = noisy_depth(make_synthetic_scene(), rng)
    depth[:, :20] = np.nan  # a walker part in front of the lens, in every frame
    seg = Segmenter(SegmenterConfig(min_part_width=0.0), rng=np.random.default_rng(0), intrinsics=KINECT_INTRINSICS)
    pts = PROJ.points(depth)
    first = seg.process(depth, pts)
    assert first.no_depth is not None and not first.no_depth[:, :20].any()  # missing from the start: persistent
    for _ in range(10):
        seg.process(depth, pts)
    hole = depth.copy()
    hole[200:300, 300:400] = np.nan  # a leg nearer than the sensor reaches
    new = np.isfinite(depth) & np.isnan(hole)  # (the scene's own speckle there is missing in every frame)
    assert new.sum() > 9000
    res = seg.process(hole, PROJ.points(hole))
    assert res.no_depth is not None and res.no_depth[new].all() and not res.no_depth[:, :20].any()
    frames = 1
    while res.no_depth[new].any():  # a hole that stays becomes background too
        res = seg.process(hole, PROJ.points(hole))
        frames += 1
    cfg = seg.config
    assert frames == math.ceil(math.log(1.0 - cfg.no_depth_persistent) / math.log(1.0 - 1.0 / cfg.no_depth_frames))
    with pytest.raises(ValueError, match="no_depth_persistent"):
        SegmenterConfig(no_depth_persistent=0.0).validate()


def test_compiled_no_depth_average_is_numpys_bit_for_bit() -> None:
    """The running share of frames without depth per pixel and the transient holes it gives, compiled
    (``_jit.transient_no_depth``) and in numpy, over frames whose holes persist, come and go."""
    from walker_gait.core import _jit, kernels

    rng = np.random.default_rng(10)
    persistent = rng.random((48, 64)) < 0.1
    frames = [~(persistent | (rng.random((48, 64)) < p)) for p in np.linspace(0.0, 0.5, 40)]
    got = {}
    for name, jit in (("numpy", None), ("compiled", _jit)):
        seg = Segmenter(SegmenterConfig(no_depth_frames=7), rng=np.random.default_rng(0))
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(kernels, "compiled", lambda jit=jit: jit)
            got[name] = [seg._transient_no_depth(valid) for valid in frames]
        got[name + " rate"] = seg._no_depth_rate
    for a, b in zip(got["numpy"], got["compiled"]):
        np.testing.assert_array_equal(b, a)
    np.testing.assert_array_equal(got["compiled rate"], got["numpy rate"])
    assert not got["numpy"][-1][persistent].any() and got["numpy"][-1].any()  # holes that stay are background


def test_thin_parts_drops_tubes_keeps_legs() -> None:
    """Widths are metric (run length x depth / f): the same 20 px are a 2.3 cm tube at 0.6 m (dropped)
    but 9 cm at 2.4 m (kept); holes inside a leg do not split it; a thin sliver touching a leg is kept."""
    m = np.zeros((240, 320), bool)
    z = np.full((240, 320), 0.6, np.float32)
    m[40:200, 20:60] = True  # leg: 40 px at 0.6 m, f = 262 -> 9 cm
    m[100:104, 30:33] = False  # a dropout hole in it
    m[20:220, 100:110] = True  # post: 10 px -> 2.3 cm
    m[150:155, 150:300] = True  # bar: 5 px high
    m[40:200, 60:66] = True  # a back leg's sliver beside the front leg (same run)
    z[:, 200:230] = 2.4
    m[40:200, 205:215] = True  # 10 px at 2.4 m -> 9 cm
    thin = thin_parts(m, z, fx=262.5, fy=262.5, min_width=0.045)
    assert not thin[40:200, 20:66].any()
    assert thin[20:220, 100:110].all() and thin[150:155, 150:200].all()
    assert not thin[40:200, 205:215].any()
    assert not (thin & ~m).any()
    assert not thin_parts(np.zeros_like(m), z, fx=262.5, fy=262.5, min_width=0.045).any()


@pytest.mark.parametrize(("stride", "close_px"), [(2, 7), (4, 7), (1, 1), (3, 5)])
def test_compiled_thin_parts_are_numpys_bit_for_bit(stride: int, close_px: int) -> None:
    """``thin_parts`` compiled (``_jit.thin_parts``: runs, metric widths and the full-resolution verdicts) as numpy
    decides it: random blobs and bars over a depth ramp, runs cut by the image's borders, widths at the threshold."""
    from walker_gait.core import _jit, kernels

    rng = np.random.default_rng(9)
    m = np.zeros((237, 319), bool)
    for _ in range(40):  # boxes of every size, some on the borders
        r, c = rng.integers(-10, 237), rng.integers(-10, 319)
        m[max(r, 0):r + rng.integers(1, 60), max(c, 0):c + rng.integers(1, 60)] = True
    m &= rng.random(m.shape) > 0.03  # dropouts inside them
    z = np.linspace(0.4, 3.0, m.shape[1], dtype=np.float32)[None, :].repeat(m.shape[0], 0)
    z[rng.random(m.shape) < 0.02] = np.nan
    got = {}
    for name, jit in (("numpy", None), ("compiled", _jit)):
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(kernels, "compiled", lambda jit=jit: jit)
            got[name] = [thin_parts(m, z, fx=262.5, fy=260.0, min_width=w, close_px=close_px, stride=stride)
                         for w in (0.02, 0.045, 0.1)]
    for a, b in zip(got["numpy"], got["compiled"]):
        np.testing.assert_array_equal(b, a)
    assert 0 < got["numpy"][1].sum() < m.sum() and not (got["numpy"][2] & ~m).any()


def test_segmenter_drops_walker_bar_in_roi() -> None:
    """The walker cross-bar inside the ROI (1.5 cm radius) is removed from the first frame on."""
    rng = np.random.default_rng(5)
    q = _quality(Segmenter(SegmenterConfig(), rng=rng, intrinsics=KINECT_INTRINSICS), 4, rng)
    assert q["bar_kept"] < 0.05 and q["leg_kept"] >= 0.98
    off = _quality(Segmenter(SegmenterConfig(min_part_width=0.0), rng=rng, intrinsics=KINECT_INTRINSICS), 4, rng)
    assert off["bar_kept"] > 0.5


@pytest.mark.parametrize("config", [
    SegmenterConfig(),
    SegmenterConfig(roi=RoiConfig(forward=0.95, max_height=0.45, min_height_per_m2=0.0, center_max_shift=0.0),
                    static_mask=StaticMaskConfig(enabled=False)),
    SegmenterConfig(roi=RoiConfig(min_height=0.05, min_height_per_m2=0.01, left=0.2, right=0.15)),
], ids=["default", "plain_threshold_no_reach", "per_m2"])
@pytest.mark.parametrize("intrinsics", [KINECT_INTRINSICS, QVGA], ids=["vga", "qvga"])
def test_compiled_pixel_pass_is_numpys_bit_for_bit(config: SegmenterConfig, intrinsics: CameraIntrinsics) -> None:
    """The floor-plane branch's pixel pass (walker coordinates, height threshold, box and reach band) compiled
    (``_jit.walker_box``) gives every frame's mask, points and counters of the numpy code, the auto-centred box's
    shift (fed back from the reach band) included."""
    from walker_gait.core import _jit, kernels

    proj = DepthProjector(intrinsics)
    frames = []
    noise_rng = np.random.default_rng(11)
    for i in range(8):
        depth = noisy_depth(scene_cached(gait_legs(3 * i), intrinsics), noise_rng)
        if i == 5:
            depth[: depth.shape[0] // 3] = np.nan  # a frame with a third of its depth gone
        depth.flags.writeable = i % 2 == 0  # and read-only depth images (a message's bytes)
        frames.append(depth)
    got = {}
    for name, jit in (("numpy", None), ("compiled", _jit)):
        seg = Segmenter(config, rng=np.random.default_rng(2), intrinsics=intrinsics)
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(kernels, "compiled", lambda jit=jit: jit)
            got[name] = [seg.process(d, proj.points(d)) for d in frames]
    for a, b in zip(got["numpy"], got["compiled"]):
        assert a.status == b.status == "ok"
        np.testing.assert_array_equal(a.mask, b.mask)
        np.testing.assert_array_equal(a.points, b.points)
        assert (a.n_valid, a.n_floor, a.n_outside_roi, a.n_static, a.n_thin, a.n_foreground, a.roi_shift) == \
            (b.n_valid, b.n_floor, b.n_outside_roi, b.n_static, b.n_thin, b.n_foreground, b.roi_shift)
    assert min(r.n_foreground for r in got["numpy"]) > 500  # legs kept: the box was not empty
    assert any(r.n_outside_roi > 0 for r in got["numpy"])  # and it cut something
    # the walker coordinates themselves, every pixel (NaN where the depth is)
    seg = Segmenter(config, rng=np.random.default_rng(2), intrinsics=intrinsics)
    for depth in frames[:3]:
        pts = proj.points(depth)
        floor = seg.process(depth, pts).floor
        valid = (depth >= config.min_range) & (depth <= config.max_range)
        box = seg._walker_box(depth, valid, floor)
        assert box is not None
        for compiled, numpy_ in zip(box[:3], seg._walker_coords(pts.reshape(-1, 3), depth, floor)):
            np.testing.assert_array_equal(compiled, numpy_)


def test_roi_sides_and_limits() -> None:
    """Camera's left = walker +y = image left: a leg 20 cm to the left is kept, 20 cm to the right is not."""
    rng = np.random.default_rng(7)
    scene = make_synthetic_scene(legs=((0.9, 0.2), (0.9, -0.2)), leg_radius=0.015, bar=None)
    depth = noisy_depth(scene, rng, dropout=0.0, edge_dropout=0.0)
    leg = (scene.labels == LABEL_LEG) & np.isfinite(depth) & (scene.height > 0.05)
    left_leg = leg & (scene.walker[..., 1] > 0)
    right_leg = leg & (scene.walker[..., 1] < 0)
    cols = np.nonzero(left_leg)[1]
    assert cols.mean() < KINECT_INTRINSICS.cx  # camera's left is the image's left
    res = Segmenter(rng=rng).process(depth, PROJ.points(depth))
    assert (res.mask & left_leg).sum() >= 0.98 * left_leg.sum()
    assert (res.mask & right_leg).sum() == 0
    # a shorter forward limit and a height limit
    cfg = SegmenterConfig(roi=RoiConfig(forward=0.8, max_height=0.2))
    res2 = Segmenter(cfg, rng=rng).process(depth, PROJ.points(depth))
    wk = scene.walker[res2.mask]
    assert res2.n_foreground == 0 or (wk[:, 0].max() < 0.8 + 0.03 and wk[:, 2].max() < 0.2 + 0.03)


def _kept_right_leg(seg: Segmenter, frames: range, offset: float, rng: np.random.Generator) -> float:
    """Fraction of the user's rightmost leg (walker -y) kept over ``frames`` of gait, both legs moved
    sideways by ``offset`` (m) as for a camera mounted off the walker's centre line."""
    proj = DepthProjector(QVGA)
    kept = total = 0
    for i in frames:
        (x0, y0), (x1, y1) = gait_legs(i)
        scene = scene_cached(((x0, y0 + offset), (x1, y1 + offset)), QVGA, bar=None)  # type: ignore[arg-type]
        depth = noisy_depth(scene, rng)
        res = seg.process(depth, proj.points(depth))
        leg = (scene.labels == LABEL_LEG) & np.isfinite(depth) & (scene.height > 0.1)
        right = leg & (scene.walker[..., 1] < offset - 0.07)
        kept += int((right & res.mask).sum())
        total += int(right.sum())
    return kept / total


def test_roi_follows_legs_of_an_off_centre_camera() -> None:
    """Legs 12 cm to one side of the box's centre (camera mounted off the centre line): the box follows
    them within a couple of seconds and the outer leg is kept; a fixed box (center_max_shift=0) keeps
    cutting it; legs near the centre (inside the dead band) leave the box exactly where it is."""
    rng = np.random.default_rng(11)
    follow = Segmenter(rng=rng, intrinsics=QVGA)
    fixed = Segmenter(SegmenterConfig(roi=RoiConfig(center_max_shift=0.0)), rng=rng, intrinsics=QVGA)
    settle, later = range(0, 60), range(60, 90)
    _kept_right_leg(follow, settle, -0.12, rng)
    _kept_right_leg(fixed, settle, -0.12, rng)
    assert -0.15 <= follow.roi_shift <= -0.06
    assert fixed.roi_shift == 0.0
    assert _kept_right_leg(follow, later, -0.12, rng) >= 0.95
    assert _kept_right_leg(fixed, later, -0.12, rng) < 0.6
    centred = Segmenter(rng=rng, intrinsics=QVGA)
    assert _kept_right_leg(centred, settle, 0.0, rng) >= 0.95
    assert centred.roi_shift == 0.0


def test_roi_stays_centred_on_a_wide_stance() -> None:
    """Legs 26 cm apart (a wide base of support, as in many patients), equal in area, the walker's posts in
    the band the box can reach: the box stays put and keeps both legs.  (A median of the legs' pixels falls
    on the inner edge of one leg, 7 cm off the centre; the box then chased that leg and cut the other one
    off entirely, the cut pulling it further each frame.)"""
    rng = np.random.default_rng(12)
    seg = Segmenter(rng=rng, intrinsics=QVGA)
    proj = DepthProjector(QVGA)
    scene = scene_cached(((0.85, 0.13), (0.85, -0.13)), QVGA)
    leg = (scene.labels == LABEL_LEG) & (scene.height > 0.1)
    for _ in range(90):
        depth = noisy_depth(scene, rng)
        res = seg.process(depth, proj.points(depth))
    assert abs(seg.roi_shift) < 0.02
    for side in (scene.walker[..., 1] > 0, scene.walker[..., 1] < 0):
        part = leg & side & np.isfinite(depth) & (np.abs(scene.walker[..., 1]) < 0.17)
        assert (res.mask & part).sum() >= 0.95 * part.sum()


def test_joined_parts_are_those_one_with_the_inside_at_one_depth() -> None:
    inside = np.zeros((20, 30), dtype=bool)
    inside[5:15, 8:12] = True  # a leg inside the box ...
    beyond = np.zeros_like(inside)
    beyond[5:15, 12:16] = True  # ... that goes on beyond its side
    beyond[5:15, 22:26] = True  # another part, apart from it in the image
    beyond[5:15, 4:8] = True  # a part beside the leg in the image, 30 cm behind it
    depth = np.ones(inside.shape, dtype=np.float32)
    depth[:, 4:8] = 1.3
    joined = joined_parts(inside, beyond, depth, max_jump=0.05)
    want = np.zeros_like(inside)
    want[5:15, 12:16] = True
    np.testing.assert_array_equal(joined, want)
    # with a jump allowed that large, the part behind joins too
    assert joined_parts(inside, beyond, depth, max_jump=0.5)[5:15, 4:8].all()
    # nothing inside: nothing joins
    assert not joined_parts(np.zeros_like(inside), beyond, depth, max_jump=0.05).any()


@pytest.mark.parametrize("join", [True, False])
def test_a_leg_across_the_side_of_the_box_is_kept_whole(join: bool) -> None:
    """A leg whose axis stands 2 cm beyond the box's right side (walker y -0.195 against -0.175; a user stepping
    wide, or landing the far foot while the box still follows the legs' approach from the other side): with
    ``roi.join_edge_parts`` the part of it beyond the side is kept with the rest; another leg wholly beyond the side
    is not.  Without it the box cuts the first leg along its side."""
    rng = np.random.default_rng(13)
    scene = make_synthetic_scene(legs=((0.9, 0.05), (0.9, -0.195), (1.2, -0.30)), leg_radius=0.05, bar=None, posts=())
    depth = noisy_depth(scene, rng, dropout=0.0, edge_dropout=0.0)
    leg = (scene.labels == LABEL_LEG) & np.isfinite(depth) & (scene.height > 0.05)
    crossing = leg & (scene.walker[..., 1] < -0.12) & (scene.walker[..., 1] > -0.25) & (scene.walker[..., 0] < 1.05)
    apart = leg & (scene.walker[..., 0] > 1.1)
    assert crossing.sum() > 500 and apart.sum() > 200
    res = Segmenter(SegmenterConfig(roi=RoiConfig(join_edge_parts=join)), rng=rng).process(depth, PROJ.points(depth))
    kept = (res.mask & crossing).sum() / crossing.sum()
    if join:
        assert kept >= 0.95, kept
    else:
        assert kept < 0.6, kept
    assert (res.mask & apart).sum() == 0


def test_joined_centred_only_is_what_the_shifted_box_left_of_the_centred_one() -> None:
    """``roi.join_centred_only``: a box centred on the walker joins nothing (the leg across its side is cut as
    without the join); a box shifted 5 cm to the user's left (walker y +0.05) keeps a leg across its right side up to
    where the centred box's side stands (y -0.175), not beyond it, where the whole reach band joins it all."""
    rng = np.random.default_rng(14)
    scene = make_synthetic_scene(legs=((0.9, 0.10), (0.9, -0.16)), leg_radius=0.05, bar=None, posts=())
    depth = noisy_depth(scene, rng, dropout=0.0, edge_dropout=0.0)
    leg = (scene.labels == LABEL_LEG) & np.isfinite(depth) & (scene.height > 0.05)
    y = scene.walker[..., 1]
    crossing = leg & (y < -0.09) & (y > -0.22)
    within, outside = crossing & (y > -0.17) & (y < -0.13), crossing & (y < -0.18)
    assert within.sum() > 200 and outside.sum() > 100

    def segment(shift: float, **roi: bool) -> np.ndarray:
        seg = Segmenter(SegmenterConfig(roi=RoiConfig(**{"join_edge_parts": True, **roi})), rng=np.random.default_rng(1))
        seg.roi_shift = shift
        return seg.process(depth, PROJ.points(depth)).mask

    cut = segment(0.05, join_edge_parts=False)
    assert (cut & within).sum() < 0.05 * within.sum()  # the shifted box's side at y -0.125 cuts the leg
    centred_only = segment(0.05, join_centred_only=True)
    assert (centred_only & within).sum() >= 0.95 * within.sum() and not (centred_only & outside).any()
    everything = segment(0.05, join_centred_only=False)
    assert (everything & outside).sum() >= 0.95 * outside.sum()
    # centred: the join adds nothing
    np.testing.assert_array_equal(segment(0.0, join_centred_only=True), segment(0.0, join_edge_parts=False))


# --------------------------------------------------------------------------- background model (seed)


def test_background_model_learn_save_load_and_segment(tmp_path: Path) -> None:
    rng = np.random.default_rng(8)
    empty = make_synthetic_scene(legs=())
    frames = [noisy_depth(empty, rng) for _ in range(8)]
    model = BackgroundModel.from_frames(frames)
    assert model.shape == (480, 640) and model.n_frames == 8
    assert np.nanmedian(np.abs(model.depth - empty.depth)) < 0.003
    path = tmp_path / "bg.npz"
    model.save(path)
    loaded = BackgroundModel.load(path)
    np.testing.assert_array_equal(loaded.depth, model.depth)
    cfg = SegmenterConfig(floor_method="background")
    seg = Segmenter(cfg, rng=rng, background=loaded)
    q = _quality(seg, 3, rng)
    assert q["leg_kept"] >= 0.98 and q["floor_leak"] <= 0.01
    assert q["bar_kept"] < 0.05  # the walker's bar is part of the background frame
    # unusable files / shapes
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(BackgroundModelError):
        BackgroundModel.load(tmp_path / "junk.npz")
    np.savez(tmp_path / "other.npz", foo=np.zeros(3))
    with pytest.raises(BackgroundModelError, match="no 'depth'"):
        BackgroundModel.load(tmp_path / "other.npz")
    with pytest.raises(BackgroundModelError):
        BackgroundModel.from_frames([])
    small = np.full((4, 5), 1.0, np.float32)
    res = Segmenter(cfg, rng=rng, background=loaded).process(small, np.zeros((4, 5, 3), np.float32))
    assert res.status in ("background_mismatch", "no_floor") and not res.mask.any()


def test_segmenter_learns_background_from_first_frames() -> None:
    rng = np.random.default_rng(9)
    cfg = SegmenterConfig(floor_method="background", background_frames=3)
    seg = Segmenter(cfg, rng=rng)
    empty = make_synthetic_scene(legs=())
    for _ in range(3):
        d = noisy_depth(empty, rng)
        res = seg.process(d, PROJ.points(d))
        assert res.status == "learning_background" and res.n_foreground == 0
    assert seg.background is not None
    scene = make_synthetic_scene()
    d = noisy_depth(scene, rng)
    res = seg.process(d, PROJ.points(d))
    assert res.status == "ok" and (res.mask & (scene.labels == LABEL_LEG)).sum() > 10000


# --------------------------------------------------------------------------- occupancy HMM (paper 003)


def test_hmm_transition_matrix_and_states() -> None:
    cfg = HmmConfig()
    assert (cfg.alpha, cfg.beta, cfg.gamma, cfg.psi, cfg.cell_size) == (0.01, 0.1, 0.4, math.exp(-38), 0.05)
    hmm = OccupancyHMM(cfg, RoiConfig())
    np.testing.assert_allclose(hmm.transition.sum(axis=1), 1.0)
    floor = camera_floor(camera_height=0.5, pitch_deg=30.0)
    static_pt = np.array([[0.5, 0.0, 0.3]] * 5)  # present from the start (walker structure)
    moving_pt = np.array([[1.0, 0.1, 0.3]] * 5)  # appears later (a leg)
    c_static, c_moving = hmm.cell_index(static_pt)[0], hmm.cell_index(moving_pt)[0]
    assert hmm.cell_index(np.array([[5.0, 0.0, 0.0], [np.nan, 0.0, 0.0]])).tolist() == [-1, -1]
    both = np.concatenate([static_pt, moving_pt])
    first_static = None
    for k in range(120):
        hmm.update(points_walker=static_pt if k < 40 else both, floor=floor)
        if first_static is None and hmm.states[c_static] == STATE_STATIC:
            first_static = k
        if k == 70:  # the leg arrived 30 frames ago: moving
            assert hmm.states[c_moving] == STATE_MOVING
            assert hmm.static_points(moving_pt).sum() == 0
    # psi = e^-38: something occupied for long enough (~76 frames) becomes static (003 Fig. 5)
    assert first_static is not None and 60 <= first_static <= 100
    assert hmm.states[c_moving] == STATE_STATIC and hmm.static_points(static_pt).all()
    # 003's static-scene initialisation: occupied in the first frame = static at once
    hmm0 = OccupancyHMM(HmmConfig(init_occupied_static=True), RoiConfig())
    hmm0.update(points_walker=static_pt, floor=floor)
    assert hmm0.states[c_static] == STATE_STATIC and hmm0.states[c_moving] == STATE_EMPTY
    for _ in range(30):
        hmm0.update(points_walker=both, floor=floor)
    assert hmm0.states[c_static] == STATE_STATIC and hmm0.states[c_moving] == STATE_MOVING


def test_hmm_free_space_evidence_empties_cells() -> None:
    hmm = OccupancyHMM(HmmConfig(), RoiConfig())
    floor = camera_floor(camera_height=0.5, pitch_deg=30.0)
    pt = np.array([[1.0, 0.0, 0.2]] * 5)
    for _ in range(5):
        hmm.update(points_walker=pt, floor=floor)
    cell = hmm.cell_index(pt)[0]
    assert hmm.states[cell] != STATE_EMPTY
    # the camera now sees the floor behind the cell: free-space evidence empties it
    scene = make_synthetic_scene(legs=(), bar=None)
    for _ in range(5):
        hmm.update(points_walker=np.empty((0, 3)), floor=scene.floor, depth_m=scene.depth, intrinsics=KINECT_INTRINSICS)
    assert hmm.states[cell] == STATE_EMPTY


def test_segmenter_hmm_removes_static_walker_bar_keeps_moving_legs() -> None:
    rng = np.random.default_rng(10)
    cfg = SegmenterConfig(use_occupancy_hmm=True, min_part_width=0.0)  # the HMM alone
    seg = Segmenter(cfg, rng=rng, intrinsics=QVGA)
    early = _quality(seg, 30, rng, intrinsics=QVGA)
    assert early["bar_kept"] > 0.5  # not yet recognised as static (psi: ~76 frames)
    _quality(seg, 60, rng, start=30, intrinsics=QVGA)  # two more gait cycles
    q = _quality(seg, 8, rng, start=90, intrinsics=QVGA)
    assert q["bar_kept"] < 0.05  # the walker's cross-bar, static in the camera frame, is removed
    assert q["leg_kept"] >= 0.98  # the moving legs are kept


# --------------------------------------------------------------------------- static structure (camera frame)


def _blocks(shift: int, *, leg_depth: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """A 60x80 depth image: floor far away (3 m, not a candidate), a static 'wheel' block at 0.6 m and a
    'leg' block at ``leg_depth`` whose column offset is ``shift``."""
    z = np.full((60, 80), 3.0, np.float32)
    cand = np.zeros((60, 80), bool)
    z[30:50, 4:16] = 0.6
    cand[30:50, 4:16] = True
    z[10:50, 30 + shift : 42 + shift] = leg_depth
    cand[10:50, 30 + shift : 42 + shift] = True
    return z, cand


def _walking(sm: StaticStructureMask, n: int, *, start: int = 0) -> np.ndarray:
    """``n`` frames of the leg block moving as walking legs do (sideways by whole grid cells and in depth);
    returns the static pixels of the last one."""
    got = np.zeros((60, 80), bool)
    for i in range(start, start + n):
        k = (i + 1) % 4
        z, cand = _blocks(2 * k, leg_depth=0.9 + 0.1 * k)
        assert sm.update(z, cand)
        got = sm.static_pixels(z, cand)
    return got


def test_static_mask_learns_structure_only_while_the_user_moves() -> None:
    cfg = StaticMaskConfig(frames=20, grid_stride=2, still_weight=0.0)  # the moving frames alone
    sm = StaticStructureMask(cfg)
    # the user stands still: nothing moves, nothing is learned however long it lasts (legs stay foreground)
    for _ in range(5 * cfg.frames):
        z, cand = _blocks(0)
        sm.update(z, cand)
        assert not sm.static_pixels(z, cand).any()
    assert sm.moving_frames == 0
    # the user walks (the leg block moves every frame): after `frames` moving frames the wheel is structure
    for i in range(cfg.frames + 2):
        k = (i + 1) % 4  # the leg moves sideways (by whole grid cells) and in depth, as walking legs do
        z, cand = _blocks(2 * k, leg_depth=0.9 + 0.1 * k)
        assert sm.update(z, cand)
        got = sm.static_pixels(z, cand)
        if i < cfg.frames - 1:
            assert not got.any()
    assert got[30:50, 4:16].all()  # the whole wheel, edges included
    assert not (got & ~cand).any()
    assert got.sum() == 20 * 12  # and nothing of the leg
    # a leg in front of the learned wheel stays foreground; the wheel beside it is still removed
    z, cand = _blocks(0)
    z[30:50, 8:12] = 0.5
    sm.update(z, cand)
    got = sm.static_pixels(z, cand)
    assert not got[30:50, 8:12].any() and got[30:50, 4:8].all() and got[30:50, 12:16].all()


def test_static_mask_counts_a_view_unchanged_since_it_began_towards_structure() -> None:
    """Before anything has moved, still frames count (``still_weight`` each, up to ``still_share`` of
    ``frames``): the wheels of a walker waiting for its user are learned after the first few moving frames,
    yet nothing is learned while nothing moves, legs standing still from the start are kept, and still
    frames after the first motion (a stop) teach nothing."""
    cfg = StaticMaskConfig(frames=20, grid_stride=2, still_weight=0.2, still_share=0.5)  # still frames: up to 10
    wheel = np.zeros((60, 80), bool)
    wheel[30:50, 4:16] = True

    def empty() -> tuple[np.ndarray, np.ndarray]:  # the wheel alone: the user is out of view
        z, cand = _blocks(0)
        z[~wheel] = 3.0
        return z, cand & wheel

    # the walker waits, its user out of view: however long, nothing is learned before something moves
    sm = StaticStructureMask(cfg)
    for _ in range(200):
        assert not sm.update(*empty())
        assert not sm.static_pixels(*empty()).any()
    assert sm.moving_frames == 0 and not sm.learned.any()
    # the user walks in: the wheel is structure after frames x (1 - still_share) = 10 moving frames, not 20
    assert not _walking(sm, 9).any()
    got = _walking(sm, 1, start=9)
    assert got[wheel].all() and not (got & ~wheel).any()
    # without the still frames it takes the full 20
    sm0 = StaticStructureMask(replace(cfg, still_weight=0.0))
    for _ in range(200):
        sm0.update(*empty())
    assert not _walking(sm0, 19).any() and _walking(sm0, 1, start=19)[wheel].all()

    # a user who stood still from the start keeps the legs once walking: only the wheel is learned
    sm = StaticStructureMask(cfg)
    for _ in range(200):
        sm.update(*_blocks(0))
    assert not sm.static_pixels(*_blocks(0)).any()
    got = _walking(sm, 10)
    assert got[wheel].all() and not (got & ~wheel).any()

    # still frames after the first motion (the user stops) teach nothing: structure that appears during a stop
    # needs the full `frames` moving frames
    sm = StaticStructureMask(cfg)
    sm.update(*_blocks(0))  # the first frame (everything new) is no motion
    _walking(sm, 4)
    box = np.zeros((60, 80), bool)
    box[2:8, 60:72] = True  # something put on the walker while the user stands still

    def with_box(shift: int, depth: float) -> tuple[np.ndarray, np.ndarray]:
        z, cand = _blocks(shift, leg_depth=depth)
        z[box] = 0.7
        return z, cand | box

    sm.update(*with_box(0, 1.0))  # the user stops and the box appears: that frame moves
    for _ in range(200):
        assert not sm.update(*with_box(0, 1.0))
    for i in range(cfg.frames):
        k = (i + 1) % 4
        z, cand = with_box(2 * k, 0.9 + 0.1 * k)
        assert sm.update(z, cand)
        assert sm.static_pixels(z, cand)[box].all() == (i == cfg.frames - 1)


@pytest.mark.parametrize(("shape", "stride"), [((480, 640), 4), ((61, 83), 4), ((50, 70), 3)])
def test_compiled_static_pixels_are_numpys_bit_for_bit(shape: tuple[int, int], stride: int) -> None:
    """The static structure's pixels compiled (``_jit.static_pixels``) as numpy finds them: learned cells and their
    neighbours at their reference depth within the depth-dependent tolerance, images whose size the grid does not
    divide, depth missing in places, references at the edges of the tolerance."""
    from walker_gait.core import _jit, kernels

    rng = np.random.default_rng(8)
    cfg = StaticMaskConfig(grid_stride=stride)
    grid = ((shape[0] + stride - 1) // stride, (shape[1] + stride - 1) // stride)
    structure = np.where(rng.random(grid) < 0.3, rng.uniform(0.4, 3.0, grid), np.nan).astype(np.float32)
    sm = StaticStructureMask(cfg)
    sm.seed(structure, shape)
    full = np.repeat(np.repeat(np.nan_to_num(structure, nan=1.5), stride, 0), stride, 1)[:shape[0], :shape[1]]
    tol = cfg.tolerance + cfg.tolerance_per_m2 * full * full
    depth = (full + rng.uniform(-1.5, 1.5, shape) * tol).astype(np.float32)  # a third of them beyond the tolerance
    depth[rng.random(shape) < 0.05] = np.nan
    mask = rng.random(shape) < 0.8
    got = {}
    for name, jit in (("numpy", None), ("compiled", _jit)):
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(kernels, "compiled", lambda jit=jit: jit)
            got[name] = sm.static_pixels(depth, mask)
    np.testing.assert_array_equal(got["compiled"], got["numpy"])
    assert 0.1 < got["numpy"].mean() < 0.6 and not got["numpy"][~mask].any()


def test_static_mask_learns_what_is_in_view_while_no_legs_are() -> None:
    """Frames whose candidates show no legs (``no_legs``) count in full, moving or not: a walker's wheel in view
    while its user is away is structure after ``frames`` such frames, before the user arrives; off
    (``learn_without_legs``), still frames teach only up to ``still_share``."""
    cfg = StaticMaskConfig(frames=20, grid_stride=2, still_weight=0.2, still_share=0.5)
    wheel = np.zeros((60, 80), bool)
    wheel[30:50, 4:16] = True
    z, cand = _blocks(0)
    z[~wheel] = 3.0
    cand &= wheel
    sm = StaticStructureMask(cfg)
    for i in range(cfg.frames + 1):  # the first frame (everything new) teaches nothing
        assert not sm.update(z, cand, no_legs=True)
        assert sm.static_pixels(z, cand)[wheel].all() == (i == cfg.frames)
    assert sm.moving_frames == 0
    off = StaticStructureMask(replace(cfg, learn_without_legs=False))
    for _ in range(200):
        off.update(z, cand, no_legs=True)
    assert not off.learned.any()


def test_segmenter_learns_the_walkers_structure_before_its_user_arrives() -> None:
    """The walker waits with only its cross-bar in view (no legs: nothing above knee height, nothing leaving the
    image at the top); when the user arrives the bar is gone from the foreground and the legs are all there."""
    rng = np.random.default_rng(12)
    cfg = SegmenterConfig(min_part_width=0.0, static_mask=StaticMaskConfig(frames=30))
    proj = DepthProjector(QVGA)
    empty = scene_cached((), QVGA)
    for learn, bar_kept in ((True, lambda q: q < 0.05), (False, lambda q: q > 0.5)):
        seg = Segmenter(replace(cfg, static_mask=replace(cfg.static_mask, learn_without_legs=learn)), rng=rng,
                        intrinsics=QVGA)
        for _ in range(40):
            depth = noisy_depth(empty, rng)
            seg.process(depth, proj.points(depth))
        q = _quality(seg, 1, rng, intrinsics=QVGA)
        assert bar_kept(q["bar_kept"]), (learn, q)
        assert q["leg_kept"] >= 0.98


def test_static_mask_seeded_with_learned_structure_removes_it_from_the_first_frame() -> None:
    """Offline the structure is learned over the whole recording first (``FrameProcessor.learn_structure``): a mask
    seeded with it removes the wheel from the first frame of a user standing still, where a fresh mask keeps it
    until the user has walked ``frames`` moving frames; the legs stay foreground, also in front of the wheel, and
    the seeded start still counts as the view's first frame (no motion)."""
    cfg = StaticMaskConfig(frames=20, grid_stride=2)
    wheel = np.zeros((60, 80), bool)
    wheel[30:50, 4:16] = True
    learner = StaticStructureMask(cfg)
    assert learner.structure() is None
    learner.update(*_blocks(0))  # the first frame (everything new) is no motion
    _walking(learner, cfg.frames + 2)
    structure = learner.structure()
    assert structure is not None and np.isfinite(structure).sum() == 10 * 6  # the wheel's cells only

    fresh, seeded = StaticStructureMask(cfg), StaticStructureMask(cfg)
    seeded.seed(structure, learner.image_shape)
    for i in range(30):  # the user stands still
        z, cand = _blocks(0)
        assert not fresh.update(z, cand) and not seeded.update(z, cand)
        got = seeded.static_pixels(z, cand)
        assert got[wheel].all() and not (got & ~wheel).any(), i
        assert not fresh.static_pixels(z, cand).any()
    assert seeded.moving_frames == 0
    # a leg in front of the seeded wheel stays foreground
    z, cand = _blocks(0)
    z[30:50, 8:12] = 0.5
    seeded.update(z, cand)
    got = seeded.static_pixels(z, cand)
    assert not got[30:50, 8:12].any() and got[30:50, 4:8].all()
    with pytest.raises(ValueError, match="does not fit"):
        StaticStructureMask(cfg).seed(structure, (60, 90))


def test_static_mask_config_rejects_bad_still_learning() -> None:
    for bad in ({"still_weight": -0.1}, {"still_weight": math.inf}, {"still_share": 1.0}, {"still_share": -0.1}):
        with pytest.raises(ValueError, match="still_"):
            StaticStructureMask(StaticMaskConfig(**bad))


def test_static_mask_forgets_structure_that_has_gone() -> None:
    sm = StaticStructureMask(StaticMaskConfig(frames=5, grid_stride=1))
    for i in range(8):
        sm.update(*_blocks(i % 4, leg_depth=1.0 + 0.1 * (i % 4)))
    z, cand = _blocks(0)
    assert sm.static_pixels(z, cand)[30:50, 4:16].all()
    # the wheel is taken off: the camera sees the far floor where it was
    z[30:50, 4:16] = 3.0
    cand[30:50, 4:16] = False
    sm.update(z, cand)
    assert not sm.learned[30:50, 4:16].any()
    # something put there later (nearer or farther) is new, not the old structure
    z[30:50, 4:16] = 0.8
    cand[30:50, 4:16] = True
    sm.update(z, cand)
    assert not sm.static_pixels(z, cand).any()
    # another image size (a new camera) starts from scratch
    sm.update(np.ones((10, 10), np.float32), np.ones((10, 10), bool))
    assert not sm.learned.any() and sm.moving_frames == 0


def test_segmenter_static_mask_removes_walker_bar_keeps_legs() -> None:
    """The walker's cross-bar (thin-part filter off, so the static mask alone) goes once the legs have moved
    for `frames` frames; moving legs are kept throughout, and so are legs that stand still."""
    rng = np.random.default_rng(11)
    cfg = SegmenterConfig(min_part_width=0.0, static_mask=StaticMaskConfig(frames=30))
    seg = Segmenter(cfg, rng=rng, intrinsics=QVGA)
    early = _quality(seg, 20, rng, intrinsics=QVGA)
    assert early["bar_kept"] > 0.5 and early["leg_kept"] >= 0.98
    _quality(seg, 30, rng, start=20, intrinsics=QVGA)
    q = _quality(seg, 10, rng, start=50, intrinsics=QVGA)
    assert q["bar_kept"] < 0.05 and q["leg_kept"] >= 0.98
    assert seg.static is not None and seg.static.moving_frames >= 45
    # without it the bar stays
    off = Segmenter(replace(cfg, static_mask=StaticMaskConfig(enabled=False)), rng=rng, intrinsics=QVGA)
    assert off.static is None
    assert _quality(off, 60, rng, intrinsics=QVGA)["bar_kept"] > 0.5
    # a user standing still (same leg positions every frame, only sensor noise) is never learned
    still = Segmenter(cfg, rng=rng, intrinsics=QVGA)
    for _ in range(4 * 30):
        q = _quality(still, 1, rng, intrinsics=QVGA)
        assert q["leg_kept"] >= 0.98
    assert still.static is not None and still.static.moving_frames < 10


# --------------------------------------------------------------------------- robustness


@pytest.mark.parametrize("shape", [(1, 1), (2, 3), (5, 1), (480, 640)])
@pytest.mark.parametrize("fill", [np.nan, 0.0, 1.0])
def test_segmenter_degenerate_frames(shape: tuple[int, int], fill: float) -> None:
    intr = CameraIntrinsics(width=shape[1], height=shape[0], fx=2.0, fy=2.0, cx=0.0, cy=0.0)
    depth = np.full(shape, fill, np.float32)
    pts = DepthProjector(intr).points(depth)
    for method in ("plane", "background"):
        cfg = SegmenterConfig(floor_method=method, background_frames=1)
        seg = Segmenter(cfg, rng=np.random.default_rng(0), intrinsics=intr)
        for _ in range(2):
            res = seg.process(depth, pts)
            assert res.mask.shape == shape and res.n_foreground == 0 and res.points.shape == (0, 3)
    with pytest.raises(ValueError, match="does not match"):
        Segmenter(rng=np.random.default_rng(0)).process(depth, pts[..., :2])


def test_segmenter_no_floor_visible_keeps_last_plane() -> None:
    rng = np.random.default_rng(11)
    seg = Segmenter(rng=rng, intrinsics=KINECT_INTRINSICS)
    wall = np.full((480, 640), 1.2, np.float32)  # camera facing a wall: no floor
    res = seg.process(wall, PROJ.points(wall))
    assert res.status == "no_floor" and not res.floor.valid and not res.mask.any()
    scene = make_synthetic_scene()
    d = noisy_depth(scene, rng)
    # after a failed search RANSAC is retried every floor.retry_interval frames (speed)
    results = [seg.process(d, PROJ.points(d)) for _ in range(seg.config.floor.retry_interval)]
    assert results[0].status == "no_floor" and not results[0].floor_refit
    ok = results[-1]
    assert ok.status == "ok" and ok.floor.valid and ok.floor_refit
    res = seg.process(wall, PROJ.points(wall))
    assert res.floor.valid and not res.floor_visible and res.floor.offset == pytest.approx(ok.floor.offset)
    assert res.status == "ok"


def test_config_validation() -> None:
    with pytest.raises(ValueError, match="floor_method"):
        Segmenter(SegmenterConfig(floor_method="magic"), rng=np.random.default_rng(0))
    with pytest.raises(ValueError, match="roi.near"):
        SegmenterConfig(roi=RoiConfig(near=2.0)).validate()
    with pytest.raises(ValueError, match="center_gain"):
        RoiConfig(center_gain=1.5).validate()
    with pytest.raises(ValueError, match="center_max_shift"):
        RoiConfig(center_max_shift=-0.1).validate()
    with pytest.raises(ValueError, match="center_deadband"):
        RoiConfig(center_deadband=math.nan).validate()
    with pytest.raises(ValueError, match="max_tilt_deg"):
        FloorConfig(max_tilt_deg=120).validate()
    with pytest.raises(ValueError, match="hmm.alpha"):
        HmmConfig(alpha=2.0).validate()


_finite_or_not = st.one_of(
    st.just(np.nan), st.just(np.inf), st.just(-np.inf), st.just(0.0), st.floats(-5, 12, width=32),
    st.floats(width=32, allow_nan=True, allow_infinity=True),
)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    depth=hnp.arrays(
        np.float32, hnp.array_shapes(min_dims=2, max_dims=2, min_side=1, max_side=24), elements=_finite_or_not
    ),
    seed=st.integers(0, 2**31 - 1),
    method=st.sampled_from(["plane", "background"]),
    hmm=st.booleans(),
)
def test_segmenter_never_raises_on_decoded_frames(depth: np.ndarray, seed: int, method: str, hmm: bool) -> None:
    # what decode_depth can produce: positive finite metres or NaN
    depth = np.where(np.isfinite(depth) & (depth > 0), depth, np.nan).astype(np.float32)
    h, w = depth.shape
    intr = CameraIntrinsics(width=w, height=h, fx=max(1.0, w / 2), fy=max(1.0, w / 2), cx=w / 2, cy=h / 2)
    pts = DepthProjector(intr).points(depth)
    cfg = SegmenterConfig(floor_method=method, background_frames=1, use_occupancy_hmm=hmm,
                          floor=FloorConfig(min_inliers=3, sample_stride=1, check_stride=1))
    seg = Segmenter(cfg, rng=np.random.default_rng(seed), intrinsics=intr)
    for _ in range(3):
        res = seg.process(depth, pts)
        assert res.mask.shape == depth.shape
        assert res.points.shape == (int(res.mask.sum()), 3) and np.all(np.isfinite(res.points))
        assert np.all(np.isfinite(depth[res.mask]))


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    height=st.floats(0.3, 0.8), pitch=st.floats(10.0, 60.0), roll=st.floats(-8.0, 8.0),
    dropout=st.floats(0.0, 0.9), seed=st.integers(0, 2**31 - 1),
)
def test_segmenter_never_raises_on_random_scenes(
    height: float, pitch: float, roll: float, dropout: float, seed: int
) -> None:
    rng = np.random.default_rng(seed)
    intr = CameraIntrinsics(width=80, height=60, fx=65.6, fy=65.6, cx=39.5, cy=29.5)
    scene = make_synthetic_scene(intrinsics=intr, camera_height=height, pitch_deg=pitch, roll_deg=roll)
    depth = kinect_raw_to_metres(add_kinect_noise(scene.depth, rng=rng, dropout=dropout))
    pts = DepthProjector(intr).points(depth)
    seg = Segmenter(rng=rng, intrinsics=intr)
    res = seg.process(depth, pts)
    assert res.mask.shape == depth.shape and np.all(np.isfinite(res.points))
    if res.floor.valid:
        assert res.floor.normal @ scene.floor.normal > 0.9  # never upside down / a wall


def test_real_xtion_frame_floor_and_person() -> None:
    """Real HSR Xtion frame: a person standing ~2 m away, shiny floor mostly without depth."""
    from test.core.test_depth import _info_kwargs, read_real_bag  # noqa: PLC0415

    from walker_gait.core.depth import intrinsics_from_camera_info  # noqa: PLC0415

    depth_msg, info = read_real_bag()
    depth = decode_depth(depth_msg.data, encoding=depth_msg.encoding, width=depth_msg.width,
                         height=depth_msg.height, step=depth_msg.step, is_bigendian=bool(depth_msg.is_bigendian))
    intr, _ = intrinsics_from_camera_info(**_info_kwargs(info), rectified=True)
    pts = DepthProjector(intr).points(depth)
    seg = Segmenter(rng=np.random.default_rng(0), intrinsics=intr)
    for _ in range(3):
        res = seg.process(depth, pts)
        assert res.mask.shape == depth.shape and np.all(np.isfinite(res.points))
        assert res.n_valid == int(((depth >= 0.2) & (depth <= 8.0)).sum())
    # the floor is found from the little depth it has (around the shoes): a head camera ~0.8 m up,
    # roughly level, and the person's feet stand on it
    floor = res.floor
    assert floor.valid and 0.5 < floor.offset < 1.2
    assert floor.normal @ np.array([0.0, -1.0, 0.0]) > math.cos(math.radians(15))
    feet = pts[440:470, 260:370].reshape(-1, 3)
    feet = feet[np.isfinite(feet).all(axis=1)]
    assert feet.shape[0] > 500 and abs(np.median(floor.height(feet))) < 0.05
    body = pts[150:400, 280:340].reshape(-1, 3)
    body_h = floor.height(body[np.isfinite(body).all(axis=1)])
    assert 0.1 < np.percentile(body_h, 5) and np.percentile(body_h, 95) < 1.9
    # nobody within the default 1.5 m ROI; with a 2.5 m deep ROI the person is the foreground
    assert res.n_foreground == 0
    wide = Segmenter(SegmenterConfig(roi=RoiConfig(forward=2.5, left=0.5, right=0.5)), rng=np.random.default_rng(0),
                     intrinsics=intr).process(depth, pts)
    vs, us = np.nonzero(wide.mask)
    assert wide.n_foreground > 20000
    assert 230 < np.percentile(us, 1) and np.percentile(us, 99) < 400  # the person's image columns


def test_bench_smoke() -> None:
    out = run_segmentation_bench(rng=np.random.default_rng(0), n_frames=3)
    assert out["floor_valid_frames"] == 3
    assert float(out["floor_angle_err_deg_median"]) < 0.5 and float(out["floor_height_err_mm_median"]) < 5
    assert float(out["leg_kept_pct"]) >= 98 and float(out["floor_leak_pct"]) <= 1
    assert float(out["ms_median"]) > 0


def test_a_close_users_legs_are_not_learned_as_the_walkers_structure() -> None:
    """A user who comes close to the walker has legs nearer than the sensor's range above the shins: the image shows
    the shins only, without depth above them up to its top (the legs leave the view through those pixels), nothing
    above knee height.  Those are legs, not the walker's structure: a segmenter that learns what it sees while no
    legs are in view (``learn_without_legs``) keeps them in the foreground.  The same shins with the room seen
    above them (low things alone in view) are learned away."""
    rng = np.random.default_rng(7)
    cfg = SegmenterConfig(min_part_width=0.0, static_mask=StaticMaskConfig(frames=20))
    proj = DepthProjector(QVGA)
    scene = scene_cached(((0.42, 0.09), (0.45, -0.07)), QVGA, bar=None, posts=())
    room = scene_cached((), QVGA, bar=None, posts=()).depth
    legs = scene.labels == LABEL_LEG
    too_near = legs & (scene.depth < 0.47)  # the legs' upper part, nearer than the sensor's range
    shins = legs & ~too_near & (scene.height > 0.05)
    assert too_near[:2].any() and shins.sum() > 500
    assert scene.height[legs & ~too_near].max() < 0.40  # nothing above knee height in view
    kept = {}
    for above in ("no depth", "room"):
        seg = Segmenter(cfg, rng=rng, intrinsics=QVGA)
        for i in range(45):
            depth = noisy_depth(scene, rng)
            if i >= 10:  # the user stood further back, then comes close
                depth[too_near] = np.nan if above == "no depth" else room[too_near]
            res = seg.process(depth, proj.points(depth))
        kept[above] = float((res.mask & shins).sum() / shins.sum())
    assert kept["no depth"] > 0.9 and kept["room"] < 0.1, kept
