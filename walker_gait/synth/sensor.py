"""Vectorised depth rendering (exact ray/plane rasteriser) and depth-sensor models.

Rendering
---------
:func:`rasterize` z-buffers a triangle soup given in the camera optical frame: every pixel
centre inside a triangle's projection gets the *exact* depth of the pixel ray's intersection
with the triangle's plane (no interpolation error), plus the face index.  The floor is
ray-cast analytically (:func:`floor_depth`).  Everything is numpy-vectorised per frame.

Sensor models (:class:`SensorModel`)
------------------------------------
``kinect_v1`` (structured light, default)
    Ideal depth -> raw 11-bit disparity with the seed paper's eq. (1),
    ``z_mm = 1000 / (-0.00307 d + 3.33)`` i.e. ``d = (3.33 - 1/z_m) / 0.00307``; Gaussian
    disparity noise (i.i.d. + spatially correlated on an 8-pixel scale) is added *in disparity
    units* and the result is rounded to an integer, so the depth noise and the quantisation
    step both grow as ``z^2`` (σ_d ≈ 0.43 units gives σ_z ≈ 1.3 mm at 1 m and ≈ 5 mm at 2 m,
    cf. Khoshelham & Elberink, Sensors 12:1437, 2012: σ_z ≈ 1.43e-3 z^2).  Invalid pixels
    get ``2047``.  Invalid when: nothing hit, z < ``near`` (0.4 m) or > ``far``, IR
    projector shadow, grazing incidence, silhouette edges, fabric dropouts, speckle.
``stereo`` (active stereo, RealSense-like)
    Same pipeline with disparity ``f B / z`` in pixels and sub-pixel noise; output in mm.
``tof`` (time-of-flight, Kinect v2-like)
    σ_z = a + b z, flying pixels (fore/background mixtures) at silhouettes, no shadow; mm.

Projector / second-imager shadow: with the projector ``baseline`` metres to the camera's +x
(image right), a pixel is unlit when a pixel to its right on the same row has a smaller
projector coordinate ``u - f b / z`` (the rays cross), which produces the characteristic
invalid band on the *left* side of every foreground silhouette (vectorised with a reversed
cumulative minimum per row).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from walker_gait.core.types import CameraIntrinsics

FloatArray = NDArray[np.float64]

KINECT_INVALID = 2047
KINECT_A = -0.00307  # eq. (1): z_mm = 1000 / (A d + B)
KINECT_B = 3.33


def kinect_depth_to_raw(z_m: FloatArray) -> FloatArray:
    """Continuous raw Kinect disparity for metric depth (inverse of eq. (1))."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return (1.0 / np.asarray(z_m, dtype=np.float64) - KINECT_B) / KINECT_A


def kinect_raw_to_m(raw: NDArray) -> NDArray[np.float32]:
    """Metric depth (float32 m, NaN for 2047/invalid) of raw Kinect disparity with eq. (1)."""
    r = np.asarray(raw).astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = 1.0 / (KINECT_A * r + KINECT_B)
    z[(r >= KINECT_INVALID) | (r < 0) | ~(z > 0)] = np.nan
    return z.astype(np.float32)


def pixel_rays(intr: CameraIntrinsics) -> FloatArray:
    """(H, W, 3) rays with unit z through every pixel centre (camera optical frame)."""
    u = np.arange(intr.width, dtype=np.float64)
    v = np.arange(intr.height, dtype=np.float64)
    uu, vv = np.meshgrid(u, v)
    return np.stack([(uu - intr.cx) / intr.fx, (vv - intr.cy) / intr.fy, np.ones_like(uu)], axis=-1)


def floor_depth(intr: CameraIntrinsics, normal: FloatArray, offset: float) -> tuple[FloatArray, FloatArray]:
    """Depth (z, m; inf where the ray misses) and cosine of incidence of the floor plane
    ``normal . p + offset = 0`` (camera frame) at every pixel."""
    rays = pixel_rays(intr)
    nr = rays @ np.asarray(normal, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -offset / nr
    z = np.where((nr < 0) & (t > 0), t, np.inf)
    cos = np.abs(nr) / np.linalg.norm(rays, axis=-1)
    return z, cos


def rasterize(
    vertices: FloatArray,
    faces: NDArray[np.int32],
    intr: CameraIntrinsics,
    *,
    near: float = 0.05,
    cull_backfaces: bool = True,
) -> tuple[FloatArray, NDArray[np.int32], FloatArray]:
    """Z-buffer a triangle soup (camera frame) at the pixel centres.

    Returns ``depth`` (H, W) float64 with ``inf`` where empty, ``face`` (H, W) int32 (-1 empty)
    and ``cos`` (H, W) |cos| of the incidence angle between pixel ray and face normal.
    Triangles with a vertex closer than ``near`` are dropped (meshes near the camera must be
    tessellated finely enough).  With ``cull_backfaces`` faces whose normal
    ``(p1-p0) x (p2-p0)`` points away from the camera are skipped (closed, outward-oriented
    meshes; see ``body.orient_faces``).
    """
    H, W = intr.height, intr.width
    depth = np.full(H * W, np.inf)
    face_id = np.full(H * W, -1, np.int32)
    cos_out = np.zeros(H * W)
    if len(faces) == 0:
        return depth.reshape(H, W), face_id.reshape(H, W), cos_out.reshape(H, W)
    p0 = vertices[faces[:, 0]]
    p1 = vertices[faces[:, 1]]
    p2 = vertices[faces[:, 2]]
    z0, z1, z2 = p0[:, 2], p1[:, 2], p2[:, 2]
    ok = (z0 > near) & (z1 > near) & (z2 > near)
    if cull_backfaces:
        nrm = np.cross(p1 - p0, p2 - p0)
        ok &= np.sum(nrm * p0, axis=-1) < 0
    fidx = np.nonzero(ok)[0]
    p0, p1, p2 = p0[ok], p1[ok], p2[ok]
    fx, fy, cx, cy = intr.fx, intr.fy, intr.cx, intr.cy
    u0, v0 = fx * p0[:, 0] / p0[:, 2] + cx, fy * p0[:, 1] / p0[:, 2] + cy
    u1, v1 = fx * p1[:, 0] / p1[:, 2] + cx, fy * p1[:, 1] / p1[:, 2] + cy
    u2, v2 = fx * p2[:, 0] / p2[:, 2] + cx, fy * p2[:, 1] / p2[:, 2] + cy
    umin = np.maximum(np.ceil(np.minimum(np.minimum(u0, u1), u2)), 0).astype(np.int64)
    umax = np.minimum(np.floor(np.maximum(np.maximum(u0, u1), u2)), W - 1).astype(np.int64)
    vmin = np.maximum(np.ceil(np.minimum(np.minimum(v0, v1), v2)), 0).astype(np.int64)
    vmax = np.minimum(np.floor(np.maximum(np.maximum(v0, v1), v2)), H - 1).astype(np.int64)
    bw = umax - umin + 1
    bh = vmax - vmin + 1
    area = (u1 - u0) * (v2 - v0) - (u2 - u0) * (v1 - v0)
    keep = (bw > 0) & (bh > 0) & (np.abs(area) > 1e-12)
    if not np.any(keep):
        return depth.reshape(H, W), face_id.reshape(H, W), cos_out.reshape(H, W)
    sel = np.nonzero(keep)[0]
    cnt = (bw * bh)[sel]
    total = int(cnt.sum())
    tri = np.repeat(sel, cnt)
    start = np.repeat(np.cumsum(cnt) - cnt, cnt)
    local = np.arange(total, dtype=np.int64) - start
    bwt = bw[tri]
    px = umin[tri] + local % bwt
    py = vmin[tri] + local // bwt
    pxf = px.astype(np.float64)
    pyf = py.astype(np.float64)
    # barycentric sign test (either winding)
    inv = 1.0 / area[tri]
    w1 = ((pxf - u0[tri]) * (v2[tri] - v0[tri]) - (u2[tri] - u0[tri]) * (pyf - v0[tri])) * inv
    w2 = ((u1[tri] - u0[tri]) * (pyf - v0[tri]) - (pxf - u0[tri]) * (v1[tri] - v0[tri])) * inv
    inside = (w1 >= 0) & (w2 >= 0) & (w1 + w2 <= 1)
    tri, px, py = tri[inside], px[inside], py[inside]
    # exact ray / plane depth
    n = np.cross(p1 - p0, p2 - p0)
    nn = np.linalg.norm(n, axis=-1)
    dpl = np.sum(n * p0, axis=-1)
    rx = (px - cx) / fx
    ry = (py - cy) / fy
    nt = n[tri]
    denom = nt[:, 0] * rx + nt[:, 1] * ry + nt[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        z = dpl[tri] / denom
    good = np.isfinite(z) & (z > near)
    tri, px, py, z, denom, rx, ry = tri[good], px[good], py[good], z[good], denom[good], rx[good], ry[good]
    lin = py * W + px
    np.minimum.at(depth, lin, z)
    win = z <= depth[lin]
    lw = lin[win]
    face_id[lw] = fidx[tri[win]]
    cos_out[lw] = np.abs(denom[win]) / (nn[tri[win]] * np.sqrt(rx[win] ** 2 + ry[win] ** 2 + 1.0))
    return depth.reshape(H, W), face_id.reshape(H, W), cos_out.reshape(H, W)


# --------------------------------------------------------------------------- sensor
@dataclass(frozen=True, kw_only=True)
class SensorModel:
    """Depth-sensor error model (see module docstring).  Lengths in metres."""

    kind: str = "kinect_v1"  # "kinect_v1" | "stereo" | "tof"
    near: float = 0.40  # near-range cutoff
    far: float = 4.5  # maximum range
    disparity_sigma: float = 0.35  # kinect: raw units; stereo: pixels (i.i.d. part)
    disparity_sigma_corr: float = 0.25  # spatially correlated part (same units)
    corr_scale: int = 8  # pixels, correlation length of the correlated noise
    baseline: float = 0.075  # projector / second imager offset along +x (m); 0: no shadow
    tof_sigma: tuple[float, float] = (0.0015, 0.0012)  # tof: sigma_z = a + b z
    grazing_cos: tuple[float, float] = (0.10, 0.30)  # drop all below the first, none above the second
    edge_dropout: float = 0.3  # probability of dropping a pixel at a depth discontinuity
    edge_jump: float = 0.03  # relative depth jump that counts as a discontinuity
    speckle_dropout: float = 0.002  # random isolated dropouts
    fabric_dropout: float = 0.04  # fraction of trouser area in dropout blobs
    invalid_right_cols: int = 0  # always-invalid columns at the right edge (Kinect v1: 8 at 640 px)

    def __post_init__(self) -> None:
        if self.kind not in ("kinect_v1", "stereo", "tof"):
            msg = f"unknown sensor kind {self.kind!r}"
            raise ValueError(msg)

    @property
    def output(self) -> str:
        """Native storage: ``"kinect_raw"`` (11-bit disparity) or ``"mm"`` (uint16 millimetres)."""
        return "kinect_raw" if self.kind == "kinect_v1" else "mm"


def _smooth_noise(rng: np.random.Generator, shape: tuple[int, int], scale: int) -> FloatArray:
    """Unit-variance-ish Gaussian field correlated over ``scale`` pixels."""
    h, w = shape
    sh, sw = max(2, h // scale + 2), max(2, w // scale + 2)
    small = rng.standard_normal((sh, sw)).astype(np.float32)
    big = cv2.resize(small, (w, h), interpolation=cv2.INTER_CUBIC)
    return big.astype(np.float64)


def shadow_mask(z: FloatArray, intr: CameraIntrinsics, baseline: float, *, tol: float = 0.5) -> NDArray[np.bool_]:
    """Pixels seen by the camera but not lit by a projector ``baseline`` m along +x (see module doc)."""
    if baseline == 0.0:
        return np.zeros(z.shape, bool)
    u = np.arange(z.shape[1], dtype=np.float64)[None, :]
    with np.errstate(divide="ignore"):
        up = u - intr.fx * baseline / z
    up = np.where(np.isfinite(z), up, np.inf)
    if baseline < 0:  # projector on the left: mirror
        up = -up[:, ::-1]
        return shadow_mask_from_proj(up, tol)[:, ::-1]
    return shadow_mask_from_proj(up, tol)


def shadow_mask_from_proj(up: FloatArray, tol: float) -> NDArray[np.bool_]:
    rev_min = np.minimum.accumulate(up[:, ::-1], axis=1)[:, ::-1]
    right_min = np.concatenate([rev_min[:, 1:], np.full((up.shape[0], 1), np.inf)], axis=1)
    return np.isfinite(up) & (right_min < up - tol)


def depth_edges(z: FloatArray, rel_jump: float) -> NDArray[np.bool_]:
    """Pixels adjacent (4-neighbourhood) to a relative depth jump larger than ``rel_jump``."""
    zf = np.where(np.isfinite(z), z, 1e3)
    e = np.zeros(z.shape, bool)
    dx = np.abs(np.diff(zf, axis=1)) > rel_jump * np.minimum(zf[:, 1:], zf[:, :-1])
    dy = np.abs(np.diff(zf, axis=0)) > rel_jump * np.minimum(zf[1:, :], zf[:-1, :])
    e[:, 1:] |= dx
    e[:, :-1] |= dx
    e[1:, :] |= dy
    e[:-1, :] |= dy
    return e


def apply_sensor(
    z: FloatArray,
    cos_inc: FloatArray,
    fabric: NDArray[np.bool_],
    intr: CameraIntrinsics,
    model: SensorModel,
    *,
    rng: np.random.Generator,
) -> NDArray[np.uint16]:
    """Turn an ideal depth image (m, inf = no surface) into sensor output.

    Returns uint16: raw Kinect disparity (2047 invalid) for ``kinect_v1``, millimetres (0
    invalid) otherwise.  ``fabric`` marks trouser pixels (dropout blobs).
    """
    H, W = z.shape
    valid = np.isfinite(z) & (z >= model.near) & (z <= model.far)
    # dropouts ------------------------------------------------------------------------
    lo, hi = model.grazing_cos
    p_graze = np.clip((hi - cos_inc) / max(hi - lo, 1e-9), 0.0, 1.0) ** 2
    edges = depth_edges(z, model.edge_jump)
    # union of independent dropout causes with a single uniform draw
    p_keep = (1.0 - p_graze) * (1.0 - model.speckle_dropout)
    p_keep = np.where(edges, p_keep * (1.0 - model.edge_dropout), p_keep)
    drop = rng.random((H, W)) >= p_keep
    if model.fabric_dropout > 0 and np.any(fabric):
        # dropout blobs: threshold a smooth field at the requested area quantile (of the
        # coarse field, which has the same distribution up to interpolation smoothing)
        scale = max(4, W // 40)
        blob = _smooth_noise(rng, (H, W), scale)
        thr = float(np.quantile(blob[::scale, ::scale], model.fabric_dropout))
        drop |= fabric & (blob < thr)
    if model.kind in ("kinect_v1", "stereo"):
        drop |= shadow_mask(z, intr, model.baseline)
    valid &= ~drop
    if model.invalid_right_cols > 0:
        valid[:, W - model.invalid_right_cols :] = False
    corr = _smooth_noise(rng, (H, W), model.corr_scale)
    white = rng.standard_normal((H, W))
    zc = np.where(valid, z, 1.0)
    if model.kind == "kinect_v1":
        d = kinect_depth_to_raw(zc) + model.disparity_sigma * white + model.disparity_sigma_corr * corr
        raw = np.rint(d)
        valid &= (raw >= 0) & (raw < KINECT_INVALID)
        out = np.where(valid, raw, KINECT_INVALID).astype(np.uint16)
        return out
    if model.kind == "stereo":
        fb = intr.fx * abs(model.baseline if model.baseline else 0.05)
        d = fb / zc + model.disparity_sigma * white + model.disparity_sigma_corr * corr
        d = np.round(d * 8.0) / 8.0  # 1/8 sub-pixel disparity
        with np.errstate(divide="ignore"):
            zn = fb / d
    else:  # tof: flying pixels at silhouettes, noise linear in z
        zn = zc + (model.tof_sigma[0] + model.tof_sigma[1] * zc) * (white + 0.5 * corr)
        fly = edges & ~drop & (rng.random((H, W)) < 0.5)
        if np.any(fly):
            zmax = cv2.dilate(np.where(np.isfinite(z), z, 0).astype(np.float32), np.ones((3, 3), np.uint8))
            w = rng.random((H, W))
            zn = np.where(fly & (zmax > 0), w * zn + (1 - w) * zmax, zn)
    mm = np.rint(zn * 1000.0)
    valid &= (mm > 0) & (mm < 65535) & (zn >= model.near)
    return np.where(valid, mm, 0).astype(np.uint16)


def sensor_output_to_m(data: NDArray[np.uint16], output: str) -> NDArray[np.float32]:
    """Decode :func:`apply_sensor` output to float32 metres (NaN invalid)."""
    if output == "kinect_raw":
        return kinect_raw_to_m(data)
    z = data.astype(np.float32) / 1000.0
    z[data == 0] = np.nan
    return z


def sensor_output_to_mm(data: NDArray[np.uint16], output: str) -> NDArray[np.uint16]:
    """Decode :func:`apply_sensor` output to uint16 millimetres (0 invalid)."""
    if output == "mm":
        return data
    z = kinect_raw_to_m(data)
    mm = np.rint(np.nan_to_num(z, nan=0.0) * 1000.0)
    return np.clip(mm, 0, 65535).astype(np.uint16)
