"""Offline pipeline: the frame-preparing worker process and the background report change nothing but speed.

`process_recording` decodes and segments frames in a forked worker (``prefetch``) and draws the report in
a second process; results, warnings and errors must be exactly those of the inline path.
"""

from __future__ import annotations

import dataclasses
import gc
import os
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from walker_gait.io.bags import Recording, RecordingError, RecordingWarning
from walker_gait.pipeline import PipelineOptions, PreparedFrame, ProcessResult, process_recording


@pytest.fixture(scope="module")
def short_session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from walker_gait.synth import SessionSpec, generate_session, write_session

    session = generate_session(SessionSpec.preset("normal", duration=2.5, scale=0.5), rng=np.random.default_rng(3))
    path = tmp_path_factory.mktemp("session") / "walk.mcap"
    write_session(session, path, fmt="mcap", encoding="16UC1")
    return path


def _options(prefetch: int, **kwargs: Any) -> PipelineOptions:
    return PipelineOptions(**{"seed": 4, "prefetch": prefetch, "write_mcap": False, "write_report": False, **kwargs})


def test_prefetch_worker_gives_identical_results(short_session: Path, tmp_path: Path) -> None:
    inline = process_recording(short_session, tmp_path / "inline", options=_options(0), progress=False)
    ahead = process_recording(short_session, tmp_path / "ahead", options=_options(3), progress=False)
    assert ahead.frames == inline.frames == 75
    for name in ("joints.csv", "steps.csv", "events.csv"):
        assert (tmp_path / "ahead" / name).read_bytes() == (tmp_path / "inline" / name).read_bytes(), name
    np.testing.assert_array_equal([p.points for p in ahead.poses], [p.points for p in inline.poses])
    assert [(s.stamp, s.side, s.step_length, s.step_width) for s in ahead.steps] == \
        [(s.stamp, s.side, s.step_length, s.step_width) for s in inline.steps]


def test_worker_backward_pass_is_scored_here_as_inline(short_session: Path) -> None:
    """The worker tracks backwards and sends its states and its poses' pending feet measures; this process scores
    them and takes the measures on the frames read back from the worker's store: the same poses (toes measured from
    the data, shoes' rise and turn) and scores as the backward pass run and scored in one process."""
    from walker_gait.io.bags import open_recording
    from walker_gait.pipeline import FrameProcessor, _Front

    proc = FrameProcessor(_options(3, tracker_runs=2))
    frames = []
    with _Front(open_recording(short_session), proc, prefetch=3, two_way=True) as front:
        assert front.forked
        for _, prepared in front.frames():
            assert proc.track(prepared) is None  # the forward pass; its results come at the end
            frames.append(prepared)
        passes = front.backward()
    assert passes is not None and len(passes) == proc.options.tracker_runs == 2  # one per run
    for run, worker in enumerate(passes):
        inline = FrameProcessor(_options(0, tracker_runs=2)).backward(frames, run=run)
        assert len(worker.poses) == len(frames) == 75
        assert np.isfinite(worker.scores).sum() >= 60  # scored, not left NaN or -inf
        np.testing.assert_array_equal(worker.scores, inline.scores)
        np.testing.assert_array_equal([p.points for p in worker.poses], [p.points for p in inline.poses])
        for name in ("shoe_rise", "shoe_turn"):
            got = [np.full(2, -1.0) if getattr(p, name) is None else getattr(p, name) for p in worker.poses]
            want = [np.full(2, -1.0) if getattr(p, name) is None else getattr(p, name) for p in inline.poses]
            np.testing.assert_array_equal(got, want)
            assert np.isfinite(got).sum() >= 60
        assert (worker.scoring_ms > 0).all()
    # the runs are independent trackings (each on a random stream of its own), not one tracking twice
    both = np.array([[p.points for p in w.poses] for w in passes])
    assert np.nanmax(np.abs(both[0] - both[1])) > 1e-3


def test_prepared_frame_pickles_with_sparse_depth() -> None:
    import pickle

    from walker_gait.core.types import CameraIntrinsics, FloorPlane

    depth = np.full((6, 8), np.nan, dtype=np.float32)
    depth[2, 3], depth[5, 7] = 1.25, 0.5
    no_depth = np.zeros((6, 8), dtype=bool)
    no_depth[0, 1:6] = True
    frame = PreparedFrame(stamp=1.0, intrinsics=CameraIntrinsics(width=8, height=6, fx=5.0, fy=5.0, cx=4.0, cy=3.0),
                          points=np.ones((2, 3)), depth_fg=depth,
                          floor=FloorPlane(normal=np.array([0.0, -1.0, 0.0]), offset=0.5), timings_ms={"depth": 1.0},
                          no_depth=no_depth)
    back = pickle.loads(pickle.dumps(frame))
    np.testing.assert_array_equal(back.no_depth, no_depth)
    assert back.no_depth.dtype == bool
    assert pickle.loads(pickle.dumps(dataclasses.replace(frame, no_depth=None))).no_depth is None
    np.testing.assert_array_equal(back.depth_fg, depth)
    assert back.depth_fg.dtype == np.float32 and back.depth_fg.shape == (6, 8)
    assert back.intrinsics == frame.intrinsics and back.stamp == 1.0
    np.testing.assert_array_equal(back.floor.normal, frame.floor.normal)


def _patch_frames(monkeypatch: pytest.MonkeyPatch, *, at: int, action: str) -> None:
    """Make ``Recording.iter_frames`` warn or fail at frame ``at`` (inherited by the forked worker)."""
    original = Recording.iter_frames

    def frames(self: Recording) -> Any:
        for i, frame in enumerate(original(self)):
            if i == at:
                if action == "fail":
                    raise RecordingError(f"{self.path}: damaged chunk at frame {at}")
                warnings.warn(f"{self.path}: odd frame {at}", RecordingWarning, stacklevel=2)
            yield frame

    monkeypatch.setattr(Recording, "iter_frames", frames)


@pytest.mark.parametrize("prefetch", [0, 3])
def test_reading_warning_reaches_the_caller(short_session: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                            prefetch: int) -> None:
    _patch_frames(monkeypatch, at=4, action="warn")
    with pytest.warns(RecordingWarning, match="odd frame 4"):
        res = process_recording(short_session, tmp_path / "out", options=_options(prefetch), progress=False)
    assert res.frames == 75


@pytest.mark.parametrize("prefetch", [0, 3])
def test_reading_error_is_raised_in_the_caller(short_session: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                               prefetch: int) -> None:
    _patch_frames(monkeypatch, at=5, action="fail")
    with pytest.raises(RecordingError, match="damaged chunk at frame 5"):
        process_recording(short_session, tmp_path / "out", options=_options(prefetch), progress=False)
    assert not (tmp_path / "out" / "steps.csv").exists()


def failing_report(path: Path, **kwargs: Any) -> None:
    """Stands in for ``write_report`` (module level: the background process looks it up by name)."""
    raise OSError(f"{path}: disk full")


def test_report_process_failure_is_raised_and_other_outputs_written(short_session: Path, tmp_path: Path,
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    import walker_gait.report

    monkeypatch.setattr(walker_gait.report, "write_report", failing_report)
    out = tmp_path / "out"
    with pytest.raises(OSError, match="disk full"):
        process_recording(short_session, out, options=PipelineOptions(seed=4, write_mcap=False), progress=False)
    assert (out / "steps.csv").is_file() and not (out / "report.html").exists()


@pytest.mark.parametrize("fmt", ["sqlite3", "ros1"])
def test_prefetch_worker_reads_every_format(tmp_path: Path, fmt: str) -> None:
    """The forked worker reads rosbag2/sqlite3 (an inherited SQLite connection) and ROS 1 bags as well."""
    from walker_gait.synth import SessionSpec, generate_session, write_session

    session = generate_session(SessionSpec.preset("normal", duration=1.0, scale=0.5), rng=np.random.default_rng(5))
    path = tmp_path / ("walk.bag" if fmt == "ros1" else "walk")
    write_session(session, path, fmt=fmt, encoding="16UC1")
    inline = process_recording(path, tmp_path / "inline", options=_options(0), progress=False)
    ahead = process_recording(path, tmp_path / "ahead", options=_options(2), progress=False)
    assert ahead.frames == inline.frames == 30
    assert (tmp_path / "ahead" / "joints.csv").read_bytes() == (tmp_path / "inline" / "joints.csv").read_bytes()


def _mcap_convert_ros1(bag: Path, out: Path) -> None:
    """What ``mcap convert`` makes of a ROS 1 bag: a ROS 1 profile MCAP with the bag's own definitions and bytes."""
    from mcap.writer import Writer as McapWriter
    from rosbags.rosbag1 import Reader

    with Reader(bag) as reader, out.open("wb") as f:
        writer = McapWriter(f)
        writer.start(profile="ros1", library="test")
        channels = {}
        for c in reader.connections:
            sid = writer.register_schema(name=c.msgtype.replace("/msg/", "/"), encoding="ros1msg",
                                         data=c.msgdef.data.encode())
            channels[c.id] = writer.register_channel(topic=c.topic, message_encoding="ros1", schema_id=sid,
                                                     metadata={"md5sum": c.digest})
        for c, t, raw in reader.messages():
            writer.add_message(channels[c.id], log_time=t, data=raw, publish_time=t)
        writer.finish()


def test_ros1_profile_mcap_gives_the_results_of_its_bag(tmp_path: Path) -> None:
    """A ROS 1 bag converted to MCAP (``mcap convert``, as Foxglove users do) is read and processed like the
    bag itself (rosbags reads only ROS 2 profile MCAPs; it was refused as "corrupt or truncated")."""
    from walker_gait.synth import SessionSpec, generate_session, write_session

    session = generate_session(SessionSpec.preset("normal", duration=1.0, scale=0.5), rng=np.random.default_rng(5))
    bag = tmp_path / "walk.bag"
    write_session(session, bag, fmt="ros1", encoding="16UC1")
    _mcap_convert_ros1(bag, tmp_path / "walk.mcap")
    with warnings.catch_warnings():
        warnings.simplefilter("error", RecordingWarning)  # nothing to warn about
        from_bag = process_recording(bag, tmp_path / "bag", options=_options(2), progress=False)
        from_mcap = process_recording(tmp_path / "walk.mcap", tmp_path / "mcap", options=_options(2), progress=False)
    assert from_mcap.frames == from_bag.frames == 30
    assert (tmp_path / "mcap" / "joints.csv").read_bytes() == (tmp_path / "bag" / "joints.csv").read_bytes()


def test_repeated_and_out_of_order_frames_are_skipped(short_session: Path, tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    """A depth image recorded twice and one whose stamp goes back are skipped with one warning and counted
    (the gait analyzer raised 'stamps must increase' and `process` died)."""
    import dataclasses
    import json

    original = Recording.iter_frames

    def frames(self: Recording) -> Any:
        for i, frame in enumerate(original(self)):
            if i == 20:
                yield frame
            if i == 30:
                frame = dataclasses.replace(frame, stamp_ns=frame.stamp_ns - 200_000_000, stamp=frame.stamp - 0.2)
            yield frame

    monkeypatch.setattr(Recording, "iter_frames", frames)
    res = process_recording(short_session, tmp_path / "out", options=_options(2), progress=False)
    assert len(res.poses) == 75 - 1
    assert [p.stamp for p in res.poses] == sorted({p.stamp for p in res.poses})
    meta = json.loads((tmp_path / "out" / "summary.json").read_text())["metadata"]
    assert meta["frames_total"] == 76 and meta["frames_skipped"] == {"stamp_not_increasing": 2}
    assert capsys.readouterr().err.count("is not after the previous frame") == 1


def test_frames_without_a_floor_are_tracked_as_no_user(short_session: Path, tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    """A recording whose first frames are blank (lens covered: no floor can be found yet) and which goes blank
    again mid-walk: every frame gets a pose (NO_USER while there is no floor; a track coasts through a short
    blackout) and the outputs are written (the tracker raised on the first frame before)."""
    import dataclasses

    from walker_gait.core.types import TrackStatus

    original = Recording.iter_frames
    blank = set(range(8)) | set(range(40, 44))

    def frames(self: Recording) -> Any:
        for i, frame in enumerate(original(self)):
            yield dataclasses.replace(frame, data=np.zeros_like(frame.data)) if i in blank else frame

    monkeypatch.setattr(Recording, "iter_frames", frames)
    res = process_recording(short_session, tmp_path / "out", options=PipelineOptions(seed=4, write_mcap=False),
                            progress=False)
    assert res.frames == 75 and len(res.poses) == 75
    assert all(res.poses[i].status == TrackStatus.NO_USER for i in range(8))
    assert all(res.poses[i].status in (TrackStatus.DEGRADED, TrackStatus.NO_USER) for i in range(40, 44))
    assert any(p.status == TrackStatus.TRACKING for p in res.poses[8:40])
    for name in ("joints.csv", "steps.csv", "events.csv", "summary.json", "report.html"):
        assert (tmp_path / "out" / name).is_file(), name


def test_frame_store_reads_frames_back_bit_for_bit(short_session: Path, tmp_path: Path) -> None:
    """The store keeps a frame without its points and recomputes them from the foreground depth: the frames that
    come back (from the temporary file: no memory allowance) are those that went in, in any order."""
    from types import SimpleNamespace

    from walker_gait.io.bags import open_recording
    from walker_gait.pipeline import FrameProcessor, FrameStore

    proc = FrameProcessor(_options(0))
    frames = []
    for i, fr in enumerate(open_recording(short_session).iter_frames()):
        if i % 9:
            continue
        proc.set_camera_info(SimpleNamespace(**{k: getattr(fr.camera_info, k) for k in
                                                ("width", "height", "k", "d", "p", "distortion_model")}))
        frames.append(proc.prepare(stamp=fr.stamp, data=fr.data, encoding=fr.encoding, width=fr.width,
                                   height=fr.height, step=fr.step, is_bigendian=fr.is_bigendian))
    assert len(frames) >= 8 and all(len(f.points) > 100 for f in frames[2:])
    store = FrameStore(memory_mb=0)
    for f in frames:
        store.append(f)
    assert len(store) == len(frames)
    for i in [5, 0, len(frames) - 1, 3, 3]:
        back, f = store[i], frames[i]
        assert back.points.dtype == f.points.dtype and back.points.tobytes() == f.points.tobytes()
        np.testing.assert_array_equal(back.depth_fg, f.depth_fg)
        np.testing.assert_array_equal(back.no_depth, f.no_depth)
        assert back.stamp == f.stamp and back.intrinsics == f.intrinsics and back.timings_ms == f.timings_ms
        np.testing.assert_array_equal(back.floor.normal, f.floor.normal)
    store.close()
    # a store file that one process writes and another reads as it grows (the forked worker and the caller)
    path = tmp_path / "frames.bin"
    view = FrameStore.reader(path)  # may come first: the file is created empty
    writer = FrameStore(path=path)
    for f in frames[:3]:
        where = writer.append(f)
        assert view.at(*where).points.tobytes() == f.points.tobytes()
    writer.close()
    view.close()


def _forward_pass_and_frames(path: Path, *, tracker_runs: int = 1) -> tuple[Any, Any, list[Any]]:
    """A two-pass ``FrameProcessor`` (each direction tracked ``tracker_runs`` times) fed every frame of the recording
    ``path`` (its forward passes: ``process`` returns nothing until ``finish``), a second one that prepares the same
    frames again for backward passes of its own, and those prepared frames."""
    from types import SimpleNamespace

    from walker_gait.io.bags import open_recording
    from walker_gait.pipeline import FrameProcessor

    proc, prep = (FrameProcessor(_options(0, passes="both", tracker_runs=tracker_runs)) for _ in range(2))
    frames = []
    for fr in open_recording(path).iter_frames():
        info = SimpleNamespace(**{k: getattr(fr.camera_info, k) for k in
                                  ("width", "height", "k", "d", "p", "distortion_model")})
        proc.set_camera_info(info)
        prep.set_camera_info(info)
        kw = dict(stamp=fr.stamp, data=fr.data, encoding=fr.encoding, width=fr.width, height=fr.height, step=fr.step,
                  is_bigendian=fr.is_bigendian)
        assert proc.process(**kw) is None
        frames.append(prep.prepare(**kw))
    return proc, prep, frames


def test_the_backward_pass_waits_for_both_feet_at_once_only_with_the_join_across_either_side() -> None:
    from walker_gait.core.segmentation import RoiConfig
    from walker_gait.pipeline import PipelineOptions, strict_backward_wait

    assert not strict_backward_wait(PipelineOptions().segmenter.roi)  # the default: the box cuts
    assert strict_backward_wait(RoiConfig(join_edge_parts=True))
    assert not strict_backward_wait(RoiConfig(join_edge_parts=True, join_centred_only=True))
    assert not strict_backward_wait(RoiConfig(join_centred_only=True))  # nothing joined


def test_an_arriving_user_is_not_reported_before_the_backward_pass_has_seen_both_feet(tmp_path: Path) -> None:
    """A user walking in from the side: the forward pass starts once it sees two legs, the backward pass ends its
    track there and, alone, carried a leg it no longer saw (both model legs on the foot in view, 20-70 cm off).
    Those frames get no pose; the frames it alone tracked after seeing both feet stay."""
    from walker_gait.core.smoothing import wait_for_both_feet
    from walker_gait.synth import SessionSpec, generate_session, write_session

    session = generate_session(SessionSpec.preset("absent_start", duration=6.0, scale=0.5, absent_start=(0.2, 0.2)),
                               rng=np.random.default_rng(1))
    path = tmp_path / "arrival.mcap"
    write_session(session, path, fmt="mcap", encoding="16UC1")
    proc, prep, frames = _forward_pass_and_frames(path)
    raw = prep.backward(frames)
    fin = proc.finish()
    fwd, kept = fin.passes
    np.testing.assert_array_equal([p.points for p in kept.poses],
                                  [p.points for p in wait_for_both_feet(raw, other=fwd).poses])

    def has(poses: list) -> np.ndarray:  # type: ignore[type-arg]
        return np.array([bool(np.all(np.isfinite(p.points))) for p in poses])

    truth = np.asarray(session.leg_points[:len(frames)], dtype=float)
    raw_feet = np.stack([p.points for p in raw.poses])[:, :, 2:]
    feet_err = np.linalg.norm(raw_feet - truth[:, :, 2:], axis=-1).mean(axis=(1, 2))
    dropped = has(raw.poses) & ~has(kept.poses)
    assert dropped.sum() >= 10 and not has(fwd.poses)[dropped].any()
    assert not has([r.pose for r in fin.results])[dropped].any()
    assert float(np.mean(feet_err[dropped])) > 0.20
    alone = has(kept.poses) & ~has(fwd.poses)  # what the backward pass alone still reports: after seeing both feet
    assert alone.sum() >= 5 and float(np.mean(feet_err[alone])) < 0.10


def test_two_passes_merge_the_forward_pass_with_a_backward_one(short_session: Path, tmp_path: Path) -> None:
    """``passes="both"``: every frame gets a pose between the forward pass's (which is the one-pass pipeline's, same
    seed) and the backward pass's (blended where their feet agree), nearer the one chosen, in the share reported;
    the outputs say which was run."""
    import json

    from walker_gait.core.smoothing import wait_for_both_feet

    # the one-pass run reports the tracker's poses as tracked (no pelvis placed), to compare with the kept passes
    one = process_recording(short_session, tmp_path / "one", options=_options(0, passes="forward", write_mcap=True,
                                                                             report_pelvis_window_s=0.0), progress=False)
    two = process_recording(short_session, tmp_path / "two", options=_options(0, passes="both", write_mcap=True,
                                                                             tracker_runs=1), progress=False)
    assert len(two.poses) == len(one.poses) == 75
    assert [p.stamp for p in two.poses] == [p.stamp for p in one.poses]
    meta_one = json.loads((tmp_path / "one" / "summary.json").read_text())["metadata"]
    meta_two = json.loads((tmp_path / "two" / "summary.json").read_text())["metadata"]
    assert meta_one["passes"] == "forward" and meta_one["frames_from_backward_pass"] is None
    assert meta_two["passes"] == "both" and 0 <= meta_two["frames_from_backward_pass"] <= 75
    assert meta_one["frames_legs_exchanged_back"] is None and 0 <= meta_two["frames_legs_exchanged_back"] <= 75
    assert "tracker_backward" in meta_two["mean_stage_ms"] and "tracker_backward" not in meta_one["mean_stage_ms"]
    assert two.passes == "both" and two.frames_from_backward_pass == meta_two["frames_from_backward_pass"]
    assert "backward" in two.describe() and "one pass" in one.describe()
    # the one pass's tracked.mcap also carries what the live leg_tracker publishes on leg_track_bridged: every frame,
    # as leg_track where no foot is hidden; the two-pass output has its hidden feet bridged anyway
    from rosbags.highlevel import AnyReader

    def read(path: Path) -> dict[str, list[Any]]:
        with AnyReader([path]) as reader:
            return {c.topic: [reader.deserialize(raw, c.msgtype) for _, _, raw in reader.messages(connections=[c])]
                    for c in reader.connections}

    got = read(tmp_path / "one" / "tracked.mcap")
    track, bridged = got["/leg_track"], got["/leg_track_bridged"]
    assert [m.header.stamp for m in bridged] == [m.header.stamp for m in track] and len(track) == 75
    hide = _options(0).tracker.hide_below
    seen = [i for i, m in enumerate(track) if min(m.foot_visibility) >= hide]
    assert seen and all([(p.x, p.y, p.z) for p in bridged[i].heel] == [(p.x, p.y, p.z) for p in track[i].heel]
                        for i in seen)
    assert "/leg_track_bridged" not in read(tmp_path / "two" / "tracked.mcap")

    proc, prep, frames = _forward_pass_and_frames(short_session)
    fin = proc.finish()
    assert len(fin.results) == 75
    # the merged passes are kept: the forward one is the one-pass pipeline's, the backward one ours without the
    # frames, where the forward pass has no pose, before it had seen both feet
    assert len(fin.passes) == 2 and all(len(p.poses) == 75 for p in fin.passes)
    np.testing.assert_array_equal([p.points for p in fin.passes[0].poses], [p.points for p in one.poses])
    backward = wait_for_both_feet(prep.backward(frames), other=fin.passes[0])
    np.testing.assert_array_equal([p.points for p in fin.passes[1].poses], [p.points for p in backward.poses])
    np.testing.assert_array_equal([r.pose.points for r in fin.results], [p.points for p in two.poses])
    # the poses reported are the merged ones with hidden feet bridged and low-passed in each frame's walker frame
    # (core.smoothing.reported_poses); the analyzer reads the merged ones
    from walker_gait.core.smoothing import merge_passes, reported_poses

    merged_track = merge_passes(list(fin.passes))
    merged = merged_track.poses
    assert merged_track.exchanged is not None
    assert meta_two["frames_legs_exchanged_back"] == fin.exchanged_frames == int(merged_track.exchanged.sum())
    assert two.frames_legs_exchanged_back == fin.exchanged_frames
    shown = reported_poses(merged, hide_below=proc.options.tracker.hide_below, max_gap_s=proc.options.bridge_hidden_s,
                           lowpass_hz=proc.options.report_lowpass_hz, floors=[r.floor for r in fin.results],
                           pelvis_window_s=proc.options.report_pelvis_window_s, mounting=proc.options.mounting)
    assert proc.options.report_lowpass_hz > 0 and not np.allclose([p.points for p in shown], [p.points for p in merged],
                                                                   equal_nan=True)
    np.testing.assert_array_equal([r.pose.points for r in fin.results], [p.points for p in shown])
    nearer_backward, at_half = 0, 0
    for m_pose, f, b in zip(merged, one.poses, backward.poses):
        m, fp, bp = m_pose.points, f.points, b.points
        if not np.all(np.isfinite(m)):
            continue
        if np.array_equal(m, fp) or np.array_equal(m, bp):
            w = 0.0 if np.array_equal(m, fp) else 1.0
        else:  # a blend: on the segment from the forward to the backward pose, one weight for every point
            d = (bp - fp).ravel()
            w = float((m - fp).ravel() @ d / (d @ d))
            np.testing.assert_allclose(m, fp + w * (bp - fp), atol=1e-9)
            assert 0.0 < w < 1.0
        nearer_backward += w > 0.5 + 1e-9
        at_half += abs(w - 0.5) <= 1e-9
    assert nearer_backward <= round(fin.backward_share * 75) <= nearer_backward + at_half
    assert round(fin.backward_share * 75) == meta_two["frames_from_backward_pass"]
    assert [(s.stamp, s.step_length) for r in fin.results for s in r.steps] + \
        [(s.stamp, s.step_length) for s in fin.steps] == [(s.stamp, s.step_length) for s in two.steps]
    # the events and steps are the analyzer's on the merged poses, checked against each pass's own: steps the two
    # passes alone do not both see alike doubted, heel strikes timed by all three analyses
    from walker_gait.bench.gait import run_analyzer
    from walker_gait.core.smoothing import check_against_passes

    floors = [r.floor for r in fin.results]
    plain = run_analyzer(merged, floors)
    alone = [run_analyzer(p.poses, floors) for p in fin.passes]
    want_ev, want_st = check_against_passes(plain.events, plain.steps, [(a.events, a.steps) for a in alone])
    got = [s for r in fin.results for s in r.steps] + fin.steps
    np.testing.assert_array_equal([(s.stamp, s.step_length, s.step_time, s.confidence) for s in got],
                                  [(s.stamp, s.step_length, s.step_time, s.confidence) for s in want_st])
    assert sorted(e.stamp for r in fin.results for e in r.events + fin.events) == sorted(e.stamp for e in want_ev)
    # the session summary is of the steps as checked (confidences and times), not of the analyzer's own
    assert two.summary["step_count"] == len(two.steps)
    assert meta_two["steps_unconfirmed"] == fin.unconfirmed_steps == two.steps_unconfirmed
    assert fin.unconfirmed_steps == sum(s.confidence != p.confidence for s, p in zip(got, plain.steps))
    assert meta_one["steps_unconfirmed"] is None
    assert (meta_two["bridge_hidden_s"], meta_two["report_lowpass_hz"]) == (1.0, 6.0)
    assert meta_one["bridge_hidden_s"] is None and meta_one["report_lowpass_hz"] is None
    assert (meta_two["report_pelvis_window_s"], meta_one["report_pelvis_window_s"]) == (1.0, 0.0)
    # the reported legs' median lengths and the hip height they make (the reported hips' height rests on them)
    from walker_gait.core.leg_model import ANKLE_HEIGHT
    from walker_gait.core.pelvis import segment_lengths

    lengths = meta_two["reported_segment_lengths_m"]
    want = segment_lengths(np.stack([p.points for p in two.poses if np.all(np.isfinite(p.points))]))
    np.testing.assert_allclose([lengths[k] for k in ("thigh", "calf", "foot")], want, atol=5e-4)
    assert lengths["leg"] == pytest.approx(want[0] + want[1] + ANKLE_HEIGHT * want[2], abs=5e-4)
    assert 0.3 < lengths["thigh"] < 0.55 and 0.2 < lengths["foot"] < 0.33
    assert lengths["foot_under_hem"] is False  # the sample's trousers fit
    assert two.summary["mean_confidence"] == pytest.approx(np.mean([s.confidence for s in two.steps]))


def test_each_direction_tracked_more_than_once_merges_every_run(short_session: Path, tmp_path: Path) -> None:
    """``tracker_runs=2`` (the ``accurate`` preset's): forwards and backwards each tracked twice, each run on a random
    stream of its own; the first run's passes are the one-run pipeline's, the second run's differ from them, and every
    frame's pose is the merge of all four passes (forward, backward, forward, backward) as reported."""
    import json

    from walker_gait.core.smoothing import merge_passes, reported_poses, wait_for_both_feet

    assert PipelineOptions().tracker_runs == PipelineOptions(preset="paper").tracker_runs == 1  # the preset's
    assert PipelineOptions(preset="accurate").tracker_runs == 2 and PipelineOptions(preset="accurate",
                                                                                    tracker_runs=1).tracker_runs == 1
    proc, prep, frames = _forward_pass_and_frames(short_session, tracker_runs=2)
    fin = proc.finish()
    assert len(fin.passes) == 4 and all(len(p.poses) == 75 for p in fin.passes)
    one_run, _, _ = _forward_pass_and_frames(short_session, tracker_runs=1)
    single = one_run.finish()
    for k in (0, 1):  # run 0: the one-run pipeline's forward and backward passes
        np.testing.assert_array_equal([p.points for p in fin.passes[k].poses], [p.points for p in single.passes[k].poses])
    for k in (2, 3):  # run 1: another tracking of the same frames, each way
        assert np.nanmax(np.abs(np.array([p.points for p in fin.passes[k].poses])
                                - np.array([p.points for p in fin.passes[k - 2].poses]))) > 1e-3
    backward = wait_for_both_feet(prep.backward(frames, run=1), other=fin.passes[2])
    np.testing.assert_array_equal([p.points for p in fin.passes[3].poses], [p.points for p in backward.poses])
    merged = merge_passes(list(fin.passes))
    shown = reported_poses(merged.poses, hide_below=proc.options.tracker.hide_below,
                           max_gap_s=proc.options.bridge_hidden_s, lowpass_hz=proc.options.report_lowpass_hz,
                           floors=[r.floor for r in fin.results], pelvis_window_s=proc.options.report_pelvis_window_s,
                           mounting=proc.options.mounting)
    np.testing.assert_array_equal([r.pose.points for r in fin.results], [p.points for p in shown])
    assert fin.backward_share == pytest.approx(merged.share(1) + merged.share(3))
    # the further forward run's work is timed apart from the live tracker's (the tracker stage is run 0 alone)
    assert all(r.timings_ms["tracker_more_runs"] > 0 for r in fin.results)
    res = process_recording(short_session, tmp_path / "out", options=_options(0, tracker_runs=2), progress=False)
    meta = json.loads((tmp_path / "out" / "summary.json").read_text())["metadata"]
    assert meta["tracker_runs"] == res.tracker_runs == 2 and "2 times each way" in res.describe()
    np.testing.assert_array_equal([p.points for p in res.poses], [r.pose.points for r in fin.results])


def test_tracker_runs_and_threads_must_be_small_whole_numbers() -> None:
    from walker_gait.config import ParameterError

    for bad in (0, -1, 9, 1.5, True, "2"):
        with pytest.raises(ParameterError, match="tracker_runs"):
            PipelineOptions(tracker_runs=bad)
    assert PipelineOptions(tracker_runs=1).tracker_runs == 1
    # one pass is tracked once, as the live graph tracks: the accurate preset's two runs do not apply, and asking for
    # more is refused
    assert PipelineOptions(passes="forward", preset="accurate").tracker_runs == 1
    with pytest.raises(ParameterError, match="tracker_runs applies to passes 'both'"):
        PipelineOptions(passes="forward", tracker_runs=2)
    # the kernels' threads: one pass only (both directions already take two cores)
    assert PipelineOptions(passes="forward", tracker_threads=2).tracker_threads == 2
    for bad in (0, -1, 1.5, True):
        with pytest.raises(ParameterError, match="tracker_threads must be"):
            PipelineOptions(passes="forward", tracker_threads=bad)
    with pytest.raises(ParameterError, match="tracker_threads applies to passes 'forward'"):
        PipelineOptions(passes="both", tracker_threads=2)


def test_one_pass_reports_the_pelvis_placed_frame_by_frame_as_the_live_node(short_session: Path) -> None:
    """``passes="forward"``: the reported poses are the tracker's with the out-of-view pelvis placed over the feet
    and the heels where the shoes show them frame by frame (``core.pelvis.LivePelvis``, as the live leg_tracker node),
    those feet's ankles with them, and the feet put on the floor (a flat foot's heel and toe on it, a toe under it
    raised); the tracker's own heels, ankles and toes (``heel_tracked``, ``ankle_tracked``, ``toe_tracked``, what the
    analysis reads), the events and the steps are the same as without it."""
    from types import SimpleNamespace

    from walker_gait.core.pelvis import LivePelvis
    from walker_gait.core.types import TOE
    from walker_gait.io.bags import open_recording
    from walker_gait.pipeline import FrameProcessor

    off = FrameProcessor(_options(0, passes="forward", report_pelvis_window_s=0.0))
    on = FrameProcessor(_options(0, passes="forward"))
    got_off, got_on = [], []
    for fr in open_recording(short_session).iter_frames():
        info = SimpleNamespace(**{k: getattr(fr.camera_info, k) for k in
                                  ("width", "height", "k", "d", "p", "distortion_model")})
        kw = dict(stamp=fr.stamp, data=fr.data, encoding=fr.encoding, width=fr.width, height=fr.height, step=fr.step,
                  is_bigendian=fr.is_bigendian)
        for proc, got in ((off, got_off), (on, got_on)):
            proc.set_camera_info(info)
            got.append(proc.process(**kw))
    assert len(got_on) == 75
    live = LivePelvis(mounting="facing_user", window_s=on.options.report_pelvis_window_s)
    placed = heels = toes = 0
    for a, b in zip(got_off, got_on):
        assert a.pose.shoe_turn is None  # the placement off: the shoes are not measured (the tracking is the same)
        np.testing.assert_array_equal(a.pose.points[:, 2:], b.pose.as_tracked().points[:, 2:])
        if b.pose.toe_tracked is None:
            np.testing.assert_array_equal(a.pose.points[:, TOE], b.pose.points[:, TOE])
        else:  # put on the floor: only its height above the floor moved, and it is not under the floor
            toes += 1
            was, now = a.floor.to_walker(a.pose.points[:, TOE]), a.floor.to_walker(b.pose.points[:, TOE])
            np.testing.assert_allclose(now[:, :2], was[:, :2], atol=1e-9)
            assert now[:, 2].min() > -1e-9 and np.abs(now[:, 2] - was[:, 2]).max() > 0
        measured = dataclasses.replace(a.pose, shoe_rise=b.pose.shoe_rise, shoe_turn=b.pose.shoe_turn)
        np.testing.assert_array_equal(live.place(measured, a.floor).points, b.pose.points)
        placed += not np.array_equal(a.pose.points, b.pose.points, equal_nan=True)
        heels += b.pose.heel_tracked is not None
        assert [s.stamp for s in a.steps] == [s.stamp for s in b.steps]
        assert [(e.stamp, e.kind) for e in a.events] == [(e.stamp, e.kind) for e in b.events]
        assert "pelvis" in b.timings_ms and "pelvis" not in a.timings_ms
    assert placed > 40  # every tracked frame's hips moved
    assert heels > 10  # and the heels of feet whose shoes the track has shown cleanly
    assert toes > 10  # and toes put on the floor


def test_the_backward_pass_tells_its_tracker_that_time_runs_backwards(monkeypatch: pytest.MonkeyPatch) -> None:
    """The backward pass's tracker is built with ``time_reversed`` (its footprints read a swinging foot the other way
    round); the forward tracker is not."""
    from types import SimpleNamespace

    import walker_gait.core.smoothing as smoothing
    import walker_gait.core.tracker as tracker
    from walker_gait.pipeline import FrameProcessor

    made: list[dict[str, Any]] = []

    class Recorder:
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            made.append(kwargs)

    def one_tracker(make: Any, frames: Any, **kwargs: Any) -> str:
        make(frames[0])
        return "pass"

    monkeypatch.setattr(tracker, "LegTracker", Recorder)
    monkeypatch.setattr(smoothing, "track_pass", one_tracker)
    proc = FrameProcessor(_options(0, passes="both"))
    assert proc.backward([SimpleNamespace(intrinsics=None)]) == "pass"
    assert made == [{"rng": made[0]["rng"], "mounting": "facing_user", "time_reversed": True, "defer_feet": False}]


def test_passes_must_be_known() -> None:
    from walker_gait.config import ParameterError

    with pytest.raises(ParameterError, match="passes"):
        PipelineOptions(passes="backward")
    for name in ("bridge_hidden_s", "report_lowpass_hz", "report_pelvis_window_s"):
        for bad in (-0.5, float("nan"), float("inf"), "6"):
            with pytest.raises(ParameterError, match=name):
                PipelineOptions(**{name: bad})
    # a leg length in metres within an adult's range, or 0 (not measured); centimetres or a stature are refused
    assert PipelineOptions(leg_length_m=0.9).leg_length_m == 0.9
    for bad in (88.0, 1.75, -0.9, float("nan"), "0.9"):
        with pytest.raises(ParameterError, match="leg_length_m"):
            PipelineOptions(leg_length_m=bad)


def _frames_of(session: Any) -> list[Any]:
    """A synthetic session's rendered frames as a recording yields them."""
    from walker_gait.bench.endtoend import recording_frames, render

    return recording_frames(session, render(session).frames)


def _first_frame(frames: list[Any], *, learn: bool) -> tuple[Any, int]:
    from walker_gait.pipeline import FrameProcessor, _prepare_one

    proc = FrameProcessor(_options(0))
    learned = proc.learn_structure(frames) if learn else 0
    prepared = _prepare_one(proc, frames[0])
    assert isinstance(prepared, PreparedFrame)
    return prepared, learned


def _off_the_legs(points: np.ndarray, legs: np.ndarray) -> np.ndarray:
    """Per point: more than 10 cm from every leg segment (hip-knee-ankle, the foot's ankle-heel-toe triangle)."""
    d = np.full(len(points), np.inf)
    for leg in legs:
        for a, b in ((0, 1), (1, 2), (2, 3), (2, 4), (3, 4)):
            ab = leg[b] - leg[a]
            t = np.clip((points - leg[a]) @ ab / (ab @ ab), 0.0, 1.0)
            d = np.minimum(d, np.linalg.norm(points - (leg[a] + t[:, None] * ab), axis=1))
    return d > 0.10


def test_structure_learned_over_the_recording_is_gone_from_its_first_frame() -> None:
    """A user stands still for 1 s with a rear wheel of the walker inside the region of interest (camera 6 cm off
    the walker's centre line), then walks.  Live, the wheel stays foreground until the user has walked ~2 s; offline
    (``learn_structure``, what ``process --passes both`` does) it is gone from the first frame, the legs all there."""
    from walker_gait.synth import SessionSpec, generate_session

    session = generate_session(SessionSpec.preset("normal", duration=3.5, scale=0.5, cam_lateral=(0.06, 0.06),
                                                  stand_start=(1.0, 1.0), clutter=False),
                               rng=np.random.default_rng(3))
    frames = _frames_of(session)
    legs = np.asarray(session.leg_points[0])
    live, none = _first_frame(frames, learn=False)
    offline, learned = _first_frame(frames, learn=True)
    assert none == 0 and learned > 50
    off_live, off_offline = _off_the_legs(live.points, legs), _off_the_legs(offline.points, legs)
    assert off_live.sum() > 1000  # the wheel
    assert off_offline.sum() < 0.1 * off_live.sum()
    assert (~off_offline).sum() == (~off_live).sum()  # every leg point kept


def test_learning_no_structure_changes_nothing() -> None:
    """Without walker parts in view nothing is learned, and the frames come out exactly as without the pass (its
    scratch processor draws from its own random streams)."""
    from walker_gait.synth import SessionSpec, generate_session

    session = generate_session(SessionSpec.preset("normal", duration=1.5, scale=0.5, walker_parts=False,
                                                  clutter=False), rng=np.random.default_rng(4))
    frames = _frames_of(session)
    live, _ = _first_frame(frames, learn=False)
    offline, learned = _first_frame(frames, learn=True)
    assert learned == 0
    np.testing.assert_array_equal(offline.points, live.points)
    np.testing.assert_array_equal(offline.depth_fg, live.depth_fg)


class _Finalised:
    """A reference cycle whose finaliser writes the id of the process that ran it."""

    def __init__(self, log: Path) -> None:
        self.log = log
        self.me = self

    def __del__(self) -> None:
        with open(self.log, "a") as fh:
            fh.write(f"{os.getpid()}\n")


def _collect_in_child() -> None:
    gc.collect()


def test_a_forked_worker_leaves_the_parents_garbage_to_the_parent(tmp_path: Path) -> None:
    """The parent's leftover reference cycles (an rclpy node's, in a program or test that made nodes) are finalised
    in the parent before a fork, never in the forked worker, which crashed collecting them."""
    from walker_gait.pipeline import _in_background

    log = tmp_path / "finalised.txt"
    _Finalised(log)  # unreachable at once: cyclic garbage only the collector frees
    gc.disable()  # no automatic collection may free it before the fork
    try:
        _in_background(_collect_in_child)()
    finally:
        gc.enable()
    gc.collect()
    assert log.read_text().split() == [str(os.getpid())]


def test_the_reported_lengths_say_whether_the_shoes_were_under_a_trouser_hem() -> None:
    """``summary.json``'s ``reported_segment_lengths_m`` flags a session whose calves were a tube of loose fabric down
    to a hem (its shoes reported at least the typical adult's, ``core.pelvis.shoe_length``), and the report says so
    next to the shoe's length."""
    from walker_gait.core import leg_model as lm
    from walker_gait.core.types import LegPose
    from walker_gait.pipeline import _reported_lengths
    from walker_gait.report import _metadata_table

    pts = lm.forward_kinematics(lm.neutral_state(right_hip_xy=(0.0, -0.09))).points[0]
    for calf, hem in ((0.115, True), (0.06, False)):
        radii = np.full((2, 3, 2), 0.05)
        radii[:, 1, 0] = calf
        poses = [LegPose(stamp=0.1 * i, points=pts, radii=radii) for i in range(5)] + [LegPose.no_user(0.5)]
        lengths = _reported_lengths(poses, placed=True)
        assert lengths is not None and lengths["foot_under_hem"] is hem
        unplaced = _reported_lengths(poses, placed=False)  # the shoes as tracked: nothing was assumed
        assert unplaced is not None and unplaced["foot_under_hem"] is False
        assert lengths["foot"] == pytest.approx(float(np.linalg.norm(pts[0, 4] - pts[0, 3])), abs=5e-4)
        row = _metadata_table({"reported_segment_lengths_m": lengths}, [])
        assert ("under a trouser hem" in row) is hem
    assert _reported_lengths([LegPose.no_user(0.0)], placed=True) is None


def test_the_tracking_note_names_the_frames_whose_exchanged_legs_were_taken_back() -> None:
    result = ProcessResult(input=Path("walk.mcap"), out_dir=Path("out"), frames=100, skipped={}, steps=[], events=[],
                           poses=[], summary={}, wall_s=1.0, timings_ms={}, files=[], passes="both",
                           frames_from_backward_pass=40, frames_legs_exchanged_back=7)
    assert "40 of 100 frames" in result.tracking_note()
    assert "exchanged taken back on 7 frames" in result.tracking_note()
    assert "exchanged" not in dataclasses.replace(result, frames_legs_exchanged_back=0).tracking_note()
    assert "exchanged" not in dataclasses.replace(result, passes="forward").tracking_note()
