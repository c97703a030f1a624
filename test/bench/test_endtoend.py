"""Scoring helpers of the end-to-end benchmark (walker_gait.bench.endtoend)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from walker_gait.bench.endtoend import (
    IN_VIEW_LEAD_S,
    IN_VIEW_TAIL_S,
    JOINT_KINDS,
    PipelineRun,
    angle_errors,
    at_walker,
    frames_off_pct,
    live_bridged,
    recovery_time,
    steps_in_view,
    true_leg_length,
)
from walker_gait.core.segmentation import RoiConfig
from walker_gait.core.types import ANKLE, HIP, FloorPlane, LegPose, TrackStatus


def test_steps_in_view_need_a_second_with_the_user_in_view_before_the_heel_strike() -> None:
    assert IN_VIEW_LEAD_S == 1.0
    stamps = np.arange(0, 300) / 30.0  # 10 s at 30 fps
    present = np.ones(300, dtype=bool)
    present[:90] = False  # the user walks in at 3 s
    present[150:153] = False  # and leaves the view for 0.1 s at 5 s
    steps = np.array([0.5, 2.0, 3.5, 4.05, 5.05, 5.9, 6.2, 9.9, 10.5])
    got = steps_in_view(steps, stamps, present)
    np.testing.assert_array_equal(got, [False, False, False, True, False, False, True, True, False])
    # all in view: only the steps in the first second (no history) and after the end are out
    got = steps_in_view(np.array([0.5, 1.0, 5.0, 10.5]), stamps, np.ones(300, dtype=bool))
    np.testing.assert_array_equal(got, [False, True, True, False])
    # a shorter lead
    assert steps_in_view(np.array([3.5]), stamps, present, lead_s=0.4).tolist() == [True]
    assert steps_in_view(np.zeros(0), stamps, present).shape == (0,)
    # a strike in the recording's last frames cannot be confirmed: with the benchmarks' tail it is not in view
    assert IN_VIEW_TAIL_S == 0.1
    last = stamps[-1]
    got = steps_in_view(np.array([last - 0.2, last - 0.05, last]), stamps, np.ones(300, dtype=bool), tail_s=IN_VIEW_TAIL_S)
    np.testing.assert_array_equal(got, [True, False, False])


def test_at_walker_needs_both_ankles_in_the_walkers_region_of_interest() -> None:
    """A user approaching from the side is in the image but not at the walker; the box's sideways limits widen by
    the auto-centring shift; a camera pitched down sees the same floor-aligned box."""
    roi = RoiConfig()
    for pitch in (0.0, 0.5):
        floor = FloorPlane.from_camera_pose(height=0.5, pitch=pitch)
        rot, t = floor.walker_transform()

        def cam(xw: float, yw: float) -> np.ndarray:  # a walker-frame floor point in the camera frame
            return rot.T @ (np.array([xw, yw, 0.0]) - t)

        frames = [((0.9, 0.10), (1.0, -0.10)),  # at the walker
                  ((0.9, roi.left + roi.center_max_shift - 0.01), (1.0, 0.0)),  # the box followed the legs left
                  ((0.9, roi.left + roi.center_max_shift + 0.05), (1.0, 0.0)),  # one ankle outside: approaching
                  ((0.9, 0.0), (1.0, -(roi.right + roi.center_max_shift) - 0.05)),  # the other side
                  ((roi.forward + 0.1, 0.05), (roi.forward + 0.2, -0.05)),  # too far back
                  ((0.9, 0.05), (np.nan, np.nan))]  # no truth
        truth = np.zeros((len(frames), 2, 5, 3))
        for k, pair in enumerate(frames):
            for side, (xw, yw) in enumerate(pair):
                truth[k, side, ANKLE] = cam(xw, yw)
        np.testing.assert_array_equal(at_walker(truth, floor), [True, True, False, False, False, False])
        # a narrower box (no auto-centring)
        narrow = RoiConfig(center_max_shift=0.0)
        np.testing.assert_array_equal(at_walker(truth, floor, narrow), [True, False, False, False, False, False])


def test_rendered_present_needs_one_leg_trackable_needs_both() -> None:
    from walker_gait.bench.endtoend import Rendered

    r = Rendered(frames=[], visible_pixels=np.array([[0, 0], [500, 0], [0, 300], [250, 250], [150, 150]]), seconds=0.0)
    assert r.present(min_pixels=200).tolist() == [False, True, True, True, False]
    assert r.trackable(min_pixels=200).tolist() == [False, False, False, True, False]


def test_recovery_time_counts_from_the_start_frame_until_the_error_stays_low() -> None:
    stamps = np.arange(20) / 10.0
    err = np.full((20, 2, 5), 0.30)
    err[:3] = np.nan  # no pose yet
    err[8] = 0.05  # one good frame is not a recovery
    err[12:] = 0.04
    start = np.zeros(20, dtype=bool)
    start[2:] = True
    assert recovery_time(stamps, err, start) == pytest.approx(1.0)  # 1.2 - 0.2
    later = np.zeros(20, dtype=bool)
    later[10:] = True
    assert recovery_time(stamps, err, later) == pytest.approx(0.2)
    assert math.isnan(recovery_time(stamps, err, np.zeros(20, dtype=bool)))
    err[17] = 0.5  # the error never stays low for five frames after the start
    err[12:16] = 0.5
    assert recovery_time(stamps, err, start) == math.inf


def test_angle_errors_pool_both_legs_per_angle_and_wrap_the_difference() -> None:
    assert JOINT_KINDS == ("hip_flexion", "hip_abduction", "hip_rotation", "knee_flexion", "ankle_flexion",
                           "ankle_inversion")
    truth = np.zeros((4, 12))
    est = np.zeros((4, 12))
    est[:, 3] = np.radians(-10.0)  # left knee 10 deg straighter than the truth in every frame
    est[:2, 9] = np.radians(4.0)  # right knee 4 deg more flexed in two frames, exact in two
    truth[:, 2] = np.radians(179.0)
    est[:, 2] = np.radians(-179.0)  # left hip rotation 2 deg off across the wrap, not 358
    est[1, 4] = np.nan  # a left ankle without an estimate is left out of its angle only
    truth[:, 10] = np.radians(5.0)
    mae, bias = angle_errors(est, truth)
    assert mae["knee_flexion"] == pytest.approx((4 * 10 + 2 * 4) / 8)
    assert bias["knee_flexion"] == pytest.approx((-4 * 10 + 2 * 4) / 8)
    assert mae["hip_rotation"] == pytest.approx(2 * 4 / 8) and bias["hip_rotation"] == pytest.approx(1.0)
    assert mae["ankle_flexion"] == pytest.approx(4 * 5 / 7) and bias["ankle_flexion"] == pytest.approx(-4 * 5 / 7)
    assert mae["hip_flexion"] == 0.0 and bias["ankle_inversion"] == 0.0
    none_mae, _ = angle_errors(np.full((3, 12), np.nan), truth[:3])
    assert all(math.isnan(v) for v in none_mae.values())
    with pytest.raises(ValueError, match="shape"):
        angle_errors(est, truth[:3])


def test_the_true_leg_length_is_the_standing_hips_height() -> None:
    """What the bench tells the pipeline as the user's measured leg length is the synthetic user's hip height standing
    still at the start (within the standing knees' slight flexion), different for each subject."""
    from walker_gait.synth import SessionSpec, generate_session

    lengths = []
    for seed in (0, 1):
        session = generate_session(SessionSpec.preset("normal", duration=1.0), rng=np.random.default_rng(seed))
        rot, origin = session.world_from_camera[0, :3, :3], session.world_from_camera[0, :3, 3]
        hips = session.leg_points[0, :, HIP] @ rot.T + origin  # world frame, z up from the floor
        lengths.append(true_leg_length(session))
        np.testing.assert_allclose(hips[:, 2], lengths[-1], atol=0.01)
    assert abs(lengths[0] - lengths[1]) > 0.005


def test_frames_off_count_frames_without_a_pose_and_only_the_frames_asked_for() -> None:
    err = np.full((6, 2, 5), 0.02)
    err[1] = 0.3  # off
    err[2] = np.nan  # no pose: off
    err[3, 0] = 0.19  # mean 0.105: off
    err[4, :, :2] = np.nan  # only the hips missing: the rest decide
    frames = np.array([True, True, True, True, True, False])
    assert frames_off_pct(err, frames) == pytest.approx(60.0)
    assert frames_off_pct(err, np.array([True, False, False, False, True, True])) == 0.0
    assert math.isnan(frames_off_pct(err, np.zeros(6, dtype=bool)))


def test_the_bridged_live_poses_and_their_delays_are_the_live_bridges() -> None:
    """``live_bridged``: a one-pass run's poses through the live bridge; a frame's delay runs from its stamp to the
    stamp of the frame that released it (0 without a hidden foot), NaN where the recording ended first."""
    from walker_gait.core.smoothing import BRIDGE_FIT_FRAMES, LiveBridge

    floor = FloorPlane.from_camera_pose(height=0.5, pitch=0.5)
    rot, t = floor.walker_transform()
    poses = []
    for i in range(40):
        pts = np.zeros((2, 5, 3))
        pts[..., 0] = -0.8 + 0.3 * i / 30
        pts[..., 2] = [0.6, 0.4, 0.2, 0.12, 0.1]
        vis = np.ones((2, 3))
        if 10 <= i < 16 or i >= 37:  # hidden, then seen again; hidden to the end
            vis[1, 2] = 0.0
            pts[1] = poses[-1].points[1] if 10 < i < 16 or i > 37 else pts[1]
        poses.append(LegPose(stamp=i / 30, points=(pts - t) @ rot, visibility=vis, status=TrackStatus.TRACKING))
    run = PipelineRun(tracker_cue="combined", poses=poses, steps=[], timing_ms={}, tracker_ms=[], floors=[floor] * 40)
    out, delay = live_bridged(run, hide_below=0.25)
    bridge = LiveBridge(hide_below=0.25)
    want = [p for i, pose in enumerate(poses) for p, _ in bridge.push(pose, floor, i)] + [p for p, _ in bridge.flush()]
    assert all(np.array_equal(o.points, w.points) for o, w in zip(out, want, strict=True))
    assert not np.array_equal(out[13].points, poses[13].points)
    k = BRIDGE_FIT_FRAMES
    assert np.allclose(delay[:10], 0.0) and np.allclose(delay[10:16 + k + 1], (16 + k - np.arange(10, 16 + k + 1)) / 30)
    assert np.allclose(delay[16 + k + 1:37], 0.0) and np.isnan(delay[37:]).all()
