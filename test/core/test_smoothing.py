"""Two-way tracking: the Viterbi merge of passes, backward passes, scoring passes' states."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pytest

from walker_gait.bench.tracker import KINECT, own_sequence
from walker_gait.core import leg_model as lm
from walker_gait.core.smoothing import (
    AGREE_M,
    BRIDGE_FIT_FRAMES,
    EXCHANGE_COST,
    IDENTITY_COST_PER_M,
    IDENTITY_MARGIN_M,
    BRIDGE_MAX_S,
    BRIDGE_PLANTED_Z,
    BRIDGE_POINTS,
    LiveBridge,
    SWITCH_COST_PER_M,
    PassTrack,
    UNCONFIRMED_FACTOR,
    best_path,
    blend_poses,
    bridge_hidden_legs,
    butter2,
    filtfilt2,
    lowpass_poses,
    check_against_passes,
    confirm_steps,
    identity_flips,
    merge_passes,
    refine_event_times,
    refine_step_lengths,
    reported_poses,
    score_passes,
    swap_sides,
    track_pass,
    wait_for_both_feet,
)
from walker_gait.core.tracker import LegTracker, preset
from walker_gait.core.types import CameraIntrinsics, EventKind, FloorPlane, GaitEvent, LegPose, Side, Step, TrackStatus

FAST = preset("default", n_particles=48, init_rounds=3)


def _points(t_n: int, k_n: int, offsets: np.ndarray | None = None) -> np.ndarray:
    """(T, K, 2, 5, 3) leg points, pass k shifted by offsets[t, k] metres along x."""
    base = np.zeros((t_n, k_n, 2, 5, 3))
    if offsets is not None:
        base[..., 0] += offsets[:, :, None, None]
    return base


def test_equal_passes_keep_the_first() -> None:
    scores = np.zeros((20, 3))
    path = best_path(scores, _points(20, 3))
    assert path.dtype == np.intp and np.all(path == 0)


def test_a_pass_without_a_pose_is_not_chosen_while_another_has_one() -> None:
    scores = np.zeros((10, 2))
    scores[3:6, 0] = -np.inf
    scores[7, 0] = np.nan
    pts = _points(10, 2)
    pts[3:6, 0] = np.nan
    path = best_path(scores, pts)
    assert list(path[3:6]) == [1, 1, 1] and path[7] == 1
    # nobody has a pose: the path stays defined, on the first pass
    assert np.all(best_path(np.full((4, 2), -np.inf), np.full((4, 2, 2, 5, 3), np.nan)) == 0)


def test_tracks_that_agree_switch_for_any_gain() -> None:
    scores = np.zeros((30, 2))
    scores[10:20, 1] = 0.01  # pass 1 slightly better in the middle, both tracks at the same place
    path = best_path(scores, _points(30, 2))
    assert np.all(path[10:20] == 1) and np.all(path[:10] == 0) and np.all(path[20:] == 0)


def test_tracks_that_meet_switch_where_they_meet() -> None:
    # pass 1 runs 40 cm from pass 0 over frames 10-19 (legs exchanged, say) and meets it before and after: it
    # takes the stretch for any gain, switching on the frames where the tracks coincide
    t_n = 30
    off = np.zeros((t_n, 2))
    off[10:20, 1] = 0.4
    scores = np.zeros((t_n, 2))
    scores[10:20, 1] = 0.1
    path = best_path(scores, _points(t_n, 2, off))
    assert np.all(path[10:20] == 1)


@pytest.mark.parametrize(("gain", "switches"), [(3.0, False), (9.0, True)])
def test_a_switch_between_distant_tracks_needs_a_gain_above_its_cost(gain: float, switches: bool) -> None:
    # tracks 40 cm apart throughout, pass 0 the better one outside frames 10-19 (by 5 a frame), pass 1 inside (by
    # `gain` a frame): going over and back costs 2 x 0.4 m x SWITCH_COST_PER_M = 80 against 10 x gain
    assert SWITCH_COST_PER_M == 100.0
    t_n = 30
    off = np.zeros((t_n, 2))
    off[:, 1] = 0.4
    scores = np.zeros((t_n, 2))
    scores[:, 0] = 5.0
    scores[10:20, 0] = 0.0
    scores[10:20, 1] = gain
    path = best_path(scores, _points(t_n, 2, off))
    assert np.all(path[10:20] == 1) == switches
    assert np.all(path[:10] == 0) and np.all(path[20:] == 0)
    assert np.all(best_path(scores, _points(t_n, 2, off), switch_cost=0.0)[10:20] == 1)


def test_best_path_rejects_bad_shapes() -> None:
    with pytest.raises(ValueError, match="scores"):
        best_path(np.zeros(5), np.zeros((5, 1, 2, 5, 3)))
    assert best_path(np.zeros((0, 2)), np.zeros((0, 2, 2, 5, 3))).shape == (0,)


def _pose(stamp: float, x: float) -> LegPose:
    return LegPose(stamp=stamp, points=np.full((2, 5, 3), x), status=TrackStatus.TRACKING, confidence=1.0)


def _track(poses: list[LegPose], scores: np.ndarray) -> PassTrack:
    n = len(poses)
    return PassTrack(poses=poses, scores=np.asarray(scores, dtype=float), tracker_ms=np.zeros(n), scoring_ms=np.zeros(n))


def test_merge_takes_each_frame_from_the_chosen_pass() -> None:
    a = _track([_pose(0.1 * i, 0.0) for i in range(6)], [1, 1, 0, 0, 1, 1])
    b = _track([_pose(0.1 * i, 0.3) for i in range(6)], [0, 0, 1, 1, 0, 0])  # 30 cm away: not blended
    merged = merge_passes([a, b], switch_cost=0.0)
    assert list(merged.choice) == [0, 0, 1, 1, 0, 0]
    assert merged.poses[2] is b.poses[2] and merged.poses[0] is a.poses[0]
    assert merged.share(1) == pytest.approx(2 / 6)
    assert merged.scores.shape == (6, 2)
    assert list(merge_passes([a, b]).choice) == [0] * 6  # two switches across 30 cm cost more than they gain
    with pytest.raises(ValueError, match="same frames"):
        merge_passes([a, _track(b.poses[:5], np.zeros(5))])
    # passes that agree are blended frame by frame
    c = _track([_pose(0.1 * i, 0.02) for i in range(6)], np.zeros(6))
    np.testing.assert_allclose(merge_passes([a, c]).poses[4].points, 0.01)


def _full_pose(x: float, *, status: TrackStatus = TrackStatus.TRACKING, confidence: float = 1.0) -> LegPose:
    pts = np.zeros((2, 5, 3))
    pts[..., 0] = x
    return LegPose(stamp=1.0, points=pts, angles=np.full(12, x), segments=np.full((2, 3, 2, 3), x),
                   radii=np.full((2, 3, 2), 0.05 + x), visibility=np.full((2, 3), 1.0 if x == 0 else 0.5),
                   status=status, confidence=confidence)


def test_poses_whose_feet_agree_are_averaged_and_others_kept_apart() -> None:
    assert AGREE_M == (0.04, 0.10)
    a = _full_pose(0.0)
    b = _full_pose(0.02, status=TrackStatus.DEGRADED, confidence=0.3)  # feet 2 cm apart: one pose, averaged
    m = blend_poses([a, b], 0)
    np.testing.assert_allclose(m.points, 0.5 * (a.points + b.points))
    np.testing.assert_allclose(m.angles, 0.01)
    np.testing.assert_allclose(m.segments, 0.01)
    np.testing.assert_allclose(m.radii, 0.06)
    np.testing.assert_allclose(m.visibility, 0.75)
    assert m.status == TrackStatus.TRACKING and m.confidence == 1.0  # the chosen pose's
    assert blend_poses([a, b], 1).status == TrackStatus.DEGRADED
    # the shoes' turns, each from its own pass's foot, are averaged with the feet; the rise is the chosen pose's
    ta = replace(a, shoe_turn=np.array([0.02, -0.01]), shoe_rise=np.array([0.3, 0.3]))
    tb = replace(b, shoe_turn=np.array([0.06, 0.01]), shoe_rise=np.array([0.4, 0.4]))
    mt = blend_poses([ta, tb], 0)
    np.testing.assert_allclose(mt.shoe_turn, [0.04, 0.0])
    np.testing.assert_array_equal(mt.shoe_rise, ta.shoe_rise)
    # 7 cm apart: half way to the cut-off, the other pose weighs 0.5 against the chosen one's 1
    c = _full_pose(0.07)
    np.testing.assert_allclose(blend_poses([a, c], 0).points[..., 0], 0.07 / 3)
    # 10 cm apart or more: another mode, not mixed in
    assert blend_poses([a, _full_pose(0.10)], 0) is a
    assert blend_poses([a, _full_pose(0.30)], 0) is a
    # a pass without a pose, or a chosen pose without feet, leaves the chosen pose as it is
    empty = LegPose(stamp=1.0, points=np.full((2, 5, 3), np.nan))
    assert blend_poses([a, empty], 0) is a and blend_poses([empty, a], 0) is empty


def _walking_points(t: float) -> np.ndarray:
    """(2, 5, 3) leg points (camera frame: x across, y down, z depth) of legs walking at 1 Hz: the left leg (0) on
    +x, the right one on -x, the feet swinging in depth in antiphase."""
    pts = np.zeros((2, 5, 3))
    for leg, side in ((0, 1.0), (1, -1.0)):
        swing = 0.25 * side * np.sin(2 * np.pi * t)
        pts[leg, :, 0] = side * np.array([0.09, 0.08, 0.06, 0.06, 0.07])  # hip, knee, ankle, heel, toe
        pts[leg, :, 1] = [-0.4, 0.0, 0.4, 0.45, 0.45]
        pts[leg, :, 2] = 1.0 + np.array([0.0, 0.5, 1.0, 1.0, 1.0]) * swing + np.array([0, 0, 0, 0.05, -0.15])
    return pts


def _walking_pose(t: float, *, exchanged: bool = False) -> LegPose:
    pose = LegPose(stamp=t, points=_walking_points(t), angles=np.arange(12.0), segments=np.zeros((2, 3, 2, 3)),
                   radii=np.stack([np.full((3, 2), 0.05), np.full((3, 2), 0.06)]),
                   visibility=np.array([[1.0, 0.9, 0.8], [0.7, 0.6, 0.5]]), shoe_rise=np.array([0.1, 0.2]),
                   shoe_turn=np.array([0.01, -0.02]), status=TrackStatus.TRACKING, confidence=1.0)
    return swap_sides(pose) if exchanged else pose


def test_swap_sides_exchanges_the_legs_below_the_hips_and_back() -> None:
    pose = _walking_pose(0.2)
    sw = swap_sides(pose)
    np.testing.assert_array_equal(sw.points[:, 0], pose.points[:, 0])  # each hip keeps its place
    np.testing.assert_array_equal(sw.points[:, 1:], pose.points[::-1, 1:])
    np.testing.assert_array_equal(sw.angles, np.r_[np.arange(6.0, 12.0), np.arange(6.0)])
    np.testing.assert_array_equal(sw.radii, pose.radii[::-1])
    np.testing.assert_array_equal(sw.visibility, pose.visibility[::-1])
    np.testing.assert_array_equal(sw.shoe_rise, [0.2, 0.1])
    np.testing.assert_array_equal(sw.shoe_turn, [-0.02, 0.01])
    np.testing.assert_array_equal(sw.segments[:, 0, 0], pose.points[:, 0])  # the thighs start at the hips kept
    back = swap_sides(sw)
    np.testing.assert_array_equal(back.points, pose.points)
    np.testing.assert_array_equal(back.angles, pose.angles)
    np.testing.assert_array_equal(back.visibility, pose.visibility)
    empty = LegPose.no_user(1.0)
    assert swap_sides(empty) is empty


def test_identity_flips_charge_only_legs_that_change_places() -> None:
    t = np.arange(12) / 30.0
    steady = np.stack([_walking_points(s) for s in t])
    flipped = steady.copy()
    flipped[6:] = np.stack([swap_sides(_walking_pose(s)).points for s in t[6:]])
    cand = np.stack([flipped, np.stack([swap_sides(LegPose(stamp=0.0, points=p)).points for p in flipped])], axis=1)
    charge = identity_flips(cand, [1, 0])
    assert charge.shape == (12, 2, 2)
    np.testing.assert_allclose(identity_flips(cand, [1, 0], margin_m=0.02), np.maximum(charge - 0.02, 0.0))
    moved = np.zeros((12, 2, 2), dtype=bool)
    moved[1:, 0, 1] = moved[1:, 1, 0] = True  # a change of labelling between two frames jumps the legs ...
    moved[6] = ~moved[6]  # ... except across the flip, where staying on one does
    assert np.all(charge[moved] > 0.05) and np.all(charge[~moved] == 0.0)
    assert np.all(identity_flips(np.stack([steady, steady], axis=1), [1, 0]) == 0.0)  # legs that move as legs do
    nan = cand.copy()
    nan[5] = np.nan
    assert np.all(identity_flips(nan, [1, 0])[5:7] == 0.0)  # a frame without points charges nothing either side


def _walking_pass(n: int, scores: np.ndarray, exchanged: np.ndarray) -> PassTrack:
    return _track([_walking_pose(i / 30.0, exchanged=bool(exchanged[i])) for i in range(n)], scores)


def _left_foot(pose: LegPose) -> np.ndarray:
    return pose.points[0, 2:5]


def _ankles_cross(pose: LegPose) -> bool:
    """The left ankle lies on the right hip's side of the right ankle (the test legs' hips are 18 cm apart)."""
    p = pose.points
    return bool((p[0, 2, 0] - p[1, 2, 0]) * (p[0, 0, 0] - p[1, 0, 0]) < 0)


def test_the_merge_takes_back_legs_that_a_pass_exchanged() -> None:
    assert (IDENTITY_COST_PER_M, IDENTITY_MARGIN_M, EXCHANGE_COST) == (100.0, 0.05, 1.0)
    n = 20
    stretch = np.zeros(n, dtype=bool)
    stretch[8:14] = True
    right = _walking_pass(n, np.zeros(n), np.zeros(n, dtype=bool))
    # the other pass exchanges its legs for six frames, where it explains the data better (switches free, so that
    # the path follows the better pass on every frame)
    wrong = _walking_pass(n, np.where(stretch, 4.0, -1.0), stretch)
    old = merge_passes([right, wrong], switch_cost=0.0, identity_cost=0.0)
    assert np.all(old.choice[stretch] == 1)  # before: the exchanged legs taken as they were
    assert not np.allclose(_left_foot(old.poses[10]), _left_foot(right.poses[10]))
    merged = merge_passes([right, wrong], switch_cost=0.0)
    assert np.all(merged.choice[stretch] == 1) and merged.exchanged is not None
    np.testing.assert_array_equal(merged.exchanged, stretch)  # ... now taken back
    for t in range(n):
        np.testing.assert_allclose(merged.poses[t].points, right.poses[t].points, atol=1e-12)
        assert not _ankles_cross(merged.poses[t])


def test_a_single_pass_gets_a_short_exchange_taken_back_and_keeps_its_labelling_over_a_long_one() -> None:
    n = 40
    truth = [_walking_pose(i / 30.0) for i in range(n)]
    short = np.zeros(n, dtype=bool)
    short[5:10] = True  # five frames with the legs exchanged, feet far apart: two jumps cost more than taking them back
    merged = merge_passes([_walking_pass(n, np.zeros(n), short)])
    np.testing.assert_array_equal(merged.exchanged, short)
    for t in range(n):
        np.testing.assert_allclose(merged.poses[t].points, truth[t].points, atol=1e-12)
    # exchanged from frame 10 to the end: one jump costs less than 30 frames taken exchanged, the tracker's
    # labelling stands (as without the identity cost)
    long = np.arange(n) >= 10
    kept = merge_passes([_walking_pass(n, np.zeros(n), long)])
    assert not kept.exchanged.any()
    assert [_ankles_cross(p) for p in kept.poses] == list(long)


def test_passes_without_an_exchange_merge_as_without_the_identity_cost() -> None:
    n = 40
    rng = np.random.default_rng(3)
    passes = []
    for k in range(2):
        poses = []
        for i in range(n):
            pose = _walking_pose(i / 30.0)
            poses.append(replace(pose, points=pose.points + rng.normal(0.0, 0.01 + 0.03 * k, (2, 5, 3))))
        passes.append(_track(poses, rng.normal(0.0, 2.0, n)))
    plain = merge_passes(passes, identity_cost=0.0)
    merged = merge_passes(passes)
    np.testing.assert_array_equal(merged.choice, plain.choice)
    assert not merged.exchanged.any()
    for a, b in zip(merged.poses, plain.poses):
        np.testing.assert_array_equal(a.points, b.points)


def _seen(stamp: float, left: float, right: float) -> LegPose:
    """A pose whose left and right feet are ``left`` / ``right`` visible."""
    vis = np.ones((2, 3))
    vis[:, 2] = (left, right)
    return LegPose(stamp=stamp, points=np.zeros((2, 5, 3)), visibility=vis, status=TrackStatus.TRACKING,
                   confidence=0.9)


def test_a_track_starts_where_both_feet_have_been_seen() -> None:
    empty = LegPose(stamp=0.0, points=np.full((2, 5, 3), np.nan), status=TrackStatus.NO_USER, confidence=0.0)
    feet = [None, (0.0, 0.9), (0.3, 0.9), (0.6, 0.2), (0.1, 0.1), None, (0.9, 0.0), (0.0, 0.7), (0.0, 0.0)]
    poses = [replace(empty, stamp=0.1 * i) if f is None else _seen(0.1 * i, *f) for i, f in enumerate(feet)]
    track = _track(poses, np.array([-np.inf if f is None else 1.0 for f in feet]))
    out = wait_for_both_feet(track, min_visibility=0.5)
    have = [bool(np.all(np.isfinite(p.points))) for p in out.poses]
    # the first track's left foot is first seen on frame 3 (its right one on frame 1): frames 1-2 dropped, and a
    # foot hidden again later (frame 4) keeps the track; the second track starts afresh and sees both by frame 7
    assert have == [False, False, False, True, True, False, False, True, True]
    assert out.poses[3] is poses[3] and out.poses[1].status == TrackStatus.NO_USER
    assert [p.stamp for p in out.poses] == [p.stamp for p in poses]
    assert list(np.isfinite(out.scores)) == have and out.tracker_ms is track.tracker_ms
    # where the other pass has a pose the merge keeps both to choose from
    other = _track([replace(empty, stamp=0.1 * i) if i != 2 else _pose(0.2, 0.0) for i in range(9)], np.zeros(9))
    assert [bool(np.all(np.isfinite(p.points))) for p in wait_for_both_feet(track, other=other).poses][:4] == \
        [False, False, True, True]
    # a track that sees both feet at once, or poses without a visibility estimate, lose nothing
    assert wait_for_both_feet(_track([_seen(0.0, 1.0, 1.0), _seen(0.1, 0.0, 0.0)], np.zeros(2))).poses[1].confidence \
        == 0.9
    plain = _track([_pose(0.1 * i, 0.0) for i in range(3)], np.zeros(3))
    assert wait_for_both_feet(plain) is plain
    with pytest.raises(ValueError, match="frames"):
        wait_for_both_feet(track, other=plain)
    with pytest.raises(ValueError, match="frames must be"):
        wait_for_both_feet(track, frames=0)


def test_at_once_a_track_starts_where_both_feet_are_seen_on_one_frame() -> None:
    """``at_once``: each foot seen on another frame is not enough (a model foot moved onto the one foot in view)."""
    empty = LegPose(stamp=0.0, points=np.full((2, 5, 3), np.nan), status=TrackStatus.NO_USER, confidence=0.0)
    feet = [None, (0.0, 0.9), (0.3, 0.9), (0.6, 0.2), (0.6, 0.7), (0.1, 0.1), None, (0.9, 0.0), (0.0, 0.7),
            (0.0, 0.0)]
    poses = [replace(empty, stamp=0.1 * i) if f is None else _seen(0.1 * i, *f) for i, f in enumerate(feet)]
    track = _track(poses, np.array([-np.inf if f is None else 1.0 for f in feet]))

    def have(out: PassTrack) -> list[bool]:
        return [bool(np.all(np.isfinite(p.points))) for p in out.poses]

    # both seen at once on frame 4 (each alone before; without at_once the track would start on frame 3), a foot
    # hidden again later (frame 5) keeps the track; the second track sees each foot, never both at once
    assert have(wait_for_both_feet(track, at_once=True)) == [False] * 4 + [True, True] + [False] * 4
    assert have(wait_for_both_feet(track)) == [False] * 3 + [True, True, True, False, False, True, True]
    other = _track([replace(empty, stamp=0.1 * i) if i != 2 else _pose(0.2, 0.0) for i in range(10)], np.zeros(10))
    assert have(wait_for_both_feet(track, other=other, at_once=True))[:5] == [False, False, True, False, True]


def test_a_foot_is_seen_where_its_visibility_holds_over_the_next_frames() -> None:
    """One frame over ``min_visibility`` between frames under it (a model foot beside the one foot in view, over its
    edge) does not count; a foot seen on a frame and over the next ``frames`` frames counts from that frame, and a
    track's last frames average over what the track has."""
    left = [0.0, 0.55, 0.25, 0.58, 0.3, 0.0, 0.6, 0.7, 0.5, 0.9, 0.0]
    poses = [_seen(0.1 * i, v, 1.0) for i, v in enumerate(left)]
    track = _track(poses, np.ones(len(left)))
    have = [bool(np.all(np.isfinite(p.points))) for p in wait_for_both_feet(track, min_visibility=0.5, frames=3).poses]
    assert have == [False] * 6 + [True] * 5  # frame 6 starts (0.6, 0.7, 0.5); frames 1 and 3 alone never do
    one = [bool(np.all(np.isfinite(p.points))) for p in wait_for_both_feet(track, min_visibility=0.5, frames=1).poses]
    assert one == [False] + [True] * 10
    # a frame the foot is not seen on does not start it, whatever the frames after it show
    late = _track([_seen(0.0, 0.0, 1.0), _seen(0.1, 0.9, 1.0), _seen(0.2, 1.0, 1.0)], np.ones(3))
    assert [bool(np.all(np.isfinite(p.points))) for p in wait_for_both_feet(late, frames=3).poses] == \
        [False, True, True]
    short = _track([_seen(0.0, 0.0, 1.0), _seen(0.1, 0.9, 1.0)], np.ones(2))  # a two-frame track: its last frame
    assert [bool(np.all(np.isfinite(p.points))) for p in wait_for_both_feet(short, frames=3).poses] == [False, True]


def _walking(n: int, hidden: dict[int, range], *, dt: float = 1 / 30) -> tuple[list[LegPose], np.ndarray]:
    """``n`` poses of legs whose points move along smooth curves (the truth, ``(n, 2, 5, 3)``), and whose reported
    points are held at the last seen frame's wherever ``hidden[leg]`` says the foot is hidden (as the tracker holds
    a hidden leg's pose).  Segments follow the points (thigh hip-knee, calf knee-ankle, foot heel-toe)."""
    t = np.arange(n) * dt
    truth = np.zeros((n, 2, 5, 3))
    for leg in (0, 1):
        for j in range(5):
            truth[:, leg, j, 0] = 0.1 * leg + 0.02 * j + 0.3 * np.sin(2.0 * t + leg)  # smooth, cubic-ish over a gap
            truth[:, leg, j, 1] = 0.5 - 0.1 * j + 0.05 * t
            truth[:, leg, j, 2] = 1.0 + 0.2 * t * t - 0.1 * leg
    poses = []
    held = truth.copy()
    for i in range(n):
        vis = np.ones((2, 3))
        for leg, frames in hidden.items():
            if i in frames:
                vis[leg, 1:] = 0.0
                held[i, leg] = held[i - 1, leg]
        segs = np.stack([np.stack([held[i, :, 0], held[i, :, 1]], axis=1), np.stack([held[i, :, 1], held[i, :, 2]], axis=1),
                         np.stack([held[i, :, 3], held[i, :, 4]], axis=1)], axis=1)
        poses.append(LegPose(stamp=float(t[i]), points=held[i].copy(), segments=segs, visibility=vis,
                             status=TrackStatus.TRACKING, confidence=0.9))
    return poses, truth


def test_a_hidden_foot_is_bridged_between_where_it_was_last_seen_and_where_it_is_seen_again() -> None:
    poses, truth = _walking(40, {1: range(15, 27)})
    before = [p.points.copy() for p in poses]
    out = bridge_hidden_legs(poses, hide_below=0.25)
    gap = slice(15, 27)
    held = np.array([p.points[1, 1:] for p in poses[gap]])
    bridged = np.array([p.points[1, 1:] for p in out[gap]])
    err_held = np.abs(held - truth[gap, 1, 1:]).max()
    err_bridged = np.abs(bridged - truth[gap, 1, 1:]).max()
    assert err_held > 0.03  # the held pose falls behind the moving leg ...
    assert err_bridged < 0.1 * err_held  # ... the bridge follows it
    # the hip is the pelvis's and stays; the other leg, the frames outside the gap and the inputs are untouched
    assert all(np.array_equal(o.points[1, 0], p.points[1, 0]) for o, p in zip(out, poses))
    assert all(np.array_equal(o.points[0], p.points[0]) for o, p in zip(out, poses))
    assert all(o is p for i, (o, p) in enumerate(zip(out, poses)) if not 15 <= i < 27)
    assert all(np.array_equal(b, p.points) for b, p in zip(before, poses))
    # segments move with the points; angles, visibility and status stay the tracker's
    for o in out[gap]:
        assert np.allclose(o.segments[1, 0, 1], o.points[1, 1]) and np.allclose(o.segments[1, 1, 1], o.points[1, 2])
        assert np.allclose(o.segments[1, 2], o.points[1, 3:5])
    assert out[20].visibility is poses[20].visibility and out[20].status == TrackStatus.TRACKING
    assert BRIDGE_POINTS == (1, 2, 3, 4)
    # the shoe measures of a bridged foot are gone with the tracked foot they were measured along; the other's stay
    measured = [replace(p, shoe_rise=np.array([0.3, 0.3]), shoe_turn=np.array([0.05, 0.05]))
                for p in poses]
    out = bridge_hidden_legs(measured, hide_below=0.25)
    for o in out[gap]:
        assert np.isnan(o.shoe_rise[1]) and np.isnan(o.shoe_turn[1])
        assert o.shoe_rise[0] == 0.3 and o.shoe_turn[0] == 0.05


def test_a_held_pose_is_bridged_as_both_feet_hidden_offline_and_live() -> None:
    """A tracker coasting through a dropout or a blanked view repeats its last pose, ``DEGRADED`` at confidence 0,
    with the visibility it had: it observed nothing, so both feet count as hidden there and both legs are bridged
    from the frames before to those after (offline and live alike), where the held pose stood still while the legs
    went on."""
    poses, truth = _walking(40, {})
    gap = slice(15, 27)
    held = [replace(poses[14], stamp=p.stamp, status=TrackStatus.DEGRADED, confidence=0.0) for p in poses[gap]]
    poses[gap] = held
    out = bridge_hidden_legs(poses, hide_below=0.25)
    for leg in (0, 1):
        err_held = np.abs(np.array([p.points[leg, 1:] for p in poses[gap]]) - truth[gap, leg, 1:]).max()
        err_bridged = np.abs(np.array([p.points[leg, 1:] for p in out[gap]]) - truth[gap, leg, 1:]).max()
        assert err_held > 0.03 and err_bridged < 0.1 * err_held
    assert all(o.status == TrackStatus.DEGRADED and o.confidence == 0.0 for o in out[gap])  # still said to be held
    assert all(o is p for i, (o, p) in enumerate(zip(out, poses)) if not 15 <= i < 27)
    floor = FloorPlane.from_camera_pose(height=0.5, pitch=np.radians(30.0))
    live, when = _live(LiveBridge(hide_below=0.25), poses, [floor] * len(poses))
    k = BRIDGE_FIT_FRAMES
    assert when[15:27] == [27 + k] * 12  # held until the legs had been tracked again for k + 1 frames
    offline = reported_poses(poses[:27 + k + 1], hide_below=0.25, lowpass_hz=0.0, floors=[floor] * (27 + k + 1))
    for o, want, p in zip(live[gap], offline[gap], poses[gap]):
        assert np.allclose(o.points, want.points, atol=1e-12, rtol=0.0)
        assert not np.allclose(o.points[:, 2:], p.points[:, 2:], atol=0.01)  # moved off the held pose
    # a frame tracked at a low confidence is an observation: left as tracked
    low = [replace(p, confidence=0.05) if 15 <= i < 27 else p for i, p in enumerate(poses)]
    assert all(o is p for o, p in zip(bridge_hidden_legs(low, hide_below=0.25), low))


def test_a_foot_moving_steadily_is_bridged_exactly() -> None:
    n, dt = 30, 0.05
    poses = []
    for i in range(n):
        pts = np.zeros((2, 5, 3))
        pts[:, :, 0] = 0.4 * i * dt  # constant velocity: the Hermite curve with both ends' velocities is the line
        vis = np.ones((2, 3))
        if 10 <= i < 16:
            vis[0, 2] = 0.1  # the foot alone hidden (its calf seen) counts
            pts[0] = poses[-1].points[0]
        poses.append(LegPose(stamp=i * dt, points=pts, visibility=vis, status=TrackStatus.TRACKING, confidence=0.9))
    out = bridge_hidden_legs(poses, hide_below=0.25)
    for i in range(10, 16):
        assert np.allclose(out[i].points[0, 1:, 0], 0.4 * i * dt)
        assert np.allclose(out[i].points[0, 0], poses[i].points[0, 0])  # the hip stays
    assert out[12].segments is None  # poses without segments keep none


@pytest.mark.parametrize("case", ["long", "start", "end", "restart", "never_seen_after", "off"])
def test_a_gap_is_left_as_tracked_without_both_ends_seen_or_when_too_long(case: str) -> None:
    hidden = {"long": range(8, 40), "start": range(3, 12), "end": range(50, 57), "restart": range(15, 25),
              "never_seen_after": range(15, 60), "off": range(15, 25)}[case]
    poses, _ = _walking(60, {0: hidden})  # 30 frames/s: "long" is 1.07 s, over the 1 s default
    if case == "restart":  # a track restart (no pose) just after the gap: its far end is another track
        poses[27] = LegPose.no_user(poses[27].stamp)
    kw = {"max_gap_s": 0.0} if case == "off" else {}
    out = bridge_hidden_legs(poses, hide_below=0.25, **kw)
    assert all(o is p for o, p in zip(out, poses))
    assert reported_poses(poses, hide_below=0.25, max_gap_s=0.0, lowpass_hz=0.0) == poses
    with pytest.raises(ValueError, match="fit_frames"):
        bridge_hidden_legs(poses, hide_below=0.25, fit_frames=0)


def test_reported_poses_are_bridged_then_low_passed() -> None:
    poses, _ = _walking(40, {0: range(15, 22)})
    shown = reported_poses(poses, hide_below=0.25)
    want = lowpass_poses(bridge_hidden_legs(poses, hide_below=0.25))
    assert [p.points.tolist() for p in shown] == [p.points.tolist() for p in want]
    assert not np.array_equal(shown[18].points, poses[18].points)
    bridged_only = reported_poses(poses, hide_below=0.25, lowpass_hz=0.0)
    assert [p.points.tolist() for p in bridged_only] == \
        [p.points.tolist() for p in bridge_hidden_legs(poses, hide_below=0.25)]
    assert reported_poses(poses, hide_below=0.25, max_gap_s=0.0, lowpass_hz=0.0) == poses


def _noisy_track(n: int, *, fps: float = 30.0, seed: int = 0) -> tuple[list[LegPose], np.ndarray, np.ndarray]:
    """A leg swinging at gait frequencies (1 Hz and its harmonics) with 1 cm of white noise on every point and
    0.05 rad on every angle: (poses, true points, true angles)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fps
    truth = np.zeros((n, 2, 5, 3))
    truth[..., 2] = 1.0 + 0.2 * np.sin(2 * np.pi * t)[:, None, None] + 0.05 * np.sin(6 * np.pi * t)[:, None, None]
    truth[..., 0] = np.arange(5)[None, None, :] * 0.1
    angles = 0.4 * np.sin(2 * np.pi * t)[:, None] * np.ones((1, 12))
    poses = []
    for i in range(n):
        pts = truth[i] + 0.01 * rng.standard_normal((2, 5, 3))
        segs = np.stack([np.stack([pts[:, 0], pts[:, 1]], axis=1), np.stack([pts[:, 1], pts[:, 2]], axis=1),
                         np.stack([pts[:, 3], pts[:, 4]], axis=1)], axis=1)
        poses.append(LegPose(stamp=float(t[i]), points=pts, angles=angles[i] + 0.05 * rng.standard_normal(12),
                             segments=segs, visibility=np.ones((2, 3)), status=TrackStatus.TRACKING, confidence=0.9))
    return poses, truth, angles


def test_a_low_pass_takes_the_jitter_off_a_walking_leg_and_keeps_its_motion() -> None:
    poses, truth, angles = _noisy_track(90)
    out = lowpass_poses(poses)
    raw_err = np.sqrt(np.mean((np.stack([p.points for p in poses]) - truth) ** 2))
    err = np.sqrt(np.mean((np.stack([p.points for p in out]) - truth) ** 2))
    assert err < 0.7 * raw_err  # white noise up to 15 Hz, kept below 6 Hz: ~0.63 of its RMS; the motion kept
    ang_err = np.sqrt(np.mean((np.stack([p.angles for p in out]) - angles) ** 2))
    assert ang_err < 0.7 * np.sqrt(np.mean((np.stack([p.angles for p in poses]) - angles) ** 2))
    # no lag: the filtered heel's height fits the true one best unshifted
    z, zt = np.stack([p.points for p in out])[10:80, 0, 3, 2], truth[:, 0, 3, 2]
    fits = {lag: float(np.mean((z - zt[10 + lag:80 + lag]) ** 2)) for lag in (-2, -1, 0, 1, 2)}
    assert min(fits, key=fits.__getitem__) == 0
    # segments follow the points; the rest stays; the input is not modified
    assert np.allclose(out[20].segments[1, 1, 1], out[20].points[1, 2])
    assert out[20].visibility is poses[20].visibility and out[20].confidence == poses[20].confidence
    assert not np.array_equal(out[20].points, poses[20].points)
    assert np.array_equal(poses[20].points, _noisy_track(90)[0][20].points)


def test_reported_poses_are_filtered_in_the_walker_frame_of_a_rocking_camera() -> None:
    """A walker rocking on its wheels (1 deg of pitch at 8 Hz) shakes its camera, so a still leg moves in the camera
    frame: filtered there, the leg's reported points would lose the shake that is really in the camera frame's view;
    filtered in each frame's walker frame they are the tracker's.  A frame without a valid floor is reported as it
    came."""
    n, fps = 60, 30.0
    still = np.zeros((2, 5, 3))
    still[..., 0] = np.linspace(0.6, 0.9, 5)[None, :]  # in front of the walker ...
    still[..., 2] = np.linspace(0.8, 0.0, 5)[None, :]  # ... from hip height to the floor
    poses, floors = [], []
    for i in range(n):
        floor = FloorPlane.from_camera_pose(height=0.5, pitch=np.radians(30.0 + np.sin(2 * np.pi * 8.0 * i / fps)))
        rot, t = floor.walker_transform()
        pts = (still - t) @ rot  # camera frame: rot.T @ (p - t)
        poses.append(LegPose(stamp=i / fps, points=pts, visibility=np.ones((2, 3)), status=TrackStatus.TRACKING,
                             confidence=0.9))
        floors.append(floor)
    walker = reported_poses(poses, hide_below=0.25, floors=floors)
    camera = reported_poses(poses, hide_below=0.25)
    err_walker = max(float(np.abs(a.points - b.points).max()) for a, b in zip(walker, poses))
    err_camera = max(float(np.abs(a.points - b.points).max()) for a, b in zip(camera, poses))
    assert err_walker < 1e-9 < 0.005 < err_camera
    floors[30] = replace(floors[30], valid=False)
    out = reported_poses(poses, hide_below=0.25, floors=floors)
    assert out[30] is poses[30]
    with pytest.raises(ValueError, match="floors"):
        reported_poses(poses, hide_below=0.25, floors=floors[:10])


def test_a_low_pass_stays_inside_each_stretch_of_tracked_frames() -> None:
    poses, _, _ = _noisy_track(60)
    poses[30] = LegPose.no_user(poses[30].stamp)  # a track ends and another starts
    poses[31] = replace(poses[31], status=TrackStatus.SEARCHING)
    out = lowpass_poses(poses)
    assert out[30] is poses[30] and out[31] is poses[31]
    # the first stretch is filtered as it would be alone: nothing from after the break leaks in
    alone = lowpass_poses(poses[:30])
    assert all(np.allclose(a.points, b.points) for a, b in zip(alone, out[:30]))
    # a stretch shorter than the filter needs, frames too sparse for the cut-off, or the filter off: as they are
    short = lowpass_poses(poses[:8])
    assert all(a is b for a, b in zip(short, poses[:8]))
    slow, _, _ = _noisy_track(40, fps=12.0)
    assert all(a is b for a, b in zip(lowpass_poses(slow), slow))
    assert all(a is b for a, b in zip(lowpass_poses(poses, cutoff_hz=0.0), poses))
    with pytest.raises(ValueError, match="order"):
        lowpass_poses(poses, order=4)


@pytest.mark.parametrize(("cutoff", "fs"), [(6.0, 30.0), (6.0, 15.0), (3.0, 100.0)])
def test_the_butterworth_filter_is_scipys(cutoff: float, fs: float) -> None:
    """butter2 / filtfilt2 give what scipy.signal.butter(2, ...) / filtfilt(..., axis=0) give (kept apart from
    scipy.signal only for its half-second import)."""
    from scipy.signal import butter, filtfilt

    b, a = butter(2, cutoff / (0.5 * fs))
    b2, a2 = butter2(cutoff, fs)
    np.testing.assert_allclose(b2, b, atol=1e-15)
    np.testing.assert_allclose(a2, a, atol=1e-15)
    x = np.random.default_rng(0).standard_normal((40, 2, 5, 3)).cumsum(axis=0)
    np.testing.assert_allclose(filtfilt2(b2, a2, x), filtfilt(b, a, x, axis=0), atol=1e-10)
    with pytest.raises(ValueError, match="half the sampling rate"):
        butter2(0.5 * fs, fs)
    with pytest.raises(ValueError, match="more than 9"):
        filtfilt2(b2, a2, x[:9])


def _step(stamp: float, side: Side, length: float, confidence: float = 1.0) -> Step:
    nan = float("nan")
    return Step(stamp=stamp, side=side, index=0, step_length=length, step_width=0.1, step_time=0.6,
                stride_length=nan, stride_time=nan, stance_time=nan, swing_time=nan, single_support_time=nan,
                double_support_time=nan, confidence=confidence)


def test_steps_are_confirmed_only_when_the_passes_see_them_alike() -> None:
    merged = [_step(1.0, Side.LEFT, 0.50), _step(1.6, Side.RIGHT, 0.45, 0.8), _step(2.2, Side.LEFT, 0.50),
              _step(2.8, Side.RIGHT, 0.40), _step(3.4, Side.LEFT, float("nan"))]
    fwd = [_step(1.05, Side.LEFT, 0.52), _step(1.6, Side.RIGHT, 0.46), _step(2.2, Side.LEFT, 0.30),
           _step(2.8, Side.LEFT, 0.40), _step(3.4, Side.LEFT, float("nan"))]
    bwd = [_step(0.9, Side.LEFT, 0.49), _step(1.9, Side.RIGHT, 0.45), _step(2.2, Side.LEFT, 0.50),
           _step(2.8, Side.RIGHT, 0.40), _step(3.45, Side.LEFT, float("nan"))]
    out = confirm_steps(merged, [fwd, bwd])
    # 1.0: both within 0.25 s and 8 cm; 1.6: the backward pass has it 0.3 s later; 2.2: the forward pass 20 cm
    # shorter; 2.8: the forward pass's step is the other foot's; 3.4: no length anywhere, same time: confirmed
    assert [s.confidence for s in out] == pytest.approx([1.0, 0.8 * UNCONFIRMED_FACTOR, UNCONFIRMED_FACTOR,
                                                         UNCONFIRMED_FACTOR, 1.0])
    assert [(s.stamp, s.step_length) for s in out[:4]] == [(s.stamp, s.step_length) for s in merged[:4]]
    assert confirm_steps(merged, [merged, merged]) == merged  # passes that agree change nothing
    assert [s.confidence for s in confirm_steps(merged, [[]])] == pytest.approx([UNCONFIRMED_FACTOR, 0.32] +
                                                                               [UNCONFIRMED_FACTOR] * 3)
    with pytest.raises(ValueError, match="factor"):
        confirm_steps(merged, [fwd], factor=1.5)
    # four passes (each direction tracked twice): three of them confirming suffice, two do not; share=1: all four
    four = confirm_steps(merged, [fwd, bwd, merged, merged])
    assert [s.confidence for s in four] == pytest.approx([1.0, 0.8, 1.0, 1.0, 1.0])
    # 1.6: three of four (the backward pass alone misses it); 2.2 / 2.8: two of four
    assert [s.confidence for s in confirm_steps(merged, [fwd, bwd, merged, fwd])] == pytest.approx(
        [1.0, 0.8, UNCONFIRMED_FACTOR, UNCONFIRMED_FACTOR, 1.0])
    assert [s.confidence for s in confirm_steps(merged, [fwd, bwd, merged, merged], share=1.0)] == \
        pytest.approx([s.confidence for s in out])
    with pytest.raises(ValueError, match="share"):
        confirm_steps(merged, [fwd], share=0.0)


def test_step_lengths_are_the_median_of_the_three_analyses_where_every_pass_has_the_step() -> None:
    left, right = Side.LEFT, Side.RIGHT
    merged = [_step(1.0, left, -0.007), _step(1.6, right, 0.50), _step(2.2, left, 0.52), _step(2.8, right, 0.48)]
    merged[0] = replace(merged[0], step_width=0.12, stride_length=0.9)
    fwd = [_step(1.05, left, 0.515), _step(1.6, right, 0.55), _step(2.2, left, 0.53), _step(2.8, right, float("nan"))]
    bwd = [_step(0.95, left, 0.572), _step(1.6, left, 0.40), _step(2.5, left, 0.60), _step(2.8, right, 0.47)]
    out = refine_step_lengths(merged, [fwd, bwd])
    # 1.0: the merged outlier replaced by the median (the forward pass's), its width, stride, time and confidence
    # kept; 1.6: the backward pass has only the other foot's step there; 2.2: its step 0.3 s off, outside 0.25 s;
    # 2.8: a pass without a length
    assert [s.step_length for s in out] == pytest.approx([0.515, 0.50, 0.52, 0.48])
    assert replace(out[0], step_length=merged[0].step_length) == merged[0]
    assert out[1:] == merged[1:]
    assert refine_step_lengths(merged, []) == merged  # nothing to compare with
    # within the check: doubted on the merged track's own length (-0.7 cm, which neither pass confirms), then refined
    _, checked = check_against_passes([], merged, [([], fwd), ([], bwd)])
    assert checked[0].step_length == pytest.approx(0.515) and checked[0].confidence == pytest.approx(UNCONFIRMED_FACTOR)


def _event(stamp: float, side: Side, kind: EventKind) -> GaitEvent:
    return GaitEvent(stamp=stamp, side=side, kind=kind, position=np.zeros(3))


def test_events_are_timed_by_the_passes_and_the_steps_follow() -> None:
    hs, to, left, right = EventKind.HEEL_STRIKE, EventKind.TOE_OFF, Side.LEFT, Side.RIGHT
    merged = [_event(1.0, left, hs), _event(1.2, right, to), _event(1.5, right, hs), _event(1.7, left, to),
              _event(2.1, left, hs)]
    fwd = [_event(1.02, left, hs), _event(1.25, right, to), _event(1.52, right, hs), _event(1.72, left, to),
           _event(2.13, left, hs)]
    bwd = [_event(1.24, left, hs), _event(1.22, right, to), _event(1.74, left, to), _event(2.12, left, hs)]
    step = replace(_step(2.1, left, 0.5), step_time=0.6, stride_time=1.1, swing_time=0.4, stance_time=0.7,
                   single_support_time=0.3, double_support_time=0.4)
    first = replace(_step(1.5, right, 0.5), step_time=float("nan"))  # no temporal figures known: they stay unknown
    events, steps = refine_event_times(merged, [first, step], [fwd, bwd])
    # each event with a mate in both passes: the median of three (the backward pass's left strike at 1.24 is an
    # outlier the median leaves out: the mean would move the strike to 1.087); the right strike at 1.5 has no mate
    # in the backward pass and keeps its time
    assert [e.stamp for e in events] == pytest.approx([1.02, 1.22, 1.5, 1.72, 2.12])
    assert [(e.side, e.kind) for e in events] == [(e.side, e.kind) for e in merged]
    got = steps[1]
    assert got.stamp == pytest.approx(2.12)
    assert got.step_time == pytest.approx(2.12 - 1.5)  # from the right heel strike at 1.5
    assert got.stride_time == pytest.approx(2.12 - 1.02)  # from the left one, moved to 1.02
    assert got.swing_time == pytest.approx(2.12 - 1.72)  # from its toe off, moved to 1.72
    assert got.stance_time == pytest.approx(1.72 - 1.02)
    assert got.single_support_time == pytest.approx(1.5 - 1.22)
    assert got.double_support_time == pytest.approx((1.22 - 1.02) + (1.72 - 1.5))
    assert (got.step_length, got.confidence) == (step.step_length, step.confidence)
    assert steps[0].stamp == 1.5 and np.isnan(steps[0].step_time) and np.isnan(steps[0].double_support_time)
    # heel strikes only when asked
    assert [e.stamp for e in refine_event_times(merged, [], [fwd, bwd], kinds=(hs,))[0]] == pytest.approx(
        [1.02, 1.2, 1.5, 1.7, 2.12])
    # nothing to compare with: nothing moves
    assert refine_event_times(merged, [first, step], [])[1] == [first, step]
    # both checks together: the step at 2.1 is confirmed by neither pass's steps (none given) and is retimed
    ev2, st2 = check_against_passes(merged, [step], [(fwd, []), (bwd, [])])
    assert st2[0].confidence == pytest.approx(UNCONFIRMED_FACTOR) and st2[0].stamp == pytest.approx(2.12)
    assert [e.stamp for e in ev2] == [e.stamp for e in events]


@dataclass
class _Frame:
    stamp: float
    points: np.ndarray
    depth_fg: np.ndarray
    floor: FloorPlane
    no_depth: np.ndarray | None = None
    intrinsics: CameraIntrinsics = KINECT


class _Recorder:
    """A stand-in tracker that records the stamps it is given."""

    def __init__(self) -> None:
        self.stamps: list[float] = []

    def update(self, *, stamp: float, points: np.ndarray, depth_fg: np.ndarray, floor: FloorPlane,
               no_depth: np.ndarray | None = None) -> LegPose:
        self.stamps.append(stamp)
        return _pose(stamp, float(points[0, 0]))

    @property
    def state(self) -> np.ndarray | None:
        return np.full(lm.STATE_DIM, self.stamps[-1])


def test_a_backward_pass_sees_increasing_stamps_and_returns_poses_in_recording_order() -> None:
    floor = FloorPlane.from_camera_pose(height=0.7, pitch=0.5)
    frames = [_Frame(stamp=0.5 + i / 30, points=np.full((1, 3), float(i)), depth_fg=np.zeros((1, 1)), floor=floor)
              for i in range(6)]
    other = replace(KINECT, fx=KINECT.fx * 1.1)
    frames[4] = replace(frames[4], intrinsics=other)  # a new calibration from frame 4 on
    frames[5] = replace(frames[5], intrinsics=other)
    made: list[_Recorder] = []

    def make(frame: _Frame) -> _Recorder:
        made.append(_Recorder())
        return made[-1]

    seen: list[tuple[int, float]] = []
    track = track_pass(make, frames, backward=True, score=lambda i, f, x: seen.append((i, float(x[0]))) or float(i))
    assert len(made) == 2  # a fresh tracker where the calibration changes, as forwards
    assert made[0].stamps == [-frames[5].stamp, -frames[4].stamp]
    assert np.all(np.diff(made[1].stamps) > 0)  # what the tracker saw: time running forwards
    assert [p.stamp for p in track.poses] == [f.stamp for f in frames]  # the poses carry their own frames' stamps
    assert [float(p.points[0, 0, 0]) for p in track.poses] == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]
    assert seen[0] == (5, pytest.approx(-frames[5].stamp))  # scored after each frame, with its state
    np.testing.assert_array_equal(track.scores, np.arange(6.0))
    assert track.tracker_ms.shape == track.scoring_ms.shape == (6,)
    fwd = track_pass(lambda f: _Recorder(), frames)
    assert [p.stamp for p in fwd.poses] == [f.stamp for f in frames] and np.all(np.isnan(fwd.scores))


@pytest.fixture(scope="module")
def seq():  # noqa: ANN201
    s = own_sequence(n_frames=16, rng=np.random.default_rng(3))
    return [_Frame(stamp=f.stamp, points=f.points, depth_fg=f.depth, floor=f.floor) for f in s.frames], s


def test_the_tracker_scores_a_fitting_state_above_one_moved_off_the_data(seq) -> None:  # noqa: ANN001
    frames, _ = seq
    tr = LegTracker(FAST, KINECT, rng=np.random.default_rng(0))
    assert tr.state is None
    for f in frames[:10]:
        tr.update(stamp=f.stamp, points=f.points, depth_fg=f.depth_fg, floor=f.floor)
    x = tr.state
    assert x is not None and x.shape == (lm.STATE_DIM,)
    off = x.copy()
    off[lm.StateLayout.ROOT.start + 1] += 0.25  # 25 cm to the side of where the legs are
    scorer = LegTracker(FAST, KINECT, rng=np.random.default_rng(5))
    f = frames[9]
    s = score_passes(scorer, f, [x, off, None], rng=np.random.default_rng(1))
    assert s[0] > s[1] and s[2] == -np.inf
    # deterministic for a seeded generator, and the scoring leaves the scorer's own generator alone
    before = scorer.rng.bit_generator.state
    s2 = score_passes(scorer, f, [x, off, None], rng=np.random.default_rng(1))
    np.testing.assert_array_equal(s, s2)
    assert scorer.rng.bit_generator.state == before
    # without a floor there is nothing to score against
    bad = replace(f, floor=replace(f.floor, valid=False))
    assert np.all(score_passes(scorer, bad, [x, off], rng=np.random.default_rng(1)) == -np.inf)


def test_a_backward_pass_of_the_tracker_tracks_the_legs(seq) -> None:  # noqa: ANN001
    frames, s = seq
    track = track_pass(lambda f: LegTracker(FAST, f.intrinsics, rng=np.random.default_rng(0)), frames, backward=True)
    assert len(track.poses) == len(frames)
    err = np.array([np.linalg.norm(p.points - f.gt, axis=-1).mean() for p, f in zip(track.poses, s.frames)])
    # tracked from the last frame back: the early frames (tracked last) are converged
    assert err[:-4].mean() < 0.08, err
    for p in track.poses:  # identity kept: the left leg on the image's right (+x), as forwards
        assert p.points[0, :3, 0].mean() > p.points[1, :3, 0].mean()


def _right_foot_held(truth: np.ndarray, hidden: range | set[int], dt: float) -> list[LegPose]:
    """Poses of the true points ``truth`` ``(n, 2, 5, 3)`` with the right foot hidden over ``hidden``: its leg held at
    the last frame seen, its calf and foot's visibility 0, as the tracker holds a leg it does not see."""
    poses, held = [], truth.copy()
    for i in range(len(truth)):
        vis = np.ones((2, 3))
        if i in hidden:
            vis[1, 1:] = 0.0
            held[i, 1] = held[i - 1, 1]
        poses.append(LegPose(stamp=i * dt, points=held[i].copy(), visibility=vis, status=TrackStatus.TRACKING,
                             confidence=0.9))
    return poses


def _rolling_foot(n: int, hidden: range | set[int], *, floor_v: float = 0.6, dt: float = 1 / 30,
                  swing_from: int | None = None) -> tuple[list[LegPose], np.ndarray]:
    """``n`` poses in a floor-aligned frame (z up, floor z = 0) of a walker moving along -x: the floor, and a planted
    foot with it, moves along +x at ``floor_v``.  The left foot stands flat throughout; the right one stands flat,
    then rolls over its planted toe (heel up) while its knee stays put, as a trailing foot does in late stance, and
    is hidden over ``hidden`` (held at the last frame seen, as the tracker holds it).  From ``swing_from`` on the
    right foot swings forward at 2.5 m/s instead (a swinging foot).  Returns the poses and the true points."""
    truth = np.zeros((n, 2, 5, 3))
    knee = np.array([0.16, -0.1, 0.45])
    ankle_from_toe = np.array([0.20, 0.0, 0.09])  # flat: the ankle 20 cm behind the toe, 9 cm up; the heel 26 cm
    heel_from_toe = np.array([0.26, 0.0, 0.0])
    calf = float(np.linalg.norm(knee - ([0.0, -0.1, 0.0] + ankle_from_toe)))  # the foot stands flat at t = 0
    for i in range(n):
        t = i * dt
        # left leg: flat, planted, carried by the floor
        toe_l = np.array([-0.05 + floor_v * t, 0.1, 0.0])
        truth[i, 0] = [toe_l + [0.3, 0, 0.85], toe_l + [0.25, 0, 0.45], toe_l + ankle_from_toe, toe_l + heel_from_toe,
                       toe_l]
        toe = np.array([floor_v * t, -0.1, 0.0])
        # the foot's turn about the toe (heel up) that keeps the ankle a calf's length from the knee: bisection
        def turned(v: np.ndarray, a: float) -> np.ndarray:  # about the toe, heel up
            return np.array([v[0] * np.cos(a) - v[2] * np.sin(a), 0.0, v[0] * np.sin(a) + v[2] * np.cos(a)])

        lo_a, hi_a = 0.0, 1.4
        for _ in range(60):
            mid = 0.5 * (lo_a + hi_a)
            lo_a, hi_a = (mid, hi_a) if np.linalg.norm(toe + turned(ankle_from_toe, mid) - knee) > calf else (lo_a, mid)
        turn = 0.0 if np.linalg.norm(toe + ankle_from_toe - knee) <= calf else lo_a
        ank, heel = toe + turned(ankle_from_toe, turn), toe + turned(heel_from_toe, turn)
        truth[i, 1] = [knee + [0.0, 0.0, 0.4], knee, ank, heel, toe]
        if swing_from is not None and i >= swing_from:
            truth[i, 1] = truth[swing_from - 1, 1] + [-2.5 * (i - swing_from + 1) * dt, 0.0, 0.03]
    return _right_foot_held(truth, hidden, dt), truth


def test_a_hidden_foot_standing_on_the_floor_rolls_over_its_toe_as_the_floor_carries_it() -> None:
    poses, truth = _rolling_foot(32, range(8, 18))
    gap = slice(8, 18)
    assert truth[17, 1, 3, 2] > 0.15  # the real heel rises over 15 cm while hidden
    rolled = bridge_hidden_legs(poses, hide_below=0.25, floor_frame=True)
    plain = bridge_hidden_legs(poses, hide_below=0.25)  # without a floor-aligned frame: the Hermite curves alone
    err = {name: np.linalg.norm(np.array([p.points[1, 2:] for p in out[gap]]) - truth[gap, 1, 2:], axis=-1)
           for name, out in (("rolled", rolled), ("plain", plain))}
    assert err["plain"].max() > 0.005
    assert err["rolled"].max() < 1e-3  # the toe with the floor, the heel up as far as its knee lets it: exact
    assert all(np.array_equal(o.points[1, :2], p.points[1, :2]) for o, p in zip(rolled[gap], plain[gap]))  # hip, knee
    assert all(o is p for i, (o, p) in enumerate(zip(rolled, poses)) if not 8 <= i < 18)
    # seen again in its swing: the toe leaves the floor late enough for the swing to get there no faster than any
    # toe was seen to move; the curves alone keep the toe too far forward and the heel too low
    poses, truth = _rolling_foot(32, range(8, 18), swing_from=16)
    err = {name: np.linalg.norm(np.array([p.points[1, 2:] for p in out[gap]]) - truth[gap, 1, 2:], axis=-1).max()
           for name, out in (("rolled", bridge_hidden_legs(poses, hide_below=0.25, floor_frame=True)),
                             ("plain", bridge_hidden_legs(poses, hide_below=0.25)))}
    assert err["plain"] > 0.08 and err["rolled"] < 0.7 * err["plain"]


def test_a_hidden_foot_standing_under_a_trouser_hem_is_rolled_though_its_toe_reads_centimetres_up() -> None:
    """The toe is measured on the shoe's front above the floor cut: under a hem a standing foot's toe reads up to
    about 4 cm up.  Such a foot, moving with the floor, is still taken for planted and rolled over its toe; one
    whose toe is higher than :data:`BRIDGE_PLANTED_Z` is left to the curves."""
    gap = slice(8, 18)
    for lift, rolls in ((0.04, True), (BRIDGE_PLANTED_Z + 0.01, False)):
        poses, truth = _rolling_foot(32, range(8, 18))
        up = np.zeros((2, 5, 3))
        up[1, :, 2] = lift  # the right leg reads `lift` higher throughout: its toe that far over the floor
        raised = [replace(p, points=p.points + up) for p in poses]
        out = bridge_hidden_legs(raised, hide_below=0.25, floor_frame=True)
        plain = bridge_hidden_legs(raised, hide_below=0.25)
        err = np.linalg.norm(np.array([p.points[1, 2:] for p in out[gap]]) - (truth + up)[gap, 1, 2:], axis=-1)
        if rolls:
            assert err.max() < 1e-3  # as on the floor: the toe with the floor, the heel up as its knee lets it
        else:
            assert [p.points.tolist() for p in out] == [p.points.tolist() for p in plain]


def test_a_hidden_planted_foot_is_rolled_from_where_the_frames_before_put_its_toe_offline_and_live() -> None:
    """A foot going out of view is measured worst in its last frame seen (what is left of the shoe's front lags, and
    the heel behind it): the roll starts from the median of the toes seen standing over the frames before, each
    carried by the floor, the heel moved with the toe, not from that last shoe; offline and live alike."""
    gap = slice(8, 18)
    floor = FloorPlane.from_camera_pose(height=0.5, pitch=np.radians(30.0))
    poses, truth = _rolling_foot(32, range(8, 18))
    lagging = poses[7].points.copy()
    lagging[1, 3:] += [-0.03, 0.01, 0.01]  # the last shoe seen 3 cm off (toe, and the heel behind it); the ankle not
    poses = [*poses[:7], replace(poses[7], points=lagging),
             *[replace(p, points=np.where(np.arange(2)[:, None, None] == 1, lagging, p.points)) for p in poses[8:18]],
             *poses[18:]]  # the held leg holds the lagging frame
    out = bridge_hidden_legs(poses, hide_below=0.25, floor_frame=True)
    err = np.linalg.norm(np.array([p.points[1, 2:] for p in out[gap]]) - truth[gap, 1, 2:], axis=-1)
    assert np.linalg.norm(poses[7].points[1, 3:] - truth[7, 1, 3:], axis=-1).min() > 0.03  # the last heel and toe
    assert err.max() < 1e-3, err.max()  # the toe with the floor from where it stood, the heel up as the knee lets it
    live, _ = _live(LiveBridge(hide_below=0.25), _to_camera(poses, floor), [floor] * len(poses))
    walker = np.array([floor.to_walker(p.points) for p in live])
    assert np.abs(walker - np.array([p.points for p in out])).max() < 1e-9
    # a last toe seen higher than a standing one is no planted foot: left to the curves (the anchor does not make one)
    lifted = [*poses[:7], replace(poses[7], points=lagging + np.where(np.arange(2)[:, None, None] == 1,
                                                                      [0.0, 0.0, BRIDGE_PLANTED_Z], 0.0))]
    lifted += [replace(p, points=lifted[7].points) for p in poses[8:18]] + poses[18:]
    assert [p.points.tolist() for p in bridge_hidden_legs(lifted, hide_below=0.25, floor_frame=True)] == \
        [p.points.tolist() for p in bridge_hidden_legs(lifted, hide_below=0.25)]


def test_a_hidden_planted_foot_seen_again_only_briefly_is_rolled_offline_and_live() -> None:
    """A trailing foot under a hem or behind the other leg may show for a frame or a few and hide again: the
    stretch before is rolled over its planted toe all the same (the far end's tangent over the frames seen, none
    for one), offline and live alike; one last seen swinging and seen as briefly is left as tracked."""
    gap = slice(8, 18)
    floor = FloorPlane.from_camera_pose(height=0.5, pitch=np.radians(30.0))
    _, truth = _rolling_foot(32, range(0))
    for seen_after, bound in ((3, 1e-3), (1, 0.04)):  # one frame: no tangent, the toe off a little early
        poses = _right_foot_held(truth, set(range(8, 18)) | set(range(18 + seen_after, 26)), 1 / 30)
        out = bridge_hidden_legs(poses, hide_below=0.25, floor_frame=True)
        err = np.linalg.norm(np.array([p.points[1, 2:] for p in out[gap]]) - truth[gap, 1, 2:], axis=-1)
        held = np.linalg.norm(np.array([p.points[1, 2:] for p in poses[gap]]) - truth[gap, 1, 2:], axis=-1)
        assert held.max() > 0.1 and err.max() < bound, (seen_after, err.max())
        assert all(o is p for i, (o, p) in enumerate(zip(out, poses)) if not 8 <= i < 18)  # the next stretch: held
        live, _ = _live(LiveBridge(hide_below=0.25), _to_camera(poses, floor), [floor] * len(poses))
        walker = np.array([floor.to_walker(p.points) for p in live])
        assert np.abs(walker - np.array([p.points for p in out])).max() < 1e-9
    # last seen swinging, seen again for a frame: as tracked, offline and live
    poses, _ = _rolling_foot(32, set(range(14, 20)) | set(range(21, 26)), swing_from=12)
    out = bridge_hidden_legs(poses, hide_below=0.25, floor_frame=True)
    assert all(o is p for o, p in zip(out, poses))
    live, _ = _live(LiveBridge(hide_below=0.25), _to_camera(poses, floor), [floor] * len(poses))
    assert np.abs(np.array([floor.to_walker(p.points) for p in live]) - np.array([p.points for p in poses])).max() < 1e-9


def test_a_hidden_foot_that_swings_or_has_no_floor_seen_is_bridged_by_the_curves_alone() -> None:
    poses, _ = _rolling_foot(32, range(14, 20), swing_from=12)  # last seen swinging at 2.5 m/s against the floor
    want = [p.points.tolist() for p in bridge_hidden_legs(poses, hide_below=0.25)]
    assert [p.points.tolist() for p in bridge_hidden_legs(poses, hide_below=0.25, floor_frame=True)] == want
    poses, _ = _rolling_foot(32, range(8, 18))
    raised = [replace(p, points=p.points + [0.0, 0.0, 0.05]) for p in poses]  # no foot on the floor: no floor seen
    want = [p.points.tolist() for p in bridge_hidden_legs(raised, hide_below=0.25)]
    assert [p.points.tolist() for p in bridge_hidden_legs(raised, hide_below=0.25, floor_frame=True)] == want


def _landing_foot(n: int, hidden: range, *, land: int, floor_v: float = 0.8, swing_v: float = 2.0,
                  dt: float = 1 / 30, stance_z: float = 0.0, stance_v: float | None = None,
                  left_raised: int = 0) -> tuple[list[LegPose], np.ndarray]:
    """``n`` poses in a floor-aligned frame (z up, floor z = 0) of a walker moving along -x at ``floor_v``, its user
    walking close to the camera: the left foot stands flat (5 cm up before frame ``left_raised``) and rides the
    floor (+x); the right one swings towards the camera (-x) at ``swing_v`` against the walker frame, 5 cm up,
    lands flat at frame ``land`` and moves at ``stance_v`` (default: the floor's) from then on, ``stance_z`` up.
    The right foot is hidden over ``hidden`` (held at the last frame seen, as the tracker holds a foot that left
    the image).  Returns the poses and the true points."""
    stance_v = floor_v if stance_v is None else stance_v
    truth = np.zeros((n, 2, 5, 3))
    heel_land = np.array([0.30, -0.1, stance_z])
    foot = np.array([[0.0, 0.0, 0.85], [-0.06, 0.0, 0.51], [-0.06, 0.0, 0.09], [0.0, 0.0, 0.0], [-0.26, 0.0, 0.0]])
    for i in range(n):
        t = i * dt
        heel_l = np.array([0.1 + floor_v * t, 0.1, 0.05 if i < left_raised else 0.0])
        truth[i, 0] = heel_l + foot
        if i < land:
            heel = heel_land + [swing_v * (land - i) * dt, 0.0, 0.05 - stance_z]
        else:
            heel = heel_land + [stance_v * (i - land) * dt, 0.0, 0.0]
        truth[i, 1] = heel + foot
    return _right_foot_held(truth, hidden, dt), truth


def test_a_foot_hidden_from_its_swing_to_its_stance_lands_and_rides_the_floor_back_into_view() -> None:
    """A user close to the camera lands the swinging foot below the image and the floor carries it back into view:
    the foot seen standing afterwards, carried back at the floor's velocity, is where the hidden one stood since
    its landing (exact); the curves alone cut the corner between the swing and the stance by centimetres."""
    hidden, land = range(14, 28), 18
    poses, truth = _landing_foot(40, hidden, land=land)
    gap = slice(hidden.start, hidden.stop)
    landed = bridge_hidden_legs(poses, hide_below=0.25, floor_frame=True)
    plain = bridge_hidden_legs(poses, hide_below=0.25)
    err = {name: np.linalg.norm(np.array([p.points[1, 2:] for p in out[gap]]) - truth[gap, 1, 2:], axis=-1)
           for name, out in (("landed", landed), ("plain", plain))}
    assert err["plain"].max() > 0.05
    assert err["landed"][-6:].max() < 1e-9  # from the landing on: standing flat where the floor carried it
    assert err["landed"].mean() < 0.5 * err["plain"].mean()
    assert all(np.array_equal(o.points[1, :2], p.points[1, :2]) for o, p in zip(landed[gap], plain[gap]))  # hip, knee
    assert all(o is p for i, (o, p) in enumerate(zip(landed, poses)) if i not in hidden)
    # seen again with its heel already rising (turned 15 deg about the toe): the hidden frames stand flat all the same
    c, s_ = np.cos(np.radians(15.0)), np.sin(np.radians(15.0))
    rising = [replace(p, points=p.points.copy()) for p in poses]
    pts = rising[hidden.stop].points[1]
    for j in (2, 3):  # ankle, heel about the toe, heel up
        dx, dz = pts[j, 0] - pts[4, 0], pts[j, 2] - pts[4, 2]
        pts[j, 0], pts[j, 2] = pts[4, 0] + c * dx - s_ * dz, pts[4, 2] + s_ * dx + c * dz
    assert pts[3, 2] > 0.06
    out = bridge_hidden_legs(rising, hide_below=0.25, floor_frame=True)
    assert np.abs(np.array([p.points[1, 2:] for p in out[gap]])[-6:] - truth[gap, 1, 2:][-6:]).max() < 1e-9
    # no flat foot seen near the stretch (the landed foot stands on a mat 2.5 cm up, the other is raised until 2 s):
    # the floor's velocity is the standing foot's own, which is how the floor moves while the walker rolls
    on_mat, mat_truth = _landing_foot(90, hidden, land=land, stance_z=0.025, left_raised=60)
    out = bridge_hidden_legs(on_mat, hide_below=0.25, floor_frame=True)
    assert np.abs(np.array([p.points[1, 2:] for p in out[gap]])[-6:] - mat_truth[gap, 1, 2:][-6:]).max() < 1e-9
    # ... and not where the foot's own velocity is not the rolling floor's (a foot seen again still swinging, low over
    # the floor, towards the camera): the curves alone
    sliding, _ = _landing_foot(90, hidden, land=land, stance_z=0.025, stance_v=-1.0, left_raised=60)
    assert ([p.points.tolist() for p in bridge_hidden_legs(sliding, hide_below=0.25, floor_frame=True)]
            == [p.points.tolist() for p in bridge_hidden_legs(sliding, hide_below=0.25)])
    # live, frame by frame: as the offline bridge of the frames received when the stretch is decided
    floor = FloorPlane.from_camera_pose(height=0.5, pitch=np.radians(30.0))
    camera = _to_camera(poses, floor)
    live, _ = _live(LiveBridge(hide_below=0.25), camera, [floor] * len(camera))
    walker = np.array([floor.to_walker(p.points) for p in live])
    assert np.abs(walker[gap, 1, 2:][-6:] - truth[gap, 1, 2:][-6:]).max() < 1e-6


def test_a_landing_near_a_walker_that_stands_or_a_foot_seen_swinging_again_is_left_to_the_curves() -> None:
    """The landing is only modelled where the floor carries the landed foot (the walker rolls) and the foot is seen
    standing after the stretch."""
    hidden = range(14, 28)
    for poses in (_landing_foot(40, hidden, land=18, floor_v=0.2)[0],  # a walker barely rolling
                  _landing_foot(40, hidden, land=30)[0]):  # still swinging when seen again
        want = [p.points.tolist() for p in bridge_hidden_legs(poses, hide_below=0.25)]
        assert [p.points.tolist() for p in bridge_hidden_legs(poses, hide_below=0.25, floor_frame=True)] == want


def test_reported_poses_roll_a_hidden_planted_foot_in_the_walker_frame() -> None:
    """With floors the bridge works in the walker frame, where the floor is z = 0: a hidden foot that stood on it is
    rolled over its toe (the camera here 0.5 m up, pitched 30 deg down); without floors the curves alone."""
    poses, truth = _rolling_foot(32, range(8, 18))
    floor = FloorPlane.from_camera_pose(height=0.5, pitch=np.radians(30.0))
    rot, t = floor.walker_transform()
    camera = [replace(p, points=(p.points - t) @ rot) for p in poses]  # camera frame: rot.T @ (p - t)
    shown = reported_poses(camera, hide_below=0.25, lowpass_hz=0.0, floors=[floor] * len(camera))
    walker = np.array([floor.to_walker(p.points) for p in shown])
    assert np.abs(walker[8:18, 1, 2:] - truth[8:18, 1, 2:]).max() < 1e-3
    plain = reported_poses(camera, hide_below=0.25, lowpass_hz=0.0)
    assert np.abs(np.array([floor.to_walker(p.points) for p in plain])[8:18, 1, 2:] - truth[8:18, 1, 2:]).max() > 0.005


def _to_camera(poses: list[LegPose], floor: FloorPlane) -> list[LegPose]:
    """Poses given in ``floor``'s walker frame, in its camera's frame."""
    rot, t = floor.walker_transform()
    return [replace(p, points=(p.points - t) @ rot) for p in poses]


def _live(bridge: LiveBridge, poses: list[LegPose], floors: list[FloorPlane]) -> tuple[list[LegPose], list[int]]:
    """Every pose pushed through ``bridge`` and the rest flushed: the poses released, in order, and the index of the
    push that released each (``len(poses)``: the flush)."""
    out: list[tuple[LegPose, int]] = []
    when: list[int] = []
    for i, (pose, floor) in enumerate(zip(poses, floors)):
        got = bridge.push(pose, floor, i)
        out += got
        when += [i] * len(got)
    got = bridge.flush()
    out += got
    when += [len(poses)] * len(got)
    assert [item for _, item in out] == list(range(len(poses)))  # every frame once, in order
    return [p for p, _ in out], when


def test_the_live_bridge_holds_a_hidden_foot_until_it_is_seen_again_and_bridges_it_as_offline() -> None:
    """Frames come out as they come while both feet are seen; from a foot's hiding on they are held until it has
    been seen again for ``fit_frames`` + 1 frames, then come out bridged as the offline bridge bridges the frames
    received so far (here: a hidden foot planted on the floor, rolled over its toe, exactly)."""
    poses, truth = _rolling_foot(40, range(8, 18))
    floor = FloorPlane.from_camera_pose(height=0.5, pitch=np.radians(30.0))
    camera = [replace(p, heel_tracked=p.points[:, 3] + 0.01) for p in _to_camera(poses, floor)]
    out, when = _live(LiveBridge(hide_below=0.25), camera, [floor] * len(camera))
    k = BRIDGE_FIT_FRAMES
    assert when[:8] == list(range(8))  # no delay before the hiding
    assert when[8:18 + k + 1] == [18 + k] * (11 + k)  # held until the foot was seen again for k + 1 frames
    assert when[18 + k + 1:] == list(range(18 + k + 1, 40))
    assert all(o is p for i, (o, p) in enumerate(zip(out, camera)) if not 8 <= i < 18)  # the rest untouched
    walker = np.array([floor.to_walker(p.points) for p in out])
    assert np.abs(walker[8:18, 1, 2:] - truth[8:18, 1, 2:]).max() < 1e-3  # as the offline bridge: exact here
    offline = reported_poses(camera[:18 + k + 1], hide_below=0.25, lowpass_hz=0.0, floors=[floor] * (18 + k + 1))
    for o, want in zip(out[8:18], offline[8:18]):
        assert np.allclose(o.points, want.points, atol=1e-12, rtol=0.0)
        assert np.array_equal(o.points[0], want.points[0])  # the other leg's points as they were (to the bit)
    assert all(np.array_equal(o.heel_tracked, p.heel_tracked) for o, p in zip(out, camera))  # what the analysis read
    assert all(o.visibility is p.visibility for o, p in zip(out, camera))


@pytest.mark.parametrize("case", ["long", "start", "never_seen_after", "restart", "no_floor", "stamps_back"])
def test_the_live_bridge_leaves_as_tracked_what_the_offline_bridge_leaves(case: str) -> None:
    hidden = {"long": range(8, 40), "start": range(3, 12), "never_seen_after": range(15, 60), "restart": range(15, 25),
              "no_floor": range(15, 25), "stamps_back": range(15, 25)}[case]
    walker, _ = _walking(60, {0: hidden})  # 30 frames/s: "long" is 1.07 s, over the 1 s default
    floor = FloorPlane.from_camera_pose(height=0.5, pitch=np.radians(30.0))
    poses, floors = _to_camera(walker, floor), [floor] * 60
    if case == "restart":  # a track restart (no pose) just after the gap: its far end is another track
        poses[27] = LegPose.no_user(poses[27].stamp)
    if case == "no_floor":  # a frame without a floor in the stretch's seen end: no walker frame to bridge in
        floors[26] = replace(floor, valid=False)
    if case == "stamps_back":  # the stream starts over (a replay looped): what is held comes out as tracked
        poses[26:] = [replace(p, stamp=p.stamp - 1.0) for p in poses[26:]]
    out, when = _live(LiveBridge(hide_below=0.25), poses, floors)
    assert all(o is p for o, p in zip(out, poses))
    if case == "long":  # released once the gap outgrew the longest bridge, each as soon as it is known
        gone = 7 + next(i for i in range(1, 60) if poses[7 + i].stamp - poses[7].stamp > BRIDGE_MAX_S)
        assert when[8:gone + 1] == [gone] * (gone - 7) and when[gone + 1:] == list(range(gone + 1, 60))
    if case == "never_seen_after":
        assert max(when) < 60  # the flush had nothing left
    if case == "stamps_back":
        assert when[15:26] == [26] * 11


@pytest.mark.parametrize("history_s", [None, BRIDGE_MAX_S])
def test_the_live_bridge_bridges_every_stretch_as_the_offline_bridge_over_the_whole_track(history_s: float | None
                                                                                          ) -> None:
    """Random hidden stretches of both legs (overlapping, too long, cut by a frame without a pose), legs away from
    the floor (the bridge's curves, which read the frames around each stretch only): frame by frame, all released,
    exactly the offline bridge's poses, with the shortest history allowed too."""
    floor = FloorPlane.from_camera_pose(height=0.45, pitch=np.radians(25.0))
    rng = np.random.default_rng(5)
    bridged_any = False
    for _ in range(12):
        hidden: dict[int, range] = {}
        for leg in (0, 1):
            a = int(rng.integers(6, 60))
            hidden[leg] = range(a, a + int(rng.integers(1, 40)))
        walker, _ = _walking(90, hidden)
        poses = _to_camera(walker, floor)
        for i in rng.choice(90, size=2, replace=False):
            if rng.random() < 0.5:
                poses[int(i)] = LegPose.no_user(poses[int(i)].stamp)
        kw = {} if history_s is None else {"history_s": history_s}
        out, _ = _live(LiveBridge(hide_below=0.25, **kw), poses, [floor] * 90)
        want = reported_poses(poses, hide_below=0.25, lowpass_hz=0.0, floors=[floor] * 90)
        for o, w, p in zip(out, want, poses):
            assert (o is p) == (w is p)
            assert np.allclose(o.points, w.points, atol=1e-12, rtol=0.0, equal_nan=True)
        bridged_any |= any(o is not p for o, p in zip(out, poses))
    assert bridged_any


def test_the_live_bridge_keeps_a_bounded_history_and_checks_its_arguments() -> None:
    walker, _ = _walking(400, {0: range(100, 110), 1: range(300, 320)})
    floor = FloorPlane.from_camera_pose(height=0.5, pitch=np.radians(30.0))
    bridge = LiveBridge(hide_below=0.25)
    most = 0
    for i, pose in enumerate(_to_camera(walker, floor)):
        bridge.push(pose, floor, i)
        most = max(most, len(bridge._frames))
    assert most <= 30 * (bridge.history_s + BRIDGE_MAX_S) + 2 * BRIDGE_FIT_FRAMES + 4
    assert bridge.held == 0
    for kwargs, match in (({"max_gap_s": 0.0}, "max_gap_s"), ({"fit_frames": 0}, "fit_frames"),
                          ({"history_s": 0.5}, "history_s")):
        with pytest.raises(ValueError, match=match):
            LiveBridge(hide_below=0.25, **kwargs)


def test_switch_costs_and_identity_flips_are_the_same_computed_in_chunks(monkeypatch: pytest.MonkeyPatch) -> None:
    import walker_gait.core.smoothing as sm

    rng = np.random.default_rng(5)
    pts = rng.normal(0.0, 0.2, (23, 4, 2, 5, 3))
    pts[7, 1] = np.nan
    whole = (sm.switch_costs(pts), identity_flips(pts, [2, 3, 0, 1], margin_m=0.01))
    monkeypatch.setattr(sm, "_CHUNK", 5)
    np.testing.assert_array_equal(sm.switch_costs(pts), whole[0])
    np.testing.assert_array_equal(identity_flips(pts, [2, 3, 0, 1], margin_m=0.01), whole[1])
    flips = whole[1]
    assert np.all(flips[0] == 0.0) and np.all(flips[7][:, 1] == 0.0) and np.all(flips[8][1] == 0.0)  # NaN: no charge
    assert np.any(flips > 0.0)
