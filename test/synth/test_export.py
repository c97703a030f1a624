"""Export of synthetic sessions: every format reads back with rosbags' AnyReader."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from rosbags.highlevel import AnyReader

from walker_gait.synth.cli import main
from walker_gait.synth.contact_sheet import write_contact_sheet
from walker_gait.synth.export import DEPTH_TOPIC, INFO_TOPIC, RGB_TOPIC, gt_path_for, write_session
from walker_gait.synth.session import Session, SessionSpec, generate_session


@pytest.fixture(scope="module")
def session() -> Session:
    spec = SessionSpec.preset("normal", duration=0.4, scale=0.25)
    return generate_session(spec, rng=np.random.default_rng(2))


def _read(path: Path) -> dict[str, list[tuple[int, object]]]:
    out: dict[str, list[tuple[int, object]]] = {}
    with AnyReader([path]) as reader:
        for conn, t, raw in reader.messages():
            out.setdefault(conn.topic, []).append((t, reader.deserialize(raw, conn.msgtype)))
    return out


def _field(msg: object, name: str) -> np.ndarray:
    return np.asarray(getattr(msg, name) if hasattr(msg, name) else getattr(msg, name.upper()))


@pytest.mark.parametrize(
    ("fmt", "name", "encoding"),
    [
        ("mcap", "s.mcap", "16UC1"),
        ("mcap", "sdir", "32FC1"),
        ("sqlite3", "s.db3", "kinect_raw"),
        ("sqlite3", "sdir", "16UC1"),
        ("ros1", "s.bag", "16UC1"),
        ("ros1", "s.bag", "32FC1"),
    ],
)
def test_formats_read_back(session: Session, tmp_path: Path, fmt: str, name: str, encoding: str) -> None:
    path = tmp_path / name
    write_session(session, path, fmt=fmt, encoding=encoding)  # type: ignore[arg-type]
    assert path.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temp leftovers
    msgs = _read(path)
    assert set(msgs) == {DEPTH_TOPIC, INFO_TOPIC, RGB_TOPIC}
    n = len(session)
    assert len(msgs[DEPTH_TOPIC]) == n and len(msgs[INFO_TOPIC]) == n
    assert 1 <= len(msgs[RGB_TOPIC]) < n
    intr = session.intrinsics
    for i, ((t, img), (t2, info)) in enumerate(zip(msgs[DEPTH_TOPIC], msgs[INFO_TOPIC], strict=True)):
        stamp = img.header.stamp.sec + img.header.stamp.nanosec * 1e-9  # type: ignore[attr-defined]
        assert stamp == pytest.approx(session.stamps[i], abs=1e-9)
        assert t == t2 == round(session.stamps[i] * 1e9)
        assert (img.width, img.height) == (intr.width, intr.height)  # type: ignore[attr-defined]
        data = np.asarray(img.data, dtype=np.uint8)  # type: ignore[attr-defined]
        if encoding == "32FC1":
            assert img.encoding == "32FC1" and img.step == intr.width * 4  # type: ignore[attr-defined]
            z = data.view("<f4").reshape(intr.height, intr.width)
            np.testing.assert_array_equal(z, session.depth_m(i))
        else:
            assert img.encoding == "16UC1" and img.step == intr.width * 2  # type: ignore[attr-defined]
            arr = data.view("<u2").reshape(intr.height, intr.width)
            want = session.frame(i).data if encoding == "kinect_raw" else session.depth_mm(i)
            np.testing.assert_array_equal(arr, want)
        assert info.distortion_model == "plumb_bob"  # type: ignore[attr-defined]
        np.testing.assert_allclose(_field(info, "k"), [intr.fx, 0, intr.cx, 0, intr.fy, intr.cy, 0, 0, 1])
        np.testing.assert_allclose(_field(info, "p")[[0, 2, 5, 6]], [intr.fx, intr.cx, intr.fy, intr.cy])
        assert len(_field(info, "d")) == 5
    rgb = msgs[RGB_TOPIC][0][1]
    assert rgb.encoding == "rgb8"  # type: ignore[attr-defined]
    gt = json.loads(gt_path_for(path).read_text())
    assert gt["depth_encoding"] == encoding
    np.testing.assert_allclose(np.array(gt["frames"]["leg_points"], float), session.leg_points, atol=1e-5)
    np.testing.assert_allclose(gt["floor"]["normal"], session.floor.normal, atol=1e-8)
    assert gt["intrinsics"]["fx"] == intr.fx


def test_gt_json_contents(session: Session, tmp_path: Path) -> None:
    s = generate_session(SessionSpec.preset("normal", duration=4.0, scale=0.1), rng=np.random.default_rng(1))
    path = write_session(s, tmp_path / "x.mcap", rgb=False)
    gt = json.loads(gt_path_for(path).read_text())
    assert gt_path_for(path) == tmp_path / "x.gt.json"
    assert len(gt["steps"]) == len(s.steps) > 0
    assert {e["kind"] for e in gt["events"]} == {"heel_strike", "toe_off"}
    ev = gt["events"][0]
    assert len(ev["position_camera"]) == 3 and ev["side"] in ("left", "right")
    assert gt["steps"][0]["stride_length"] is None or gt["steps"][0]["stride_length"] > 0
    assert np.array(gt["frames"]["walker_pose"]).shape == (len(s), 3)
    vis = np.array(gt["frames"]["visible_pixels"])
    assert vis.shape == (len(s), 2) and vis.min() >= 0 and vis.max() > 0
    assert gt["frames"]["walker_tilt_rad"] is None and gt["frames"]["floor_per_frame"] is None  # a rigid walker


def test_cli_writes_a_rocking_walkers_floor_per_frame(tmp_path: Path) -> None:
    out = tmp_path / "rock.mcap"
    assert main(["--duration", "2.0", "--scale", "0.1", "--out", str(out), "--seed", "2", "--vibration", "1.5", "--quiet"]) == 0
    gt = json.loads(gt_path_for(out).read_text())
    assert gt["spec"]["vibration_deg"] == [1.5, 1.5]
    s = generate_session(SessionSpec.preset("normal", duration=2.0, scale=0.1, vibration_deg=(1.5, 1.5)),
                         rng=np.random.default_rng(2))
    floors = gt["frames"]["floor_per_frame"]
    assert len(floors) == len(s) == len(gt["frames"]["walker_tilt_rad"])
    for i in (0, len(s) // 2, len(s) - 1):
        np.testing.assert_allclose(floors[i]["normal"], s.floor_at(i).normal, atol=1e-8)
        assert floors[i]["offset"] == pytest.approx(s.floor_at(i).offset)
    assert np.ptp(np.array([f["normal"] for f in floors]), axis=0).max() > 0.005  # it rocks
    assert main(["--out", str(tmp_path / "bad.mcap"), "--vibration", "-1", "--quiet"]) == 2


def test_existing_output_not_overwritten(session: Session, tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    write_session(session, path)
    before = path.read_bytes()
    with pytest.raises(Exception, match="exists"):
        write_session(session, path)
    assert path.read_bytes() == before
    write_session(session, path, overwrite=True, encoding="32FC1")
    assert path.read_bytes() != before


def test_cli_and_contact_sheet(tmp_path: Path) -> None:
    out = tmp_path / "cli.mcap"
    sheet = tmp_path / "sheet.png"
    rc = main(["--scenario", "occlusion", "--duration", "0.5", "--scale", "0.25", "--out", str(out), "--seed", "3", "--contact-sheet", str(sheet), "--quiet"])
    assert rc == 0 and out.is_file() and sheet.is_file() and (tmp_path / "cli.gt.json").is_file()
    assert sheet.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(SystemExit):
        main(["--scenario", "nope", "--out", str(out)])
    assert main(["--scenario", "normal", "--duration", "0.2", "--scale", "0.1", "--out", str(out), "--quiet"]) == 1  # exists


def test_contact_sheet_direct(session: Session, tmp_path: Path) -> None:
    p = write_contact_sheet(session, tmp_path / "c.png", n_frames=4, columns=2, tile_width=80)
    assert p.is_file()
