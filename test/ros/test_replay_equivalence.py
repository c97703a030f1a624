"""Replaying a session into the live graph (real processes, real DDS) gives the same steps as `process` with the
live graph's one tracking pass (`--passes forward`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytestmark = [pytest.mark.ros, pytest.mark.slow]


@pytest.fixture(scope="module")
def walking_session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from walker_gait.synth import SessionSpec, generate_session, write_session

    session = generate_session(SessionSpec.preset("normal", duration=5.0, scale=0.5),
                               rng=np.random.default_rng(11))
    path = tmp_path_factory.mktemp("session") / "walk.mcap"
    write_session(session, path, fmt="mcap", encoding="16UC1")
    return path


def test_replay_into_live_graph_matches_offline_process(walking_session: Path, tmp_path: Path) -> None:
    from walker_gait.bench.live import run_live
    from walker_gait.pipeline import PipelineOptions, process_recording

    offline = process_recording(walking_session, tmp_path / "out", options=PipelineOptions(seed=0, passes="forward"),
                                progress=False)
    assert len(offline.steps) >= 3, "the session must contain steps for the comparison to mean anything"
    # Slow enough that no stage drops a frame on a 2-core machine shared by 6 processes: by design the
    # live graph drops frames rather than queueing them when a node is slower than the camera. The
    # tracker's first frame (initial search) takes several frame periods, so its input queue holds 5
    # here (the default, 2, favours latency over completeness).
    live = run_live(walking_session, rate=0.15, timeout_s=300, params=("leg_tracker.input_depth=5",))
    assert live.run_exit_code == 0
    missing = [(t - (live.first_stamp_ns or 0)) / 1e9 for t in live.missing_stamps_ns]
    assert live.joint_states == offline.frames, f"the live graph dropped frames at t = {missing} s after the first"
    assert not live.skipped, live.skipped
    # leg_track_bridged: the same frames in the same order, each once (those held when the replay ended come out
    # once the input has paused for bridge_hidden_s)
    stamps = sorted(live.bridged_stamps_ns)
    assert live.bridged_stamps_ns == stamps and len(set(stamps)) == len(stamps) == offline.frames
    got = sorted(live.steps, key=lambda s: s.stamp)
    want = sorted(offline.steps, key=lambda s: s.stamp)
    assert len(got) == len(want)
    for a, b in zip(got, want, strict=True):
        assert a.side == b.side
        assert a.stamp == pytest.approx(b.stamp, abs=1e-3)
        # the same core code on the same bytes: equal up to the messages' float32 (the LegTrack carries the reported
        # points; with its segment ends instead, widths differed by up to 6 mm)
        assert abs(a.step_length - b.step_length) <= 1e-5
        assert abs(a.step_width - b.step_width) <= 1e-5
