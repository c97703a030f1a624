"""Tests for walker_gait/io/outputs.py: atomic writes, CSV schemas and round trips, summary.json."""

from __future__ import annotations

import csv
import json
import math
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from walker_gait import __version__
from walker_gait.core.types import (
    JOINT_NAMES,
    EventKind,
    GaitEvent,
    LegPose,
    Side,
    Step,
    TrackStatus,
)
from walker_gait.io.outputs import (
    DECIMALS,
    EVENTS_COLUMNS,
    JOINTS_COLUMNS,
    METADATA_KEYS,
    STEPS_COLUMNS,
    SUMMARY_JSON_KEYS,
    SUMMARY_SCHEMA,
    OutputFormatError,
    atomic_write,
    build_metadata,
    json_to_summary,
    read_events_csv,
    read_joints_csv,
    read_steps_csv,
    read_summary_json,
    summary_to_json,
    write_events_csv,
    write_joints_csv,
    write_steps_csv,
    write_summary_json,
)

REPO = Path(__file__).resolve().parents[2]

# --------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------


def _step(i: int, *, side: Side = Side.LEFT, nan_stride: bool = False) -> Step:
    return Step(
        stamp=1700000000.123456 + 0.6 * i,
        side=side,
        index=i,
        step_length=0.41234 + 0.01 * i,
        step_width=0.17,
        step_time=0.6,
        stride_length=math.nan if nan_stride else 0.8,
        stride_time=math.nan if nan_stride else 1.2,
        stance_time=0.74,
        swing_time=0.46,
        single_support_time=0.46,
        double_support_time=0.14,
        confidence=0.875,
    )


def _pose(t: float, *, nan: bool = False, status: TrackStatus = TrackStatus.TRACKING) -> LegPose:
    rng = np.random.default_rng(int(t * 1000))
    points = rng.uniform(-1.0, 2.0, size=(2, 5, 3))
    angles = rng.uniform(-1.5, 1.5, size=len(JOINT_NAMES))
    if nan:
        points[1, 3:] = np.nan
        angles[5] = np.nan
    return LegPose(stamp=t, points=points, angles=angles, status=status, confidence=0.75)


def _read_rows(path: Path) -> list[list[str]]:
    with open(path, encoding="utf-8", newline="") as fh:
        return list(csv.reader(fh))


def _same(a: float, b: float, decimals: int) -> bool:
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    if math.isinf(a) or math.isinf(b):
        return a == b
    return abs(a - b) <= 0.5 * 10.0**-decimals + 1e-9 * max(1.0, abs(a))


# --------------------------------------------------------------------------------------------
# schemas
# --------------------------------------------------------------------------------------------


def test_steps_and_events_columns_are_the_issue_5_schema() -> None:
    assert STEPS_COLUMNS == (
        "time", "foot", "step_length", "step_width", "step_time", "stride_length", "stride_time",
        "stance_time", "swing_time", "single_support_time", "double_support_time", "step_index", "confidence",
    )
    assert EVENTS_COLUMNS == ("time", "foot", "event", "x", "y", "z", "confidence")


def test_joints_columns() -> None:
    assert len(JOINTS_COLUMNS) == 1 + 2 * 5 * 3 + len(JOINT_NAMES) + 2
    assert JOINTS_COLUMNS[:4] == ("time", "left_hip_x", "left_hip_y", "left_hip_z")
    assert JOINTS_COLUMNS[13:16] == ("left_toe_x", "left_toe_y", "left_toe_z")
    assert JOINTS_COLUMNS[16] == "right_hip_x"
    assert JOINTS_COLUMNS[30] == "right_toe_z"
    assert JOINTS_COLUMNS[31:43] == JOINT_NAMES
    assert JOINTS_COLUMNS[-2:] == ("status", "confidence")
    assert len(set(JOINTS_COLUMNS)) == len(JOINTS_COLUMNS)


def test_docs_list_every_column_and_key() -> None:
    doc = (REPO / "docs" / "OUTPUTS.md").read_text(encoding="utf-8")
    for name in (*STEPS_COLUMNS, *EVENTS_COLUMNS, *SUMMARY_JSON_KEYS, *METADATA_KEYS, "left_hip_x", "status"):
        assert f"`{name}`" in doc, name


# --------------------------------------------------------------------------------------------
# steps.csv
# --------------------------------------------------------------------------------------------


def test_steps_csv_header_rows_and_nan_as_empty(tmp_path: Path) -> None:
    steps = [_step(0, nan_stride=True), _step(1, side=Side.RIGHT), _step(2)]
    path = tmp_path / "steps.csv"
    write_steps_csv(path, steps)
    raw = path.read_bytes()
    assert b"\r" not in raw and raw.endswith(b"\n")
    rows = _read_rows(path)
    assert tuple(rows[0]) == STEPS_COLUMNS
    assert len(rows) == 4
    first = dict(zip(STEPS_COLUMNS, rows[1], strict=True))
    assert first["time"] == "1700000000.123456"
    assert first["foot"] == "left"
    assert first["stride_length"] == "" and first["stride_time"] == ""
    assert first["step_index"] == "0"
    assert first["step_length"] == "0.41234"
    assert rows[2][1] == "right"
    assert "nan" not in raw.decode().lower()


def test_steps_csv_round_trip(tmp_path: Path) -> None:
    steps = [_step(0, nan_stride=True), _step(1, side=Side.RIGHT), _step(2)]
    path = tmp_path / "steps.csv"
    write_steps_csv(path, steps)
    back = read_steps_csv(path)
    assert len(back) == len(steps)
    for a, b in zip(steps, back, strict=True):
        assert b.side is a.side and b.index == a.index
        assert _same(a.stamp, b.stamp, DECIMALS["time"])
        for col in ("step_length", "step_width", "stride_length", "confidence", "stance_time"):
            kind = "length" if col in ("step_length", "step_width", "stride_length") else (
                "confidence" if col == "confidence" else "duration")
            assert _same(getattr(a, col), getattr(b, col), DECIMALS[kind]), col
    assert math.isnan(back[0].stride_length) and math.isnan(back[0].stride_time)


def test_empty_steps_csv_is_header_only(tmp_path: Path) -> None:
    path = tmp_path / "steps.csv"
    write_steps_csv(path, [])
    assert path.read_text() == ",".join(STEPS_COLUMNS) + "\n"
    assert read_steps_csv(path) == []


_finite_or_special = st.one_of(
    st.floats(min_value=-1e3, max_value=1e3, allow_nan=False, allow_infinity=False),
    st.just(math.nan),
    st.just(math.inf),
)


@settings(max_examples=60, deadline=None)
@given(
    stamp=st.floats(min_value=0.0, max_value=2e9, allow_nan=False),
    values=st.lists(_finite_or_special, min_size=9, max_size=9),
    conf=st.one_of(st.floats(min_value=0.0, max_value=1.0), st.just(math.nan)),
    side=st.sampled_from(list(Side)),
    index=st.integers(min_value=0, max_value=10**6),
)
def test_steps_round_trip_property(tmp_path_factory: pytest.TempPathFactory, stamp: float, values: list[float],
                                   conf: float, side: Side, index: int) -> None:
    names = ("step_length", "step_width", "step_time", "stride_length", "stride_time", "stance_time",
             "swing_time", "single_support_time", "double_support_time")
    step = Step(stamp=stamp, side=side, index=index, confidence=conf, **dict(zip(names, values, strict=True)))
    path = tmp_path_factory.mktemp("prop") / "steps.csv"
    write_steps_csv(path, [step])
    (back,) = read_steps_csv(path)
    assert back.side is side and back.index == index
    assert _same(stamp, back.stamp, DECIMALS["time"])
    assert _same(conf, back.confidence, DECIMALS["confidence"])
    for name, value in zip(names, values, strict=True):
        assert _same(value, getattr(back, name), 5), (name, value, getattr(back, name))


def test_reader_accepts_nan_text_and_rejects_bad_files(tmp_path: Path) -> None:
    path = tmp_path / "steps.csv"
    write_steps_csv(path, [_step(0)])
    rows = _read_rows(path)
    rows[1][STEPS_COLUMNS.index("step_width")] = "nan"
    with open(path, "w", newline="") as fh:
        csv.writer(fh, lineterminator="\n").writerows(rows)
    assert math.isnan(read_steps_csv(path)[0].step_width)

    bad_header = tmp_path / "bad_header.csv"
    bad_header.write_text("time,foot\n1.0,left\n")
    with pytest.raises(OutputFormatError, match="header"):
        read_steps_csv(bad_header)

    bad_foot = tmp_path / "bad_foot.csv"
    rows[1][1] = "middle"
    with open(bad_foot, "w", newline="") as fh:
        csv.writer(fh, lineterminator="\n").writerows(rows)
    with pytest.raises(OutputFormatError, match="foot"):
        read_steps_csv(bad_foot)

    short = tmp_path / "short.csv"
    short.write_text(",".join(STEPS_COLUMNS) + "\n1.0,left\n")
    with pytest.raises(OutputFormatError, match="fields"):
        read_steps_csv(short)

    empty = tmp_path / "empty.csv"
    empty.write_text("")
    with pytest.raises(OutputFormatError, match="empty"):
        read_steps_csv(empty)
    assert issubclass(OutputFormatError, ValueError)


# --------------------------------------------------------------------------------------------
# events.csv
# --------------------------------------------------------------------------------------------


def test_events_csv_schema_and_round_trip(tmp_path: Path) -> None:
    events = [
        GaitEvent(stamp=10.0, side=Side.LEFT, kind=EventKind.HEEL_STRIKE, position=np.array([0.1, 0.6, 1.2]),
                  confidence=0.9),
        GaitEvent(stamp=10.35, side=Side.RIGHT, kind=EventKind.TOE_OFF,
                  position=np.array([-0.1, np.nan, 1.1]), confidence=0.5),
    ]
    path = tmp_path / "events.csv"
    write_events_csv(path, events)
    rows = _read_rows(path)
    assert tuple(rows[0]) == EVENTS_COLUMNS
    assert rows[1][:3] == ["10.000000", "left", "heel_strike"]
    assert rows[2][:3] == ["10.350000", "right", "toe_off"]
    assert rows[2][4] == ""
    back = read_events_csv(path)
    for a, b in zip(events, back, strict=True):
        assert (b.side, b.kind) == (a.side, a.kind)
        assert b.stamp == pytest.approx(a.stamp, abs=1e-6)
        np.testing.assert_allclose(b.position, a.position, atol=1e-5, equal_nan=True)
        assert b.confidence == pytest.approx(a.confidence, abs=1e-4)


def test_events_csv_rejects_bad_position(tmp_path: Path) -> None:
    bad = GaitEvent(stamp=1.0, side=Side.LEFT, kind=EventKind.HEEL_STRIKE, position=np.zeros(2))
    path = tmp_path / "events.csv"
    path.write_text("previous")
    with pytest.raises(ValueError, match="3 elements"):
        write_events_csv(path, [bad])
    assert path.read_text() == "previous"


# --------------------------------------------------------------------------------------------
# joints.csv
# --------------------------------------------------------------------------------------------


def test_joints_csv_schema_and_round_trip(tmp_path: Path) -> None:
    poses = [_pose(5.0), _pose(5.033, nan=True, status=TrackStatus.DEGRADED),
             LegPose(stamp=5.066, points=np.full((2, 5, 3), np.nan), status=TrackStatus.NO_USER, confidence=0.0)]
    path = tmp_path / "joints.csv"
    write_joints_csv(path, poses)
    rows = _read_rows(path)
    assert tuple(rows[0]) == JOINTS_COLUMNS
    assert len(rows) == 4
    rec = dict(zip(JOINTS_COLUMNS, rows[2], strict=True))
    assert rec["status"] == "degraded"
    assert rec["right_heel_x"] == "" and rec["left_heel_x"] != ""
    assert float(rec["left_knee_y"]) == pytest.approx(poses[1].points[0, 1, 1], abs=1e-5)
    assert float(rec["right_knee_flexion"]) == pytest.approx(poses[1].angles[9], abs=1e-6)
    back = read_joints_csv(path)
    assert [p.status for p in back] == [TrackStatus.TRACKING, TrackStatus.DEGRADED, TrackStatus.NO_USER]
    for a, b in zip(poses, back, strict=True):
        assert b.stamp == pytest.approx(a.stamp, abs=1e-6)
        np.testing.assert_allclose(b.points, a.points, atol=5e-6, equal_nan=True)
        np.testing.assert_allclose(b.angles, a.angles, atol=5e-7, equal_nan=True)
        assert b.confidence == pytest.approx(a.confidence, abs=1e-4)


def test_joints_csv_rejects_bad_shapes(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="shape"):
        write_joints_csv(tmp_path / "j.csv", [LegPose(stamp=0.0, points=np.zeros((2, 4, 3)))])
    with pytest.raises(ValueError, match="angles"):
        write_joints_csv(tmp_path / "j.csv", [LegPose(stamp=0.0, points=np.zeros((2, 5, 3)), angles=np.zeros(3))])
    assert not (tmp_path / "j.csv").exists()
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------------------------
# atomic_write
# --------------------------------------------------------------------------------------------


def test_atomic_write_replaces_on_success(tmp_path: Path) -> None:
    target = tmp_path / "out.txt"
    target.write_text("old")
    with atomic_write(target) as fh:
        fh.write("new ")
        assert target.read_text() == "old"  # not visible until the block ends
        fh.write("content")
    assert target.read_text() == "new content"
    assert [p.name for p in tmp_path.iterdir()] == ["out.txt"]


def test_atomic_write_binary(tmp_path: Path) -> None:
    target = tmp_path / "blob.bin"
    with atomic_write(target, mode="wb") as fh:
        fh.write(b"\x00\x01\x02")
    assert target.read_bytes() == b"\x00\x01\x02"


@pytest.mark.parametrize("exc_type", [RuntimeError, KeyboardInterrupt])
def test_atomic_write_keeps_old_file_on_exception(tmp_path: Path, exc_type: type[BaseException]) -> None:
    target = tmp_path / "steps.csv"
    target.write_text("old content\n")
    with pytest.raises(exc_type):
        with atomic_write(target) as fh:
            fh.write("half a fi")
            raise exc_type("boom")
    assert target.read_text() == "old content\n"
    assert [p.name for p in tmp_path.iterdir()] == ["steps.csv"]


@pytest.mark.parametrize("exc_type", [RuntimeError, KeyboardInterrupt])
def test_atomic_write_leaves_no_file_on_exception(tmp_path: Path, exc_type: type[BaseException]) -> None:
    target = tmp_path / "summary.json"
    with pytest.raises(exc_type):
        with atomic_write(target) as fh:
            fh.write("{")
            raise exc_type
    assert list(tmp_path.iterdir()) == []


def test_writer_failing_mid_way_keeps_old_file(tmp_path: Path) -> None:
    target = tmp_path / "steps.csv"
    write_steps_csv(target, [_step(0)])
    before = target.read_bytes()

    def steps():
        yield _step(0)
        yield _step(1)
        raise KeyboardInterrupt  # Ctrl-C while the rows are being produced

    with pytest.raises(KeyboardInterrupt):
        write_steps_csv(target, steps())
    assert target.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["steps.csv"]


def test_atomic_write_permissions(tmp_path: Path) -> None:
    target = tmp_path / "new.txt"
    with atomic_write(target) as fh:
        fh.write("x")
    umask = os.umask(0)
    os.umask(umask)
    assert target.stat().st_mode & 0o777 == 0o666 & ~umask  # not mkstemp's 0o600
    target.chmod(0o640)
    with atomic_write(target) as fh:
        fh.write("y")
    assert target.stat().st_mode & 0o777 == 0o640  # replaced file keeps its permissions


def test_atomic_write_argument_errors(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="mode"):
        with atomic_write(tmp_path / "x", mode="a"):  # type: ignore[arg-type]
            pass
    with pytest.raises(FileNotFoundError):
        with atomic_write(tmp_path / "missing_dir" / "x"):
            pass
    assert list(tmp_path.iterdir()) == []


def test_atomic_write_survives_hard_kill(tmp_path: Path) -> None:
    """A process killed (SIGKILL) mid-write leaves the previous file complete under the final name."""
    target = tmp_path / "joints.csv"
    target.write_text("complete previous file\n")
    script = textwrap.dedent(
        f"""
        import sys, time
        sys.path.insert(0, {str(REPO)!r})
        from walker_gait.io.outputs import atomic_write
        with atomic_write({str(target)!r}) as fh:
            fh.write("partial" * 1000)
            fh.flush()
            print("writing", flush=True)
            time.sleep(30)
        """
    )
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        assert proc.stdout.readline().strip() == "writing"
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert target.read_text() == "complete previous file\n"
    leftovers = [p.name for p in tmp_path.iterdir() if p.name != "joints.csv"]
    assert len(leftovers) == 1 and leftovers[0].startswith(".joints.csv.") and leftovers[0].endswith(".tmp")


# --------------------------------------------------------------------------------------------
# summary.json
# --------------------------------------------------------------------------------------------


def _summary() -> dict:
    return {
        "scope": 1,
        "window_duration": 0.0,
        "duration": 9.6,
        "step_count": 16,
        "cadence": 100.0,
        "gait_speed": 0.65,
        "step_length_mean": 0.40,
        "step_width_mean": 0.18,
        "step_time_mean": 0.6,
        "step_length_mean_side": np.array([0.42, 0.38], dtype=np.float32),
        "step_length_sd_side": [0.02, math.nan],
        "step_length_cv_side": (4.8, 5.5),
        "step_width_mean_side": [0.18, 0.18],
        "step_width_sd_side": [0.01, 0.01],
        "step_width_cv_side": [5.6, 5.5],
        "step_time_mean_side": [0.6, 0.6],
        "step_time_sd_side": [0.01, 0.02],
        "step_time_cv_side": [1.7, 3.3],
        "stance_percent_side": [62.0, 61.0],
        "swing_percent_side": [38.0, 39.0],
        "double_support_percent": 24.0,
        "step_length_symmetry": 0.42 / 0.38,
        "swing_time_symmetry": math.nan,
        "mean_confidence": np.float32(0.85),
    }


def test_summary_to_json_keys_units_and_nan() -> None:
    out = summary_to_json(_summary())
    assert set(SUMMARY_JSON_KEYS) <= set(out)
    assert out["cadence_steps_per_min"] == 100.0
    assert out["gait_speed_m_per_s"] == 0.65
    assert out["step_length_mean_m"] == 0.40
    assert out["step_length_mean_left_m"] == pytest.approx(0.42, abs=1e-6)
    assert out["step_length_mean_right_m"] == pytest.approx(0.38, abs=1e-6)
    assert out["step_length_sd_right_m"] is None
    assert out["step_length_cv_left_percent"] == 4.8
    assert out["stance_left_percent"] == 62.0 and out["swing_right_percent"] == 39.0
    assert out["double_support_percent"] == 24.0
    assert out["swing_time_symmetry_ratio"] is None
    assert out["scope"] == "session"
    assert out["step_count"] == 16 and isinstance(out["step_count"], int)
    assert isinstance(out["mean_confidence"], float)
    assert "extra" not in out
    unitless = {"scope", "step_count", "mean_confidence"}
    suffixes = ("_s", "_m", "_m_per_s", "_steps_per_min", "_percent", "_ratio")
    for key in SUMMARY_JSON_KEYS:
        assert key in unitless or key.endswith(suffixes), key
    json.dumps(out, allow_nan=False)


def test_summary_to_json_missing_extra_idempotent_and_errors() -> None:
    empty = summary_to_json({})
    assert set(empty) == set(SUMMARY_JSON_KEYS)
    assert all(v is None for v in empty.values())
    out = summary_to_json({**_summary(), "header": {"stamp": 12.5, "frame_id": "cam"}, "new_field": np.int64(3)})
    assert out["stamp_s"] == 12.5
    assert out["extra"] == {"new_field": 3}
    assert summary_to_json(out) == out  # idempotent on already-mapped dicts
    with pytest.raises(ValueError, match="2 values"):
        summary_to_json({"step_length_mean_side": [0.4]})

    class FakeSummaryData:  # stands in for core.gait.GaitSummaryData
        def to_dict(self) -> dict:
            return _summary()

    assert summary_to_json(FakeSummaryData()) == summary_to_json(_summary())  # type: ignore[arg-type]
    with pytest.raises(TypeError):
        summary_to_json([1, 2])  # type: ignore[arg-type]


def test_write_summary_json_strict_json_metadata_and_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "summary.json"
    meta = build_metadata(input_file=Path("/data/walk.mcap"), preset="default", seed=7, frames_processed=300,
                          frames_skipped={"decode_error": 2, "no_camera_info": 1}, processing_time_s=math.nan,
                          topic="/camera/depth/image_raw")
    written = write_summary_json(path, _summary(), metadata=meta)
    text = path.read_text(encoding="utf-8")

    def no_constants(name: str) -> None:
        raise AssertionError(f"non-standard JSON constant {name}")

    data = json.loads(text, parse_constant=no_constants)
    assert data == written == read_summary_json(path)
    assert data["schema"] == SUMMARY_SCHEMA
    assert data["cadence_steps_per_min"] == 100.0
    assert data["step_length_sd_right_m"] is None
    md = data["metadata"]
    assert set(METADATA_KEYS) <= set(md)
    assert md["input_file"] == "/data/walk.mcap"
    assert md["preset"] == "default" and md["seed"] == 7
    assert md["frames_processed"] == 300
    assert md["frames_skipped"] == {"decode_error": 2, "no_camera_info": 1}
    assert md["frames_skipped_total"] == 3
    assert md["walker_gait_version"] == __version__
    assert md["processing_time_s"] is None  # NaN -> null
    assert md["topic"] == "/camera/depth/image_raw"
    back = json_to_summary(data)
    orig = _summary()
    for name, value in orig.items():
        if name == "scope":
            assert back[name] == "session"
            continue
        np.testing.assert_allclose(np.asarray(back[name], dtype=float), np.asarray(value, dtype=float),
                                   rtol=1e-6, equal_nan=True)


def test_write_summary_json_minimal_metadata_is_completed(tmp_path: Path) -> None:
    path = tmp_path / "summary.json"
    write_summary_json(path, {"cadence": math.inf}, metadata={"input_file": "x.bag"})
    data = read_summary_json(path)
    assert data["cadence_steps_per_min"] is None
    assert set(METADATA_KEYS) <= set(data["metadata"])
    assert data["metadata"]["frames_skipped"] == {} and data["metadata"]["frames_skipped_total"] == 0
    assert data["metadata"]["seed"] is None


def test_write_summary_json_unserialisable_keeps_old_file(tmp_path: Path) -> None:
    path = tmp_path / "summary.json"
    path.write_text("{}")
    with pytest.raises(TypeError):
        write_summary_json(path, {"cadence": 1.0}, metadata={"callback": object()})
    assert path.read_text() == "{}"
    with pytest.raises(ValueError, match="frames_skipped"):
        write_summary_json(path, {}, metadata={"frames_skipped": 3})


def test_read_summary_json_rejects_other_files(tmp_path: Path) -> None:
    path = tmp_path / "summary.json"
    path.write_text('{"cadence": 3}')
    with pytest.raises(OutputFormatError):
        read_summary_json(path)
    path.write_text("{not json")
    with pytest.raises(OutputFormatError):
        read_summary_json(path)
