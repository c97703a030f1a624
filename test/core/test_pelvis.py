"""The reported pelvis placed over the feet (walker_gait.core.pelvis): the feet held, the hips moved."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from walker_gait.core import leg_model as lm
from walker_gait.core import pelvis as pv
from walker_gait.core.leg_model import StateLayout as L
from walker_gait.core.types import ANKLE, HEEL, HIP, KNEE, TOE, FloorPlane, LegPose, TrackStatus

FLIP = np.diag([-1.0, -1.0, 1.0])  # body frame -> walker frame for a camera facing the user


@pytest.fixture
def placed_heels_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    """The placed heels without the tracked ones drawn in (:data:`~walker_gait.core.pelvis.TRACKED_HEEL_WEIGHT` 0):
    the tests of where the placement puts a heel (its length, pitch, heading, the floor) read the heel it places;
    :func:`test_the_reported_heel_draws_the_placed_one_towards_the_tracked_one` covers the weight."""
    monkeypatch.setattr(pv, "TRACKED_HEEL_WEIGHT", 0.0)


@pytest.fixture
def feet_at_placed_heights(monkeypatch: pytest.MonkeyPatch) -> None:
    """The feet at the heights the other rules place them (:data:`~walker_gait.core.pelvis.FEET_ON_FLOOR` off): the
    tests of those rules (the pelvis, the lengths, the heels' pitch and heading, the ankles) pose feet a little off
    the floor or through it; :func:`test_feet_are_put_on_the_floor` and the tests after it cover the floor."""
    monkeypatch.setattr(pv, "FEET_ON_FLOOR", False)


def _state(angles_deg: list[float], *, root_xy: tuple[float, float] = (0.0, -0.09),
           thigh: float | None = None, calf: float | None = None) -> np.ndarray:
    x = lm.neutral_state(right_hip_xy=root_xy)
    x[L.ANGLES] = np.radians(angles_deg)
    if thigh is not None:
        x[L.LEN_THIGH] = thigh
    if calf is not None:
        x[L.LEN_CALF] = calf
    return lm.enforce_constraints(x[None])[0][0]


def _walk(n: int = 90, fps: float = 30.0, *, lean_deg: float = 0.0,
          thigh: float | None = None, calf: float | None = None) -> tuple[list[LegPose], np.ndarray]:
    """A walking-like sequence in the walker frame: the legs swing in antiphase at 1 Hz under a still pelvis, the
    thighs leaning ``lean_deg`` back from where they would bring the pelvis over the feet (the tracked pelvis's
    error: a pelvis ahead of the feet); returns the poses and each frame's state."""
    poses, states = [], []
    for i in range(n):
        s = np.sin(2 * np.pi * i / fps)
        ang = [20 * s - lean_deg, 2, 0, 30 + 15 * s, 5 * s, 0, -20 * s - lean_deg, 2, 0, 30 - 15 * s, -5 * s, 0]
        x = _state(ang, thigh=thigh, calf=calf)
        pts = lm.forward_kinematics(x).points[0]
        states.append(x)
        segs = np.zeros((2, 3, 2, 3))
        poses.append(LegPose(stamp=i / fps, points=pts @ FLIP, angles=lm.joint_angles(x), segments=segs))
    return poses, np.stack(states)


def _assert_same_feet(after: np.ndarray, before: np.ndarray, *, toe_atol: float = 0.0) -> None:
    """The toes of ``after`` (body frame) are those of ``before`` bit for bit, the heels to rounding (their feet are
    of one length already, so moving the heels to the track's foot length leaves them), and the ankles the tracked
    ones moved :data:`~walker_gait.core.pelvis.FOOT_ANKLE_WEIGHT` of the way to where the leg model puts the ankle in
    that foot: the model's feet's own ankles but for the foot's roll, which heel and toe do not show (a few mm)."""
    np.testing.assert_allclose(after[..., HEEL, :], before[..., HEEL, :], atol=1e-12)
    _assert_placed_ankles(after, before, toe_atol=toe_atol)
    assert np.abs(after[..., ANKLE, :] - before[..., ANKLE, :]).max() < 0.005


def _assert_placed_ankles(after: np.ndarray, before: np.ndarray, *, atol: float = 1e-12,
                          toe_atol: float = 0.0) -> None:
    """The toes of ``after`` (body frame, ``(..., 5, 3)``) are those of ``before`` (bit for bit unless ``toe_atol``:
    poses moved between frames and back) and each ankle is the tracked one moved
    :data:`~walker_gait.core.pelvis.FOOT_ANKLE_WEIGHT` of the way to where the leg model puts the ankle in the reported
    foot (:func:`~walker_gait.core.pelvis.foot_ankle` of the reported heel and toe)."""
    np.testing.assert_allclose(after[..., TOE, :], before[..., TOE, :], rtol=0.0, atol=toe_atol)
    w = pv.FOOT_ANKLE_WEIGHT
    expected = (1.0 - w) * before[..., ANKLE, :] + w * pv.foot_ankle(after[..., HEEL, :], after[..., TOE, :])
    np.testing.assert_allclose(after[..., ANKLE, :], expected, atol=atol)


def _ahead(points: np.ndarray) -> float:
    """How far (body frame x) the pelvis of ``points`` ``(2, 5, 3)`` stands ahead of the midpoint of its ankles."""
    return float(points[:, HIP, 0].mean() - points[:, ANKLE, 0].mean())


def test_the_pelvis_leads_the_ankles_more_walking_than_standing() -> None:
    """The lean grows from a standing user's to a walking one's with the feet's fore-aft swing, and no further."""
    still = np.full(30, 0.02) + 1e-3 * np.random.default_rng(0).standard_normal(30)
    assert pv.lean(still) == pytest.approx(pv.STAND_LEAN_M, abs=1e-3)
    t = np.arange(30) / 30.0
    leans = [pv.lean(a * np.sin(2 * np.pi * t)) for a in (0.1, 0.2, 0.3, 0.5)]
    assert pv.STAND_LEAN_M < leans[0] < leans[1] < pv.WALK_LEAN_M
    assert leans[2] == leans[3] == pytest.approx(pv.WALK_LEAN_M)
    # support_sample reads the ankles' midpoint and separation and the feet's heading (toe-outs of 10 deg cancel)
    pts = np.zeros((2, 5, 3))
    pts[0, ANKLE], pts[1, ANKLE] = [0.2, 0.1, 0.09], [-0.1, -0.1, 0.09]
    out = np.radians(10.0)
    pts[0, TOE, :2], pts[1, TOE, :2] = [np.cos(out), np.sin(out)], [np.cos(out), -np.sin(out)]
    np.testing.assert_allclose(pv.support_sample(pts), [0.05, 0.0, 0.3, 2 * np.cos(out), 0.0], atol=1e-12)
    # the target: the ankles' mean midpoint, the lean ahead of it along the feet's heading, facing it
    samples = np.array([[0.0, 0.01, 0.0, 1.0, 0.0], [0.02, -0.01, 0.0, 1.0, 0.0]])
    np.testing.assert_allclose(pv.pelvis_target(samples), [0.01 + pv.STAND_LEAN_M, 0.0, 0.0], atol=1e-12)
    turned = samples.copy()
    turned[:, 3:] = [np.cos(0.3), np.sin(0.3)]
    np.testing.assert_allclose(pv.pelvis_target(turned),
                               [0.01 + pv.STAND_LEAN_M * np.cos(0.3), pv.STAND_LEAN_M * np.sin(0.3), 0.3], atol=1e-12)
    pts[1, ANKLE] = np.nan
    assert np.all(np.isnan(pv.support_sample(pts)[[0, 2]]))


def test_pose_state_rebuilds_the_state_of_a_model_pose() -> None:
    x = _state([20, 3, 2, 35, 5, 1, -10, 2, -3, 15, -5, 0])
    pts = lm.forward_kinematics(x).points[0]
    rebuilt = pv.pose_state(pts, lm.joint_angles(x))
    np.testing.assert_allclose(lm.forward_kinematics(rebuilt).points[0], pts, atol=1e-9)
    np.testing.assert_allclose(rebuilt[L.ANGLES], x[L.ANGLES])


def test_place_pelvis_moves_the_pelvis_and_holds_the_knees_and_feet() -> None:
    x = _state([20, 3, 2, 35, 5, 1, -10, 2, -3, 15, -5, 0])
    pts = lm.forward_kinematics(x).points[0]
    mid = lm.hip_positions(x)[0].mean(axis=0)
    new = pv.place_pelvis(x, pv.held_points(pts), mid[:2] + np.array([-0.05, 0.01]))
    moved = lm.hip_positions(new)[0].mean(axis=0)
    np.testing.assert_allclose(moved[:2], mid[:2] + np.array([-0.05, 0.01]), atol=1e-9)
    after = lm.forward_kinematics(new).points[0]
    off = np.linalg.norm(after - pts, axis=-1)  # (2 legs, 5 points)
    # the feet stay within a centimetre and the knees within two, as near as the model's fixed lengths allow ...
    assert off[:, ANKLE:].max() < 0.01 and off[:, KNEE].max() < 0.02
    # ... where the same pelvis move without the re-solve carries every point of the legs 5 cm along
    naive = x.copy()
    naive[[L.ROOT_X, L.ROOT_Y]] += np.array([-0.05, 0.01])
    assert np.linalg.norm(lm.forward_kinematics(naive).points[0] - pts, axis=-1)[:, KNEE:].min() > 0.05
    # the legs' angles changed, within the model's limits
    assert np.abs(new[L.ANGLES] - x[L.ANGLES]).max() > np.radians(2)
    assert np.all(new >= lm.STATE_LOWER - 1e-12) and np.all(new <= lm.STATE_UPPER + 1e-12)


@pytest.mark.usefixtures("feet_at_placed_heights")
def test_place_poses_puts_the_pelvis_over_the_feet_and_leaves_the_feet_alone() -> None:
    poses, states = _walk(lean_deg=-4.0)
    placed = pv.place_poses(poses)
    before = np.stack([p.points for p in poses]) @ FLIP
    after = np.stack([p.points for p in placed]) @ FLIP
    # the feet are the tracked ones (a model walk: its feet are of the track's one length already)
    _assert_same_feet(after, before)
    # the pelvis stood 15 cm ahead of the ankles; placed, it leads their midpoint averaged over a stride by a walking
    # user's lean (the feet swing: sd of their separation 0.25 m)
    ahead_before = np.array([_ahead(p) for p in before])
    ahead_after = np.array([_ahead(p) for p in after])
    assert ahead_before.mean() - pv.WALK_LEAN_M > 0.05
    inner = slice(15, -15)  # frames with a full window either side
    assert abs(ahead_after[inner].mean() - pv.WALK_LEAN_M) < 0.01
    # the pelvis went back over the feet: the thighs reach forward to the knees, hip flexion rises on both legs
    a_before = np.stack([p.angles for p in poses])
    a_after = np.stack([p.angles for p in placed])
    assert np.all(a_after[inner, [0, 6]] != a_before[inner, [0, 6]])
    assert (a_after[inner][:, [0, 6]] - a_before[inner][:, [0, 6]]).mean() > np.radians(3)
    # the segments follow the moved hips and knees
    segs = np.stack([p.segments for p in placed])
    np.testing.assert_array_equal(segs[:, :, 0, 0], np.stack([p.points for p in placed])[:, :, HIP])
    np.testing.assert_array_equal(segs[:, :, 1, 0], np.stack([p.points for p in placed])[:, :, KNEE])
    np.testing.assert_array_equal(segs[:, :, 1, 1], np.stack([p.points for p in placed])[:, :, ANKLE])
    # the placed hips and knees are a model pose with the typical adult's thighs (the walk's are the model's mean)
    thigh = np.linalg.norm(after[:, :, HIP] - after[:, :, KNEE], axis=-1)
    assert abs(np.linalg.norm(before[:, :, HIP] - before[:, :, KNEE], axis=-1).mean() - pv.TYPICAL_THIGH_CALF_M[0]) > 0.01
    np.testing.assert_allclose(thigh, pv.TYPICAL_THIGH_CALF_M[0], atol=1e-6)


def test_place_poses_passes_frames_without_a_track_through() -> None:
    poses, _ = _walk(n=30)
    poses[5] = LegPose.no_user(poses[5].stamp)
    poses[6] = dataclasses.replace(poses[6], status=TrackStatus.SEARCHING)
    poses[7] = dataclasses.replace(poses[7], angles=np.full(12, np.nan))
    placed = pv.place_poses(poses)
    for k in (5, 6, 7):
        assert placed[k] is poses[k]
    assert not np.array_equal(placed[8].points, poses[8].points)


def test_place_poses_mounting_and_window_are_checked() -> None:
    poses, _ = _walk(n=5)
    with pytest.raises(ValueError, match="mounting"):
        pv.place_poses(poses, mounting="sideways")
    with pytest.raises(ValueError, match="window_s"):
        pv.place_poses(poses, window_s=0.0)


def _floor() -> FloorPlane:
    """A camera 0.5 m up, pitched 30 deg down (camera optical frame: y down, z forward)."""
    pitch = np.radians(30.0)
    up = np.array([0.0, -np.cos(pitch), np.sin(pitch)])  # the floor normal, towards the camera's side
    return FloorPlane(normal=up, offset=0.5, rms=0.0, inlier_ratio=1.0, valid=True)


def _body(camera: list[LegPose]) -> np.ndarray:
    """The points of poses in the camera frame of :func:`_floor` in the body frame."""
    floor = _floor()
    return np.stack([floor.to_walker(p.points) for p in camera]) @ FLIP


def _with_hips_and_knees(poses: list[LegPose], true_pts: np.ndarray, states: np.ndarray) -> list[LegPose]:
    """``poses`` as a tracker would report them holding ``states`` ``(F, 23)``: their feet (``true_pts``, body
    frame) kept, the hips, knees and joint angles those of the states."""
    out = []
    for p, pts, x in zip(poses, true_pts, states):
        pts = pts.copy()
        pts[:, [HIP, KNEE]] = lm.forward_kinematics(x).points[0][:, [HIP, KNEE]]
        out.append(pv.with_points(p, pts @ FLIP, angles=lm.joint_angles(x)))
    return out


def _placed_live(live: pv.LivePelvis, poses: list[LegPose]) -> np.ndarray:
    """``(F, 2, 5, 3)`` body-frame points of walker-frame ``poses`` placed frame by frame by ``live``, through the
    camera frame of :func:`_floor`."""
    floor = _floor()
    rot, t = floor.walker_transform()
    return _body([live.place(pv.moved_pose(p, rot.T, -(rot.T @ t)), floor) for p in poses])


@pytest.mark.usefixtures("feet_at_placed_heights")
def test_live_pelvis_follows_a_drifting_user_without_lag_and_keeps_the_feet() -> None:
    """Frame by frame, causal: a user who drifts back from the walker at 0.2 m/s (legs still: a standing user's lean)
    gets the pelvis placed over the ankles where they are now (a line through the last second's midpoints), not where
    they were half a second ago (10 cm off: the mean of the last second); the feet are the tracked ones bit for bit;
    a frame without a user starts the history afresh."""
    floor = _floor()
    body = lm.BodyFrame.from_floor(floor, mounting="facing_user")
    x0 = _state([-8, 2, 0, 30, 0, 0, -8, 2, 0, 30, 0, 0])
    live = pv.LivePelvis(window_s=1.0)
    ahead = []
    for i in range(60):
        x = x0.copy()
        x[L.ROOT_X] -= 0.2 * i / 30.0  # body frame: +x is the user's forward, towards the walker
        pts_body = lm.forward_kinematics(x).points[0]
        pose = LegPose(stamp=i / 30.0, points=body.to_camera(pts_body), angles=lm.joint_angles(x))
        out = live.place(pose, floor)
        np.testing.assert_array_equal(out.points[:, ANKLE:], pose.points[:, ANKLE:])
        placed = body.to_body(out.points)
        ahead.append(_ahead(placed) - pv.STAND_LEAN_M)
    assert abs(_ahead(lm.forward_kinematics(x0).points[0]) - pv.STAND_LEAN_M) > 0.05
    assert np.abs(ahead[20:]).max() < 0.01
    # no user, then the user back 0.3 m further off: placed over where the feet are now from the first frame
    assert live.place(LegPose.no_user(2.0), floor).status == TrackStatus.NO_USER
    x = x0.copy()
    x[L.ROOT_X] += 0.3
    pts_body = lm.forward_kinematics(x).points[0]
    out = live.place(LegPose(stamp=2.1, points=body.to_camera(pts_body), angles=lm.joint_angles(x)), floor)
    placed = body.to_body(out.points)
    assert abs(_ahead(placed) - pv.STAND_LEAN_M) < 0.01
    # a floor it cannot use: the pose as given
    bad = dataclasses.replace(floor, valid=False)
    pose = LegPose(stamp=2.2, points=body.to_camera(pts_body), angles=lm.joint_angles(x))
    assert live.place(pose, bad) is pose


@pytest.mark.usefixtures("feet_at_placed_heights")
def test_reported_poses_place_the_pelvis_in_the_walker_frame() -> None:
    """``smoothing.reported_poses`` places the pelvis as :func:`place_poses` does in each frame's walker frame, the
    feet kept; without floors (no walker frame) or with a window of 0 the hips stay as tracked."""
    from walker_gait.core.smoothing import reported_poses

    floor = _floor()
    body = lm.BodyFrame.from_floor(floor, mounting="facing_user")
    walker_poses, _ = _walk(n=60, lean_deg=-8.0)
    rot, t = floor.walker_transform()
    cam = [pv.moved_pose(p, rot.T, -(rot.T @ t)) for p in walker_poses]
    shown = reported_poses(cam, hide_below=0.25, max_gap_s=0.0, lowpass_hz=0.0, floors=[floor] * len(cam),
                           pelvis_window_s=1.0)
    want = pv.place_poses(walker_poses, window_s=1.0)
    np.testing.assert_allclose([floor.to_walker(p.points) for p in shown], [p.points for p in want], atol=1e-9)
    _assert_same_feet(_body(shown), np.stack([p.points for p in walker_poses]) @ FLIP, toe_atol=1e-12)
    assert np.abs(np.stack([body.to_body(p.points)[:, HIP] for p in shown])
                  - np.stack([body.to_body(p.points)[:, HIP] for p in cam])).max() > 0.03
    for kwargs in ({"floors": None, "pelvis_window_s": 1.0}, {"floors": [floor] * len(cam), "pelvis_window_s": 0.0}):
        same = reported_poses(cam, hide_below=0.25, max_gap_s=0.0, lowpass_hz=0.0, **kwargs)
        assert all(a is b for a, b in zip(same, cam))


def test_a_held_pose_is_held_as_placed() -> None:
    """A pose the tracker held (a blanked view: the same points and angles again) is reported as the pose before it
    was placed, live and offline, though the feet's window moves on."""
    floor = _floor()
    poses, _ = _walk(n=40, lean_deg=-8.0)
    held = [*poses[:20], *[dataclasses.replace(poses[19], stamp=poses[k].stamp, status=TrackStatus.DEGRADED,
                                               confidence=0.0) for k in range(20, 24)], *poses[24:]]
    offline = pv.place_poses(held)
    for k in range(20, 24):
        np.testing.assert_array_equal(offline[k].points, offline[19].points)
        np.testing.assert_array_equal(offline[k].angles, offline[19].angles)
        assert offline[k].status == TrackStatus.DEGRADED
    rot, t = floor.walker_transform()
    live = pv.LivePelvis()
    out = [live.place(pv.moved_pose(p, rot.T, -(rot.T @ t)), floor) for p in held]
    for k in range(20, 24):
        np.testing.assert_array_equal(out[k].points, out[19].points)
        np.testing.assert_array_equal(out[k].angles, out[19].angles)
    assert not np.array_equal(out[24].points, out[19].points)


@pytest.mark.usefixtures("feet_at_placed_heights")
def test_the_hips_are_reported_a_typical_adults_width_apart() -> None:
    """The tracker's hip distance is unseen and starts from the feet's, narrower than the hips: a track carrying the
    hips 0.14 m apart over the same feet and knees is reported with them the typical adult's 0.18 m apart, each near
    its true place across the body (2 cm off as tracked), the feet kept; offline and live alike."""
    assert pv.TYPICAL_HIP_WIDTH_M == 0.18
    poses, states = _walk(n=60, lean_deg=-10.0)  # the model's neutral hips, 0.18 m apart; the pelvis a lean ahead
    true_pts = np.stack([p.points for p in poses]) @ FLIP
    narrow = states.copy()
    narrow[:, L.HIP_DIST] = 0.14
    solved = pv.place_pelvis(narrow, np.stack([pv.held_points(p) for p in true_pts]),
                             lm.hip_positions(states).mean(axis=1)[:, :2])
    tracked = _with_hips_and_knees(poses, true_pts, solved)
    tracked_pts = np.stack([p.points for p in tracked]) @ FLIP
    inner = slice(15, -15)

    def across(pts: np.ndarray) -> np.ndarray:  # each hip's sideways distance from its true place (m)
        return np.abs(pts[inner][:, :, HIP, 1] - true_pts[inner][:, :, HIP, 1])

    np.testing.assert_allclose(np.linalg.norm(tracked_pts[:, 0, HIP] - tracked_pts[:, 1, HIP], axis=-1), 0.14)
    assert across(tracked_pts).mean() > 0.015
    offline = np.stack([p.points for p in pv.place_poses(tracked)]) @ FLIP
    live = _placed_live(pv.LivePelvis(), tracked)
    for placed in (offline, live):
        np.testing.assert_allclose(np.linalg.norm(placed[:, 0, HIP] - placed[:, 1, HIP], axis=-1), 0.18, atol=1e-9)
        assert across(placed).mean() < 0.005
    _assert_placed_ankles(offline, tracked_pts, atol=1e-9, toe_atol=1e-9)
    # live, no shoe measures: the heels, ankles and toes the tracker's
    np.testing.assert_allclose(live[:, :, ANKLE:], tracked_pts[:, :, ANKLE:], rtol=0.0, atol=1e-9)


def test_unmeasured_legs_are_a_typical_adults_not_the_models_mean() -> None:
    """Without a measured leg length the thighs and calves are reported as Winter's shares of a 1.70 m adult's
    stature, not as the tracker's mean shape (0.43 / 0.42 m, a 1.73 m adult's): a user of that stature tracked on
    the model's mean legs has the hips reported at their height (they stood 1.5 cm high before), offline and live."""
    thigh, calf = pv.TYPICAL_THIGH_CALF_M
    np.testing.assert_allclose([thigh, calf], np.array([pv.THIGH_OF_STATURE, pv.CALF_OF_STATURE]) * 1.70)
    poses, states = _walk(n=60, lean_deg=-10.0, thigh=thigh, calf=calf)  # the pelvis a walking lean ahead
    true_pts = np.stack([p.points for p in poses]) @ FLIP
    assert abs(np.mean([_ahead(p) for p in true_pts]) - pv.WALK_LEAN_M) < 0.01
    held = np.stack([pv.held_points(p) for p in true_pts])
    model = pv.with_lengths(states, held, thigh=np.full(len(states), lm.MEAN_SHAPE[0]),
                            calf=np.full(len(states), lm.MEAN_SHAPE[1]))
    solved = pv.place_pelvis(*model, lm.hip_positions(states).mean(axis=1)[:, :2])
    tracked = _with_hips_and_knees(poses, true_pts, solved)
    inner = slice(15, -15)
    hip_z = true_pts[inner][:, :, HIP, 2]
    tracked_z = (np.stack([p.points for p in tracked]) @ FLIP)[inner][:, :, HIP, 2]
    assert (tracked_z - hip_z).mean() > 0.01  # the model's legs stand the hips high
    placed = np.stack([p.points for p in pv.place_poses(tracked)]) @ FLIP
    assert abs((placed[inner][:, :, HIP, 2] - hip_z).mean()) < 0.004
    live_pts = _placed_live(pv.LivePelvis(), tracked)
    assert abs((live_pts[inner][:, :, HIP, 2] - hip_z).mean()) < 0.004


@pytest.mark.usefixtures("feet_at_placed_heights")
def test_a_measured_leg_length_puts_the_hips_at_their_height() -> None:
    """A tall user (thighs and calves 3 cm longer than the typical adult's) tracked on legs 6 cm short in all (the
    camera sees neither the thighs nor the knees): not measured, the legs are reported as the typical adult's and the
    hips stand low; with the user's measured leg length the thighs and calves have its lengths, each knee moves along
    its tracked calf, the feet stay bit for bit and the hips come to their true height, offline and live alike."""
    typical_thigh, typical_calf = pv.TYPICAL_THIGH_CALF_M
    poses, states = _walk(n=60, lean_deg=-4.0, thigh=typical_thigh + 0.03, calf=typical_calf + 0.03)
    true_pts = np.stack([p.points for p in poses]) @ FLIP
    foot = states[0, L.LEN_FOOT]
    leg = states[0, L.LEN_THIGH] + states[0, L.LEN_CALF] + lm.ANKLE_HEIGHT * foot  # the hips' standing height
    # the "tracked" poses: the same feet and lower calves on legs 6 cm short
    held = np.stack([pv.held_points(p) for p in true_pts])
    short, short_held = pv.with_leg_length(states, held, leg - 0.06)
    solved = pv.place_pelvis(short, short_held, lm.hip_positions(states).mean(axis=1)[:, :2])
    tracked = _with_hips_and_knees(poses, true_pts, solved)
    inner = slice(15, -15)
    hip_z = true_pts[inner][:, :, HIP, 2]

    def hips_off(placed: list[LegPose]) -> float:
        got = np.stack([p.points for p in placed])[inner] @ FLIP
        return float(np.abs(got[:, :, HIP, 2] - hip_z).mean())

    typical = np.stack([p.points for p in pv.place_poses(tracked)]) @ FLIP
    assert hips_off(pv.place_poses(tracked)) > 0.04
    np.testing.assert_allclose(np.linalg.norm(typical[:, :, HIP] - typical[:, :, KNEE], axis=-1), typical_thigh,
                               atol=2e-3)
    placed = pv.place_poses(tracked, leg_length_m=leg)
    assert hips_off(placed) < 0.015
    after = np.stack([p.points for p in placed]) @ FLIP
    _assert_same_feet(after, np.stack([p.points for p in tracked]) @ FLIP)
    # the model's lengths: Winter's shares of the leg less the ankle height; the knee near the tracked calf's line
    legs = leg - lm.ANKLE_HEIGHT * foot
    np.testing.assert_allclose(np.linalg.norm(after[:, :, HIP] - after[:, :, KNEE], axis=-1), pv.THIGH_SHARE * legs,
                               atol=2e-3)
    calf_t = np.stack([p.points for p in tracked])[:, :, KNEE] @ FLIP - after[:, :, ANKLE]
    calf_p = after[:, :, KNEE] - after[:, :, ANKLE]
    cos = np.sum(calf_t * calf_p, axis=-1) / np.linalg.norm(calf_t, axis=-1) / np.linalg.norm(calf_p, axis=-1)
    ang = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))  # least squares with the feet: near the line, not on it
    assert np.median(ang) < 5.0 and ang.max() < 8.0
    # live: the same lengths
    live_pts = _placed_live(pv.LivePelvis(), tracked)
    np.testing.assert_allclose(np.linalg.norm(live_pts[:, :, HIP] - live_pts[:, :, KNEE], axis=-1), typical_thigh,
                               atol=2e-3)
    live_pts = _placed_live(pv.LivePelvis(leg_length_m=leg), tracked)
    np.testing.assert_allclose(np.linalg.norm(live_pts[:, :, HIP] - live_pts[:, :, KNEE], axis=-1),
                               pv.THIGH_SHARE * legs, atol=2e-3)
    assert float(np.abs(live_pts[inner][:, :, HIP, 2] - hip_z).mean()) < 0.015


def test_foot_ankle_is_the_models_ankle_in_a_foot_without_roll() -> None:
    """:func:`foot_ankle` puts the ankle where the leg model has it in a foot from its heel and toe: exactly for a
    model foot without roll, flat or pitched either way; a few mm off for one rolled by the hip's abduction and the
    ankle's inversion; NaN for a foot of no length or standing upright."""
    x = _state([20, 0, 0, 35, -15, 0, -10, 0, 0, 15, 10, 0])  # left heel up, right toe up, no roll
    pts = lm.forward_kinematics(x).points[0]
    np.testing.assert_allclose(pv.foot_ankle(pts[:, HEEL], pts[:, TOE]), pts[:, ANKLE], atol=1e-12)
    rolled = lm.forward_kinematics(_state([20, 5, 3, 35, -15, 4, -10, 2, 0, 15, 10, 0])).points[0]
    off = np.linalg.norm(pv.foot_ankle(rolled[:, HEEL], rolled[:, TOE]) - rolled[:, ANKLE], axis=-1)
    assert np.all(off > 1e-3) and np.all(off < 0.01)
    flat = pv.foot_ankle(np.array([0.1, 0.2, 0.0]), np.array([0.1, 0.45, 0.0]))  # a 25 cm foot along +y
    np.testing.assert_allclose(flat, [0.1, 0.2 + lm.HEEL_BACK * 0.25, lm.ANKLE_HEIGHT * 0.25], atol=1e-12)
    assert np.all(np.isnan(pv.foot_ankle(np.zeros(3), np.zeros(3))))
    assert np.all(np.isnan(pv.foot_ankle(np.zeros(3), np.array([0.0, 0.0, 0.25]))))


@pytest.mark.usefixtures("feet_at_placed_heights")
def test_an_ankle_is_reported_halfway_to_where_the_placed_foot_puts_it() -> None:
    """The tracker's ankle and the one the reported foot puts at the model's place in it err apart (it is fitted to
    the calf as well): a track whose ankles sit 3 cm above and 2 cm behind where its feet put them is reported with
    them :data:`FOOT_ANKLE_WEIGHT` of the way there, offline and live (once the shoe shows its heel), the knees about
    the typical calf's length above them, and the ankles as tracked kept live for the gait analysis
    (``ankle_tracked``)."""
    assert pv.FOOT_ANKLE_WEIGHT == 0.5
    x = _state([0, 0, 0, 5, 5, 0, 0, 0, 0, 5, 5, 0])  # standing, the feet flat and without roll
    poses = [LegPose(stamp=i / 30.0, points=lm.forward_kinematics(x).points[0] @ FLIP, angles=lm.joint_angles(x),
                     segments=np.zeros((2, 3, 2, 3))) for i in range(40)]
    true_pts = np.stack([p.points for p in poses]) @ FLIP
    assert np.all(true_pts[:, :, [HEEL, TOE], 2] < pv.SHOE_FLAT_HEIGHT_M)
    shift = np.array([-0.02, 0.0, 0.03])  # body frame: behind (towards the heel) and up
    tracked = []
    for p, pts in zip(poses, true_pts):
        moved = pts.copy()
        moved[:, ANKLE] += shift
        tracked.append(dataclasses.replace(pv.with_points(p, moved @ FLIP), shoe_rise=np.full(2, 0.25)))
    want = true_pts[:, :, ANKLE] + (1.0 - pv.FOOT_ANKLE_WEIGHT) * shift
    offline = np.stack([p.points for p in pv.place_poses(tracked)]) @ FLIP
    np.testing.assert_allclose(offline[:, :, ANKLE], want, atol=1e-9)
    # the knees about the typical calf above them (the re-solve's least squares with the feet held) and near the
    # true ones, which the track had
    np.testing.assert_allclose(np.linalg.norm(offline[:, :, KNEE] - offline[:, :, ANKLE], axis=-1),
                               pv.TYPICAL_THIGH_CALF_M[1], atol=0.01)
    assert np.abs(offline[:, :, KNEE] - true_pts[:, :, KNEE]).max() < 0.015
    given, out, live = _live(tracked)
    shown = np.array([o.ankle_tracked is not None for o in out])
    assert shown[pv.SHOE_FLAT_FRAMES:].all() and not shown[0]
    np.testing.assert_allclose(live[shown][:, :, ANKLE], want[shown], atol=1e-6)
    np.testing.assert_allclose(live[~shown][:, :, ANKLE], true_pts[~shown][:, :, ANKLE] + shift, atol=1e-6)
    for g, o in zip(given, out):
        np.testing.assert_array_equal(o.as_tracked().points[:, ANKLE], g.points[:, ANKLE])


def test_a_leg_length_must_be_in_metres_within_an_adults_range() -> None:
    assert pv.check_leg_length(None) is None
    assert pv.check_leg_length(0.9) == 0.9
    assert pv.check_leg_length(0.0) is None  # the parameters' "not measured"
    for bad in (88.0, 1.75, 0.2, float("nan"), "0.9", True):
        with pytest.raises(ValueError, match="leg_length_m .* metres"):
            pv.check_leg_length(bad)
    with pytest.raises(ValueError, match=r"a stature\? .* 0\.93 m"):  # 0.530 x 1.75
        pv.check_leg_length(1.75)
    with pytest.raises(ValueError, match=r"centimetres\? 0\.88 m"):
        pv.check_leg_length(88)
    poses, _ = _walk(n=5)
    with pytest.raises(ValueError, match="leg_length_m"):
        pv.place_poses(poses, leg_length_m=90.0)
    with pytest.raises(ValueError, match="leg_length_m"):
        pv.LivePelvis(leg_length_m=90.0)


@pytest.mark.usefixtures("feet_at_placed_heights")
def test_the_placed_pelvis_faces_the_feet() -> None:
    """A pelvis tracked turned 15 deg from where the feet point (its turn is as unseen as its place), the legs reaching
    the same knees and feet with other hip angles, is reported facing the feet's heading with the hip rotations of the
    same walk tracked untwisted; the feet stay bit for bit."""
    poses, states = _walk(n=60)
    turned = []
    for p, x in zip(poses, states):
        pts = np.asarray(p.points) @ FLIP
        y = pv.place_pelvis(x, pv.held_points(pts), lm.hip_positions(x)[0].mean(axis=0)[:2], yaw=np.radians(15.0))
        twisted = pts.copy()
        twisted[:, [HIP, KNEE]] = lm.forward_kinematics(y).points[0][:, [HIP, KNEE]]
        turned.append(pv.with_points(p, twisted @ FLIP, angles=lm.joint_angles(y)))
    placed, straight = pv.place_poses(turned), pv.place_poses(poses)
    got = np.stack([p.points for p in placed]) @ FLIP
    d = got[:, 0, HIP] - got[:, 1, HIP]
    assert np.abs(np.degrees(np.arctan2(-d[:, 0], d[:, 1]))).max() < 1.0
    _assert_same_feet(got, np.stack([p.points for p in turned]) @ FLIP)
    rotation = [2, 8]  # JOINT_NAMES: left / right hip rotation
    twist = np.stack([p.angles for p in turned])[:, rotation] - np.stack([p.angles for p in straight])[:, rotation]
    left = np.stack([p.angles for p in placed])[:, rotation] - np.stack([p.angles for p in straight])[:, rotation]
    assert np.abs(twist).mean() > np.radians(5)
    assert np.abs(left).max() < np.radians(1)


def test_the_placement_is_the_same_in_the_body_frame_for_either_mounting() -> None:
    """A camera facing forward (the user's left on the image's left) places the same body-frame pelvis, hips and knees
    as one facing the user: the mounting only says how the body frame lies in the walker frame."""
    poses, _ = _walk(n=40, lean_deg=-4.0)
    facing_user = np.stack([p.points for p in pv.place_poses(poses, mounting="facing_user", leg_length_m=0.9)]) @ FLIP
    forward = [pv.with_points(p, np.asarray(p.points) @ FLIP) for p in poses]  # the same bodies, walker = body
    facing_forward = np.stack([p.points for p in pv.place_poses(forward, mounting="facing_forward", leg_length_m=0.9)])
    np.testing.assert_allclose(facing_forward, facing_user, atol=1e-9)
    assert np.abs(facing_user[:, :, HIP] - np.stack([p.points for p in poses])[:, :, HIP] @ FLIP).max() > 0.02


def _wandering(poses: list[LegPose], rng: np.random.Generator, *, foot_sd: float, calf_sd: float) -> list[LegPose]:
    """``poses`` (walker frame) as a tracker reports them: each frame's heels moved along their feet (the shoe's
    length wanders by ``foot_sd``) and knees along their calves (``calf_sd``), the toes, ankles and hips where they
    were; the left leg's change is the right one's negated, so the track's median lengths are the true ones."""
    out = []
    for p in poses:
        pts = np.asarray(p.points, dtype=np.float64) @ FLIP
        sign = np.array([[1.0], [-1.0]])
        foot = pts[:, HEEL] - pts[:, TOE]
        pts[:, HEEL] += foot / np.linalg.norm(foot, axis=-1, keepdims=True) * sign * foot_sd * rng.standard_normal()
        calf = pts[:, KNEE] - pts[:, ANKLE]
        pts[:, KNEE] += calf / np.linalg.norm(calf, axis=-1, keepdims=True) * sign * calf_sd * rng.standard_normal()
        out.append(pv.with_points(p, pts @ FLIP))
    return out


def _lengths(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Calf (knee to ankle) and foot (heel to toe) lengths of ``points`` ``(F, 2, 5, 3)``."""
    return (np.linalg.norm(points[:, :, KNEE] - points[:, :, ANKLE], axis=-1),
            np.linalg.norm(points[:, :, TOE] - points[:, :, HEEL], axis=-1))


@pytest.mark.usefixtures("placed_heels_alone", "feet_at_placed_heights")
def test_a_track_is_reported_with_one_length_of_each_segment() -> None:
    """The tracker's lengths wander from frame to frame (they are part of its state), a user's do not: placed, a track
    whose calves and shoes wander about the true lengths is reported as the same walk tracked without the wander:
    every heel at the track's median foot length along its tracked foot from the seen toe, the knees and hips within
    a few mm; the toes stay bit for bit and the ankles go towards the placed feet's.  A frame without a user ends a
    track: the next one (another user, feet 3 cm longer) gets its own lengths.  Live, without the shoes measured
    (nothing shows where the heels are), the heels stay the tracker's and the knees and hips are those of the walk
    without the wander."""
    rng = np.random.default_rng(3)
    poses, _ = _walk(n=90, thigh=0.47)  # a thigh 5 cm longer than the calf
    longer = []  # the second user's feet: 3 cm longer (heels further back)
    for p in poses[46:]:
        pts = np.asarray(p.points, dtype=np.float64) @ FLIP
        foot = pts[:, HEEL] - pts[:, TOE]
        pts[:, HEEL] += 0.03 * foot / np.linalg.norm(foot, axis=-1, keepdims=True)
        longer.append(pv.with_points(p, pts @ FLIP))
    clean = poses[:45] + [LegPose.no_user(poses[45].stamp)] + longer
    tracked = _wandering(clean[:45], rng, foot_sd=0.02, calf_sd=0.03) + [clean[45]] \
        + _wandering(clean[46:], rng, foot_sd=0.02, calf_sd=0.03)
    before = np.stack([p.points for p in tracked]) @ FLIP
    placed = pv.place_poses(tracked)
    assert placed[45] is tracked[45]
    after = np.stack([p.points for p in placed]) @ FLIP
    want = np.stack([p.points for p in pv.place_poses(clean)]) @ FLIP
    for track in (slice(0, 45), slice(46, 90)):
        b, a, w = before[track], after[track], want[track]
        _assert_placed_ankles(a, b)
        calf_b, foot_b = _lengths(b)
        assert foot_b.std() > 0.015 and calf_b.std() > 0.02  # as tracked: wandering
        np.testing.assert_allclose(a[:, :, HEEL], w[:, :, HEEL], atol=1e-9)  # the median is the true length
        assert np.abs(a[:, :, [HIP, KNEE]] - w[:, :, [HIP, KNEE]]).max() < 0.005
        assert np.abs(b[:, :, KNEE] - w[:, :, KNEE]).max() > 0.04
    assert np.median(_lengths(after[46:])[1]) - np.median(_lengths(after[:45])[1]) > 0.025
    np.testing.assert_allclose(pv.segment_lengths(before[:45])[1:],
                               [np.median(_lengths(before[:45])[k]) for k in (0, 1)])
    assert np.all(np.isnan(pv.segment_lengths(np.full((3, 2, 5, 3), np.nan))))
    # live, no shoe measures: the heels as tracked; the knees and hips those of the clean walk's live placement
    got, live_want = _placed_live(pv.LivePelvis(), tracked), _placed_live(pv.LivePelvis(), clean)
    np.testing.assert_allclose(got[:, :, HEEL], before[:, :, HEEL], atol=1e-9)
    ok = np.ones(90, dtype=bool)
    ok[45] = False
    assert np.abs(got[ok][:, :, [HIP, KNEE]] - live_want[ok][:, :, [HIP, KNEE]]).max() < 0.005


def _shod(poses: list[LegPose], *, longer: float, calf_radius: float) -> list[LegPose]:
    """``poses`` (walker frame) with each heel moved ``longer`` (m) back along its foot (a shoe that much longer) and
    the calves' proximal radii ``calf_radius`` (a tube of baggy trousers down to a hem beyond ``LOOSE_CALF_RADIUS``)."""
    out = []
    for p in poses:
        pts = np.asarray(p.points, dtype=np.float64) @ FLIP
        foot = pts[:, HEEL] - pts[:, TOE]
        pts[:, HEEL] += longer * foot / np.linalg.norm(foot, axis=-1, keepdims=True)
        radii = np.full((2, 3, 2), 0.05)
        radii[:, 1, 0] = calf_radius
        out.append(dataclasses.replace(pv.with_points(p, pts @ FLIP), radii=radii))
    return out


@pytest.mark.usefixtures("placed_heels_alone", "feet_at_placed_heights")
def test_a_shoe_under_a_trouser_hem_is_reported_at_least_the_typical_shoes_length() -> None:
    """A hem hides the back of the shoe, which the tracker then leaves out of its foot (short, never long): a track
    whose calves are a tube of loose fabric has its heels placed at least :data:`HEMMED_SHOE_M` behind their toes, a
    longer tracked shoe is kept, and without a hem the tracked length stands, offline and live (where the heels are
    placed: a shoe shown cleanly).  The toes and ankles stay the tracker's."""
    lo, hi = lm.LOOSE_CALF_RADIUS
    assert pv.hemmed(np.full((30, 2), hi)) and pv.hemmed(np.full(5, 0.5 * (lo + hi) + 1e-3))
    assert not pv.hemmed(np.full((30, 2), lo)) and not pv.hemmed(np.full(5, 0.5 * (lo + hi) - 1e-3))
    assert not pv.hemmed(np.full(4, np.nan)) and pv.hemmed(np.array([np.nan, hi, hi]))
    typical = pv.HEMMED_SHOE_M
    assert typical is not None and 0.24 < typical < 0.29
    assert pv.shoe_length(0.20, hem=True) == typical and pv.shoe_length(0.30, hem=True) == 0.30
    assert pv.shoe_length(0.20, hem=False) == 0.20 and np.isnan(pv.shoe_length(np.nan, hem=True))
    walk, _ = _walk(n=60)
    true_len = float(np.median(_lengths(np.stack([p.points for p in walk]) @ FLIP)[1]))
    for longer, radius, want in ((-0.05, 0.115, typical), (-0.05, 0.06, true_len - 0.05),
                                 (0.03, 0.115, true_len + 0.03)):
        tracked = _shod(walk, longer=longer, calf_radius=radius)
        before = np.stack([p.points for p in tracked]) @ FLIP
        after = np.stack([p.points for p in pv.place_poses(tracked)]) @ FLIP
        _assert_placed_ankles(after, before)
        np.testing.assert_allclose(_lengths(after)[1], want, atol=1e-9)
    # live: a shoe shown cleanly (a steady rise of its upper on flat frames) has its heel placed at the tracked
    # length, from its calibration on; under a hem, never shown cleanly, both heels from the first frame at the
    # typical shoe's
    stand = _stand_then_heel_up(tracked_pitch_deg=20.0)
    shown = [dataclasses.replace(p, shoe_rise=np.full(2, 0.25)) for p in stand]
    stand_len = float(np.median(_lengths(np.stack([p.points for p in stand]) @ FLIP)[1]))
    for seq, radius, want in ((stand, 0.115, typical), (shown, 0.06, stand_len - 0.05)):
        given, out, after = _live(_shod(seq, longer=-0.05, calf_radius=radius))
        placed = np.array([o.heel_tracked is not None for o in out])
        assert placed.all() if radius > lo else (placed[pv.SHOE_FLAT_FRAMES:].all() and not placed[0])
        np.testing.assert_allclose(_lengths(after[placed])[1], want, atol=1e-6)
        for g, o in zip(given, out):
            np.testing.assert_array_equal(o.points[:, TOE], g.points[:, TOE])
            np.testing.assert_array_equal(o.as_tracked().points[:, ANKLE:], g.points[:, ANKLE:])
        _assert_placed_ankles(after[placed], _body(given)[placed], atol=1e-9, toe_atol=1e-9)
    _, plain, _ = _live(_shod(stand, longer=-0.05, calf_radius=0.06))  # no hem, no shoe shown: as tracked
    assert all(o.heel_tracked is None for o in plain)


def _stand_then_heel_up(*, tracked_pitch_deg: float, n: int = 60, fps: float = 30.0) -> list[LegPose]:
    """Standing with both feet flat for ``n // 2`` frames, then the left heel up by 20 deg (the pelvis over it moved
    back, the knee bent) while the tracker reports that foot pitched only ``tracked_pitch_deg`` heel-up; walker frame.
    A foot's pitch (toe up) is hip flexion - knee flexion + ankle dorsiflexion."""
    poses = []
    for i in range(n):
        if i < n // 2:
            left = [0, 2, 0, 5, 5, 0]
        else:
            hip, knee = -10.0, 15.0
            left = [hip, 2, 0, knee, knee - hip - tracked_pitch_deg, 0]
        x = _state([*left, 0, 2, 0, 5, 5, 0])
        poses.append(LegPose(stamp=i / fps, points=lm.forward_kinematics(x).points[0] @ FLIP,
                             angles=lm.joint_angles(x), segments=np.zeros((2, 3, 2, 3))))
    return poses


def _shown_heel_rise(rng: np.random.Generator) -> tuple[list[LegPose], np.ndarray, list[LegPose]]:
    """:func:`_stand_then_heel_up` with the tracker 12 deg too flat in the heel rise, and the same poses with the rise
    their shoes' uppers show (0.25 rad, the shoe's own, with 0.002 rad of noise; the left one 20 deg more in the heel
    rise): the tracked poses, the rises ``(F, 2)`` and the measured poses."""
    tracked = _stand_then_heel_up(tracked_pitch_deg=8.0)
    n = len(tracked)
    rise = 0.25 + rng.normal(0.0, 0.002, (n, 2))
    rise[n // 2:, 0] += np.radians(20.0)
    return tracked, rise, [dataclasses.replace(p, shoe_rise=r) for p, r in zip(tracked, rise)]


@pytest.mark.usefixtures("placed_heels_alone", "feet_at_placed_heights")
def test_a_heel_is_reported_at_the_pitch_its_shoe_upper_shows() -> None:
    """The tracker holds a foot in its heel rise several degrees flatter than it is (its foot is fitted to the whole
    leg's data), while the shoe's upper, the foot's best-seen surface, turns with the foot: the rise measured on the
    track's flat frames calibrates the shoe, and a frame whose upper rises 20 deg more is reported with its heel 20
    deg up behind the seen toe, the track's foot length from it, along the tracked heading; a flat foot stays put.  An
    upper whose rise scatters over the flat frames (a trouser hem over the shoe) or too few flat frames leave the
    heels as tracked."""
    rng = np.random.default_rng(5)
    tracked, rise, with_rise = _shown_heel_rise(rng)  # the shoe's own rise 0.25 rad, toe box to instep
    n = len(tracked)
    before = np.stack([p.points for p in tracked]) @ FLIP
    flat = before[: n // 2, :, [HEEL, TOE], 2]
    assert np.all(flat < pv.SHOE_FLAT_HEIGHT_M) and np.all(flat > -0.005)  # both feet stand flat at first
    plain = np.stack([p.points for p in pv.place_poses(tracked)]) @ FLIP
    after = np.stack([p.points for p in pv.place_poses(with_rise)]) @ FLIP
    toe, heel = before[n // 2:, 0, TOE], before[n // 2:, 0, HEEL]
    length = np.linalg.norm(before[0, 0, TOE] - before[0, 0, HEEL])
    heading = (heel - toe)[:, :2] / np.linalg.norm((heel - toe)[:, :2], axis=-1, keepdims=True)
    p = np.radians(20.0)
    want = toe + length * np.column_stack([np.cos(p) * heading, np.full(len(toe), np.sin(p))])
    assert np.abs(after[n // 2:, 0, HEEL] - want).max() < 0.003
    assert np.abs(plain[n // 2:, 0, HEEL] - want).max() > 0.04  # as tracked: 12 deg too flat, 5 cm off
    _assert_placed_ankles(after, before)
    assert np.abs(after[:, 1, HEEL] - plain[:, 1, HEEL]).max() < 0.002  # the flat right foot: as before
    # the angles are solved for the reported points: the ankle more plantarflexed with the heel up (the ankle point
    # held where tracked keeps the solved foot between the two pitches)
    ank = 4  # left ankle dorsiflexion in JOINT_NAMES order
    placed_ank = np.array([q.angles[ank] for q in pv.place_poses(with_rise)[n // 2:]])
    plain_ank = np.array([q.angles[ank] for q in pv.place_poses(tracked)[n // 2:]])
    assert np.all(plain_ank - placed_ank > np.radians(3.0))
    # no clean upper: the rise scatters 3 deg; or a track with only 5 flat frames
    scattered = rise + rng.normal(0.0, np.radians(3.0), (n, 2))
    noisy = [dataclasses.replace(q, shoe_rise=r) for q, r in zip(tracked, scattered)]
    np.testing.assert_allclose(np.stack([q.points for q in pv.place_poses(noisy)]) @ FLIP, plain, atol=1e-12)
    short = with_rise[n // 2 - 5:]  # the left foot's five flat frames (the right one is flat throughout)
    np.testing.assert_allclose(np.stack([q.points[0, HEEL] for q in pv.place_poses(short)]),
                               np.stack([q.points[0, HEEL] for q in pv.place_poses(tracked[n // 2 - 5:])]), atol=1e-12)


def test_shoe_pitch_is_the_rise_less_the_flat_shoes() -> None:
    """:func:`shoe_pitch` per foot: the median rise of the flat frames less each frame's rise; NaN for a foot without
    enough flat frames, one whose flat rise scatters, and unmeasured frames."""
    n = 30
    pts = np.zeros((n, 2, 5, 3))
    pts[:, :, TOE, 0] = 0.26
    pts[20:, 0, HEEL, 2] = 0.08  # the left heel up in the last ten frames
    rise = np.full((n, 2), 0.3)
    rise[20:, 0] = 0.3 + np.radians(18.0)
    rise[5, 1] = np.nan
    rise[:, 1] += np.radians(np.linspace(-2.0, 2.0, n))[np.random.default_rng(1).permutation(n)]  # scatters 1 deg
    got = pv.shoe_pitch(pts, rise)
    np.testing.assert_allclose(got[:20, 0], 0.0)
    np.testing.assert_allclose(got[20:, 0], -np.radians(18.0))
    assert np.all(np.isnan(got[:, 1]))
    assert np.all(np.isnan(pv.shoe_pitch(pts[15:], rise[15:])[:, 0]))  # five flat frames: not calibrated


def test_a_scattered_rise_that_follows_the_tracked_foot_through_its_swing_measures_its_pitch() -> None:
    """A shoe's rise that scatters more than :data:`SHOE_RISE_MAD` over the flat frames (a lower-resolution camera's
    fewer points) still measures the foot's pitch where, over the frames off the flat, the pitch it gives follows the
    tracker's foot through the swing (:data:`SHOE_RISE_FOLLOW`); a trouser hem's slope, which does not, or too few
    frames off the flat to judge (:data:`SHOE_RISE_FOLLOW_FRAMES`), leave it unmeasured."""
    rng = np.random.default_rng(4)
    n_flat, n_off = 40, 40
    n = n_flat + n_off
    true = np.concatenate([np.zeros(n_flat), np.radians(35.0) * np.sin(np.linspace(0.0, np.pi, n_off))])  # heel-up
    tracked = 0.7 * true + np.radians(2.0) * rng.standard_normal(n) * (true > 0)  # the tracker's: flatter, noisy
    pts = np.zeros((n, 2, 5, 3))
    pts[:, :, TOE, 0] = 0.26 * np.cos(tracked)[:, None]
    pts[:, :, HEEL, 2] = 0.26 * np.sin(tracked)[:, None]  # both feet alike; toes on the floor
    off = pts[:, 0, HEEL, 2] >= pv.SHOE_FLAT_HEIGHT_M
    assert not off[:n_flat].any() and off.sum() >= 30
    noise = np.radians(1.5) * rng.standard_normal((n, 2))  # flat-frame scatter about 1 deg: over SHOE_RISE_MAD
    rise = 0.3 + true[:, None] + noise
    rise[:, 1] = 0.3 + noise[:, 1]  # the right foot's: a hem's slope that does not turn with the foot
    flat_mad = np.median(np.abs(rise[:n_flat, 0] - np.median(rise[:n_flat, 0])))
    assert flat_mad > pv.SHOE_RISE_MAD
    got = pv.shoe_pitch(pts, rise)
    np.testing.assert_allclose(got[:, 0], np.median(rise[~off, 0]) - rise[:, 0])
    assert np.mean(np.abs(got[n_flat:, 0] + true[n_flat:])) < np.mean(np.abs(tracked - true)[n_flat:])
    assert np.all(np.isnan(got[:, 1]))
    short = n_flat + pv.SHOE_RISE_FOLLOW_FRAMES - 1  # the swing's first frames only: too few to judge
    assert np.all(np.isnan(pv.shoe_pitch(pts[:short], rise[:short])[:, 0]))
    # live, frame by frame: measured once the track has had enough frames off the flat to judge
    live = pv.LivePelvis()
    judged = [live._shoe_frame(pts[i], rise[i], np.full(2, np.nan))[0] for i in range(n)]
    left = np.array([j[0] for j in judged])
    off_seen = np.cumsum(off)
    assert np.all(np.isnan(left[off_seen < pv.SHOE_RISE_FOLLOW_FRAMES]))
    late = off_seen >= pv.SHOE_RISE_FOLLOW_FRAMES + 5
    assert late.any() and np.all(np.isfinite(left[late]))
    assert np.all(np.isnan([j[1] for j in judged]))


def _heading(points: np.ndarray) -> np.ndarray:
    d = points[..., TOE, :2] - points[..., HEEL, :2]
    return np.arctan2(d[..., 1], d[..., 0])


@pytest.mark.usefixtures("feet_at_placed_heights")
def test_the_reported_heel_draws_the_placed_one_towards_the_tracked_one(monkeypatch: pytest.MonkeyPatch) -> None:
    """The tracker's heel and the placed one err partly apart: each placed heel is reported
    :data:`TRACKED_HEEL_WEIGHT` of the way from the placed heel (behind the toe at the shoe's pitch) back to the
    tracked one, offline and live; the ankle is put in the placed foot before (it is the same as with the placed heel
    alone) and the toes are the tracker's.  A heel rise the tracker holds 12 deg too flat: 5 cm off as tracked, the
    reported heel a quarter of that."""
    assert pv.TRACKED_HEEL_WEIGHT == 0.25
    rng = np.random.default_rng(5)
    tracked, rise, with_rise = _shown_heel_rise(rng)
    n = len(tracked)
    before = np.stack([p.points for p in tracked]) @ FLIP
    blended = np.stack([p.points for p in pv.place_poses(with_rise)]) @ FLIP
    _, live_out, live = _live(with_rise)
    with monkeypatch.context() as m:
        m.setattr(pv, "TRACKED_HEEL_WEIGHT", 0.0)
        alone = np.stack([p.points for p in pv.place_poses(with_rise)]) @ FLIP
        _, _, live_alone = _live(with_rise)
    w = pv.TRACKED_HEEL_WEIGHT
    np.testing.assert_allclose(blended[:, :, HEEL], (1.0 - w) * alone[:, :, HEEL] + w * before[:, :, HEEL], atol=1e-12)
    np.testing.assert_allclose(blended[:, :, ANKLE], alone[:, :, ANKLE], atol=1e-12)
    np.testing.assert_array_equal(blended[:, :, TOE], before[:, :, TOE])
    up = slice(n // 2, None)
    off = np.linalg.norm(alone[up, 0, HEEL] - before[up, 0, HEEL], axis=-1)
    assert off.min() > 0.04
    np.testing.assert_allclose(np.linalg.norm(blended[up, 0, HEEL] - alone[up, 0, HEEL], axis=-1), w * off,
                               atol=1e-12)
    # live: the heels the shoe has shown cleanly, the same weight; the tracker's kept for the analysis
    placed = np.array([o.heel_tracked is not None for o in live_out])
    assert placed[up].all()
    np.testing.assert_allclose(live[placed][:, :, HEEL],
                               (1.0 - w) * live_alone[placed][:, :, HEEL] + w * before[placed][:, :, HEEL], atol=1e-9)
    np.testing.assert_allclose(live[placed][:, :, ANKLE], live_alone[placed][:, :, ANKLE], atol=1e-9)


@pytest.mark.usefixtures("placed_heels_alone", "feet_at_placed_heights")
def test_a_flat_foot_is_reported_along_the_heading_its_shoe_shows() -> None:
    """The tracker holds a standing foot several degrees off its heading (its yaw is the end of the leg's chain);
    the shoe's centre line measures the turn: a flat foot is reported with its heel behind the seen toe along the
    heading the line shows, the track's foot length from it, at its height; the other foot, the toes and ankles stay.
    A line that sways from frame to frame (a trouser hem over the shoe), a foot off the floor or too few flat frames
    leave the heels as tracked."""
    rng = np.random.default_rng(6)
    n, turned = 40, 7.0
    true = _state([0, 2, 0, 5, 5, 0, 0, 2, 0, 5, 5, 0])
    x = _state([0, 2, turned, 5, 5, 0, 0, 2, 0, 5, 5, 0])  # the left hip turned: the left foot 7 deg off
    tracked = [LegPose(stamp=i / 30.0, points=lm.forward_kinematics(x).points[0] @ FLIP, angles=lm.joint_angles(x),
                       segments=np.zeros((2, 3, 2, 3))) for i in range(n)]
    body = tracked[0].points @ FLIP
    want_heading = _heading(lm.forward_kinematics(true).points[0])[0]
    assert abs(np.degrees(want_heading - _heading(body)[0])) > 5.0
    assert np.all(body[:, [HEEL, TOE], 2] < pv.SHOE_FLAT_HEIGHT_M)
    turn = np.column_stack([np.full(n, want_heading - _heading(body)[0]), np.zeros(n)])
    turn = turn + rng.normal(0.0, np.radians(0.2), (n, 2))
    measured = [dataclasses.replace(p, shoe_turn=t) for p, t in zip(tracked, turn)]
    plain = np.stack([p.points for p in pv.place_poses(tracked)]) @ FLIP
    after = np.stack([p.points for p in pv.place_poses(measured)]) @ FLIP
    heel, toe = after[:, 0, HEEL], after[:, 0, TOE]
    assert np.all(np.abs(np.degrees(_heading(after)[:, 0] - want_heading)) < 0.6)
    np.testing.assert_allclose(np.linalg.norm(toe - heel, axis=-1), np.linalg.norm(body[0, TOE] - body[0, HEEL]),
                               atol=1e-6)
    np.testing.assert_allclose(heel[:, 2], plain[:, 0, HEEL, 2], atol=1e-3)
    assert np.abs(plain[:, 0, HEEL, :2] - heel[:, :2]).max() > 0.02  # as tracked: 3 cm to the side
    _assert_placed_ankles(after, np.stack([p.points for p in tracked]) @ FLIP)
    assert np.abs(after[:, 1, HEEL] - plain[:, 1, HEEL]).max() < 0.002  # the right foot: as before
    # a swaying line; a foot off the floor; five flat frames: as tracked
    swaying = [dataclasses.replace(p, shoe_turn=t + rng.normal(0.0, np.radians(5.0), 2)) for p, t in zip(tracked, turn)]
    np.testing.assert_allclose(np.stack([q.points for q in pv.place_poses(swaying)]) @ FLIP, plain, atol=1e-12)
    raised = [dataclasses.replace(p, points=p.points + np.array([0.0, 0.0, 0.03])) for p in measured]
    np.testing.assert_allclose(np.stack([q.points for q in pv.place_poses(raised)]),
                               np.stack([q.points for q in pv.place_poses(tracked)]) + np.array([0.0, 0.0, 0.03]),
                               atol=1e-9)
    short = np.stack([q.points for q in pv.place_poses(measured[:5])]) @ FLIP
    np.testing.assert_allclose(short, np.stack([q.points for q in pv.place_poses(tracked[:5])]) @ FLIP, atol=1e-12)


def test_shoe_heading_is_the_reported_heading_turned_on_flat_frames() -> None:
    """:func:`shoe_heading` per foot: the reported heading plus the measured turn on the flat frames, carried forward
    into the heel rise and back into the frames after the heel strike; NaN for a foot in the air, a foot without enough
    flat frames and one whose measured heading jumps from frame to frame."""
    n = 40
    pts = np.zeros((n, 2, 5, 3))
    pts[:, :, TOE, 0] = 0.26
    pts[:, 1, TOE, 1] = 0.26 * np.tan(np.radians(np.linspace(-4.0, 4.0, n)))  # the right foot's heading wanders
    pts[15:20, 0, HEEL, 2] = 0.05  # the left heel rises, then the foot swings ...
    pts[20:25, 0, [HEEL, TOE], 2] = 0.08
    pts[25:28, 0, TOE, 2] = 0.05  # ... and lands on its heel
    turn = np.full((n, 2), np.radians(3.0))
    turn[28:, 0] = np.radians(5.0)  # planted 2 deg further out
    turn[:, 1] = -np.arctan2(pts[:, 1, TOE, 1], 0.26) + np.radians(2.0)  # ... which the line takes back: 2 deg
    turn[7, 0] = np.nan
    got = pv.shoe_heading(pts, turn)
    np.testing.assert_allclose(got[:20, 0], np.radians(3.0))  # the unmeasured frame 7 and the heel rise carried
    assert np.all(np.isnan(got[20:25, 0]))
    np.testing.assert_allclose(got[25:, 0], np.radians(5.0))
    np.testing.assert_allclose(got[:, 1], np.radians(2.0), atol=1e-12)
    assert np.all(np.isnan(pv.shoe_heading(pts[31:], turn[31:])[:, 0]))  # nine flat frames measured: too few
    jumpy = turn + np.radians(np.where(np.arange(n) % 2, 2.5, -2.5))[:, None]
    assert np.all(np.isnan(pv.shoe_heading(pts, jumpy)))
    swaying = turn.copy()
    swaying[28:, 0] += np.radians(np.where(np.arange(28, n) % 2, 3.0, -3.0))  # the second stance's line sways
    got = pv.shoe_heading(pts, swaying)
    np.testing.assert_allclose(got[:20, 0], np.radians(3.0))
    assert np.all(np.isnan(got[20:, 0]))  # neither measured nor carried back to its heel strike
    lone = turn.copy()
    lone[29:, 0] = np.nan  # a single flat frame measured in the second stance: nothing to check it by
    assert np.all(np.isnan(pv.shoe_heading(pts, lone)[25:, 0]))
    astray = turn + np.radians(np.array([[13.0, 0.0]]))  # the left line steadily 16-18 deg from the reported foot
    assert np.all(np.isnan(pv.shoe_heading(pts, astray)[:, 0]))
    np.testing.assert_allclose(pv.shoe_heading(pts, astray)[:, 1], np.radians(2.0), atol=1e-12)


def test_a_heading_is_carried_through_a_heel_rise_whose_tip_is_held_off_the_floor() -> None:
    """The tracker holds a pivoting foot's tip a few centimetres up: the heading measured flat is carried into the heel
    rise while the reported toe stays below :data:`SHOE_CARRY_TOE_M` (3 cm here; at the flat frames' 2 cm the carry
    broke off there), and no further than the toe off (the toe 6 cm up)."""
    n = 40
    pts = np.zeros((n, 2, 5, 3))
    pts[:, :, TOE, 0] = 0.26
    pts[15:25, 0, HEEL, 2] = np.linspace(0.03, 0.15, 10)  # the left heel rises ...
    pts[19:25, 0, TOE, 2] = 0.03  # ... its tip held 3 cm up from the fifth frame of it
    pts[25:30, 0, [HEEL, TOE], 2] = 0.06  # the toe off
    turn = np.full((n, 2), np.radians(3.0))
    got = pv.shoe_heading(pts, turn)
    np.testing.assert_allclose(got[:25, 0], np.radians(3.0))
    assert np.all(np.isnan(got[25:30, 0]))
    assert pv.SHOE_FLAT_HEIGHT_M < 0.03 < pv.SHOE_CARRY_TOE_M


@pytest.mark.usefixtures("placed_heels_alone")
def test_live_heel_rise_keeps_the_heading_its_shoe_showed_flat() -> None:
    """Live: the heel rise after a flat stance whose shoe showed its heading keeps that heading (within 0.6 deg, the
    tracker 7 deg off) while the tracker holds the toe 3 cm up, and is the tracker's again after the toe off."""
    n = 30
    true = _state([0, 2, 0, 5, 5, 0, 0, 2, 0, 5, 5, 0])
    x = _state([0, 2, 7.0, 5, 5, 0, 0, 2, 0, 5, 5, 0])
    base = lm.forward_kinematics(x).points[0] @ FLIP
    want = _heading(lm.forward_kinematics(true).points[0])[0]
    turn = np.column_stack([np.full(n, want - _heading(base @ FLIP)[0]), np.zeros(n)])
    turn[15:, 0] = np.nan  # not flat: not measured
    poses = []
    for i in range(n):
        pts = base.copy()
        if 15 <= i < 25:  # the left heel rises with the tip held 3 cm up
            pts[0, HEEL, 2] += 0.02 + 0.01 * (i - 15)
            pts[0, TOE, 2] = 0.03
        elif i >= 25:  # the toe off
            pts[0, [HEEL, TOE], 2] += 0.08
        poses.append(LegPose(stamp=i / 30.0, points=pts, angles=lm.joint_angles(x), segments=np.zeros((2, 3, 2, 3)),
                             shoe_turn=turn[i]))
    _, _, after = _live(poses)
    err = np.degrees(np.abs(_heading(after)[:, 0] - want))
    assert np.all(err[pv.SHOE_FLAT_FRAMES:25] < 0.6)
    assert np.all(err[25:] > 5.0)


@pytest.mark.usefixtures("placed_heels_alone")
def test_a_foot_standing_on_its_heel_is_reported_with_the_heel_on_the_floor() -> None:
    """A reported foot whose toe is higher than its heel and whose heel is below :data:`HEEL_ON_FLOOR_M` (landed on
    its heel, or flat with its heel a little up or below the floor) has its heel turned about the toe onto the floor at
    the foot's length and heading; a foot in the air (heel 6 cm up) and one in its heel rise (toe down) keep theirs."""
    length = 0.26
    toe_up = np.radians(11.0)
    cases = {  # heel (x, y, z) and toe-up pitch of each foot
        "landing": ((0.0, 0.10, 0.015), toe_up),
        "below the floor": ((0.0, -0.10, -0.008), np.radians(2.0)),
        "in the air": ((0.1, 0.10, 0.06), toe_up),
        "heel rise": ((0.1, -0.10, 0.03), -np.radians(7.0)),
    }
    names = list(cases)
    held = np.zeros((2, 2, 4, 3))
    for k, name in enumerate(names):
        heel, pitch = cases[name]
        f, side = divmod(k, 2)
        heading = np.radians(8.0 * (k + 1))
        held[f, side, 2] = heel
        held[f, side, 3] = np.asarray(heel) + length * np.array([np.cos(pitch) * np.cos(heading),
                                                                 np.cos(pitch) * np.sin(heading), np.sin(pitch)])
        held[f, side, 1] = held[f, side, 2] + [0.05, 0.0, 0.08]  # the ankle
        held[f, side, 0] = held[f, side, 1] + [0.0, 0.0, 0.4]  # the knee
    x = np.repeat(_state([0] * 12)[None], 2, axis=0)
    _, out = pv.with_lengths(x, held, thigh=x[:, L.LEN_THIGH], calf=x[:, L.LEN_CALF], foot=np.full(2, length))
    for k, name in enumerate(names):
        f, side = divmod(k, 2)
        heel, toe = out[f, side, 2], held[f, side, 3]
        assert np.linalg.norm(toe - heel) == pytest.approx(length, abs=1e-9), name
        before = held[f, side, 3, :2] - held[f, side, 2, :2]
        after = toe[:2] - heel[:2]
        assert np.arctan2(after[1], after[0]) == pytest.approx(np.arctan2(before[1], before[0]), abs=1e-9), name
        if name in ("landing", "below the floor"):
            assert heel[2] == pytest.approx(0.0, abs=1e-12), name
        else:
            np.testing.assert_allclose(heel, held[f, side, 2], atol=1e-12, err_msg=name)
    assert pv.HEEL_ON_FLOOR_M > 0.015


def _live(poses: list[LegPose]) -> tuple[list[LegPose], list[LegPose], np.ndarray]:
    """``poses`` (walker frame) given to a fresh :class:`LivePelvis` in the camera frame of :func:`_floor`, frame by
    frame: the camera-frame poses given and placed, and the placed points in the body frame.  Each frame's hips are
    moved by a micrometre more than the last's: a tracker reports the same pose twice only when it holds it (a blanked
    view), which the placement holds too."""
    floor = _floor()
    rot, t = floor.walker_transform()
    given = []
    for i, p in enumerate(poses):
        pts = np.array(p.points, dtype=np.float64, copy=True)
        pts[:, HIP, 0] += 1e-6 * i
        given.append(pv.moved_pose(dataclasses.replace(p, points=pts), rot.T, -(rot.T @ t)))
    live = pv.LivePelvis()
    out = [live.place(p, floor) for p in given]
    return given, out, _body(out)


@pytest.mark.usefixtures("placed_heels_alone", "feet_at_placed_heights")
def test_live_heels_are_placed_causally_where_the_shoe_shows_them() -> None:
    """Live, frame by frame: once a foot's shoe has stood flat for :data:`SHOE_FLAT_FRAMES` frames with a steady rise,
    its heel is reported at the pitch its upper shows (a heel rise the tracker holds 12 deg too flat: as offline,
    within 3 mm) at the track's foot length so far; before that, and for an upper whose rise scatters and which
    shows no steady heading, the tracker's heels bit for bit.  The toes stay the tracker's, the ankles of the feet
    whose heels moved go towards the placed foot's, and a pose whose heels and ankles moved keeps the tracker's as
    ``heel_tracked`` and ``ankle_tracked`` (what the gait analysis reads)."""
    rng = np.random.default_rng(5)
    tracked, rise, with_rise = _shown_heel_rise(rng)
    n = len(tracked)
    given, out, after = _live(with_rise)
    offline = np.stack([p.points for p in pv.place_poses(with_rise)]) @ FLIP
    assert np.abs(after[n // 2:, 0, HEEL] - offline[n // 2:, 0, HEEL]).max() < 0.003
    before = np.stack([p.points for p in tracked]) @ FLIP
    assert np.abs(before[n // 2:, 0, HEEL] - offline[n // 2:, 0, HEEL]).max() > 0.04  # as tracked: 5 cm off
    early = pv.SHOE_FLAT_FRAMES - 1  # frames before the shoe is calibrated
    for g, o in zip(given, out):
        np.testing.assert_array_equal(o.points[:, TOE], g.points[:, TOE])
        np.testing.assert_array_equal(o.as_tracked().points[:, 2:], g.points[:, 2:])
    # the ankles of the feet whose heels moved are moved towards the placed foot's, the others the tracker's
    assert all((o.ankle_tracked is None) == (o.heel_tracked is None) for o in out)
    assert all(np.array_equal(o.points[:, ANKLE], g.points[:, ANKLE]) for g, o in zip(given[:early], out[:early]))
    _assert_placed_ankles(after[early:], _body(given)[early:], atol=1e-9, toe_atol=1e-9)
    assert all(o.heel_tracked is None and np.array_equal(o.points[:, HEEL], g.points[:, HEEL])
               for g, o in zip(given[:early], out[:early]))
    assert all(o.heel_tracked is not None for o in out[early:])
    # the angles are solved for the reported heels: the raised left ankle more plantarflexed than as tracked
    ank = 4  # left ankle dorsiflexion in JOINT_NAMES order
    _, plain, _ = _live(tracked)
    assert all(p.heel_tracked is None for p in plain)  # no shoe measures: the tracker's heels
    assert all(p.angles[ank] - o.angles[ank] > np.radians(3.0) for p, o in zip(plain[n // 2:], out[n // 2:]))
    scattered = [dataclasses.replace(p, shoe_rise=r + rng.normal(0.0, np.radians(3.0), 2)) for p, r in zip(tracked, rise)]
    _, noisy, _ = _live(scattered)
    assert all(q.heel_tracked is None and np.array_equal(q.points[:, HEEL], p.points[:, HEEL])
               for q, p in zip(noisy, plain))


@pytest.mark.usefixtures("placed_heels_alone", "feet_at_placed_heights")
def test_live_flat_feet_follow_the_heading_their_shoe_shows() -> None:
    """Live: a flat foot the tracker holds 7 deg off its heading is reported along the heading its shoe's centre line
    shows once the track has :data:`SHOE_FLAT_FRAMES` flat frames of a steady line (within 0.6 deg, as offline), its
    heel behind the seen toe at the foot's length; a swaying line leaves the heels as tracked."""
    rng = np.random.default_rng(6)
    n = 30
    true = _state([0, 2, 0, 5, 5, 0, 0, 2, 0, 5, 5, 0])
    x = _state([0, 2, 7.0, 5, 5, 0, 0, 2, 0, 5, 5, 0])
    tracked = [LegPose(stamp=i / 30.0, points=lm.forward_kinematics(x).points[0] @ FLIP, angles=lm.joint_angles(x),
                       segments=np.zeros((2, 3, 2, 3))) for i in range(n)]
    body = tracked[0].points @ FLIP
    want = _heading(lm.forward_kinematics(true).points[0])[0]
    turn = np.column_stack([np.full(n, want - _heading(body)[0]), np.zeros(n)]) + rng.normal(0.0, np.radians(0.2), (n, 2))
    given, out, after = _live([dataclasses.replace(p, shoe_turn=t) for p, t in zip(tracked, turn)])
    early = pv.SHOE_FLAT_FRAMES
    assert np.all(np.abs(np.degrees(_heading(after[early:])[:, 0] - want)) < 0.6)
    assert np.all(np.abs(np.degrees(_heading(after[:early - 1])[:, 0] - want)) > 5.0)  # not yet: as tracked
    np.testing.assert_allclose(np.linalg.norm(after[:, 0, TOE] - after[:, 0, HEEL], axis=-1),
                               np.linalg.norm(body[0, TOE] - body[0, HEEL]), atol=1e-6)
    for g, o in zip(given, out):
        np.testing.assert_array_equal(o.as_tracked().points[:, 2:], g.points[:, 2:])
    swaying = [dataclasses.replace(p, shoe_turn=t + rng.normal(0.0, np.radians(5.0), 2)) for p, t in zip(tracked, turn)]
    given, out, _ = _live(swaying)
    assert all(o.heel_tracked is None and np.array_equal(o.points[:, HEEL], g.points[:, HEEL])
               for g, o in zip(given, out))


@pytest.mark.usefixtures("placed_heels_alone", "feet_at_placed_heights")
def test_live_a_hem_is_recognised_on_the_last_frames_calves() -> None:
    """A new track's calves start at the model's mean radius and widen to a tube of loose fabric only after a while:
    live, the hem is judged on the calves of the last :data:`LIVE_HEM_FRAMES` frames, so the heels under it are
    placed at the typical shoe's length as soon as most of those frames are loose, not once the loose frames
    outnumber the tight ones over the whole track so far (at frame 50 here, where a whole-track median would first
    see the hem)."""
    lo, hi = lm.LOOSE_CALF_RADIUS
    stand = _stand_then_heel_up(tracked_pitch_deg=20.0)
    tight = _shod(stand[:25], longer=-0.05, calf_radius=0.06)  # no shoe shown cleanly, no hem yet
    loose = _shod(stand[25:], longer=-0.05, calf_radius=0.115)
    _, out, after = _live(tight + loose)
    placed = np.array([o.heel_tracked is not None for o in out])
    assert not placed[:25].any()
    first = 25 + pv.LIVE_HEM_FRAMES // 2  # the first frame with most of the last LIVE_HEM_FRAMES frames loose
    assert pv.LIVE_HEM_FRAMES <= 20 and 0.06 < lo < 0.115 < hi + 0.01
    assert not placed[first - 1] and placed[first:].all()
    np.testing.assert_allclose(_lengths(after[first:])[1], pv.HEMMED_SHOE_M, atol=1e-6)


def test_feet_are_put_on_the_floor() -> None:
    """A foot whose heel and toe both read lower than :data:`SHOE_FLAT_HEIGHT_M` stands flat: both go onto the floor,
    its ankle down with them by their drops interpolated at its place along the foot
    (:data:`~walker_gait.core.leg_model.HEEL_BACK` from the heel); a toe under the floor of a foot in its heel rise is
    raised onto it, the heel kept, the ankle up by that share of the toe's rise; a heel under the floor likewise.  Feet
    off the floor and the knees stay bit for bit, only heights change, and NaN stays NaN."""
    b = lm.HEEL_BACK
    held = np.zeros((3, 2, 4, 3))
    held[..., 0] = np.arange(24).reshape(3, 2, 4) * 0.01  # x, y: anything; kept
    held[..., 1] = -np.arange(24).reshape(3, 2, 4) * 0.02
    held[..., 0, 2], held[..., 1, 2] = 0.5, 0.09  # knees, ankles
    held[0, 0, 2:, 2] = [0.012, 0.006]  # flat, a little up
    held[0, 1, 2:, 2] = [0.08, -0.01]  # heel rise, its toe dipping under the floor
    held[1, 0, 2:, 2] = [0.05, 0.03]  # in the air
    held[1, 1, 2:, 2] = [0.015, 0.025]  # in the air: the toe over the flat height
    held[2, 0] = np.nan
    held[2, 1, 2:, 2] = [-0.004, 0.001]  # flat, the heel a little under the floor
    out = pv.feet_on_floor(held)
    np.testing.assert_array_equal(out[..., :2], held[..., :2])
    np.testing.assert_array_equal(out[..., 0, :], held[..., 0, :])
    np.testing.assert_array_equal(out[1], held[1])
    assert np.all(np.isnan(out[2, 0]))
    np.testing.assert_allclose(out[0, 0, 1:, 2], [0.09 - (1 - b) * 0.012 - b * 0.006, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(out[0, 1, 1:, 2], [0.09 + b * 0.01, 0.08, 0.0], atol=1e-15)
    np.testing.assert_allclose(out[2, 1, 1:, 2], [0.09 + (1 - b) * 0.004 - b * 0.001, 0.0, 0.0], atol=1e-15)
    np.testing.assert_array_equal(held[0, 0, 2:, 2], [0.012, 0.006])  # the input is left alone


def test_the_reported_feet_stand_on_the_floor_offline_and_live(monkeypatch: pytest.MonkeyPatch) -> None:
    """The walk's feet as the other rules place them (flat feet a little up, toes that dip under the floor as the
    model's foot swings in its heel rise) are reported on the floor (:func:`feet_on_floor` of them), offline and live
    alike; live, the tracker's own ankles, heels and toes stay in ``ankle_tracked``, ``heel_tracked`` and
    ``toe_tracked`` for the gait analysis, which reads the poses as given (:meth:`LegPose.as_tracked`)."""
    poses, _ = _walk(n=60, lean_deg=-8.0)
    for i in range(0, 60, 2):  # every other frame the left foot flat, its heel 1.2 cm and its toe 0.6 cm up
        pts = np.array(poses[i].points, dtype=np.float64, copy=True)
        pts[0, [HEEL, TOE], 2] = [0.012, 0.006]
        poses[i] = dataclasses.replace(poses[i], points=pts)
    placed = {}
    for on in (False, True):
        monkeypatch.setattr(pv, "FEET_ON_FLOOR", on)
        given, out, live = _live(poses)
        placed[on] = (np.stack([p.points for p in pv.place_poses(poses)]) @ FLIP, live)
    for before, after in zip(placed[False], placed[True]):
        want = pv.feet_on_floor(before[:, :, [KNEE, ANKLE, HEEL, TOE]])
        np.testing.assert_allclose(after[:, :, [ANKLE, HEEL, TOE]], want[:, :, 1:], atol=1e-9)
        flat = (before[..., HEEL, 2] < pv.SHOE_FLAT_HEIGHT_M) & (before[..., TOE, 2] < pv.SHOE_FLAT_HEIGHT_M)
        assert (flat & (np.abs(before[..., TOE, 2]) > 0.002)).sum() >= 10  # flat feet put down ...
        assert (~flat & (before[..., TOE, 2] < -0.005)).sum() >= 10  # ... and toes raised, in enough frames
        assert after[..., [HEEL, TOE], 2].min() > -1e-9
    for g, o in zip(given, out):
        np.testing.assert_array_equal(o.as_tracked().points[:, ANKLE:], g.points[:, ANKLE:])
    assert sum(o.toe_tracked is not None for o in out) >= 20
