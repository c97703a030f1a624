"""Tests of walker_gait.core.leg_model (geometry, constraints, frames)."""

from __future__ import annotations

import numpy as np

from walker_gait.core import leg_model as lm
from walker_gait.core.leg_model import BodyFrame, StateLayout as L
from walker_gait.core.types import ANKLE, HEEL, HIP, KNEE, TOE, FloorPlane


def _random_states(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = np.tile(lm.neutral_state(), (n, 1))
    x[:, L.ANGLES] += rng.normal(0.0, 0.2, (n, 12))
    x[:, L.SHAPE] *= 1.0 + 0.05 * rng.standard_normal((n, 5))
    x[:, L.HIP_AZ] += rng.normal(0, 0.1, n)
    x, _, _ = lm.enforce_constraints(x, fallback=np.tile(lm.neutral_state(), (n, 1)))
    return x


def test_state_layout_has_23_elements() -> None:
    assert lm.STATE_DIM == 23
    assert len(L.NAMES) == 23
    assert lm.STATE_LOWER.shape == lm.STATE_UPPER.shape == (23,)
    assert L.NAMES[11].startswith("left_hip_flexion") and L.NAMES[22] == "right_ankle_inversion"


def test_segment_lengths_and_foot_points() -> None:
    x = _random_states(50)
    kin = lm.forward_kinematics(x)
    p = kin.points
    np.testing.assert_allclose(np.linalg.norm(p[:, :, KNEE] - p[:, :, HIP], axis=-1), x[:, [L.LEN_THIGH] * 2], atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(p[:, :, ANKLE] - p[:, :, KNEE], axis=-1), x[:, [L.LEN_CALF] * 2], atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(p[:, :, TOE] - p[:, :, HEEL], axis=-1), x[:, [L.LEN_FOOT] * 2], atol=1e-9)
    # the foot segment lies on the heel-toe sole axis, inset by its end radii so that the capsule's
    # rounded ends reach exactly the heel and toe points
    fwd = (p[:, :, TOE] - p[:, :, HEEL]) / x[:, [L.LEN_FOOT] * 2, None]
    r = kin.radii[:, :, 2]
    np.testing.assert_allclose(kin.segments[:, :, 2, 0], p[:, :, HEEL] + fwd * r[..., 0, None] * lm.FOOT_CAP_INSET,
                               atol=1e-12)
    np.testing.assert_allclose(kin.segments[:, :, 2, 1], p[:, :, TOE] - fwd * r[..., 1, None] * lm.FOOT_CAP_INSET,
                               atol=1e-12)
    assert np.all(r[..., 0] + r[..., 1] < x[:, [L.LEN_FOOT] * 2])  # the inset axis keeps a positive length
    # the ankle is above the sole: distance from ankle to heel fixed by the foot length
    d = np.linalg.norm(p[:, :, ANKLE] - p[:, :, HEEL], axis=-1)
    np.testing.assert_allclose(d, np.hypot(lm.ANKLE_HEIGHT, lm.HEEL_BACK) * x[:, [L.LEN_FOOT] * 2], atol=1e-9)


def test_neutral_pose_geometry() -> None:
    x = lm.neutral_state(right_hip_xy=(0.0, -0.09), hip_dist=0.18)
    kin = lm.forward_kinematics(x)
    p = kin.points[0]
    # left hip at +y (anatomical left), feet point forward (+x), flat on the floor
    assert p[0, HIP, 1] > p[1, HIP, 1]
    assert p[0, TOE, 0] > p[0, HEEL, 0]
    np.testing.assert_allclose(p[:, HEEL, 2], 0.0, atol=1e-9)
    np.testing.assert_allclose(p[:, TOE, 2], 0.0, atol=1e-9)
    # heel is the posterior-most sole point: behind the ankle by HEEL_BACK * length
    np.testing.assert_allclose(p[:, ANKLE, 0] - p[:, HEEL, 0], lm.HEEL_BACK * x[L.LEN_FOOT], atol=1e-9)
    assert not lm.constraint_violations(x[None])[0]


def test_angle_signs() -> None:
    base = lm.neutral_state()
    for side in (0, 1):
        o = L.leg(side).start
        x = base.copy()
        x[o + L.HIP_FLEX] = 0.4
        p = lm.forward_kinematics(x).points[0, side]
        assert p[KNEE, 0] > p[HIP, 0]  # flexion: thigh forward
        x = base.copy()
        x[o + L.KNEE_FLEX] = 0.6
        p = lm.forward_kinematics(x).points[0, side]
        assert p[ANKLE, 0] < p[KNEE, 0]  # knee flexion: calf backwards
        x = base.copy()
        x[o + L.ANKLE_FLEX] = 0.3
        p = lm.forward_kinematics(x).points[0, side]
        assert p[TOE, 2] > p[HEEL, 2]  # dorsiflexion lifts the toes
        x = base.copy()
        x[o + L.HIP_ABD] = 0.3
        p = lm.forward_kinematics(x).points[0, side]
        away = 1.0 if side == 0 else -1.0  # left leg abducts towards +y
        assert away * (p[KNEE, 1] - p[HIP, 1]) > 0


def test_floor_contact_and_constraints_after_enforcement() -> None:
    rng = np.random.default_rng(3)
    x = _random_states(200)
    noisy = x + rng.normal(0, 0.1, x.shape)
    y, kin, _ = lm.enforce_constraints(noisy, fallback=x)
    assert not np.any(lm.constraint_violations(y))
    low = lm.sole_heights(kin)
    np.testing.assert_allclose(low.min(axis=1), 0.0, atol=1e-9)  # >= 1 foot on the floor
    assert np.all(low >= -1e-9)  # none below
    np.testing.assert_allclose(kin.points, lm.forward_kinematics(y).points, atol=1e-9)


def test_collision_detected() -> None:
    x = lm.neutral_state(hip_dist=0.12)
    x[L.LEFT.start + L.HIP_ABD] = -0.3  # adduct both legs: they cross
    x[L.RIGHT.start + L.HIP_ABD] = -0.3
    kin = lm.forward_kinematics(x)
    assert lm.collisions(kin)[0]
    assert lm.constraint_violations(lm.apply_floor_contact(x))[0]


def test_segment_distance_known_cases() -> None:
    p1, q1 = np.array([0.0, 0, 0]), np.array([1.0, 0, 0])
    p2, q2 = np.array([0.5, 1, -1]), np.array([0.5, 1, 1])
    assert lm.segment_distances(p1, q1, p2, q2) == np.float64(1.0)
    p2, q2 = np.array([2.0, 0, 0]), np.array([3.0, 0, 0])  # collinear, disjoint
    np.testing.assert_allclose(lm.segment_distances(p1, q1, p2, q2), 1.0)


def test_body_frame_left_right_mapping() -> None:
    floor = FloorPlane.from_camera_pose(height=0.7, pitch=0.5)
    x = lm.neutral_state(right_hip_xy=(-0.9, -0.09))
    pts = lm.forward_kinematics(x).points[0]
    cam_user = BodyFrame.from_floor(floor, mounting="facing_user").to_camera(pts)
    # facing the user: anatomical left leg appears on the image's right (+x camera), in front of the camera
    assert np.all(cam_user[0, :, 0] > cam_user[1, :, 0])
    assert np.all(cam_user[..., 2] > 0.3)
    x_fwd = lm.neutral_state(right_hip_xy=(0.9, -0.09))
    pts_f = lm.forward_kinematics(x_fwd).points[0]
    cam_fwd = BodyFrame.from_floor(floor, mounting="facing_forward").to_camera(pts_f)
    assert np.all(cam_fwd[0, :, 0] < cam_fwd[1, :, 0])
    assert np.all(cam_fwd[..., 2] > 0.3)
    # round trip and floor height = body z
    bf = BodyFrame.from_floor(floor, mounting="facing_user")
    np.testing.assert_allclose(bf.to_body(cam_user), pts, atol=1e-9)
    np.testing.assert_allclose(floor.height(cam_user), pts[..., 2], atol=1e-9)


def test_joint_angles_order() -> None:
    x = lm.neutral_state()
    x[L.ANGLES] = np.arange(12) * 0.01
    np.testing.assert_allclose(lm.joint_angles(x), np.arange(12) * 0.01)
