"""Benchmark of the depth + segmentation core on a simple synthetic walker scene.

The scene (self-contained, independent of :mod:`walker_gait.synth`) is ray-cast
per pixel: a floor plane, two vertical leg cylinders (the user's lower legs),
a horizontal walker cross-bar inside the ROI and two vertical walker posts just
outside it.  Kinect-like noise (:func:`add_kinect_noise`): Gaussian depth noise
growing with z², quantisation through eq. (1) (raw 11-bit disparity), random
dropouts and dropouts along depth discontinuities.

Run (one core; the thread variables must be set before numpy is imported)::

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python -m walker_gait.bench.segmentation
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from walker_gait.core.depth import DepthProjector, decode_depth, kinect_raw_to_metres, metres_to_kinect_raw
from walker_gait.core.segmentation import Segmenter, SegmenterConfig, fit_floor_ransac
from walker_gait.core.types import CameraIntrinsics, FloorPlane

F32 = NDArray[np.float32]

LABEL_NONE, LABEL_FLOOR, LABEL_LEG, LABEL_BAR, LABEL_POST = 0, 1, 2, 3, 4
"""Ground-truth pixel labels of :class:`SyntheticScene`."""

KINECT_INTRINSICS = CameraIntrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=319.5, cy=239.5)


@dataclass(kw_only=True)
class SyntheticScene:
    """One noise-free synthetic frame with per-pixel ground truth.

    ``depth``: ``(H, W)`` float32 optical-axis depth (m), NaN where no surface is hit;
    ``labels``: ``(H, W)`` uint8 ``LABEL_*``; ``height``: true height above the floor (m);
    ``walker``: ``(H, W, 3)`` true walker-frame coordinates (m); ``floor``: true plane.
    """

    depth: F32
    labels: NDArray[np.uint8]
    height: F32
    walker: F32
    floor: FloorPlane
    intrinsics: CameraIntrinsics


def camera_floor(*, camera_height: float, pitch_deg: float, roll_deg: float = 0.0) -> FloorPlane:
    """True floor plane (camera optical frame) of a camera ``camera_height`` m up, pitched down, rolled."""
    th, ph = math.radians(pitch_deg), math.radians(roll_deg)
    n = np.array([-math.cos(th) * math.sin(ph), -math.cos(th) * math.cos(ph), -math.sin(th)])
    return FloorPlane(normal=n / np.linalg.norm(n), offset=float(camera_height), rms=0.0, inlier_ratio=1.0)


def make_synthetic_scene(
    *,
    intrinsics: CameraIntrinsics = KINECT_INTRINSICS,
    camera_height: float = 0.5,
    pitch_deg: float = 30.0,
    roll_deg: float = 0.0,
    legs: tuple[tuple[float, float], ...] = ((0.75, 0.09), (1.0, -0.07)),
    leg_radius: float = 0.055,
    leg_height: float = 0.9,
    bar: tuple[float, float, float] | None = (0.3, 0.22, 0.015),
    posts: tuple[tuple[float, float], ...] = ((0.55, 0.32), (0.55, -0.32)),
    post_radius: float = 0.015,
) -> SyntheticScene:
    """Ray-cast the scene.  Positions in the walker frame (m): ``legs`` = (x, y) axis positions of
    vertical cylinders from the floor to ``leg_height``; ``bar`` = (x, z, radius) of a horizontal
    cross-bar along y (|y| <= 0.35); ``posts`` = (x, y) of vertical walker posts up to the camera."""
    floor = camera_floor(camera_height=camera_height, pitch_deg=pitch_deg, roll_deg=roll_deg)
    rot, _ = floor.walker_transform()
    w, h = intrinsics.width, intrinsics.height
    u = ((np.arange(w) - intrinsics.cx) / intrinsics.fx)[None, :]
    v = ((np.arange(h) - intrinsics.cy) / intrinsics.fy)[:, None]
    # walker-frame ray direction per unit optical depth (a point at depth t is origin + t * d)
    dx, dy, dz = (rot[k, 0] * u + rot[k, 1] * v + rot[k, 2] for k in range(3))
    oz = camera_height
    best = np.full((h, w), np.inf)
    labels = np.zeros((h, w), dtype=np.uint8)

    def take(t: NDArray[np.float64], label: int) -> None:
        closer = (t > 1e-6) & (t < best)
        best[closer] = t[closer]
        labels[closer] = label

    with np.errstate(divide="ignore", invalid="ignore"):
        take(np.where(dz < 0, -oz / dz, np.inf), LABEL_FLOOR)
        a_xy = dx * dx + dy * dy

        def vcyl(cx: float, cy: float, r: float, z0: float, z1: float) -> NDArray[np.float64]:
            # |(-cx, -cy) + t (dx, dy)|² = r², nearest root
            b = -2.0 * (dx * cx + dy * cy)
            c = cx * cx + cy * cy - r * r
            disc = b * b - 4.0 * a_xy * c
            t = (-b - np.sqrt(disc)) / (2.0 * a_xy)
            zt = oz + t * dz
            return np.where((disc >= 0) & (zt >= z0) & (zt <= z1), t, np.inf)

        for lx, ly in legs:
            take(vcyl(lx, ly, leg_radius, 0.0, leg_height), LABEL_LEG)
        for px_, py_ in posts:
            take(vcyl(px_, py_, post_radius, 0.0, camera_height), LABEL_POST)
        if bar is not None:
            bx, bz, br = bar
            pz = oz - bz
            a = dx * dx + dz * dz
            b = 2.0 * (-dx * bx + dz * pz)
            c = bx * bx + pz * pz - br * br
            disc = b * b - 4.0 * a * c
            t = (-b - np.sqrt(disc)) / (2.0 * a)
            take(np.where((disc >= 0) & (np.abs(t * dy) <= 0.35), t, np.inf), LABEL_BAR)

    depth = np.where(best < 20.0, best, np.nan)
    labels[np.isnan(depth)] = LABEL_NONE
    walker = np.stack([depth * dx, depth * dy, oz + depth * dz], axis=-1).astype(np.float32)
    return SyntheticScene(
        depth=depth.astype(np.float32),
        labels=labels,
        height=walker[..., 2].copy(),
        walker=walker,
        floor=floor,
        intrinsics=intrinsics,
    )


def add_kinect_noise(
    depth_m: F32,
    *,
    rng: np.random.Generator,
    sigma_per_m2: float = 0.0014,
    dropout: float = 0.02,
    edge_dropout: float = 0.5,
    edge_jump: float = 0.05,
    radial_bias: float = 0.0,
) -> NDArray[np.uint16]:
    """Kinect-like raw 11-bit disparity image (uint16, 2047 = no reading) of a true depth image (m).

    Gaussian noise sigma = ``sigma_per_m2 * z²`` (m; Khoshelham & Elberink 2012: ~1.4 mm/m²),
    quantisation by eq. (1), random dropouts (fraction ``dropout``) and, with probability
    ``edge_dropout``, dropouts of the farther pixel at depth jumps > ``edge_jump`` m (shadows), and
    an optional systematic radial depth bias ``z *= 1 + radial_bias * r²`` (r = 1 at the image
    corners), like the low-frequency distortion of uncalibrated structured-light sensors.
    """
    z = depth_m.astype(np.float64)
    if radial_bias:
        h, w = z.shape
        yy, xx = np.mgrid[0:h, 0:w]
        r2 = ((xx - (w - 1) / 2) ** 2 + (yy - (h - 1) / 2) ** 2) / (((w - 1) / 2) ** 2 + ((h - 1) / 2) ** 2)
        z = z * (1.0 + radial_bias * r2)
    noisy = z + rng.standard_normal(z.shape) * sigma_per_m2 * z * z
    raw = metres_to_kinect_raw(noisy)
    drop = rng.random(z.shape) < dropout
    if edge_dropout > 0:
        zf = np.nan_to_num(z, nan=100.0)
        jump = np.zeros(z.shape, dtype=bool)
        dx = zf[:, 1:] - zf[:, :-1]
        dy = zf[1:, :] - zf[:-1, :]
        jump[:, 1:] |= dx > edge_jump  # this pixel is farther than its left neighbour
        jump[:, :-1] |= dx < -edge_jump
        jump[1:, :] |= dy > edge_jump
        jump[:-1, :] |= dy < -edge_jump
        drop |= jump & (rng.random(z.shape) < edge_dropout)
    raw[drop] = 2047
    return raw


def rocking(t: float, rms_deg: float) -> tuple[float, float]:
    """Pitch and roll offsets (deg) at time ``t`` (s) of a walker rocking with ``rms_deg`` RMS on each axis: a
    1.7 Hz sway (the user's steps) plus a 7.3 Hz bump (the floor under the wheels), equal parts."""
    pitch = math.sin(2 * math.pi * 1.7 * t) + math.sin(2 * math.pi * 7.3 * t + 1.0)
    roll = math.sin(2 * math.pi * 1.7 * t + 2.0) + math.sin(2 * math.pi * 7.3 * t + 0.3)
    return rms_deg * pitch, rms_deg * roll


def _angle_deg(a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
    return math.degrees(math.acos(float(np.clip(np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b)), -1, 1))))


def run_segmentation_bench(
    *,
    rng: np.random.Generator,
    n_frames: int = 60,
    camera_height: float = 0.5,
    pitch_deg: float = 30.0,
    roll_deg: float = 0.0,
    noise_scale: float = 1.0,
    dropout: float = 0.02,
    radial_bias: float = 0.0,
    rocking_deg: float = 0.0,
    config: SegmenterConfig | None = None,
) -> dict[str, float | int | str]:
    """Measure speed and quality of decode + back-project + floor + ROI on synthetic 640x480 frames.

    Each frame moves the legs along a simple gait cycle; the camera is rigid.  ``noise_scale``
    multiplies the Gaussian depth noise (1 = Kinect-like 1.4 mm/m²), ``dropout`` is the random
    dropout fraction (plus shadow dropouts at depth edges), ``radial_bias`` a systematic radial depth
    error (see :func:`add_kinect_noise`), ``rocking_deg`` the RMS of a walker rocking on its wheels (camera pitch and
    roll each the sum of a 1.7 Hz sway and a 7.3 Hz bump, see :func:`rocking`).  ``*_final_pct`` figures cover the
    last quarter of the frames
    (after the occupancy HMM, if enabled, has settled).  The input is the
    noisy raw Kinect image as ``16UC1`` bytes decoded with ``depth_format="kinect_raw"``.
    Returned figures:

    * ``ms_median`` / ``ms_p90``: wall time per frame (decode + back-project + ``Segmenter.process``),
      first frame (initial RANSAC) excluded from the median; ``cpu_ms_median``: process CPU time (≈ wall on one core);
      ``ms_median_16uc1``: same with a millimetre ``16UC1`` input; ``ms_median_no_intrinsics``: kinect_raw
      input, Segmenter built without intrinsics (walker coordinates by transforming the points);
    * ``floor_angle_err_deg_*`` / ``floor_height_err_mm_*``: tracked floor vs truth (median / max over frames),
      ``ransac_*``: single RANSAC run on the first frame;
    * ``leg_kept_pct``: leg pixels with valid depth, inside the ROI and true height >= min_height + 2 cm,
      that end up in the foreground; ``leg_kept_all_pct``: all valid in-ROI leg pixels (incl. the lowest 4.5 cm);
    * ``floor_leak_pct``: valid floor pixels inside the ROI box that end up in the foreground;
      ``floor_leak_all_pct``: relative to all valid floor pixels;
    * ``bar_kept_pct``: walker cross-bar pixels kept (they are in the ROI; removed as thinner than
      ``min_part_width``, or by the HMM once static);
      ``post_kept_pct``: walker posts (outside the ROI laterally).
    """
    cfg = config or SegmenterConfig()
    cv_threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        intr = KINECT_INTRINSICS
        seg = Segmenter(cfg, rng=rng, intrinsics=intr)
        proj = DepthProjector(intr)
        w, h = intr.width, intr.height
        roi = cfg.roi
        times: list[float] = []
        cpu_times: list[float] = []
        times_mm: list[float] = []
        times_noint: list[float] = []
        ang_err: list[float] = []
        h_err: list[float] = []
        per_frame: list[tuple[int, int, int, int]] = []  # (leg, leg_kept, bar, bar_kept)
        tot = {"leg": 0, "leg_kept": 0, "leg_all": 0, "leg_all_kept": 0, "floor_roi": 0, "floor_leak": 0,
               "floor_all": 0, "bar": 0, "bar_kept": 0, "post": 0, "post_kept": 0}
        ransac_ang = ransac_h = float("nan")
        seg_mm = Segmenter(cfg, rng=np.random.default_rng(0), intrinsics=intr)
        seg_noint = Segmenter(cfg, rng=np.random.default_rng(0))
        for i in range(n_frames):
            phase = 2 * math.pi * i / 30.0
            legs = ((0.85 + 0.2 * math.sin(phase), 0.09), (0.85 - 0.2 * math.sin(phase), -0.07))
            d_pitch, d_roll = rocking(i / 30.0, rocking_deg)
            scene = make_synthetic_scene(camera_height=camera_height, pitch_deg=pitch_deg + d_pitch,
                                         roll_deg=roll_deg + d_roll, legs=legs)
            raw = add_kinect_noise(scene.depth, rng=rng, sigma_per_m2=0.0014 * noise_scale, dropout=dropout,
                                   radial_bias=radial_bias)
            data = raw.astype("<u2").tobytes()
            mm = np.where(raw < 2047, np.rint(kinect_raw_to_metres(raw) * 1000), 0)
            data_mm = np.nan_to_num(mm).astype("<u2").tobytes()
            t0, c0 = time.perf_counter(), time.process_time()
            depth = decode_depth(data, encoding="16UC1", width=w, height=h, step=2 * w,
                                 is_bigendian=False, depth_format="kinect_raw")
            pts = proj.points(depth)
            result = seg.process(depth, pts)
            t1, c1 = time.perf_counter(), time.process_time()
            t2 = time.perf_counter()
            depth_mm = decode_depth(data_mm, encoding="16UC1", width=w, height=h, step=2 * w, is_bigendian=False)
            seg_mm.process(depth_mm, proj.points(depth_mm))
            times_mm.append(time.perf_counter() - t2)
            t3 = time.perf_counter()
            depth_k = decode_depth(data, encoding="16UC1", width=w, height=h, step=2 * w,
                                   is_bigendian=False, depth_format="kinect_raw")
            seg_noint.process(depth_k, proj.points(depth_k))
            times_noint.append(time.perf_counter() - t3)
            times.append(t1 - t0)
            cpu_times.append(c1 - c0)
            if i == 0:
                p0 = fit_floor_ransac(proj.points(depth), rng=rng, config=cfg.floor)
                if p0.valid:
                    ransac_ang = _angle_deg(p0.normal, scene.floor.normal)
                    ransac_h = abs(p0.offset - scene.floor.offset) * 1000
            if result.floor.valid:
                ang_err.append(_angle_deg(result.floor.normal, scene.floor.normal))
                h_err.append(abs(result.floor.offset - scene.floor.offset) * 1000)
            valid = np.isfinite(depth)
            wk = scene.walker
            in_roi = (
                (wk[..., 0] <= roi.forward) & (wk[..., 0] >= roi.near)
                & (wk[..., 1] <= roi.left) & (wk[..., 1] >= -roi.right)
            )
            m = result.mask
            leg_all = (scene.labels == LABEL_LEG) & valid & in_roi
            leg = leg_all & (scene.height >= roi.min_height + 0.02)
            floor_px = (scene.labels == LABEL_FLOOR) & valid
            bar = (scene.labels == LABEL_BAR) & valid
            post = (scene.labels == LABEL_POST) & valid
            tot["leg"] += int(leg.sum())
            tot["leg_kept"] += int((leg & m).sum())
            tot["leg_all"] += int(leg_all.sum())
            tot["leg_all_kept"] += int((leg_all & m).sum())
            tot["floor_roi"] += int((floor_px & in_roi).sum())
            tot["floor_leak"] += int((floor_px & m).sum())
            tot["floor_all"] += int(floor_px.sum())
            tot["bar"] += int(bar.sum())
            tot["bar_kept"] += int((bar & m).sum())
            tot["post"] += int(post.sum())
            tot["post_kept"] += int((post & m).sum())
            per_frame.append((int(leg.sum()), int((leg & m).sum()), int(bar.sum()), int((bar & m).sum())))
    finally:
        cv2.setNumThreads(cv_threads)

    def pct(a: str, b: str) -> float:
        return 100.0 * tot[a] / tot[b] if tot[b] else float("nan")

    warm = times[1:] if len(times) > 1 else times
    last = np.asarray(per_frame[-max(1, n_frames // 4):], dtype=np.float64)
    leg_final = 100.0 * last[:, 1].sum() / last[:, 0].sum() if last[:, 0].sum() else float("nan")
    bar_final = 100.0 * last[:, 3].sum() / last[:, 2].sum() if last[:, 2].sum() else float("nan")
    return {
        "n_frames": n_frames,
        "image": f"{w}x{h}",
        "omp_num_threads": os.environ.get("OMP_NUM_THREADS", "unset"),
        "openblas_num_threads": os.environ.get("OPENBLAS_NUM_THREADS", "unset"),
        "cpu_count": os.cpu_count() or 0,
        "ms_median": 1000 * float(np.median(warm)),
        "ms_p90": 1000 * float(np.percentile(warm, 90)),
        "cpu_ms_median": 1000 * float(np.median(cpu_times[1:] if len(cpu_times) > 1 else cpu_times)),
        "ms_median_16uc1": 1000 * float(np.median(times_mm[1:] if len(times_mm) > 1 else times_mm)),
        "ms_median_no_intrinsics": 1000 * float(np.median(times_noint[1:] if len(times_noint) > 1 else times_noint)),
        "ransac_runs": seg.floor_tracker.ransac_runs,
        "ransac_angle_err_deg": ransac_ang,
        "ransac_height_err_mm": ransac_h,
        "floor_angle_err_deg_median": float(np.median(ang_err)) if ang_err else float("nan"),
        "floor_angle_err_deg_max": float(np.max(ang_err)) if ang_err else float("nan"),
        "floor_height_err_mm_median": float(np.median(h_err)) if h_err else float("nan"),
        "floor_height_err_mm_max": float(np.max(h_err)) if h_err else float("nan"),
        "floor_valid_frames": len(ang_err),
        "leg_kept_pct": pct("leg_kept", "leg"),
        "leg_kept_all_pct": pct("leg_all_kept", "leg_all"),
        "floor_leak_pct": pct("floor_leak", "floor_roi"),
        "floor_leak_all_pct": pct("floor_leak", "floor_all"),
        "bar_kept_pct": pct("bar_kept", "bar"),
        "leg_kept_final_pct": leg_final,
        "bar_kept_final_pct": bar_final,
        "post_kept_pct": pct("post_kept", "post"),
    }


def main() -> None:
    """Print the benchmark figures (seeded) for three settings."""
    runs = {
        "kinect (h 0.5 m, pitch 30 deg)": {},
        "stress (3x noise, 10% dropout, 1% radial depth bias, h 0.45 m, pitch 40 deg, roll 4 deg)": {
            "noise_scale": 3.0, "dropout": 0.10, "radial_bias": 0.01, "camera_height": 0.45, "pitch_deg": 40.0,
            "roll_deg": 4.0},
        "kinect + occupancy HMM (120 frames)": {"config": SegmenterConfig(use_occupancy_hmm=True), "n_frames": 120},
        "kinect, walker rocking 1 deg RMS": {"rocking_deg": 1.0},
    }
    for title, kw in runs.items():
        res = run_segmentation_bench(rng=np.random.default_rng(12345), **kw)  # type: ignore[arg-type]
        print(f"== {title}")
        width = max(len(k) for k in res)
        for k, v in res.items():
            print(f"{k:<{width}}  {v:.3f}" if isinstance(v, float) else f"{k:<{width}}  {v}")


if __name__ == "__main__":
    main()
