"""Tests of walker_gait.core.likelihood (3D cue eq. 4-7, 2D cue eq. 8-9, eq. 10)."""

from __future__ import annotations

import numpy as np
import pytest

from walker_gait.bench.tracker import KINECT, render_frame
from walker_gait.core import leg_model as lm
from walker_gait.core.leg_model import BodyFrame, StateLayout as L
from walker_gait.core.likelihood import (
    PAPER_LAMBDA_2D,
    PAPER_LAMBDA_3D,
    Cue2DParams,
    Cue3DParams,
    CueImage,
    combine_log_likelihoods,
    log_likelihood_2d,
    log_likelihood_3d,
    render_depth,
    skeleton_points,
)
from walker_gait.core.types import FloorPlane

FLOOR = FloorPlane.from_camera_pose(height=0.7, pitch=0.5)
BODY = BodyFrame.from_floor(FLOOR, mounting="facing_user")


def _truth() -> np.ndarray:
    x = lm.neutral_state(right_hip_xy=(-0.85, -0.09), hip_dist=0.18)
    x[L.LEFT.start + L.HIP_FLEX] = 0.3
    x[L.RIGHT.start + L.HIP_FLEX] = -0.2
    x[L.RIGHT.start + L.KNEE_FLEX] = 0.3
    return lm.enforce_constraints(x[None])[0][0]


def _cam(states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    kin = lm.forward_kinematics(states)
    p = states.shape[0]
    return BODY.to_camera(kin.segments).reshape(p, 6, 2, 3), kin.radii.reshape(p, 6, 2)


@pytest.fixture(scope="module")
def frame():  # noqa: ANN201
    return render_frame(_truth(), intrinsics=KINECT, floor=FLOOR, mounting="facing_user", rng=np.random.default_rng(0), noise_m=0.0)


def _perturbed() -> np.ndarray:
    x = np.tile(_truth(), (5, 1))
    x[1, L.ROOT_X] += 0.05
    x[2, L.ROOT_Y] += 0.05
    x[3, L.LEFT.start + L.HIP_FLEX] -= 0.3
    x[4, L.RIGHT.start + L.KNEE_FLEX] += 0.4
    return lm.enforce_constraints(x)[0]


def test_paper_lambdas_in_si() -> None:
    # exp(-λ_mm d_mm) == exp(-λ_m d_m)
    assert PAPER_LAMBDA_3D * 0.010 == pytest.approx(10.0 / 5.0)
    assert PAPER_LAMBDA_2D * 0.003 == pytest.approx(3.0 / 3.0)


def test_skeleton_points_and_widths() -> None:
    seg, rad = _cam(_truth()[None])
    pts, w = skeleton_points(seg, rad, n=10)
    assert pts.shape == (1, 6, 12, 3) and w.shape == (1, 6, 12)
    np.testing.assert_allclose(pts[0, :, 0], seg[0, :, 0])
    np.testing.assert_allclose(pts[0, :, -1], seg[0, :, 1])
    np.testing.assert_allclose(w[0, :, 0], rad[0, :, 0])


def test_3d_cue_prefers_truth(frame) -> None:  # noqa: ANN001
    seg, rad = _cam(_perturbed())
    fg = frame.points[np.random.default_rng(0).choice(len(frame.points), 300, replace=False)]
    cue = CueImage.from_depth(frame.depth, intrinsics=KINECT, stride=4, floor=FLOOR, min_height=0.03)
    ll = log_likelihood_3d(seg, rad, fg=fg, params=Cue3DParams(occlusion_aware=True), cue_image=cue)
    assert np.argmax(ll) == 0
    # surface points of the true model: distances d1 of a few mm
    assert -ll[0] / PAPER_LAMBDA_3D < 0.01


def test_2d_cue_prefers_truth_and_zero_at_identity(frame) -> None:  # noqa: ANN001
    for stride in (1, 8):
        cue = CueImage.from_depth(frame.depth, intrinsics=KINECT, stride=stride, floor=FLOOR, min_height=0.03)
        seg, rad = _cam(_perturbed())
        clip = np.array([False, False, True] * 2)
        ll = log_likelihood_2d(seg, rad, cue=cue, params=Cue2DParams(stride=stride), floor_clip=clip)
        assert np.argmax(ll) == 0
        if stride == 1:
            assert -ll[0] / PAPER_LAMBDA_2D < 1e-3  # same renderer: < 1 mm per pixel (float32, floor-cut edge)


def test_renderer_cylinder_front_depth() -> None:
    # vertical cylinder of radius 5 cm, axis at z = 1 m straight ahead: front surface at 0.95 m
    seg = np.array([[[[0.0, -0.2, 1.0], [0.0, 0.2, 1.0]]]])
    rad = np.array([[[0.05, 0.05]]])
    depth = np.full((KINECT.height, KINECT.width), np.nan, np.float32)
    cue = CueImage.from_depth(depth, intrinsics=KINECT, stride=1, floor=FLOOR)
    img = render_depth(seg, rad, cue=cue, bbox=(0, KINECT.height, 0, KINECT.width)).reshape(KINECT.height, KINECT.width)
    assert img[240, 320] == pytest.approx(0.95, abs=1e-3)
    width_px = np.isfinite(img[240]).sum()
    assert width_px == pytest.approx(2 * 0.05 * KINECT.fx / 1.0, abs=3)


def test_render_z_buffer_equals_min_of_parts(frame) -> None:  # noqa: ANN001
    seg, rad = _cam(_truth()[None])
    cue = CueImage.from_depth(frame.depth, intrinsics=KINECT, stride=4, floor=FLOOR)
    bbox = (0, cue.intrinsics.height, 0, cue.intrinsics.width)
    both = render_depth(seg, rad, cue=cue, bbox=bbox)
    parts = np.minimum(render_depth(seg[:, :3], rad[:, :3], cue=cue, bbox=bbox), render_depth(seg[:, 3:], rad[:, 3:], cue=cue, bbox=bbox))
    np.testing.assert_array_equal(both, parts)


def test_combined_is_sum_of_logs() -> None:
    a, b = np.array([-1.0, -2.0]), np.array([-0.5, -4.0])
    np.testing.assert_allclose(combine_log_likelihoods(a, b), a + b)


def test_occlusion_aware_3d_ignores_hidden_points(frame) -> None:  # noqa: ANN001
    cue = CueImage.from_depth(frame.depth, intrinsics=KINECT, stride=4, floor=FLOOR)
    # a model leg placed 30 cm behind the observed legs is "hidden" by them
    x = _truth()
    x[L.ROOT_X] -= 0.3
    x = lm.enforce_constraints(x[None])[0]
    seg, rad = _cam(x)
    pts, w = skeleton_points(seg, rad, n=6)
    occ = cue.occluded(pts.reshape(1, -1, 3), w.reshape(1, -1), tol=0.04)
    assert occ.mean() > 0.3
