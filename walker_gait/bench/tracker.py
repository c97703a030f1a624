"""Leg-tracker benchmark: accuracy, swaps, recovery and speed per scenario / preset / cue.

Data: the synthetic session generator (:mod:`walker_gait.synth`, ``generate_session``) when it
is importable; otherwise (or with ``source="own"``) a sequence rendered with the tracker's
*own* leg model (:func:`own_sequence`, labelled ``"own-model"`` in the results — optimistic,
since model and data share the same geometry).

Run: ``python -m walker_gait.bench.tracker --presets default --cues 3d 2d combined``.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from walker_gait.core import leg_model as lm
from walker_gait.core.leg_model import BodyFrame, StateLayout
from walker_gait.core.likelihood import CueImage, project_bbox, render_depth
from walker_gait.core.tracker import LegTracker, TrackStatus, camera_segments, preset
from walker_gait.core.types import LEG_POINTS, CameraIntrinsics, FloorPlane

FloatArray = NDArray[np.float64]
L = StateLayout

KINECT = CameraIntrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=319.5, cy=239.5)
"""Default intrinsics of the own-model sequences (Kinect v1 depth camera)."""


@dataclass
class Frame:
    """One synthetic frame (camera optical frame, metres)."""

    stamp: float
    depth: NDArray[np.float32]  # (H, W) foreground depth, NaN elsewhere
    points: NDArray[np.float32]  # (N, 3) foreground points
    floor: FloorPlane
    gt: FloatArray | None  # (2, 5, 3) ground-truth leg points, None when absent


@dataclass
class Sequence:
    """A synthetic sequence and its provenance."""

    frames: list[Frame]
    intrinsics: CameraIntrinsics
    fps: float
    source: str  # "synth" or "own-model"
    scenario: str
    reappear_stamps: list[float]  # stamps at which the user (or a leg) (re)appears


def gait_state(t: float, *, cadence_hz: float = 0.8, base: FloatArray | None = None) -> FloatArray:
    """A walking pose (body frame) at time ``t`` s: sinusoidal hip/knee/ankle patterns."""
    x = lm.neutral_state(right_hip_xy=(-0.85, -0.09), hip_dist=0.18) if base is None else base.copy()
    for side, ph0 in ((0, 0.0), (1, math.pi)):
        ph = 2 * math.pi * cadence_hz * t + ph0
        o = L.leg(side).start
        x[o + L.HIP_FLEX] = 0.08 + 0.32 * math.sin(ph)
        x[o + L.HIP_ABD] = 0.03
        x[o + L.HIP_ROT] = 0.0
        x[o + L.KNEE_FLEX] = 0.12 + 0.55 * (0.5 + 0.5 * math.cos(ph - 2.3)) ** 3
        x[o + L.ANKLE_FLEX] = 0.12 * math.sin(ph + 0.6)
        x[o + L.ANKLE_INV] = 0.0
    x[L.HIP_AZ] = 0.05 * math.sin(2 * math.pi * cadence_hz * t)
    out, _, bad = lm.enforce_constraints(x[None])
    return out[0]


def render_frame(
    state: FloatArray | None,
    *,
    intrinsics: CameraIntrinsics,
    floor: FloorPlane,
    mounting: str,
    rng: np.random.Generator,
    noise_m: float = 0.002,
    stamp: float = 0.0,
    drop_leg: int | None = None,
    elliptic_foot: bool = False,
) -> Frame:
    """Render the model ``state`` (body frame) into a foreground depth image + points.

    ``elliptic_foot``: feet with the narrow elliptical cross-section of the ``default`` tracker
    instead of the seed's half-cylinder (the default, which keeps these frames the paper's model)."""
    h, w = intrinsics.height, intrinsics.width
    depth = np.full((h, w), np.nan, np.float32)
    gt = None
    if state is not None:
        body = BodyFrame.from_floor(floor, mounting=mounting)
        kin = lm.forward_kinematics(state[None])
        seg, rad, sil = camera_segments(kin, body, elliptic_foot=elliptic_foot)
        gt = body.to_camera(kin.points[0])
        cue = CueImage.from_depth(depth, intrinsics=intrinsics, stride=1, floor=floor)
        keep = [j for j in range(6) if drop_leg is None or j // 3 != drop_leg]
        seg, rad, sil = seg[:, keep], rad[:, keep], sil[:, keep]
        bbox = project_bbox(seg, np.maximum(rad, sil), intrinsics=intrinsics)
        v0, v1, u0, u1 = bbox
        if v1 > v0 and u1 > u0:
            clip = np.array([j % 3 == 2 for j in keep])
            z = render_depth(seg, sil, cue=cue, bbox=bbox, floor_clip=clip, depth_radii=rad)[0].reshape(v1 - v0, u1 - u0)
            z = np.where(np.isfinite(z), z + rng.normal(0.0, noise_m, z.shape), np.nan)
            depth[v0:v1, u0:u1] = z.astype(np.float32)
    vv, uu = np.nonzero(np.isfinite(depth))
    pts = intrinsics.backproject(uu.astype(float), vv.astype(float), depth[vv, uu].astype(float))
    keep_pts = floor.height(pts) > 0.03
    pts = pts[keep_pts]
    vv, uu = vv[keep_pts], uu[keep_pts]
    fg = np.full((h, w), np.nan, np.float32)
    fg[vv, uu] = depth[vv, uu]
    return Frame(stamp=stamp, depth=fg, points=pts.astype(np.float32), floor=floor, gt=gt)


def own_sequence(
    *,
    scenario: str = "normal",
    n_frames: int = 90,
    fps: float = 30.0,
    rng: np.random.Generator,
    mounting: str = "facing_user",
    intrinsics: CameraIntrinsics = KINECT,
    camera_height: float = 0.70,
    camera_pitch: float = 0.50,
) -> Sequence:
    """Own-model synthetic sequence.  Scenarios: ``normal``; ``absent_start`` (no user for the
    first 0.5 s); ``gap`` (user leaves for 0.5 s mid-sequence); ``one_leg_gap`` (the left leg
    vanishes for 0.4 s)."""
    floor = FloorPlane.from_camera_pose(height=camera_height, pitch=camera_pitch)
    # the user stands 0.85 m from the camera, on its optical-axis side
    user_x = -0.85 if mounting == "facing_user" else 0.85
    base = lm.neutral_state(right_hip_xy=(user_x, -0.09), hip_dist=0.18)
    base[L.SHAPE] = lm.MEAN_SHAPE * (1.0 + 0.05 * rng.standard_normal(5))
    frames: list[Frame] = []
    reappear: list[float] = []
    absent = np.zeros(n_frames, dtype=bool)
    drop = np.zeros(n_frames, dtype=bool)
    if scenario == "absent_start":
        absent[: int(0.5 * fps)] = True
        reappear.append(int(0.5 * fps) / fps)
    elif scenario == "gap":
        a = n_frames // 3
        absent[a : a + int(0.5 * fps)] = True
        reappear.append((a + int(0.5 * fps)) / fps)
    elif scenario == "one_leg_gap":
        a = n_frames // 3
        drop[a : a + int(0.4 * fps)] = True
        reappear.append((a + int(0.4 * fps)) / fps)
    elif scenario != "normal":
        raise ValueError(f"unknown own-model scenario {scenario!r}")
    phase0 = float(rng.uniform(0, 1.0))
    for i in range(n_frames):
        t = i / fps
        state = None if absent[i] else gait_state(t + phase0, base=base)
        fr = render_frame(
            state,
            intrinsics=intrinsics,
            floor=floor,
            mounting=mounting,
            rng=rng,
            stamp=t,
            drop_leg=0 if drop[i] else None,
        )
        frames.append(fr)
    return Sequence(frames=frames, intrinsics=intrinsics, fps=fps, source="own-model", scenario=scenario, reappear_stamps=reappear)


def _synth_sequence(
    scenario: str, *, rng: np.random.Generator, n_frames: int | None, fps: float = 30.0
) -> Sequence | None:
    """Sequence from the project's generator (``walker_gait.synth``), or None when unavailable.

    Foreground = oracle segmentation: pixels whose ideal material is a leg (skin, trousers,
    shoe) in the generator's noisy depth, minus points < 3 cm above the floor (what the
    segmentation stage delivers).
    """
    try:
        from walker_gait.synth import body as sb
        from walker_gait.synth.session import SessionSpec, generate_session
    except Exception:  # noqa: BLE001 - generator not ready: caller falls back
        return None
    duration = (n_frames if n_frames is not None else 300) / fps
    spec = SessionSpec.preset(scenario, duration=duration, fps=fps)
    session = generate_session(spec, rng=rng)
    intr = session.intrinsics
    leg_mats = np.array([sb.MAT_SKIN, sb.MAT_TROUSERS, sb.MAT_SHOE])
    frames: list[Frame] = []
    reappear: list[float] = []
    was_absent = False
    for i in range(len(session)):
        rf = session.frame(i)
        floor = session.floor_at(i)  # the true floor (it moves in the camera frame if the walker rocks)
        depth = np.asarray(session.depth_m(i), dtype=np.float32)
        mask = np.isin(rf.material, leg_mats) & np.isfinite(depth) & (depth > 0)
        vv, uu = np.nonzero(mask)
        pts = intr.backproject(uu.astype(float), vv.astype(float), depth[vv, uu].astype(float))
        keep = floor.height(pts) > 0.03
        fg = np.full(depth.shape, np.nan, np.float32)
        fg[vv[keep], uu[keep]] = depth[vv[keep], uu[keep]]
        gt = np.asarray(session.leg_points[i], dtype=np.float64)
        absent = int(keep.sum()) < 60
        if was_absent and not absent:
            reappear.append(float(session.stamps[i]))
        was_absent = absent
        frames.append(
            Frame(
                stamp=float(session.stamps[i]),
                depth=fg,
                points=pts[keep].astype(np.float32),
                floor=floor,
                gt=gt if (np.all(np.isfinite(gt)) and not absent) else None,
            )
        )
    return Sequence(frames=frames, intrinsics=intr, fps=fps, source="synth", scenario=scenario, reappear_stamps=reappear)


def evaluate(
    seq: Sequence, *, preset_name: str, cue: str, seed: int, max_frames: int | None = None, **overrides: Any
) -> dict[str, Any]:
    """Run the tracker over ``seq`` and compute the metrics (one result row)."""
    cfg = preset(preset_name, cue=cue, **overrides)
    tracker = LegTracker(cfg, seq.intrinsics, rng=np.random.default_rng(seed))
    errs: list[FloatArray] = []
    per_frame_mean: list[float] = []
    swaps = 0
    times: list[float] = []
    cpu: list[float] = []
    statuses: list[int] = []
    recovery: list[float] = []
    pending = list(seq.reappear_stamps)
    frames = seq.frames if max_frames is None else seq.frames[:max_frames]
    for fr in frames:
        t0, c0 = time.perf_counter(), time.process_time()
        pose = tracker.update(stamp=fr.stamp, points=fr.points, depth_fg=fr.depth, floor=fr.floor)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
        statuses.append(int(pose.status))
        if fr.gt is None or not np.all(np.isfinite(pose.points)):
            continue
        e = np.linalg.norm(pose.points - fr.gt, axis=-1)  # (2, 5)
        e_sw = np.linalg.norm(pose.points[::-1] - fr.gt, axis=-1)
        if e_sw.mean() + 0.02 < e.mean() and e.mean() > 0.08:
            swaps += 1
        errs.append(e)
        per_frame_mean.append(float(e.mean()))
        if pending and fr.stamp >= pending[0] and e.mean() < 0.05:
            recovery.append(fr.stamp - pending.pop(0))
    if pending:
        recovery.extend([math.inf] * len(pending))
    err = np.array(errs) if errs else np.full((1, 2, 5), np.nan)
    pf = np.array(per_frame_mean) if per_frame_mean else np.array([np.nan])
    # skip the first-frame search cost when reporting the steady-state frame time
    steady = np.array(times[1:]) if len(times) > 1 else np.array(times)
    row: dict[str, Any] = {
        "scenario": seq.scenario,
        "source": seq.source,
        "preset": preset_name,
        "cue": cue,
        "n_frames": len(frames),
        "ms_per_frame": 1000.0 * float(np.mean(steady)),
        "cpu_ms_per_frame": 1000.0 * float(np.mean(cpu[1:] if len(cpu) > 1 else cpu)),
        "ms_first_frame": 1000.0 * float(times[0]) if times else math.nan,
        "fps": 1.0 / float(np.mean(steady)),
        "mean_err_m": float(np.nanmean(err)),
        "pct_frames_gt_10cm": 100.0 * float(np.mean(pf > 0.10)),
        "swaps": swaps,
        "recovery_s": recovery,
        "frames_tracking": int(np.sum(np.array(statuses) == int(TrackStatus.TRACKING))),
    }
    for k, name in enumerate(LEG_POINTS):
        row[f"err_{name}_m"] = float(np.nanmean(err[:, :, k]))
    return row


def run_tracker_bench(
    *,
    scenarios: tuple[str, ...] = ("normal",),
    presets: tuple[str, ...] = ("default",),
    cues: tuple[str, ...] = ("combined",),
    seed: int = 0,
    n_frames: int = 90,
    max_frames: dict[str, int] | None = None,
    source: str = "auto",
    **overrides: Any,
) -> list[dict[str, Any]]:
    """Benchmark rows for every scenario × preset × cue (see module docstring).

    ``source``: ``"auto"`` (generator if available, else own model), ``"synth"`` or ``"own"``.
    ``max_frames``: per-preset frame cap (e.g. ``{"paper": 10}``: 5000 particles are slow).
    """
    rows: list[dict[str, Any]] = []
    for sc in scenarios:
        rng = np.random.default_rng(seed)
        seq = None
        own_only = sc in ("gap", "one_leg_gap")  # own-model-only scenarios
        if source in ("auto", "synth") and not own_only:
            seq = _synth_sequence(sc, rng=rng, n_frames=n_frames)
            if seq is None and source == "synth":
                raise RuntimeError("walker_gait.synth generator not available")
        if seq is None:
            seq = own_sequence(scenario=sc, n_frames=n_frames, rng=np.random.default_rng(seed))
        for pr in presets:
            for cue in cues:
                mf = None if max_frames is None else max_frames.get(pr)
                rows.append(evaluate(seq, preset_name=pr, cue=cue, seed=seed, max_frames=mf, **overrides))
    return rows


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scenarios", nargs="+", default=["normal"])
    ap.add_argument("--presets", nargs="+", default=["default"])
    ap.add_argument("--cues", nargs="+", default=["combined"])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--frames", type=int, default=90)
    ap.add_argument("--paper-frames", type=int, default=10)
    ap.add_argument("--source", default="auto", choices=["auto", "synth", "own"])
    a = ap.parse_args(argv)
    rows = run_tracker_bench(
        scenarios=tuple(a.scenarios),
        presets=tuple(a.presets),
        cues=tuple(a.cues),
        seed=a.seed,
        n_frames=a.frames,
        max_frames={"paper": a.paper_frames},
        source=a.source,
    )
    for r in rows:
        print(json.dumps(r))


if __name__ == "__main__":
    main()
