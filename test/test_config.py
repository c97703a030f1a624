"""config/walker_gait.yaml, the parameter spec and the core configs agree."""

from __future__ import annotations

from pathlib import Path

import pytest

from walker_gait.config import ParameterError, build, flatten, load_params_file, parse_overrides
from walker_gait.paramspec import NODE_PARAMS, all_params, validate_node_params


def test_params_file_names_only_known_parameters(repo_root: Path) -> None:
    params = load_params_file(repo_root / "config" / "walker_gait.yaml")
    assert set(params) == set(NODE_PARAMS)
    for node, values in params.items():
        validate_node_params(node, values)


def test_node_level_defaults_in_file_match_spec(repo_root: Path) -> None:
    params = load_params_file(repo_root / "config" / "walker_gait.yaml")
    for node, spec in NODE_PARAMS.items():
        for name, default, doc in spec:
            assert doc, f"{node}.{name} has no description"
            if name in params[node]:
                assert params[node][name] == default, f"{node}.{name}"


def test_unknown_parameter_is_rejected_with_its_name() -> None:
    with pytest.raises(ParameterError, match="no_such_param"):
        validate_node_params("gait_analyzer", {"no_such_param": 1})
    with pytest.raises(ParameterError, match="unknown node"):
        validate_node_params("nope", {})


def test_bad_value_type_is_rejected() -> None:
    from walker_gait.core.segmentation import SegmenterConfig

    with pytest.raises(ParameterError, match="roi.forward|forward"):
        build(SegmenterConfig, {"roi.forward": "far"})


def test_build_round_trips_flatten() -> None:
    from walker_gait.core.segmentation import SegmenterConfig

    cfg = build(SegmenterConfig, {"roi.forward": 1.2, "floor_method": "background"})
    assert cfg.roi.forward == 1.2 and cfg.floor_method == "background"
    again = build(SegmenterConfig, flatten(cfg))
    assert flatten(again) == flatten(cfg)


def test_parse_overrides_types_values() -> None:
    assert parse_overrides(["leg_tracker.n_particles=300", "gait_analyzer.use_odometry=true", "a.b=x"]) == {
        "leg_tracker.n_particles": 300, "gait_analyzer.use_odometry": True, "a.b": "x"}
    with pytest.raises(ParameterError, match="KEY=VALUE"):
        parse_overrides(["nonsense"])


def test_readme_parameter_table_is_up_to_date(repo_root: Path) -> None:
    import subprocess
    import sys

    res = subprocess.run([sys.executable, str(repo_root / "tools" / "update_readme.py"), "--check"],
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stderr


def test_camera_params_reach_every_stage_and_must_match(repo_root: Path) -> None:
    from walker_gait.pipeline import PipelineOptions

    params = load_params_file(repo_root / "config" / "walker_gait.yaml")
    options = PipelineOptions.from_params(params, {"depth_to_cloud.depth_format": "kinect_raw",
                                                   "depth_to_cloud.use_rectified": False})
    assert options.depth_format == "kinect_raw" and options.use_rectified is False
    # the leg_tracker node's reported-pose parameters reach the offline options; a command line's own value wins
    assert (options.report_pelvis_window_s, options.leg_length_m) == (1.0, 0.0)
    given = PipelineOptions.from_params(params, {"leg_tracker.leg_length_m": 0.91, "leg_tracker.pelvis_window_s": 0.5})
    assert (given.report_pelvis_window_s, given.leg_length_m) == (0.5, 0.91)
    cli = PipelineOptions.from_params(params, {"leg_tracker.leg_length_m": 0.91}, leg_length_m=0.85)
    assert cli.leg_length_m == 0.85
    # the node's longest bridged gap is offline's: both bridge a hidden foot's stretch as long
    assert options.bridge_hidden_s == 1.0
    assert PipelineOptions.from_params(params, {"leg_tracker.bridge_hidden_s": 0.5}).bridge_hidden_s == 0.5
    assert PipelineOptions.from_params(params, {"leg_tracker.bridge_hidden_s": 0.5}, bridge_hidden_s=0.0
                                       ).bridge_hidden_s == 0.0
    params["floor_segmentation"]["depth_format"] = "kinect_raw"  # disagrees with depth_to_cloud's `auto`
    with pytest.raises(ParameterError, match="floor_segmentation.depth_format must match"):
        PipelineOptions.from_params(params, {})


def test_tracker_presets_reach_the_offline_options(repo_root: Path) -> None:
    from walker_gait.pipeline import PipelineOptions

    params = load_params_file(repo_root / "config" / "walker_gait.yaml")
    assert PipelineOptions.from_params(params, {}).tracker.n_particles == 192
    accurate = PipelineOptions.from_params(params, {}, preset="accurate")  # `process --preset accurate`
    assert (accurate.preset, accurate.tracker.n_particles) == ("accurate", 288)
    # as a node parameter, and a field given beside it overrides the preset's (the --param example of the CLI's help)
    mixed = PipelineOptions.from_params(params, parse_overrides(["leg_tracker.preset=accurate",
                                                                 "leg_tracker.n_particles=300"]))
    assert (mixed.preset, mixed.tracker.n_particles) == ("accurate", 300)
    with pytest.raises(ParameterError, match="unknown preset 'fast'"):
        PipelineOptions.from_params(params, {}, preset="fast")


def test_every_listed_node_parameter_is_accepted_by_the_offline_options() -> None:
    """`walker-gait process --params FILE` reads the live graph's parameters file: every parameter the README lists
    for a node (its default) must be accepted, the live-only ones (queues, threads, transport) ignored offline
    (leg_tracker.kernel_threads was refused as unknown to TrackerConfig)."""
    from walker_gait.pipeline import PipelineOptions

    params = {node: {name: default for name, default, _ in spec} for node, spec in NODE_PARAMS.items()}
    params.pop("bag_replay", None)  # the player, not a stage `process` runs
    options = PipelineOptions.from_params(params, {})
    assert options.tracker.n_particles == 192 and options.bridge_hidden_s == 1.0
    for node, values in params.items():
        for name, value in values.items():
            PipelineOptions.from_params({node: {name: value}}, {})  # each alone too
