"""Tests for walker_gait/report.py: the self-contained HTML report."""

from __future__ import annotations

import base64
import math
import re
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from walker_gait.core.types import (
    JOINT_NAMES,
    EventKind,
    FloorPlane,
    GaitEvent,
    LegPose,
    Side,
    Step,
    TrackStatus,
)
from walker_gait.report import estimate_floor_from_events, footprint_chain, gait_cycles, write_report

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
FLOOR = FloorPlane.from_camera_pose(height=0.75, pitch=math.radians(35.0))


def make_session(
    *, duration: float = 10.0, fps: float = 30.0, stride_time: float = 1.2, seed: int = 0
) -> tuple[list[Step], list[GaitEvent], list[LegPose], dict]:
    """A hand-made walking session: sagittal leg kinematics, events at fixed phases, steps.

    Legs are built in the walker frame (x towards the user, z up; the user walks towards -x
    and the walker moves with them, so the hips stay ~0.8 m from the camera) and transformed
    into the camera optical frame of ``FLOOR``.  Heel strike at phase 0, toe off at 0.62.
    """
    rng = np.random.default_rng(seed)
    rot, t_vec = FLOOR.walker_transform()
    n = int(duration * fps)
    stamps = 1000.0 + np.arange(n) / fps
    phase_offset = {Side.LEFT: 0.0, Side.RIGHT: 0.5}
    lengths = (0.45, 0.43, 0.08, 0.06, 0.20)  # thigh, shank, ankle height, heel back, foot

    def leg_points(side: Side, ph: float) -> tuple[np.ndarray, np.ndarray]:
        hip_flex = math.radians(20.0 * math.cos(2 * math.pi * ph) + 5.0)
        knee_flex = math.radians(max(0.0, 60.0 * math.sin(math.pi * (ph - 0.55) / 0.45)) if ph > 0.55
                                 else 15.0 * math.sin(math.pi * ph / 0.4) if ph < 0.4 else 2.0)
        ankle_flex = math.radians(10.0 * math.sin(2 * math.pi * ph) - 5.0)
        y = -0.1 if side == Side.LEFT else 0.1
        hip = np.array([0.8, y, 0.9])
        thigh = np.array([-math.sin(hip_flex), 0.0, -math.cos(hip_flex)])
        knee = hip + lengths[0] * thigh
        shank_angle = hip_flex - knee_flex
        shank = np.array([-math.sin(shank_angle), 0.0, -math.cos(shank_angle)])
        ankle = knee + lengths[1] * shank
        foot_angle = shank_angle + math.pi / 2 + ankle_flex
        foot_dir = np.array([-math.sin(foot_angle), 0.0, -math.cos(foot_angle)])
        heel = ankle - lengths[2] * np.array([0, 0, 1.0]) - lengths[3] * foot_dir
        toe = heel + lengths[4] * foot_dir
        pts_w = np.stack([hip, knee, ankle, heel, toe])
        return pts_w, np.array([hip_flex, knee_flex, ankle_flex])

    poses: list[LegPose] = []
    for i, t in enumerate(stamps):
        pts = np.zeros((2, 5, 3))
        ang = np.full(len(JOINT_NAMES), np.nan)
        for side in Side:
            ph = ((t - stamps[0]) / stride_time + phase_offset[side]) % 1.0
            pts_w, sag = leg_points(side, ph)
            pts[side] = (pts_w - t_vec) @ rot  # p_c = R^T (p_w - t)
            pts[side] += rng.normal(0.0, 0.003, size=(5, 3))
            ang[JOINT_NAMES.index(f"{side.label}_hip_flexion")] = sag[0]
            ang[JOINT_NAMES.index(f"{side.label}_knee_flexion")] = sag[1]
            ang[JOINT_NAMES.index(f"{side.label}_ankle_flexion")] = sag[2]
            for k in ("hip_abduction", "hip_rotation", "ankle_inversion"):
                ang[JOINT_NAMES.index(f"{side.label}_{k}")] = rng.normal(0.0, 0.02)
        status = TrackStatus.SEARCHING if i < 5 else TrackStatus.DEGRADED if 150 <= i < 165 else TrackStatus.TRACKING
        conf = 0.2 if i < 5 else 0.5 if status == TrackStatus.DEGRADED else 0.9
        if 150 <= i < 155:  # a short dropout
            pts[:] = np.nan
            ang[:] = np.nan
        poses.append(LegPose(stamp=float(t), points=pts, angles=ang, status=status, confidence=conf))

    events: list[GaitEvent] = []
    steps: list[Step] = []
    pose_t = np.array([p.stamp for p in poses])
    for side in Side:
        for k in range(int(duration / stride_time) + 2):
            for kind, frac, point in ((EventKind.HEEL_STRIKE, 0.0, 3), (EventKind.TOE_OFF, 0.62, 4)):
                te = stamps[0] + (k + frac - phase_offset[side]) * stride_time
                if not stamps[0] + 0.05 <= te <= stamps[-1] - 0.05:
                    continue
                j = int(np.argmin(np.abs(pose_t - te)))
                pos = poses[j].points[side, point]
                if not np.all(np.isfinite(pos)):
                    continue
                events.append(GaitEvent(stamp=float(te), side=side, kind=kind, position=pos.copy(),
                                        confidence=0.9))
    events.sort(key=lambda e: e.stamp)
    hs = [e for e in events if e.kind == EventKind.HEEL_STRIKE]
    for idx, e in enumerate(hs[1:]):
        prev = hs[idx]
        base_len = 0.42 if e.side == Side.LEFT else 0.38
        steps.append(
            Step(stamp=e.stamp, side=e.side, index=idx, step_length=base_len + rng.normal(0, 0.02),
                 step_width=0.18 + rng.normal(0, 0.01), step_time=e.stamp - prev.stamp,
                 stride_length=math.nan if idx == 0 else 0.8 + rng.normal(0, 0.02),
                 stride_time=math.nan if idx == 0 else stride_time, stance_time=0.62 * stride_time,
                 swing_time=0.38 * stride_time, single_support_time=0.38 * stride_time,
                 double_support_time=0.12 * stride_time, confidence=0.85)
        )
    summary = {
        "scope": 1, "window_duration": 0.0, "duration": steps[-1].stamp - steps[0].stamp,
        "step_count": len(steps), "cadence": 100.0, "gait_speed": 0.67, "step_length_mean": 0.40,
        "step_width_mean": 0.18, "step_time_mean": 0.6, "step_length_mean_side": [0.42, 0.38],
        "step_length_sd_side": [0.02, 0.021], "step_length_cv_side": [4.8, 5.5],
        "step_width_mean_side": [0.18, 0.18], "step_width_sd_side": [0.01, 0.01],
        "step_width_cv_side": [5.6, 5.5], "step_time_mean_side": [0.6, 0.6],
        "step_time_sd_side": [0.0, 0.0], "step_time_cv_side": [0.0, 0.0],
        "stance_percent_side": [62.0, 62.0], "swing_percent_side": [38.0, 38.0],
        "double_support_percent": 24.0, "step_length_symmetry": 0.42 / 0.38,
        "swing_time_symmetry": 1.0, "mean_confidence": 0.85,
    }
    return steps, events, poses, summary


METADATA = {
    "input_file": "/data/sessions/patient_<07>.mcap",
    "preset": "default",
    "seed": 3,
    "frames_processed": 300,
    "frames_skipped": {"depth_decode_error": 2, "no_camera_info": 1},
    "processing_time_s": 12.5,
    "report_pelvis_window_s": 1.0,
    "leg_length_m": None,
    "reported_segment_lengths_m": {"thigh": 0.412, "calf": 0.398, "foot": 0.262, "leg": 0.902},
}


class _Collector(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.ids: list[str] = []
        self.imgs: list[str] = []
        self.stack: list[str] = []
        self.errors: list[str] = []
        self.external: list[str] = []

    _VOID = {"meta", "img", "br", "hr", "link", "input"}

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if "id" in a and a["id"]:
            self.ids.append(a["id"])
        if tag == "img":
            self.imgs.append(a.get("src") or "")
        for key in ("src", "href"):
            val = a.get(key)
            if val and not (val.startswith("data:") or val.startswith("#")):
                self.external.append(val)
        if tag not in self._VOID:
            self.stack.append(tag)

    def handle_endtag(self, tag: str) -> None:
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"unbalanced </{tag}>, open: {self.stack[-3:]}")
            return
        self.stack.pop()


def _parse(path: Path) -> tuple[str, _Collector]:
    text = path.read_text(encoding="utf-8")
    parser = _Collector()
    parser.feed(text)
    parser.close()
    return text, parser


SECTIONS = ("header", "summary", "steps-plot", "footprints", "joint-angles", "gait-cycle", "foot-heights", "quality",
            "steps-table")


@pytest.fixture(scope="module")
def session() -> tuple[list[Step], list[GaitEvent], list[LegPose], dict]:
    return make_session()


def test_full_report_is_valid_self_contained_html(tmp_path: Path, session) -> None:
    steps, events, poses, summary = session
    # its time is `make bench`'s (the `process` wall time includes the report), not a test's
    out = write_report(tmp_path / "report.html", steps=steps, events=events, poses=poses, summary=summary,
                       metadata=METADATA)
    assert out == tmp_path / "report.html"
    text, parser = _parse(out)
    assert text.startswith("<!DOCTYPE html>")
    assert parser.errors == []
    assert parser.stack == []
    assert parser.external == []  # no network resources
    assert "<script" not in text
    for anchor in SECTIONS:
        assert anchor in parser.ids
    # 6 figures: steps, footprints, joint angles, gait cycle, foot heights, quality
    assert len(parser.imgs) == 6
    for src in parser.imgs:
        assert src.startswith("data:image/png;base64,")
        assert base64.b64decode(src.split(",", 1)[1]).startswith(PNG_MAGIC)
    # clinical names, units, escaped metadata
    for needle in ("Cadence", "steps/min", "Gait speed", "m/s", "Step length, mean", "cm", "% gait cycle",
                   "Step length symmetry", "Left", "Right", "patient_&lt;07&gt;.mcap", "depth_decode_error: 2",
                   "Frames skipped", "Leg length given (m)</th><td>—", "window (s; 0 = as tracked)</th><td>1.0",
                   "thigh, calf, shoe; hip height</th><td>0.412, 0.398, 0.262; 0.902"):
        assert needle in text, needle
    assert "patient_<07>" not in text
    assert "100.0" in text  # cadence
    assert "42.0" in text and "38.0" in text  # step length left/right in cm
    assert "1.11" in text  # L/R ratio 0.42/0.38
    # steps table has one row per step
    table = text.split('id="steps-table"', 1)[1]
    assert table.count('<tr class="left">') + table.count('<tr class="right">') == len(steps)
    assert "No steps detected" not in text
    assert not list(tmp_path.glob(".*.tmp"))


def _without_render_time(text: str) -> str:
    return re.sub(r"Generated by walker_gait \S+ in [0-9.]+ s", "", text)


def test_figures_drawn_in_two_processes_are_those_drawn_in_one(tmp_path: Path, session) -> None:
    """``processes=2`` (``walker-gait process``) draws half of the figures in a forked child: the same report."""
    steps, events, poses, summary = session
    kw = dict(steps=steps, events=events, poses=poses, summary=summary, metadata=METADATA)
    one = write_report(tmp_path / "one.html", processes=1, **kw).read_text()
    two = write_report(tmp_path / "two.html", processes=2, **kw).read_text()
    assert one.count("data:image/png;base64,") == 6
    assert _without_render_time(two) == _without_render_time(one)


def test_a_figure_child_that_fails_is_drawn_here_instead(tmp_path: Path, session, monkeypatch) -> None:  # noqa: ANN001
    """A figure that fails in the child (killed, out of memory) is drawn again by the parent: the same report."""
    import os

    import walker_gait.report as report

    parent = os.getpid()
    steps_fig = report._fig_steps

    def fails_in_the_child(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
        if os.getpid() != parent:
            raise MemoryError
        return steps_fig(*args, **kwargs)

    steps, events, poses, summary = session
    kw = dict(steps=steps, events=events, poses=poses, summary=summary, metadata=METADATA)
    one = write_report(tmp_path / "one.html", processes=1, **kw).read_text()
    monkeypatch.setattr(report, "_fig_steps", fails_in_the_child)
    drawn = report._draw({"a": (fails_in_the_child, (steps, [], 0.0)), "b": (len, ([1, 2],))}, processes=2)
    assert drawn["b"] == 2 and drawn["a"] == steps_fig(steps, [], 0.0)
    two = write_report(tmp_path / "two.html", processes=2, **kw).read_text()
    assert _without_render_time(two) == _without_render_time(one)


def test_report_with_zero_steps_and_zero_poses(tmp_path: Path) -> None:
    out = write_report(tmp_path, steps=[], events=[], poses=[], summary={}, metadata={})
    assert out == tmp_path / "report.html"
    text, parser = _parse(out)
    assert parser.errors == [] and parser.stack == []
    assert "No steps detected" in text
    assert "No leg poses were tracked" in text
    for anchor in SECTIONS:
        assert anchor in parser.ids
    assert parser.imgs == []


def test_report_with_poses_but_no_steps(tmp_path: Path, session) -> None:
    _, _, poses, _ = session
    out = write_report(tmp_path / "r.html", steps=[], events=[], poses=poses[:60], summary={"cadence": math.nan},
                       metadata={"input_file": "x.mcap"})
    text, parser = _parse(out)
    assert "No steps detected" in text
    assert "No complete gait cycle" in text
    # joint angles, foot heights and quality still drawn
    assert len(parser.imgs) == 3
    assert all(s.startswith("data:image/png;base64,") for s in parser.imgs)


def test_report_copes_with_nans(tmp_path: Path, session) -> None:
    steps, events, poses, summary = session
    nan_steps = [Step(stamp=s.stamp, side=s.side, index=s.index, step_length=math.nan, step_width=s.step_width,
                      step_time=math.nan, stride_length=math.nan, stride_time=math.nan, stance_time=math.nan,
                      swing_time=math.nan, single_support_time=math.nan, double_support_time=math.nan,
                      confidence=math.nan) for s in steps[:4]]
    nan_poses = [LegPose(stamp=p.stamp, points=np.full((2, 5, 3), np.nan), status=TrackStatus.NO_USER,
                         confidence=0.0) for p in poses[:30]]
    nan_summary = dict.fromkeys(summary, math.nan)
    nan_summary["step_length_mean_side"] = [math.nan, math.nan]
    for key in [k for k in nan_summary if k.endswith("_side")]:
        nan_summary[key] = [math.nan, math.nan]
    out = write_report(tmp_path / "r.html", steps=nan_steps, events=events[:3], poses=nan_poses,
                       summary=nan_summary, metadata=METADATA)
    text, parser = _parse(out)
    assert parser.errors == []
    assert "nan" not in re.sub(r"data:image/png;base64,[^\"]+", "", text).lower().replace("nanmean", "")
    assert "—" in text
    assert "4 of 4 steps have no double-support time" in text  # and why: the toe offs the camera did not see
    full = write_report(tmp_path / "full.html", steps=steps, events=events, poses=poses, summary=summary,
                        metadata=METADATA)
    known = sum(1 for st in steps if math.isfinite(st.double_support_time))
    assert ("have no double-support time" in full.read_text()) == (known < len(steps))


def test_report_with_ground_truth(tmp_path: Path, session) -> None:
    steps, events, poses, summary = session
    gt = {
        "steps": [{"time": s.stamp, "foot": s.side.label, "step_length": 0.40, "step_width": 0.17}
                  for s in steps],
        "summary": {"cadence_steps_per_min": 101.0, "step_length_mean_left_m": 0.41},
    }
    out = write_report(tmp_path / "r.html", steps=steps, events=events, poses=poses, summary=summary,
                       metadata=METADATA, ground_truth=gt)
    text, parser = _parse(out)
    assert "Truth left" in text
    assert "101.0" in text and "41.0" in text
    assert "ground truth" in text
    assert len(parser.imgs) == 6


def test_report_is_atomic_old_file_kept_on_failure(tmp_path: Path, session) -> None:
    steps, events, poses, summary = session
    target = tmp_path / "report.html"
    target.write_text("old report")
    bad = {"steps": [object()]}
    with pytest.raises(TypeError):
        write_report(target, steps=steps, events=events, poses=poses, summary=summary, metadata=METADATA,
                     ground_truth=bad)
    assert target.read_text() == "old report"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.html"]


def _step(t: float, side: Side, length: float, width: float, confidence: float = 1.0) -> Step:
    nan = math.nan
    return Step(stamp=t, side=side, index=0, step_length=length, step_width=width, step_time=nan, stride_length=nan,
                stride_time=nan, stance_time=nan, swing_time=nan, single_support_time=nan, double_support_time=nan,
                confidence=confidence)


def test_footprint_chain_places_each_foot_from_the_other_ones_last_footfall() -> None:
    """Right, left, right steps of known length and width: each foot lands one step length ahead of the other
    foot's last footfall and one width to its own side (the user's left for the left foot); a step of unknown
    length breaks the chain and the next run starts after the last one; an asymmetric gait shows as such."""
    steps = [_step(1.0, Side.RIGHT, 0.20, 0.16), _step(1.6, Side.LEFT, 0.50, 0.14),
             _step(2.2, Side.RIGHT, 0.40, 0.18, confidence=0.3), _step(2.8, Side.LEFT, math.nan, 0.15),
             _step(3.4, Side.RIGHT, 0.45, 0.12), _step(4.0, Side.LEFT, 0.35, 0.12)]
    runs = footprint_chain(steps[::-1])  # any order: by time
    assert [len(r) for r in runs] == [4, 3]
    first = runs[0]
    assert [(f.side, round(f.along, 3), round(f.across, 3)) for f in first] == [
        (Side.LEFT, 0.0, 0.08), (Side.RIGHT, 0.2, -0.08), (Side.LEFT, 0.7, 0.06), (Side.RIGHT, 1.1, -0.12)]
    assert math.isnan(first[0].confidence) and first[3].confidence == 0.3
    second = runs[1]
    assert second[0].along == pytest.approx(1.1 + 0.3) and second[0].side == Side.LEFT
    assert second[1].along - second[0].along == pytest.approx(0.45)
    assert second[2].along - second[1].along == pytest.approx(0.35)
    assert second[2].across - second[1].across == pytest.approx(0.12)
    assert footprint_chain([]) == [] and footprint_chain([_step(1.0, Side.LEFT, math.nan, 0.1)]) == []


def test_a_long_walk_draws_its_first_walkway_rows_and_says_so(tmp_path: Path) -> None:
    steps = [_step(0.6 * k, Side(k % 2), 0.5, 0.15) for k in range(80)]  # 40 m
    out = write_report(tmp_path / "r.html", steps=steps, events=[], poses=[], summary={}, metadata={})
    text, parser = _parse(out)
    assert parser.errors == []
    assert "The first 24 m of 40 m are shown." in text
    assert len(parser.imgs) == 2  # steps, footprints


def test_gait_cycles_normalisation() -> None:
    t = np.arange(0.0, 5.0, 0.02)
    values = np.sin(2 * np.pi * t / 1.25)
    hs = np.array([0.0, 1.25, 2.5, 3.75])
    cycles, bounds = gait_cycles(t, values, hs)
    assert cycles.shape == (3, 101)
    np.testing.assert_allclose(bounds[:, 1] - bounds[:, 0], 1.25)
    expected = np.sin(2 * np.pi * np.linspace(0, 1, 101))
    np.testing.assert_allclose(cycles, np.broadcast_to(expected, cycles.shape), atol=2e-3)
    # a gap in the middle of the second cycle removes just that cycle
    gap = values.copy()
    gap[(t > 1.5) & (t < 2.0)] = np.nan
    cycles_gap, bounds_gap = gait_cycles(t, gap, hs)
    assert cycles_gap.shape == (2, 101)
    assert 1.25 not in bounds_gap[:, 0]
    # implausible durations are rejected
    assert gait_cycles(t, values, np.array([0.0, 0.1]))[0].shape == (0, 101)
    assert gait_cycles(t, values, np.array([1.0]))[0].shape == (0, 101)


def test_floor_estimated_from_events() -> None:
    rng = np.random.default_rng(1)
    rot, t_vec = FLOOR.walker_transform()
    # footfalls on the floor: two feet 0.2 m apart, 0.5..1.2 m from the camera, 5 mm noise
    walker_pts = np.stack([rng.uniform(0.5, 1.2, 12), np.tile([-0.1, 0.1], 6), np.zeros(12)], axis=1)
    cam_pts = (walker_pts - t_vec) @ rot + rng.normal(0.0, 0.005, (12, 3))
    events = [GaitEvent(stamp=float(i), side=Side(i % 2), kind=EventKind(i // 2 % 2), position=p)
              for i, p in enumerate(cam_pts)]
    plane = estimate_floor_from_events(events)
    assert plane is not None
    assert float(plane.normal @ FLOOR.normal) > 0.99
    assert abs(plane.offset - FLOOR.offset) < 0.03
    np.testing.assert_allclose(plane.height(cam_pts), 0.0, atol=0.02)
    assert estimate_floor_from_events(events[:3]) is None
    # one foot only, all on a line: no plane
    line = [GaitEvent(stamp=0.0, side=Side.LEFT, kind=EventKind.HEEL_STRIKE, position=np.array([0.1, 0.5, z]))
            for z in np.linspace(0.5, 1.5, 6)]
    assert estimate_floor_from_events(line) is None
