"""Tests of walker_gait.core.likelihood (3D cue eq. 4-7, 2D cue eq. 8-9, eq. 10)."""

from __future__ import annotations

import numpy as np
import pytest

from walker_gait.bench.tracker import KINECT, render_frame
from walker_gait.core import kernels
from walker_gait.core import leg_model as lm
from walker_gait.core.leg_model import BodyFrame, StateLayout as L
from walker_gait.core.likelihood import (
    PAPER_LAMBDA_2D,
    PAPER_LAMBDA_3D,
    Cue2DParams,
    Cue3DParams,
    CueImage,
    Workspace,
    _pairwise_distances,
    _surface_costs,
    combine_log_likelihoods,
    depth_costs,
    elliptic_section_radii,
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
    return render_frame(_truth(), intrinsics=KINECT, floor=FLOOR, mounting="facing_user", rng=np.random.default_rng(0), noise_m=0.0,
                        elliptic_foot=False)  # the circular sections that `_cam` gives the cues (the default)


def _perturbed() -> np.ndarray:
    x = np.tile(_truth(), (5, 1))
    x[1, L.ROOT_X] += 0.05
    x[2, L.ROOT_Y] += 0.05
    x[3, L.LEFT.start + L.HIP_FLEX] -= 0.3
    x[4, L.RIGHT.start + L.KNEE_FLEX] += 0.4
    return lm.enforce_constraints(x)[0]


@pytest.fixture(params=["numpy", "compiled"])
def backend(request, monkeypatch) -> str:  # noqa: ANN001
    """Run a test with the likelihood's numpy code and with its compiled (numba) kernels.

    numba is a pinned dependency (requirements.txt), so the compiled case imports it directly: it fails, not
    skips, where numba is missing."""
    if request.param == "numpy":
        monkeypatch.setattr(kernels, "compiled", lambda: None)
    else:
        from walker_gait.core import _jit

        monkeypatch.setattr(kernels, "compiled", lambda: _jit)
    return str(request.param)


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


def test_renderer_depth_radii_set_how_far_the_surface_stands_out() -> None:
    # the same vertical capsule, 5 cm wide in the image but standing out only 2 cm towards the camera
    seg = np.array([[[[0.0, -0.2, 1.0], [0.0, 0.2, 1.0]]]])
    rad = np.array([[[0.05, 0.05]]])
    cue = CueImage.from_depth(np.full((KINECT.height, KINECT.width), np.nan, np.float32), intrinsics=KINECT,
                              stride=1, floor=FLOOR)
    bbox = (0, KINECT.height, 0, KINECT.width)
    img = render_depth(seg, rad, cue=cue, bbox=bbox, depth_radii=np.array([[[0.02, 0.02]]])).reshape(KINECT.height, KINECT.width)
    assert img[240, 320] == pytest.approx(0.98, abs=1e-3)
    assert np.isfinite(img[240]).sum() == pytest.approx(2 * 0.05 * KINECT.fx / 1.0, abs=3)  # silhouette unchanged
    # tapered along the axis: 1 cm at the top end, 3 cm at the bottom end
    img = render_depth(seg, rad, cue=cue, bbox=bbox, depth_radii=np.array([[[0.01, 0.03]]])).reshape(KINECT.height, KINECT.width)
    assert img[240, 320] == pytest.approx(0.98, abs=1e-3)
    top, bottom = (int(round(KINECT.fy * y / 1.0 + KINECT.cy)) for y in (-0.15, 0.15))
    assert img[top, 320] == pytest.approx(1.0 - 0.0125, abs=1e-3)
    assert img[bottom, 320] == pytest.approx(1.0 - 0.0275, abs=1e-3)
    # depth radii equal to the radii: exactly the circular renderer
    np.testing.assert_array_equal(render_depth(seg, rad, cue=cue, bbox=bbox, depth_radii=rad.copy()),
                                  render_depth(seg, rad, cue=cue, bbox=bbox))


def test_elliptic_section_radii() -> None:
    # horizontal segment across the image at 1 m; section 2 cm (half-width) x 5 cm (height)
    seg = np.array([[[[-0.1, 0.0, 1.0], [0.1, 0.0, 1.0]]]])
    heights, widths = np.full((1, 1, 2), 0.05), np.full((1, 1, 2), 0.02)
    # half-width axis along the line of sight: the image shows the height, the width faces the camera
    sil, toward = elliptic_section_radii(seg, np.array([[[0.0, 0.0, 1.0]]]), heights, widths)
    np.testing.assert_allclose(sil, 0.05, atol=1e-3)
    np.testing.assert_allclose(toward, 0.02, atol=1e-3)
    # half-width axis across the image (vertical): the other way round
    sil, toward = elliptic_section_radii(seg, np.array([[[0.0, 1.0, 0.0]]]), heights, widths)
    np.testing.assert_allclose(sil, 0.02, atol=1e-3)
    np.testing.assert_allclose(toward, 0.05, atol=1e-3)
    # at 45 degrees: the ellipse's support in each direction, sqrt((a^2 + b^2) / 2)
    c = np.sqrt(0.5)
    sil, toward = elliptic_section_radii(seg, np.array([[[0.0, c, c]]]), heights, widths)
    np.testing.assert_allclose(sil, np.hypot(0.02, 0.05) * c, atol=1e-3)
    np.testing.assert_allclose(toward, np.hypot(0.02, 0.05) * c, atol=1e-3)
    # a circular section has its radius everywhere, whatever the segment's direction
    rng = np.random.default_rng(3)
    seg = rng.normal(0.0, 0.2, (4, 3, 2, 3)) + np.array([0.0, 0.0, 1.5])
    axis = seg[:, :, 1] - seg[:, :, 0]
    lateral = np.cross(axis, rng.normal(size=(4, 3, 3)))
    lateral /= np.linalg.norm(lateral, axis=-1, keepdims=True)
    r = rng.uniform(0.02, 0.08, (4, 3, 2))
    sil, toward = elliptic_section_radii(seg, lateral, r, r)
    np.testing.assert_allclose(sil, r, rtol=1e-9)
    np.testing.assert_allclose(toward, r, rtol=1e-9)


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


# -- optimised kernels vs straightforward references (results must be bit-identical) -----------
def _render_reference(seg: np.ndarray, rad: np.ndarray, cue: CueImage, bbox: tuple[int, int, int, int], clip: np.ndarray) -> np.ndarray:
    """The renderer's arithmetic with plain boolean masks, one segment at a time over its bbox (union over
    particles of the projected segment grown by its radius)."""
    intr = cue.intrinsics
    v0, v1, u0, u1 = bbox
    p, s = seg.shape[:2]
    out = np.full((p, v1 - v0, u1 - u0), np.inf, dtype=np.float32)
    fx, fy = float(intr.fx), float(intr.fy)
    za, zb = np.maximum(seg[:, :, 0, 2], 0.05), np.maximum(seg[:, :, 1, 2], 0.05)
    ax, ay = fx * seg[:, :, 0, 0] / za + intr.cx, fy * seg[:, :, 0, 1] / za + intr.cy
    bx, by = fx * seg[:, :, 1, 0] / zb + intr.cx, fy * seg[:, :, 1, 1] / zb + intr.cy
    rmax_px = fx * np.maximum(rad[:, :, 0] / za, rad[:, :, 1] / zb)
    for j in range(s):
        su0 = max(int(np.floor(np.min(np.minimum(ax[:, j], bx[:, j]) - rmax_px[:, j]))) - 1, u0)
        su1 = min(int(np.ceil(np.max(np.maximum(ax[:, j], bx[:, j]) + rmax_px[:, j]))) + 2, u1)
        sv0 = max(int(np.floor(np.min(np.minimum(ay[:, j], by[:, j]) - rmax_px[:, j]))) - 1, v0)
        sv1 = min(int(np.ceil(np.max(np.maximum(ay[:, j], by[:, j]) + rmax_px[:, j]))) + 2, v1)
        if su1 <= su0 or sv1 <= sv0:
            continue
        uu, vv = np.arange(su0, su1, dtype=np.float64), np.arange(sv0, sv1, dtype=np.float64)
        dx, dy = bx[:, j] - ax[:, j], by[:, j] - ay[:, j]
        len2 = np.maximum(dx * dx + dy * dy, 1e-6)
        ln = np.sqrt(len2)
        tu = ((uu[None, :] - ax[:, j, None]) * (dx / len2)[:, None]).astype(np.float32)
        tv = ((vv[None, :] - ay[:, j, None]) * (dy / len2)[:, None]).astype(np.float32)
        pu = ((uu[None, :] - ax[:, j, None]) * (-dy / ln)[:, None]).astype(np.float32)
        pv = ((vv[None, :] - ay[:, j, None]) * (dx / ln)[:, None]).astype(np.float32)
        t_raw = tv[:, :, None] + tu[:, None, :]
        t = np.clip(t_raw, 0.0, 1.0)
        excess = (t_raw - t) * ln.astype(np.float32)[:, None, None]
        dperp = pv[:, :, None] + pu[:, None, :]
        d2 = dperp * dperp + excess * excess
        r = t * (rad[:, j, 1] - rad[:, j, 0]).astype(np.float32)[:, None, None] + rad[:, j, 0].astype(np.float32)[:, None, None]
        z = t * (zb[:, j] - za[:, j]).astype(np.float32)[:, None, None] + za[:, j].astype(np.float32)[:, None, None]
        rho = r * np.float32(fx) / z
        q = 1.0 - d2 / (rho * rho)
        inside = q > 0
        z = z - np.sqrt(np.maximum(q, 0.0)) * r
        if clip[j]:
            h = z * cue.ray_up[sv0:sv1, su0:su1][None] + np.float32(cue.floor_offset)
            inside &= h >= np.float32(max(cue.min_height, 0.0) - 0.005)
        view = out[:, sv0 - v0 : sv1 - v0, su0 - u0 : su1 - u0]
        view[...] = np.minimum(view, np.where(inside, z, np.float32(np.inf)))
    return out.reshape(p, -1)


def _degenerate_particles() -> tuple[np.ndarray, np.ndarray]:
    seg, rad = _cam(_perturbed())
    seg, rad = seg.copy(), rad.copy()
    rad[1, 0] = 0.0  # zero radius: rho = 0, nothing rendered
    seg[2, 1, 1] = seg[2, 1, 0]  # zero-length segment (a sphere)
    seg[3, 4, :, 2] = [0.01, 0.02]  # in front of the near clip (depth clamped)
    return seg, rad


def test_render_depth_matches_reference(frame, backend) -> None:  # noqa: ANN001
    seg, rad = _degenerate_particles()
    clip = np.array([False, False, True] * 2)
    for stride in (4, 10):
        cue = CueImage.from_depth(frame.depth, intrinsics=KINECT, stride=stride, floor=FLOOR, min_height=0.03)
        bbox = (0, cue.intrinsics.height, 0, cue.intrinsics.width)
        with np.errstate(invalid="ignore", divide="ignore"):
            ref = _render_reference(seg, rad, cue, bbox, clip)
        with np.errstate(divide="ignore"):  # the zero-radius segment
            got = render_depth(seg, rad, cue=cue, bbox=bbox, floor_clip=clip)
        assert not np.isnan(got).any()
        assert np.isinf(got[1]).sum() > np.isinf(got[0]).sum()  # the zero-radius thigh is not drawn
        np.testing.assert_array_equal(got, ref)
        # same result rendered into a caller's (dirty) buffer with a workspace, twice
        work = Workspace()
        buf = np.full(ref.shape, -1.0, np.float32)
        with np.errstate(divide="ignore"):
            for _ in range(2):
                np.testing.assert_array_equal(render_depth(seg, rad, cue=cue, bbox=bbox, floor_clip=clip, work=work, out=buf), ref)
            # a bbox cropping the model
            crop = (bbox[0] + 5, bbox[1] - 3, bbox[2] + 7, bbox[3] - 2)
            cropped = render_depth(seg, rad, cue=cue, bbox=crop, floor_clip=clip, work=work)
        full = ref.reshape(len(seg), bbox[1], bbox[3])
        np.testing.assert_array_equal(cropped.reshape(len(seg), crop[1] - crop[0], -1), full[:, crop[0] : crop[1], crop[2] : crop[3]])


def test_depth_costs_match_reference(frame) -> None:  # noqa: ANN001
    cue = CueImage.from_depth(frame.depth, intrinsics=KINECT, stride=8, floor=FLOOR, min_height=0.03)
    seg, rad = _cam(_perturbed())
    bbox = (0, cue.intrinsics.height, 0, cue.intrinsics.width)
    model = render_depth(seg, rad, cue=cue, bbox=bbox)
    obs = cue.depth.ravel()
    assert (np.isinf(model).any(axis=1)).all() and (obs > 0).any()
    for params in (Cue2DParams(), Cue2DParams(occlusion_aware=True, truncate=0.5), Cue2DParams(truncate=0.01)):
        empty = ~np.isfinite(model)
        m = np.where(empty, np.float32(0.0), model)
        ref = np.abs(m - obs[None, :])
        if params.occlusion_aware:
            ref[(obs[None, :] > 0) & ~empty & (obs[None, :] < m - np.float32(params.occlusion_tol))] = np.float32(params.occluded_cost)
        if np.isfinite(params.truncate):
            ref = np.minimum(ref, np.float32(params.truncate))
        kept = model.copy()
        np.testing.assert_array_equal(depth_costs(model, obs, params=params), ref)
        np.testing.assert_array_equal(model, kept)  # not overwritten by default
        work = Workspace()
        got = depth_costs(model.copy(), obs, params=params, overwrite=True, work=work)
        np.testing.assert_array_equal(got, ref)
        assert got.dtype == np.float32
        # other dtypes / layouts take the plain (allocating) path: same costs
        np.testing.assert_allclose(depth_costs(model.astype(np.float64), obs, params=params), ref, atol=1e-6)
        np.testing.assert_array_equal(depth_costs(np.asfortranarray(model), obs, params=params), ref)


def test_pairwise_distances_match_reference(frame) -> None:  # noqa: ANN001
    seg, rad = _cam(_perturbed())
    pts, _ = skeleton_points(seg, rad, n=6)
    model = pts.reshape(5, -1, 3).astype(np.float32)
    fg = frame.points[:200].astype(np.float32)
    fg = np.concatenate([fg, model[0, :3]])  # foreground points on model points: distance 0 (rounding can give sq < 0)
    fg_sq = np.einsum("ij,ij->i", fg, fg)
    flat = model.reshape(-1, 3)
    sq = flat @ (-2.0 * fg.T) + np.einsum("ij,ij->i", flat, flat)[:, None] + fg_sq[None, :]
    ref = np.sqrt(np.maximum(sq, 0.0)).reshape(5, -1, fg.shape[0])
    np.testing.assert_array_equal(_pairwise_distances(model, fg, fg_sq), ref)
    np.testing.assert_array_equal(_pairwise_distances(model, fg, fg_sq, work=Workspace()), ref)


def test_skeleton_points_and_3d_cue_match_reference(frame, backend) -> None:  # noqa: ANN001
    seg, rad = _cam(_perturbed())
    pts, w = skeleton_points(seg, rad, n=6)
    t = np.linspace(0.0, 1.0, 8)
    ref_pts = seg[:, :, 0, None, :] + (seg[:, :, 1, None, :] - seg[:, :, 0, None, :]) * t[None, None, :, None]
    np.testing.assert_array_equal(pts, ref_pts)
    assert pts.flags.c_contiguous
    fg = frame.points[np.random.default_rng(2).choice(len(frame.points), 100, replace=False)]
    # eq. 4-7 in float64 with the distances taken directly
    pts32, fg32 = pts.reshape(5, -1, 3).astype(np.float32), fg.astype(np.float32)
    d = np.linalg.norm(pts32[:, :, None, :].astype(np.float64) - fg32[None, None].astype(np.float64), axis=-1)
    w64 = w.reshape(5, -1).astype(np.float32).astype(np.float64)
    d_mf = np.abs(d.min(axis=2) - w64).mean(axis=1)
    d_fm = np.abs(d - w64[:, :, None]).min(axis=1).mean(axis=1)
    ref = -PAPER_LAMBDA_3D * 0.5 * (d_fm + d_mf)
    got = log_likelihood_3d(seg, rad, fg=fg, params=Cue3DParams(n_skeleton=6))
    # float32 distances: within 1e-4 log units of the float64 ones (costs of several log units)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-4)
    assert np.all(np.diff(np.argsort(got)) != 0) and np.array_equal(np.argsort(got), np.argsort(ref))


def test_surface_costs_of_both_backends_agree_with_direct_distances(frame) -> None:  # noqa: ANN001
    from walker_gait.core import _jit

    rng = np.random.default_rng(5)
    seg, rad = _cam(_perturbed())
    pts, w = skeleton_points(seg, rad, n=6)
    model = pts.reshape(5, -1, 3).astype(np.float32)
    widths = w.reshape(5, -1).astype(np.float32)
    fg = frame.points[rng.choice(len(frame.points), 300, replace=False)].astype(np.float32)
    fg = np.concatenate([fg, model[0, :3], model[3, -2:]])  # foreground points on model points: distance 0
    d = np.linalg.norm(model[:, :, None, :].astype(np.float64) - fg[None, None].astype(np.float64), axis=-1)
    ref_row, ref_fm = d.min(axis=2), np.abs(d - widths[:, :, None]).min(axis=1)
    assert (ref_row == 0).sum() >= 5
    results = {}
    for name, jit in (("numpy", None), ("compiled", _jit)):
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(kernels, "compiled", lambda jit=jit: jit)
            for work in (None, Workspace()):
                row, fm = _surface_costs(model, widths, fg, work=work)
                assert row.dtype == fm.dtype == np.float32 and row.shape == (5, model.shape[1]) and fm.shape == (5, len(fg))
                results[name] = (row.copy(), fm.copy())
    # direct float32 distances are within rounding of float64 ones; numpy's |a|^2 - 2ab + |b|^2 within 1e-4 m
    for name, tol in (("compiled", 2e-6), ("numpy", 1e-4)):
        row, fm = results[name]
        np.testing.assert_allclose(row, ref_row, rtol=0, atol=tol)
        np.testing.assert_allclose(fm, ref_fm, rtol=0, atol=tol)
    # the compiled kernel's nearest distances are the float64 reference's within two float32 roundings (a
    # foreground point on a model point at distance 0 exactly)
    np.testing.assert_allclose(results["compiled"][0], ref_row, rtol=2.5e-7, atol=0)


def test_compiled_kernels_can_be_turned_off(monkeypatch) -> None:  # noqa: ANN001
    kernels.compiled.cache_clear()
    try:
        monkeypatch.setenv(kernels.ENV, "0")
        assert kernels.compiled() is None
        kernels.compiled.cache_clear()
        monkeypatch.setenv(kernels.ENV, "1")
        assert kernels.compiled() is not None  # numba is a pinned dependency
    finally:
        monkeypatch.delenv(kernels.ENV)
        kernels.compiled.cache_clear()


def test_likelihoods_with_workspace_are_identical(frame) -> None:  # noqa: ANN001
    cue = CueImage.from_depth(frame.depth, intrinsics=KINECT, stride=8, floor=FLOOR, min_height=0.03)
    seg, rad = _cam(_perturbed())
    fg = frame.points[np.random.default_rng(1).choice(len(frame.points), 150, replace=False)]
    p3 = Cue3DParams(occlusion_aware=True, truncate=0.15, n_skeleton=6)
    p2 = Cue2DParams(stride=8, occlusion_aware=True, truncate=0.5)
    clip = np.array([False, False, True] * 2)
    ref3 = log_likelihood_3d(seg, rad, fg=fg, params=p3, cue_image=cue, active=np.array([True, False, True] * 2))
    ref2 = log_likelihood_2d(seg, rad, cue=cue, params=p2, floor_clip=clip)
    work = Workspace()
    # shared workspace, alternating sizes (fewer segments/points/particles in between): no stale state
    for _ in range(2):
        np.testing.assert_array_equal(
            log_likelihood_3d(seg, rad, fg=fg, params=p3, cue_image=cue, active=np.array([True, False, True] * 2), work=work), ref3
        )
        np.testing.assert_array_equal(log_likelihood_2d(seg, rad, cue=cue, params=p2, floor_clip=clip, work=work), ref2)
        log_likelihood_3d(seg[:2, :3], rad[:2, :3], fg=fg[:40], params=p3, cue_image=cue, work=work)
        log_likelihood_2d(seg[:2, :3], rad[:2, :3], cue=cue, params=p2, floor_clip=clip[:3], work=work)
    # chunked particles (shared scratch across chunks)
    np.testing.assert_array_equal(log_likelihood_2d(seg, rad, cue=cue, params=p2, floor_clip=clip, work=work, chunk=2), ref2)


def test_workspace_reuses_and_grows_buffers() -> None:
    work = Workspace()
    a = work.buffer("x", (4, 5))
    assert a.shape == (4, 5) and a.dtype == np.float32 and a.flags.c_contiguous
    b = work.buffer("x", (2, 3))
    assert np.shares_memory(a, b)  # same memory handed out again
    c = work.buffer("x", (10, 10))  # larger: a new buffer
    assert c.shape == (10, 10) and not np.shares_memory(a, c)
    d = work.buffer("x", (3,), np.bool_)  # another dtype is another buffer
    assert d.dtype == np.bool_ and not np.shares_memory(c, d)
    assert not np.shares_memory(work.buffer("y", (4, 5)), work.buffer("x", (4, 5)))


# -- pixels without a depth measurement ---------------------------------------------------------
def _holed(frame):  # noqa: ANN001, ANN202
    """The frame with the left calf and foot's pixels unmeasured (a leg nearer than the sensor's near limit)."""
    seg, rad = _cam(_truth()[None])
    full = (0, KINECT.height, 0, KINECT.width)
    cue = CueImage.from_depth(frame.depth, intrinsics=KINECT, stride=1, floor=FLOOR)
    lower_left = render_depth(seg[:, 1:3], rad[:, 1:3], cue=cue, bbox=full)[0].reshape(KINECT.height, KINECT.width)
    hole = np.isfinite(lower_left) & np.isfinite(frame.depth)
    depth = np.where(hole, np.float32(np.nan), frame.depth).astype(np.float32)
    return depth, hole


def test_a_leg_over_pixels_without_depth_costs_nothing_in_the_2d_cue(frame) -> None:  # noqa: ANN001
    depth, hole = _holed(frame)
    assert hole.sum() > 500
    clip = np.array([False, False, True] * 2)
    seg, rad = _cam(_truth()[None])
    as_background = CueImage.from_depth(depth, intrinsics=KINECT, stride=1, floor=FLOOR, min_height=0.03)
    as_unknown = CueImage.from_depth(depth, intrinsics=KINECT, stride=1, floor=FLOOR, min_height=0.03, unknown=hole)
    assert as_background.unknown is None and as_unknown.unknown is not None
    params = Cue2DParams(truncate=0.5)
    ll_bg = log_likelihood_2d(seg, rad, cue=as_background, params=params, floor_clip=clip)[0]
    ll_unk = log_likelihood_2d(seg, rad, cue=as_unknown, params=params, floor_clip=clip)[0]
    # the true legs explain every measured pixel; over the hole, the paper's convention charges them as if over
    # background, the unknown pixels charge nothing
    assert -ll_unk / params.lam < 1e-3
    assert -ll_bg / params.lam > 20 * (-ll_unk / params.lam) + 1e-3
    # the model leg pulled out of the hole is no better than the true one any more
    x = np.tile(_truth(), (2, 1))
    x[1, L.LEFT.start + L.KNEE_FLEX] += 0.5
    seg2, rad2 = _cam(lm.enforce_constraints(x)[0])
    ll = log_likelihood_2d(seg2, rad2, cue=as_unknown, params=params, floor_clip=clip)
    assert ll[0] > ll[1]


def test_2d_cue_leaves_exactly_the_pixels_without_depth_out_of_its_sum(frame) -> None:  # noqa: ANN001
    depth, hole = _holed(frame)
    cue = CueImage.from_depth(depth, intrinsics=KINECT, stride=8, floor=FLOOR, min_height=0.03, unknown=hole)
    assert cue.unknown is not None and cue.unknown.any()
    seg, rad = _cam(_perturbed())
    bbox = (0, cue.intrinsics.height, 0, cue.intrinsics.width)
    params = Cue2DParams(occlusion_aware=True, truncate=0.5)
    costs = depth_costs(render_depth(seg, rad, cue=cue, bbox=bbox), cue.depth.ravel(), params=params)
    measured = ~cue.unknown.ravel()
    ref = -params.lam * costs[:, measured].sum(axis=1, dtype=np.float64) / cue.depth.size
    np.testing.assert_allclose(log_likelihood_2d(seg, rad, cue=cue, params=params, bbox=bbox), ref, rtol=1e-6)
    assert not np.allclose(ref, -params.lam * costs.sum(axis=1, dtype=np.float64) / cue.depth.size, rtol=1e-3)


def test_skeleton_points_over_pixels_without_depth_count_as_occluded(frame) -> None:  # noqa: ANN001
    depth, hole = _holed(frame)
    seg, rad = _cam(_truth()[None])
    pts, w = skeleton_points(seg, rad, n=6)
    as_background = CueImage.from_depth(depth, intrinsics=KINECT, stride=4, floor=FLOOR)
    as_unknown = CueImage.from_depth(depth, intrinsics=KINECT, stride=4, floor=FLOOR, unknown=hole)
    lower_left = pts[0, 1:3].reshape(-1, 3)
    over = as_unknown.sample(lower_left)[2]
    assert over.mean() > 0.5
    assert not as_background.occluded(lower_left, w[0, 1:3].ravel(), tol=0.04)[over].any()
    assert as_unknown.occluded(lower_left, w[0, 1:3].ravel(), tol=0.04)[over].all()
    # the right leg, measured, is not affected
    assert not as_unknown.sample(pts[0, 3:].reshape(-1, 3))[2].any()
    # a pixel whose foreground depth was measured is never unknown, whatever the mask says
    everywhere = CueImage.from_depth(frame.depth, intrinsics=KINECT, stride=4, floor=FLOOR,
                                     unknown=np.ones_like(hole))
    assert everywhere.unknown is not None and not (everywhere.unknown & (everywhere.depth > 0)).any()
    with pytest.raises(ValueError, match="unknown shape"):
        CueImage.from_depth(frame.depth, intrinsics=KINECT, stride=4, floor=FLOOR, unknown=hole[:-1])


def test_cross_is_numpys() -> None:
    from walker_gait.core.likelihood import _cross

    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(7, 6, 3)), rng.normal(size=(7, 6, 3))
    np.testing.assert_array_equal(_cross(a, b), np.cross(a, b))
    np.testing.assert_array_equal(_cross(a, b[0]), np.cross(a, b[0]))  # broadcast


def test_2d_cue_of_both_backends_agree(frame) -> None:  # noqa: ANN001
    from walker_gait.core import _jit

    seg, rad = _cam(_perturbed())
    depth = frame.depth.copy()
    unknown = np.zeros(depth.shape, bool)
    unknown[200:260, 250:400] = True  # a hole over part of the legs
    depth[unknown] = np.nan
    cue = CueImage.from_depth(depth, intrinsics=KINECT, stride=4, floor=FLOOR, min_height=0.03, unknown=unknown)
    assert cue.unknown is not None
    ref_render = render_depth(seg[:1, 3:], rad[:1, 3:], cue=cue,
                              bbox=(0, cue.intrinsics.height, 0, cue.intrinsics.width))[0]
    for params in (Cue2DParams(), Cue2DParams(occlusion_aware=True, truncate=0.3)):
        for ref in (None, ref_render):
            got = {}
            for name, jit in (("numpy", None), ("compiled", _jit)):
                with pytest.MonkeyPatch.context() as mp:
                    mp.setattr(kernels, "compiled", lambda jit=jit: jit)
                    got[name] = log_likelihood_2d(seg[:, :3], rad[:, :3], cue=cue, params=params,
                                                  bbox=(0, cue.intrinsics.height, 0, cue.intrinsics.width),
                                                  ref_render=ref, floor_clip=np.array([False, False, True]),
                                                  chunk=2, work=Workspace())
            assert np.all(np.isfinite(got["numpy"])) and np.ptp(got["numpy"]) > 0
            # the same float32 costs, summed in float64 in another order
            np.testing.assert_allclose(got["compiled"], got["numpy"], rtol=1e-12, atol=0)


def test_3d_cue_of_both_backends_agree(frame) -> None:  # noqa: ANN001
    from walker_gait.core import _jit

    rng = np.random.default_rng(4)
    x = np.tile(_truth(), (40, 1))
    x[:, L.ROOT_X] += rng.normal(0.0, 0.1, 40)
    x[:, L.ANGLES] += rng.normal(0.0, 0.2, (40, 12))
    seg, rad = _cam(lm.enforce_constraints(x)[0])
    seg[0, 0] = [[0.1, 0.2, 0.02], [0.1, 0.3, 0.04]]  # in front of the camera's near limit: out of the image
    depth = frame.depth.copy()
    unknown = np.zeros(depth.shape, bool)
    unknown[200:260, 250:400] = True  # a hole over part of the legs
    depth[unknown] = np.nan
    fg = frame.points[rng.choice(len(frame.points), 128, replace=False)]
    cues = (None, CueImage.from_depth(frame.depth, intrinsics=KINECT, stride=10, floor=FLOOR),
            CueImage.from_depth(depth, intrinsics=KINECT, stride=10, floor=FLOOR, min_height=0.03, unknown=unknown))
    ref_costs = rng.uniform(0.0, 0.05, 128).astype(np.float32)
    tried = 0
    for cue in cues:
        for params in (Cue3DParams(n_skeleton=6), Cue3DParams(n_skeleton=4, occlusion_aware=True, truncate=0.15)):
            for ref, active in ((None, None), (ref_costs, np.array([True, True, False, True, False, True]))):
                got = {}
                for name, jit in (("numpy", None), ("compiled", _jit)):
                    with pytest.MonkeyPatch.context() as mp:
                        mp.setattr(kernels, "compiled", lambda jit=jit: jit)
                        got[name] = log_likelihood_3d(seg, rad, fg=fg, params=params, ref_fg_costs=ref,
                                                      active=active, cue_image=cue, work=Workspace())
                assert np.all(np.isfinite(got["numpy"])) and np.ptp(got["numpy"]) > 0
                # the same terms; the distances in float32 by another formula (see the surface costs' test): within
                # 1e-4 log units, where one skeleton point counted differently moves a particle by ~0.01-0.1
                np.testing.assert_allclose(got["compiled"], got["numpy"], rtol=0, atol=1e-4)
                tried += 1
    assert tried == 12


def test_workspace_chunks_cover_every_particle_once() -> None:
    from walker_gait.core.likelihood import MIN_THREAD_PARTICLES

    for threads in (1, 2, 3, 8):
        work = Workspace(threads=threads)
        for n in (0, 1, MIN_THREAD_PARTICLES - 1, 2 * MIN_THREAD_PARTICLES - 1, 2 * MIN_THREAD_PARTICLES, 50, 192):
            parts = work.chunks(n)
            assert parts[0][0] == 0 and parts[-1][1] == n
            assert all(a[1] == b[0] for a, b in zip(parts, parts[1:]))  # consecutive, no gap or overlap
            assert len(parts) <= threads
            assert len(parts) == 1 or all(b - a >= MIN_THREAD_PARTICLES for a, b in parts)
    assert len(Workspace(threads=2).chunks(2 * MIN_THREAD_PARTICLES)) == 2
    for bad in (0, -1, 1.5, True):
        with pytest.raises(ValueError, match="threads"):
            Workspace(threads=bad)  # type: ignore[arg-type]


def test_workspace_spread_runs_every_slice_and_raises_a_threads_error() -> None:
    import threading

    work = Workspace(threads=3)
    seen: list[tuple[int, int, int, bool]] = []
    lock = threading.Lock()

    def record(i: int, a: int, b: int) -> None:
        with lock:
            seen.append((i, a, b, threading.current_thread() is threading.main_thread()))

    work.spread(record, 60)
    assert sorted(x[:3] for x in seen) == [(0, 0, 20), (1, 20, 40), (2, 40, 60)]
    assert [x[3] for x in sorted(seen)] == [True, False, False]  # the first slice on the calling thread
    done: list[int] = []

    def fail_second(i: int, a: int, b: int) -> None:
        if i == 1:
            raise RuntimeError("slice 1 failed")
        done.append(i)

    with pytest.raises(RuntimeError, match="slice 1 failed"):
        work.spread(fail_second, 60)
    assert sorted(done) == [0, 2]  # the others ran to the end


def test_cues_spread_over_threads_are_the_same_bit_for_bit(frame) -> None:  # noqa: ANN001
    """``Workspace(threads=...)``: the compiled kernels over slices of the particles give each particle the same
    terms, so both cues' log likelihoods are identical, not merely close."""
    from walker_gait.core import _jit  # a pinned dependency: fails, not skips, where numba is missing

    assert kernels.compiled() is _jit
    rng = np.random.default_rng(5)
    x = np.tile(_truth(), (50, 1))
    x[:, L.ROOT_X] += rng.normal(0.0, 0.1, 50)
    x[:, L.ANGLES] += rng.normal(0.0, 0.2, (50, 12))
    seg, rad = _cam(lm.enforce_constraints(x)[0])
    fg = frame.points[rng.choice(len(frame.points), 128, replace=False)]
    cue = CueImage.from_depth(frame.depth, intrinsics=KINECT, stride=4, floor=FLOOR, min_height=0.03)
    got = {}
    for threads in (1, 3):
        work = Workspace(threads=threads)
        got[threads] = (
            log_likelihood_3d(seg, rad, fg=fg, params=Cue3DParams(n_skeleton=6, occlusion_aware=True),
                              cue_image=cue, work=work),
            log_likelihood_2d(seg[:, :3], rad[:, :3], cue=cue, params=Cue2DParams(occlusion_aware=True),
                              floor_clip=np.array([False, False, True]), work=work),
        )
    assert np.ptp(got[1][0]) > 0 and np.ptp(got[1][1]) > 0
    np.testing.assert_array_equal(got[3][0], got[1][0])
    np.testing.assert_array_equal(got[3][1], got[1][1])


def test_a_broken_numba_install_falls_back_to_numpy_with_a_warning(monkeypatch) -> None:  # noqa: ANN001
    import builtins
    import sys

    real_import = builtins.__import__

    def failing_import(name, *args, **kwargs):  # noqa: ANN001, ANN002, ANN003, ANN202
        if name == "walker_gait.core" and args and args[2] and "_jit" in args[2]:
            raise OSError("libllvmlite.so: cannot open shared object file")
        return real_import(name, *args, **kwargs)

    kernels.compiled.cache_clear()
    monkeypatch.delitem(sys.modules, "walker_gait.core._jit", raising=False)
    monkeypatch.setattr(builtins, "__import__", failing_import)
    try:
        with pytest.warns(RuntimeWarning, match="libllvmlite.so"):
            assert kernels.compiled() is None
    finally:
        monkeypatch.setattr(builtins, "__import__", real_import)
        kernels.compiled.cache_clear()
    assert kernels.compiled() is not None
