"""Offline pipeline: a recording in, every stage in-process, result files out.

The same core classes as the live nodes (``DepthProjector``, ``Segmenter``, ``LegTracker``,
``GaitAnalyzer``) run frame by frame without building ROS messages in between; the results are
also written as the messages the live nodes would publish (``tracked.mcap``).  Deterministic for
a given seed.
"""

from __future__ import annotations

import contextlib
import dataclasses
import gc
import json
import math
import sys
import threading
import time
import warnings
from collections import Counter
from collections.abc import Iterable, Iterator, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import numpy as np

from walker_gait import __version__
from walker_gait.config import ParameterError, build
from walker_gait.core.smoothing import PassTrack
from walker_gait.core.types import CameraIntrinsics, FloorPlane, GaitEvent, LegPose, Step

#: ``process --param`` keys are ``<node>.<param>``; these are the nodes whose parameters apply offline.
OFFLINE_NODES = ("depth_to_cloud", "floor_segmentation", "leg_tracker", "gait_analyzer")


STRUCTURE_MOVING_FRAMES = 2
""":meth:`FrameProcessor.learn_structure` reads the recording until its scratch mask has seen this many times
``static_mask.frames`` moving frames (twice what learns a part in full view: a leg passing in front of it restarts
its count)."""
STRUCTURE_STRIDE = 2
""":meth:`FrameProcessor.learn_structure` decodes and segments every this-many-th frame, its mask learning in
``static_mask.frames / STRUCTURE_STRIDE`` moving frames (half the time of a pass over every frame)."""

MAX_TRACKER_RUNS = 8
"""The most runs per direction ``PipelineOptions.tracker_runs`` takes (each costs one more tracking of the recording)."""
PRESET_TRACKER_RUNS = {"paper": 1, "default": 1, "accurate": 2}
"""How many times ``process`` tracks each direction by tracker preset when ``tracker_runs`` is not given: ``default``
keeps a 10 s recording's processing under 10 s on two cores (7.5-9.9 s with one run, 16-17 with two); ``accurate``, the
offline preset, spends the time on a second run, which gains more than its extra particles (eighty-second session)."""


@dataclasses.dataclass(kw_only=True)
class PipelineOptions:
    """Everything that configures an offline run (built from the same YAML as the live nodes)."""

    depth_format: str = "auto"
    use_rectified: bool = True
    segmenter: Any = None  # SegmenterConfig
    tracker: Any = None  # TrackerConfig
    gait: Any = None  # GaitConfig
    preset: str = "default"
    mounting: str = "facing_user"
    summary_window: float = 10.0
    seed: int = 0
    depth_topic: str | None = None
    info_topic: str | None = None
    camera_info_file: str | None = None
    write_mcap: bool = True
    write_report: bool = True
    prefetch: int = 4  # frames decoded + segmented ahead in a forked worker process (0: all in this process)
    passes: str = "both"  # "both": tracked forwards and backwards, merged (core.smoothing); "forward": as the live graph
    # "both": each direction tracked this many times, each run on a random stream of its own, every run merged;
    # None: the preset's (PRESET_TRACKER_RUNS: 1, 2 with "accurate")
    tracker_runs: int | None = None
    store_memory_mb: int = 256  # "both": prepared frames kept in memory up to this size, beyond it in a temporary file
    # "both": a hidden foot's stretch up to this long bridged in the reported poses (smoothing.bridge_hidden_legs; 0 = off)
    bridge_hidden_s: float = 1.0
    # "both": the reported points and angles low-passed at this cut-off (smoothing.lowpass_poses; 0 = off)
    report_lowpass_hz: float = 6.0
    # the reported out-of-view pelvis placed over the ankles averaged over this long (core.pelvis; "both":
    # a centred window, "forward": the last window_s, as the live graph; 0 = the hips and knees as tracked)
    report_pelvis_window_s: float = 1.0
    # the user's measured leg length (m, the hip joint centre's standing height above the floor): the reported thighs
    # and calves of that length with the pelvis placed (core.pelvis.with_leg_length; 0 = not measured: as tracked)
    leg_length_m: float = 0.0
    # "forward": threads the tracker's compiled likelihood kernels spread the particles over (LegTracker's threads:
    # the same tracks, less time where a core is idle; "both" keeps one, its two directions already take two cores)
    tracker_threads: int = 1

    def __post_init__(self) -> None:
        from walker_gait.core.gait import GaitConfig
        from walker_gait.core.pelvis import check_leg_length
        from walker_gait.core.segmentation import SegmenterConfig
        from walker_gait.core.smoothing import PASSES
        from walker_gait.core.tracker import preset as tracker_preset

        if self.passes not in PASSES:
            raise ParameterError(f"passes must be one of {', '.join(PASSES)}, got {self.passes!r}")
        if self.tracker_runs is None:  # the preset's; one pass is tracked once, as the live graph tracks
            self.tracker_runs = PRESET_TRACKER_RUNS.get(self.preset, 1) if self.passes == "both" else 1
        if isinstance(self.tracker_runs, bool) or not isinstance(self.tracker_runs, int) or \
                not 1 <= self.tracker_runs <= MAX_TRACKER_RUNS:
            raise ParameterError(f"tracker_runs must be a whole number from 1 to {MAX_TRACKER_RUNS}, got "
                                 f"{self.tracker_runs!r}")
        if self.passes != "both" and self.tracker_runs != 1:
            raise ParameterError(f"tracker_runs applies to passes 'both' (the live graph's one pass is tracked once), "
                                 f"got {self.tracker_runs} with passes {self.passes!r}")
        if isinstance(self.tracker_threads, bool) or not isinstance(self.tracker_threads, int) or \
                self.tracker_threads < 1:
            raise ParameterError(f"tracker_threads must be a whole number >= 1, got {self.tracker_threads!r}")
        if self.passes != "forward" and self.tracker_threads != 1:
            raise ParameterError(f"tracker_threads applies to passes 'forward' (with 'both' the two directions already "
                                 f"take two cores), got {self.tracker_threads} with passes {self.passes!r}")
        for name in ("bridge_hidden_s", "report_lowpass_hz", "report_pelvis_window_s"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ParameterError(f"{name} must be a finite number >= 0 (0 = off), got {value!r}")
        try:
            check_leg_length(self.leg_length_m)
        except ValueError as exc:
            raise ParameterError(str(exc)) from None

        if self.segmenter is None:
            self.segmenter = SegmenterConfig()
        if self.tracker is None:
            self.tracker = tracker_preset(self.preset)
        if self.gait is None:
            self.gait = GaitConfig()

    @classmethod
    def from_params(cls, file_params: Mapping[str, Mapping[str, Any]], overrides: Mapping[str, Any], *,
                    preset: str | None = None, seed: int = 0, **kwargs: Any) -> PipelineOptions:
        """Options from a parameters file (``{node: {param: value}}``) and ``node.param=value`` overrides."""
        from walker_gait.core.gait import GaitConfig
        from walker_gait.core.segmentation import SegmenterConfig
        from walker_gait.core.tracker import PRESETS, preset as tracker_preset
        from walker_gait.paramspec import CAMERA_PARAMS

        per_node: dict[str, dict[str, Any]] = {n: dict(file_params.get(n, {})) for n in OFFLINE_NODES}
        for n, values in file_params.items():
            if n == "*":
                for node in OFFLINE_NODES:
                    per_node[node].update(values)
        for key, value in overrides.items():
            node, _, param = key.partition(".")
            if node not in per_node or not param:
                raise ParameterError(f"--param {key}: expected <node>.<param> with node one of {', '.join(OFFLINE_NODES)}")
            per_node[node][param] = value
            if node == "depth_to_cloud" and param in CAMERA_PARAMS:  # as `walker-gait run` does
                for other in CAMERA_PARAMS[param]:
                    per_node[other][param] = value
        d2c = per_node["depth_to_cloud"]
        seg = per_node["floor_segmentation"]
        trk = per_node["leg_tracker"]
        gait = per_node["gait_analyzer"]
        preset_name = preset or str(trk.pop("preset", "default"))
        trk.pop("preset", None)
        if preset_name not in PRESETS:
            raise ParameterError(f"unknown preset {preset_name!r}; presets: {', '.join(PRESETS)}")
        mounting = str(trk.pop("mounting", "facing_user"))
        trk_rect = trk.pop("use_rectified", None)
        trk.pop("seed", None)
        seg.pop("seed", None)
        seg.pop("input", None)  # live transport only: offline, segmentation always gets the decoded depth
        seg.pop("input_reliability", None)
        for name, value in (("depth_format", d2c.get("depth_format", "auto")),
                            ("use_rectified", d2c.get("use_rectified", True))):
            if name in seg and seg.pop(name) != value:
                raise ParameterError(f"floor_segmentation.{name} must match depth_to_cloud.{name} ({value!r})")
        d2c.pop("input_reliability", None)  # live transport only
        trk.pop("input_depth", None)  # live transport only
        trk.pop("kernel_threads", None)  # the live node's; offline a one-pass run takes --tracker-threads
        pelvis = trk.pop("pelvis_window_s", None)  # the node's reported pelvis; a command line's own value wins
        if pelvis is not None and "report_pelvis_window_s" not in kwargs:
            kwargs["report_pelvis_window_s"] = float(pelvis)
        bridge = trk.pop("bridge_hidden_s", None)  # the node's bridged hidden feet, offline's reported ones
        if bridge is not None and "bridge_hidden_s" not in kwargs:
            kwargs["bridge_hidden_s"] = float(bridge)
        leg = trk.pop("leg_length_m", None)
        if leg is not None and "leg_length_m" not in kwargs:
            kwargs["leg_length_m"] = float(leg)
        window = float(gait.pop("summary_window", 10.0))
        gait.pop("use_odometry", None)
        options = cls(
            depth_format=str(d2c.pop("depth_format", "auto")),
            use_rectified=bool(d2c.pop("use_rectified", True if trk_rect is None else trk_rect)),
            segmenter=build(SegmenterConfig, seg),
            tracker=build(type(tracker_preset(preset_name)), trk, base=tracker_preset(preset_name)),
            gait=build(GaitConfig, gait),
            preset=preset_name,
            mounting=mounting,
            summary_window=window,
            seed=seed,
            **kwargs,
        )
        unknown = set(d2c)
        if unknown:
            raise ParameterError(f"unknown depth_to_cloud parameter(s): {sorted(unknown)}")
        return options


@dataclasses.dataclass
class FrameResult:
    pose: LegPose
    floor: FloorPlane
    events: list[GaitEvent]
    steps: list[Step]
    n_foreground: int
    timings_ms: dict[str, float]


@dataclasses.dataclass
class PreparedFrame:
    """One depth image decoded, back-projected and segmented: what the tracker stage needs."""

    stamp: float
    intrinsics: CameraIntrinsics
    points: np.ndarray  # (N, 3) foreground points, camera optical frame
    depth_fg: np.ndarray  # (H, W) foreground depth, NaN elsewhere
    floor: FloorPlane
    timings_ms: dict[str, float]
    no_depth: np.ndarray | None = None  # (H, W) bool, pixels without a depth measurement

    def __getstate__(self) -> dict[str, Any]:
        # pickled between processes (`prefetch`): the foreground depth travels sparse (a few % of pixels),
        # the no-depth mask as bits
        state = dict(self.__dict__)
        depth = state.pop("depth_fg")
        flat = depth.ravel()
        idx = np.flatnonzero(~np.isnan(flat))
        state["_depth_sparse"] = (depth.shape, depth.dtype.str, idx.astype(np.int32), flat[idx])
        no_depth = state.pop("no_depth")
        state["_no_depth_bits"] = None if no_depth is None else (no_depth.shape, np.packbits(no_depth, axis=None))
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        shape, dtype, idx, values = state.pop("_depth_sparse")
        depth = np.full(int(np.prod(shape)), np.nan, dtype=np.dtype(dtype))
        depth[idx] = values
        state["depth_fg"] = depth.reshape(shape)
        bits = state.pop("_no_depth_bits", None)
        state["no_depth"] = None if bits is None else (
            np.unpackbits(bits[1], count=int(np.prod(bits[0]))).astype(bool).reshape(bits[0]))
        self.__dict__.update(state)


class FrameStore:
    """Prepared frames kept for the backward tracking pass, in a file (a temporary one, in memory up to
    ``memory_mb``, or ``path``, which a second process may read as frames are added: :meth:`reader`, :meth:`at`).

    A frame is stored as it travels between processes (foreground depth sparse, the no-depth mask as bits) without
    its points: they are the back-projection of the foreground depth's pixels (the segmenter selects both with
    one mask), recomputed on reading with the projector's arithmetic, so a frame reads back bit for bit.  About
    0.25 MB a frame of a 640x480 camera with the user at the walker: a five-minute session at 30 Hz writes ~2 GB
    to the temporary directory (``TMPDIR``), removed when the store is closed.
    """

    def __init__(self, *, memory_mb: int = 256, path: Path | None = None) -> None:
        import tempfile

        from walker_gait.core.depth import DepthProjector

        self._file: Any = (tempfile.SpooledTemporaryFile(max_size=max(0, int(memory_mb)) * 2**20) if path is None
                           else open(path, "r+b" if path.exists() else "w+b"))  # noqa: SIM115 - closed by close()
        self._index: list[tuple[int, int]] = []
        self._end = 0
        self._projector = DepthProjector()

    @classmethod
    def reader(cls, path: Path) -> FrameStore:
        """A read-only view of the store file ``path`` that another process appends to (created empty if missing,
        so that the writer may open it after the reader)."""
        if not path.exists():
            path.touch()
        store = cls.__new__(cls)
        store._file = open(path, "rb")  # noqa: SIM115 - closed by close()
        store._index, store._end = [], 0
        from walker_gait.core.depth import DepthProjector

        store._projector = DepthProjector()
        return store

    def __len__(self) -> int:
        return len(self._index)

    def append(self, frame: PreparedFrame) -> tuple[int, int]:
        """Add ``frame``; returns where it lies in the file (``offset, length``), written through to the file."""
        import pickle

        state = frame.__getstate__()
        state.pop("points")
        blob = pickle.dumps(state, protocol=pickle.HIGHEST_PROTOCOL)
        self._file.seek(self._end)
        self._file.write(blob)
        self._file.flush()
        where = (self._end, len(blob))
        self._index.append(where)
        self._end += len(blob)
        return where

    def __getitem__(self, i: int) -> PreparedFrame:
        return self.at(*self._index[i])

    def at(self, offset: int, length: int) -> PreparedFrame:
        """The frame stored at ``offset`` (what :meth:`append`, perhaps another process's, returned)."""
        import pickle

        self._file.seek(offset)
        state = pickle.loads(self._file.read(length))  # noqa: S301 - written by a FrameStore of this run
        _, _, idx, values = state["_depth_sparse"]
        self._projector.set_intrinsics(state["intrinsics"])
        rx, ry = self._projector.rays
        z = np.asarray(values, dtype=np.float32)
        with np.errstate(over="ignore", invalid="ignore"):
            points = np.stack([z * rx.reshape(-1)[idx], z * ry.reshape(-1)[idx], z], axis=1)
        frame = PreparedFrame.__new__(PreparedFrame)
        frame.__setstate__(state)
        frame.points = points
        return frame

    def close(self) -> None:
        self._file.close()


@dataclasses.dataclass
class Finished:
    """What :meth:`FrameProcessor.finish` returns: the frames' results not returned by ``track`` yet (with
    ``passes="both"`` all of them, in order) and the gait analyzer's last events and steps."""

    results: list[FrameResult]
    events: list[GaitEvent]
    steps: list[Step]
    backward_share: float = math.nan  # "both": fraction of the frames whose pose came from the backward pass
    passes: tuple[PassTrack, ...] = ()  # "both": the passes merged, forward and backward run by run (for re-merging)
    unconfirmed_steps: int | None = None  # "both": steps doubted because the passes alone did not both see them alike
    exchanged_frames: int | None = None  # "both": frames whose pass's legs the merge took exchanged back (merge_passes)


def strict_backward_wait(roi: Any) -> bool:
    """Whether the backward pass's tracks wait for both feet seen on one frame, over three
    (:func:`walker_gait.core.smoothing.wait_for_both_feet` ``frames=3, at_once=True``) instead of each foot seen
    once: with a region of interest (``RoiConfig``) that joins a leg across either side of the box
    (``join_edge_parts`` without ``join_centred_only``), which shows an arriving user's far foot sooner while the
    backward pass still has both model feet on the one foot in view, each seen there in turn (a leg reported 15-40 cm
    off for 5-8 frames).  The narrower join (``join_centred_only``) did better with the plain wait: the strict one
    dropped about 20 frames of two sweep sessions' arrivals that the backward pass alone tracked within 10 cm
    (DEVELOPERS.md, eighty-fourth session)."""
    return bool(roi.join_edge_parts) and not bool(roi.join_centred_only)


class FrameProcessor:
    """All stages for one camera, frame by frame (the offline twin of the live node graph).

    Two halves that may run in different processes, each touching only its own state:
    :meth:`set_camera_info` + :meth:`prepare` (decode, back-project, segment) and :meth:`track`
    (tracker + gait analyzer); :meth:`process` runs both.

    With ``options.passes == "both"`` :meth:`track` runs the forward tracking passes only (``options.tracker_runs``
    of them, each tracker on a random stream of its own) and keeps the frame (:class:`FrameStore`); :meth:`finish`
    then tracks the frames backwards as many times, merges every pass (:mod:`walker_gait.core.smoothing`) and runs
    the gait analyzer over the merged poses.
    """

    def __init__(self, options: PipelineOptions) -> None:
        from walker_gait.config import stage_rng
        from walker_gait.core.depth import DepthProjector
        from walker_gait.core.gait import GaitAnalyzer
        from walker_gait.core.segmentation import Segmenter

        self.options = options
        self.projector = DepthProjector()
        self.segmenter = Segmenter(options.segmenter, rng=stage_rng(options.seed, "floor_segmentation"))
        self.tracker: Any = None
        self.analyzer = GaitAnalyzer(options.gait)
        self.undistorter: Any = None
        self.intrinsics: CameraIntrinsics | None = None
        self._info_key: Any = None
        self._tracker_intrinsics: CameraIntrinsics | None = None
        self._last_stamp = -math.inf
        self._two_way = options.passes == "both"
        # "both": the forward pass analysed alone as it is tracked (the main process waits for the backward pass
        # anyway), for the check of the merged track's steps against each pass (check_against_passes)
        self._fwd_alone = GaitAnalyzer(options.gait) if self._two_way else None
        self.keep_frames = True  # "both": keep the frames for the backward pass (False: another process keeps them)
        self._store: FrameStore | None = None
        self._scorer: Any = None
        # "both": per frame the forward pass's pose, its score, stage times, floor and foreground size
        self._fwd: list[tuple[LegPose, float, dict[str, float], FloorPlane, int]] = []
        # "both": each direction tracked options.tracker_runs times; the further forward runs' trackers (run 1, 2,
        # ...) and per run, per frame their pose, its score and the tracker's time (ms)
        self._runs = options.tracker_runs or 1
        self._more: list[Any] = []
        self._more_fwd: list[list[tuple[LegPose, float, float]]] = [[] for _ in range(self._runs - 1)]
        # "forward": the reported pelvis placed frame by frame, as the live leg_tracker node does
        self._pelvis: Any = None
        if not self._two_way and options.report_pelvis_window_s > 0:
            from walker_gait.core.pelvis import LivePelvis

            self._pelvis = LivePelvis(mounting=options.mounting, window_s=options.report_pelvis_window_s,
                                      leg_length_m=options.leg_length_m)

    def set_camera_info(self, info: Any) -> None:
        """Apply a CameraInfo (``CameraInfoData`` or any object with width/height/k/d/p/distortion_model)."""
        from walker_gait.core.depth import intrinsics_from_camera_info

        key = (info.width, info.height, tuple(info.k), tuple(info.d), tuple(info.p), info.distortion_model)
        if key == self._info_key:
            return
        intr, undist = intrinsics_from_camera_info(width=info.width, height=info.height, k=info.k, d=info.d,
                                                   p=info.p, distortion_model=info.distortion_model,
                                                   rectified=self.options.use_rectified)
        self._info_key = key
        self.undistorter = undist
        self.projector.set_intrinsics(intr)
        self.segmenter.set_intrinsics(intr)
        self.intrinsics = intr

    def prepare(self, *, stamp: float, data: Any, encoding: str, width: int, height: int, step: int,
                is_bigendian: bool) -> PreparedFrame:
        """Decode, back-project and segment one depth image (call :meth:`set_camera_info` first)."""
        from walker_gait.core.depth import check_info_matches, decode_depth

        if self.intrinsics is None:
            raise MissingCalibration("no CameraInfo for this depth frame")
        t0 = time.perf_counter()
        check_info_matches(self.intrinsics, width=width, height=height)
        depth = decode_depth(data, encoding=encoding, width=width, height=height, step=step,
                             is_bigendian=is_bigendian, depth_format=self.options.depth_format)
        if self.undistorter is not None:
            depth = self.undistorter.apply(depth)
        points = self.projector.points(depth)
        t1 = time.perf_counter()
        seg = self.segmenter.process(depth, points)
        t2 = time.perf_counter()
        return PreparedFrame(stamp=stamp, intrinsics=self.intrinsics, points=seg.points,
                             depth_fg=seg.foreground_depth(depth), floor=seg.floor,
                             timings_ms={"depth": (t1 - t0) * 1e3, "segmentation": (t2 - t1) * 1e3},
                             no_depth=seg.no_depth)

    def learn_structure(self, frames: Iterable[Any], *, progress: Any = None) -> int:
        """Offline, before the first frame: learn the walker's own structure from the recording.

        The segmentation removes structure that keeps its place in the image while the user moves
        (:class:`~walker_gait.core.segmentation.StaticStructureMask`), but live it can only learn it from the frames
        seen so far: about 2 s of walking.  A user who stands still at the start with a wheel or post of the walker
        inside the region of interest leaves it in the foreground until then, and a model leg can take it.
        Offline the recording is there: ``frames`` (as a recording yields them: ``stamp``, ``data``, ``encoding``,
        ``width``, ``height``, ``step``, ``is_bigendian``, ``camera_info``) are decoded and segmented by a scratch
        processor (its own copies of every stage, so this processor's state and random streams stay as they were;
        every :data:`STRUCTURE_STRIDE`-th frame, its mask learning from as many fewer frames), and this processor's
        segmentation starts from the structure learned by the end, or once the scratch mask has seen
        :data:`STRUCTURE_MOVING_FRAMES` times its ``static_mask.frames`` moving frames: whatever kept its place since
        the start is learned by then, and what appears later is learned as the frames come, as always (a 300-frame
        session of a user walking from the start: ~75 frames decoded and segmented a second time).  ``progress``
        wraps the iteration (e.g. a tqdm bar).  Returns the number of learned cells (0: none, nothing changes).
        Frames that fail to decode are passed over here; tracking reports them.
        """
        static = self.segmenter.static
        if static is None:
            return 0
        # every STRUCTURE_STRIDE-th frame, each counting as many: the same span of walking teaches the mask
        seg = self.options.segmenter
        mask = dataclasses.replace(seg.static_mask, frames=max(1, math.ceil(seg.static_mask.frames / STRUCTURE_STRIDE)))
        scratch = FrameProcessor(dataclasses.replace(self.options,
                                                     segmenter=dataclasses.replace(seg, static_mask=mask)))
        learner = scratch.segmenter.static
        assert learner is not None
        enough = STRUCTURE_MOVING_FRAMES * mask.frames
        for i, frame in enumerate(progress(frames) if progress is not None else frames):
            if i % STRUCTURE_STRIDE:
                continue
            _prepare_one(scratch, frame)
            if learner.moving_frames >= enough:
                break
        structure = learner.structure()
        if structure is None:
            return 0
        static.seed(structure, learner.image_shape)
        return int(np.count_nonzero(np.isfinite(structure)))

    def track(self, frame: PreparedFrame) -> FrameResult | None:
        """Tracker and gait analyzer on a prepared frame (a new calibration restarts the tracker); with
        ``passes="both"`` the forward tracking pass only, and None (the results come from :meth:`finish`).

        Raises:
            StampOrderError: the frame's stamp is not after the previous frame's (duplicate or out of order);
                nothing has changed, the frame can be skipped.
        """
        from walker_gait.config import stage_rng
        from walker_gait.core.gait import StampOrderError
        from walker_gait.core.tracker import LegTracker

        if not frame.stamp > self._last_stamp:
            msg = f"stamp {frame.stamp:.6f} s is not after the previous frame's ({self._last_stamp:.6f} s)"
            raise StampOrderError(msg)
        self._last_stamp = frame.stamp
        if self.tracker is None or frame.intrinsics != self._tracker_intrinsics:
            # the shoes' rise and turn place the reported heels (both passes: afterwards; one: frame by frame, as
            # live)
            self.tracker = LegTracker(self.options.tracker, frame.intrinsics,
                                      rng=stage_rng(self.options.seed, "leg_tracker"), mounting=self.options.mounting,
                                      measure_shoes=self._two_way or self._pelvis is not None,
                                      threads=self.options.tracker_threads)
            self._more = [LegTracker(self.options.tracker, frame.intrinsics,
                                     rng=stage_rng(self.options.seed, "leg_tracker", run=run),
                                     mounting=self.options.mounting, measure_shoes=True) for run in range(1, self._runs)]
            self._tracker_intrinsics = frame.intrinsics
            if self._pelvis is not None:
                self._pelvis.reset()
        t2 = time.perf_counter()
        pose = self.tracker.update(stamp=frame.stamp, points=frame.points, depth_fg=frame.depth_fg, floor=frame.floor,
                                   no_depth=frame.no_depth)
        t3 = time.perf_counter()
        if self._two_way:
            index = len(self._fwd)
            score = self._score(frame, self.tracker.state, index)
            t4 = time.perf_counter()
            more_ms = 0.0  # the further forward runs, tracked and scored
            for tracker, runs in zip(self._more, self._more_fwd, strict=True):
                t0 = time.perf_counter()
                more = tracker.update(stamp=frame.stamp, points=frame.points, depth_fg=frame.depth_fg,
                                      floor=frame.floor, no_depth=frame.no_depth)
                t1 = time.perf_counter()
                runs.append((more, self._score(frame, tracker.state, index), (t1 - t0) * 1e3))
                more_ms += (time.perf_counter() - t0) * 1e3
            if self.keep_frames:
                if self._store is None:
                    self._store = FrameStore(memory_mb=self.options.store_memory_mb)
                self._store.append(frame)
            assert self._fwd_alone is not None
            t5 = time.perf_counter()
            self._fwd_alone.update(pose, frame.floor)  # its events and steps are read back at the end
            t6 = time.perf_counter()
            timings = dict(frame.timings_ms, tracker=(t3 - t2) * 1e3, pass_scoring=(t4 - t3) * 1e3,
                           gait=(t6 - t5) * 1e3)
            if self._more:
                timings["tracker_more_runs"] = more_ms
            self._fwd.append((pose, score, timings, frame.floor, len(frame.points)))
            return None
        events, steps = self.analyzer.update(pose, frame.floor)
        t4 = time.perf_counter()
        timings = dict(frame.timings_ms, tracker=(t3 - t2) * 1e3, gait=(t4 - t3) * 1e3)
        if self._pelvis is not None:  # what is reported; the analyzer has read the pose as tracked (its heels too)
            pose = self._pelvis.place(pose, frame.floor)
            timings["pelvis"] = (time.perf_counter() - t4) * 1e3
        return FrameResult(pose=pose, floor=frame.floor, events=list(events), steps=list(steps),
                           n_foreground=len(frame.points), timings_ms=timings)

    def _score(self, frame: PreparedFrame, state: Any, index: int) -> float:
        """Log likelihood of a pass's ``state`` on the ``index``-th tracked frame: one scorer and one generator per
        frame (``frame_rng``), so that the forward pass in one process and the backward pass in another score
        alike."""
        from walker_gait.config import frame_rng, stage_rng
        from walker_gait.core.smoothing import score_passes
        from walker_gait.core.tracker import LegTracker

        if self._scorer is None or self._scorer.intrinsics != frame.intrinsics:
            # scores with the frame's own generator (below), never its own
            self._scorer = LegTracker(self.options.tracker, frame.intrinsics,
                                      rng=stage_rng(self.options.seed, "pass_scoring"), mounting=self.options.mounting)
        return float(score_passes(self._scorer, frame, [state], rng=frame_rng(self.options.seed, index))[0])

    def backward(self, frames: Any, *, progress: Any = None, score: Any = None, defer_feet: bool = False,
                 run: int = 0) -> PassTrack:
        """The backward tracking pass over ``frames`` (a :class:`FrameStore` or sequence of prepared frames: every
        frame the forward pass tracked, in recording order), each estimate scored on its frame (by ``score(i, frame,
        state)`` if given, as :func:`~walker_gait.core.smoothing.track_pass` takes it; else here).  ``defer_feet``:
        the poses come without the feet's measures (``LegTracker(defer_feet=True)``) and ``score`` is called as
        ``score(i, frame, state, pending_feet)`` for the caller to complete them (:meth:`backward_feet`).  ``run``:
        which of the direction's ``tracker_runs`` runs (its own random stream)."""
        from walker_gait.core.smoothing import track_pass

        current: list[Any] = []

        def make(frame: Any) -> Any:
            current[:] = [self._backward_tracker(frame.intrinsics, defer_feet=defer_feet, run=run)]
            return current[0]

        if defer_feet:
            if score is None:
                raise ValueError("defer_feet needs a score callback that takes the pending feet")
            outer = score

            def score(i: int, f: Any, x: Any) -> float:
                return float(outer(i, f, x, current[0].pending_feet))

        return track_pass(make, frames, backward=True, score=score or (lambda i, f, x: self._score(f, x, i)),
                          progress=progress)

    def _backward_tracker(self, intrinsics: Any, *, defer_feet: bool = False, run: int = 0) -> Any:
        """A tracker of :meth:`backward`'s (a fresh one per camera, each on the pass's own random stream)."""
        from walker_gait.config import stage_rng
        from walker_gait.core.tracker import LegTracker

        return LegTracker(self.options.tracker, intrinsics,
                          rng=stage_rng(self.options.seed, "leg_tracker_backward", run=run),
                          mounting=self.options.mounting, time_reversed=True, defer_feet=defer_feet)

    def backward_feet(self, intrinsics: Any) -> Any:
        """The feet's measures of :meth:`backward`'s trackers for a camera (their
        :class:`~walker_gait.core.tracker.FeetReport`, for :meth:`~walker_gait.core.tracker.FeetReport.complete` with
        ``defer_feet``)."""
        return self._backward_tracker(intrinsics).feet

    def process(self, *, stamp: float, data: Any, encoding: str, width: int, height: int, step: int,
                is_bigendian: bool) -> FrameResult | None:
        """Run every stage on one depth image (call :meth:`set_camera_info` first); None as :meth:`track`."""
        return self.track(self.prepare(stamp=stamp, data=data, encoding=encoding, width=width, height=height,
                                       step=step, is_bigendian=is_bigendian))

    def finish(self, *, backward: Sequence[PassTrack] | None = None, progress: Any = None) -> Finished:
        """End of the recording.  ``passes="both"``: the backward passes, one per run (``options.tracker_runs``;
        ``backward``, when another process ran them over the same frames, else over the frames kept here;
        ``progress`` wraps each loop's frame indices, e.g. a tqdm bar), without the poses each alone gave before it
        had seen both feet (:func:`walker_gait.core.smoothing.wait_for_both_feet`), every pass merged
        (:func:`walker_gait.core.smoothing.merge_passes`), the gait analyzer over the merged poses.  Then the gait
        analyzer's last events and steps."""
        results: list[FrameResult] = []
        share = math.nan
        exchanged: int | None = None
        kept: tuple[PassTrack, ...] = ()
        if self._two_way and self._fwd:
            from walker_gait.core.gait import GaitAnalyzer
            from walker_gait.core.smoothing import (
                START_FRAMES,
                check_against_passes,
                merge_passes,
                reported_poses,
                wait_for_both_feet,
            )

            fwd, self._fwd = self._fwd, []
            more_fwd, self._more_fwd = self._more_fwd, [[] for _ in range(self._runs - 1)]
            store, self._store = self._store, None
            try:
                if backward is None:
                    if store is None:
                        raise RuntimeError("no frames kept for the backward pass (keep_frames is off)")
                    backward = [self.backward(store, progress=progress, run=run) for run in range(self._runs)]
            finally:
                if store is not None:
                    store.close()
            n = len(fwd)
            if len(backward) != self._runs or any(len(b.poses) != n for b in backward):
                raise RuntimeError(f"{len(backward)} backward passes of {[len(b.poses) for b in backward]} frames "
                                   f"for {self._runs} forward passes of {n}")
            forwards = [PassTrack(poses=[f[0] for f in fwd], scores=np.array([f[1] for f in fwd], dtype=np.float64),
                                  tracker_ms=np.zeros(n), scoring_ms=np.zeros(n))]
            forwards += [PassTrack(poses=[m[0] for m in run], scores=np.array([m[1] for m in run], dtype=np.float64),
                                   tracker_ms=np.array([m[2] for m in run], dtype=np.float64), scoring_ms=np.zeros(n))
                         for run in more_fwd]
            # a track starts where both feet have been seen, whichever way it was tracked (the forward tracker waits
            # for two legs; backwards, an arriving user's first frames end the track)
            strict = strict_backward_wait(self.options.segmenter.roi)
            backwards = [wait_for_both_feet(b, other=f, frames=3 if strict else START_FRAMES, at_once=strict)
                         for b, f in zip(backward, forwards, strict=True)]
            # forward and backward run by run (ties in the merge go to the first: the forward pass of run 0)
            passes = [p for pair in zip(forwards, backwards, strict=True) for p in pair]
            merged = merge_passes(passes)
            share, kept = sum(merged.share(k) for k in range(1, len(passes), 2)), tuple(passes)
            exchanged = int(merged.exchanged.sum()) if merged.exchanged is not None else 0
            # the analyzer reads the merged track as tracked (its confidences know a hidden foot's held pose for what
            # it is); the poses reported have the hidden feet's stretches bridged and are low-passed
            floors = [f[3] for f in fwd]
            shown = reported_poses(merged.poses, hide_below=self.options.tracker.hide_below,
                                   max_gap_s=self.options.bridge_hidden_s, lowpass_hz=self.options.report_lowpass_hz,
                                   floors=floors, pelvis_window_s=self.options.report_pelvis_window_s,
                                   mounting=self.options.mounting, leg_length_m=self.options.leg_length_m)
            # each pass analysed alone (the forward one as it was tracked): the merged track's steps are checked
            # against theirs (check_against_passes)
            assert self._fwd_alone is not None
            self._fwd_alone.finish()
            t0 = time.perf_counter()
            per_pass: list[tuple[Sequence[GaitEvent], Sequence[Step]]] = []
            for k, track in enumerate(passes):
                if k == 0:
                    per_pass.append((self._fwd_alone.events, self._fwd_alone.steps))
                    continue
                alone = GaitAnalyzer(self.options.gait)
                for pose, floor in zip(track.poses, floors):
                    alone.update(pose, floor)
                alone.finish()
                per_pass.append((alone.events, alone.steps))
            passes_gait_ms = (time.perf_counter() - t0) * 1e3 / n
            for i, ((_, _, fwd_ms, floor, n_fg), pose, pose_shown) in enumerate(zip(fwd, merged.poses, shown)):
                t0 = time.perf_counter()
                events, steps = self.analyzer.update(pose, floor)
                t1 = time.perf_counter()
                timings = dict(fwd_ms, tracker_backward=sum(float(b.tracker_ms[i]) for b in backwards),
                               pass_scoring=fwd_ms.get("pass_scoring", 0.0) + sum(float(b.scoring_ms[i])
                                                                                  for b in backwards),
                               gait=(t1 - t0) * 1e3 + passes_gait_ms + fwd_ms.get("gait", 0.0))
                results.append(FrameResult(pose=pose_shown, floor=floor, events=list(events), steps=list(steps),
                                           n_foreground=n_fg, timings_ms=timings))
            last_ev, last_st = self.analyzer.finish()
            raw = [s for r in results for s in r.steps] + list(last_st)
            all_ev, all_st = check_against_passes([e for r in results for e in r.events] + list(last_ev), raw, per_pass)
            doubted = sum(a.confidence != b.confidence for a, b in zip(raw, all_st))
            ne = ns = 0
            for r in results:  # each frame keeps the events and steps it finalised, checked
                r.events, ne = all_ev[ne:ne + len(r.events)], ne + len(r.events)
                r.steps, ns = all_st[ns:ns + len(r.steps)], ns + len(r.steps)
            return Finished(results=results, events=all_ev[ne:], steps=all_st[ns:], backward_share=share, passes=kept,
                            unconfirmed_steps=doubted, exchanged_frames=exchanged)
        events, steps = self.analyzer.finish()
        return Finished(results=results, events=list(events), steps=list(steps), backward_share=share, passes=kept)


class MissingCalibration(ValueError):
    kind = "no_camera_info"


@dataclasses.dataclass
class ProcessResult:
    input: Path
    out_dir: Path
    frames: int
    skipped: dict[str, int]
    steps: list[Step]
    events: list[GaitEvent]
    poses: list[LegPose]
    summary: dict[str, Any]
    wall_s: float
    timings_ms: dict[str, float]
    files: list[Path]
    passes: str = "forward"
    frames_from_backward_pass: int | None = None  # passes "both": frames whose pose came from a backward pass
    steps_unconfirmed: int | None = None  # passes "both": steps doubted as the passes did not all see them alike
    tracker_runs: int | None = None  # passes "both": how many times each direction was tracked
    frames_legs_exchanged_back: int | None = None  # passes "both": frames whose legs a pass had exchanged, taken back

    def tracking_note(self) -> str:
        """How the legs were tracked, in words."""
        if self.passes != "both":
            return "tracked forwards (one pass)"
        runs = self.tracker_runs or 1
        note = ("tracked forwards and backwards" + (f", {runs} times each way" if runs > 1 else "")
                + f", {self.frames_from_backward_pass} of {self.frames} frames' poses from "
                + ("a backward pass" if runs > 1 else "the backward pass"))
        if self.steps_unconfirmed:
            note += (f"; {self.steps_unconfirmed} of {len(self.steps)} steps not seen alike by "
                     + ("every pass" if runs > 1 else "both passes") + " (low confidence)")
        if self.frames_legs_exchanged_back:
            note += f"; left and right legs a pass had exchanged taken back on {self.frames_legs_exchanged_back} frames"
        return note

    def describe(self) -> str:
        lines = [f"{self.input}: {self.frames} frames in {self.wall_s:.1f} s "
                 f"({self.frames / max(self.wall_s, 1e-9):.1f} frames/s), {len(self.steps)} steps; "
                 + self.tracking_note()]
        if self.skipped:
            lines.append("skipped frames: " + ", ".join(f"{k} x{v}" for k, v in sorted(self.skipped.items())))
        lines.append(format_steps_table(self.steps))
        lines.append(format_summary(self.summary))
        lines.append("outputs: " + ", ".join(str(p) for p in self.files))
        return "\n".join(lines)


def _reported_lengths(poses: Sequence[LegPose], *, placed: bool) -> dict[str, Any] | None:
    """The median thigh, calf and foot (heel to toe) length of the reported poses (m, to the mm), the standing hip
    height they make (``leg``: thigh + calf + the model's ankle height), which sets the reported hips' height, and
    whether their shoes were reported under a trouser hem (``foot_under_hem``: the reported pelvis ``placed``, which
    gives a shoe whose back a hem hides at least the typical adult's length, :func:`walker_gait.core.pelvis.hemmed`
    and ``shoe_length``); ``None`` without a pose."""
    from walker_gait.core.leg_model import ANKLE_HEIGHT
    from walker_gait.core.pelvis import calf_radii, hemmed, segment_lengths

    if not poses:
        return None
    thigh, calf, foot = (float(v) for v in segment_lengths(np.stack([p.points for p in poses])))
    if not math.isfinite(thigh):  # no pose with all its points
        return None
    out: dict[str, Any] = {k: round(v, 3) for k, v in (("thigh", thigh), ("calf", calf), ("foot", foot),
                                                        ("leg", thigh + calf + ANKLE_HEIGHT * foot))}
    out["foot_under_hem"] = placed and hemmed(np.stack([calf_radii(p) for p in poses]))
    return out


def _summary_dict(analyzer_summary: Any) -> dict[str, Any]:
    if hasattr(analyzer_summary, "to_dict"):
        return dict(analyzer_summary.to_dict())
    return dict(analyzer_summary)


def format_steps_table(steps: list[Step], *, truth: dict[int, Step] | None = None) -> str:
    """Text table of ``steps``; ``truth`` maps an index into ``steps`` to its matched ground-truth step."""
    if not steps:
        return "no steps detected"
    head = f"{'#':>3} {'time s':>7} {'foot':<5} {'length cm':>9} {'width cm':>8} {'time s':>6}"
    if truth is not None:
        head += f"  {'true len':>8} {'true wid':>8}"
    rows = [head]
    for i, st in enumerate(steps):
        row = (f"{st.index:>3} {st.stamp:>7.2f} {st.side.label:<5} {st.step_length * 100:>9.1f} "
               f"{st.step_width * 100:>8.1f} {st.step_time:>6.2f}")
        match = truth.get(i) if truth is not None else None
        if match is not None:
            row += f"  {match.step_length * 100:>8.1f} {match.step_width * 100:>8.1f}"
        rows.append(row)
    return "\n".join(rows)


def format_summary(summary: Mapping[str, Any]) -> str:
    def f(key: str, scale: float = 1.0, fmt: str = "{:.1f}") -> str:
        value = summary.get(key)
        if value is None:
            return "n/a"
        try:
            if isinstance(value, (list, tuple)):
                return " / ".join("n/a" if v is None or not np.isfinite(v) else fmt.format(v * scale) for v in value)
            return "n/a" if not np.isfinite(value) else fmt.format(value * scale)
        except TypeError:
            return str(value)

    return (f"steps {summary.get('step_count', 0)}, cadence {f('cadence')} steps/min, speed "
            f"{f('gait_speed', 1, '{:.2f}')} m/s, step length L/R {f('step_length_mean_side', 100)} cm, "
            f"width L/R {f('step_width_mean_side', 100)} cm")


def _progress(iterable: Any, *, total: int, enabled: bool, desc: str) -> Any:
    if not enabled:
        return iterable
    from tqdm import tqdm

    return tqdm(iterable, total=total, desc=desc, unit="frame", disable=not sys.stderr.isatty(), leave=False)


def _progress_bar(*, total: int, enabled: bool, desc: str) -> Any:
    """A bar advanced by hand (``update(n)``), or None."""
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit="frame", disable=not sys.stderr.isatty(), leave=False)


def _prepare_one(proc: FrameProcessor, frame: Any) -> PreparedFrame | Exception:
    """Decode and segment ``frame``; a per-frame input problem is returned (the caller skips it in order)."""
    from walker_gait.core.depth import CameraInfoError, DepthDecodeError

    try:
        if frame.camera_info is None:
            raise MissingCalibration(f"no CameraInfo for the frame at {frame.stamp:.3f} s")
        proc.set_camera_info(frame.camera_info)
        return proc.prepare(stamp=frame.stamp, data=frame.data, encoding=frame.encoding, width=frame.width,
                            height=frame.height, step=frame.step, is_bigendian=frame.is_bigendian)
    except (DepthDecodeError, CameraInfoError, MissingCalibration) as exc:
        return exc


def _can_fork() -> bool:
    """Whether worker processes can be forked here (not on platforms without fork, nor from a daemonic
    ``batch`` worker, which may not have children)."""
    import multiprocessing as mp

    return "fork" in mp.get_all_start_methods() and not mp.current_process().daemon


@contextlib.contextmanager
def _fork_safely() -> Iterator[None]:
    """Around a fork: this process's garbage collected here, the rest kept out of the child's collector.  A child
    that collected the parent's leftover reference cycles ran their finalisers against state it does not own: an
    rclpy node's (a program or a test that made nodes before processing a recording) crashed the forked report
    writer with a segmentation fault in its garbage collection."""
    gc.collect()
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def _floor_up_hint(configured: Any, floors: list[FloorPlane]) -> tuple[tuple[float, float, float], bool]:
    """The up direction around which the recording's floor was found (``floor.up_hint``, or the half-turned one of
    ``floor.auto_flip``: a camera mounted upside down) and whether it is the half-turned one.  The segmenter may
    run in another process (``prefetch``), so this is read off the floor planes: the last valid one's normal lies
    nearer the one than the other."""
    from walker_gait.core.segmentation import flipped_up_hint

    x, y, z = (float(v) for v in configured)
    hint = (x, y, z)
    flipped_hint = flipped_up_hint(hint)
    last = next((f for f in reversed(floors) if f.valid), None)
    if last is None:
        return hint, False
    n = np.asarray(last.normal, dtype=np.float64)
    flipped = float(n @ np.asarray(flipped_hint)) > float(n @ np.asarray(hint))  # both hints have the same length
    return (flipped_hint if flipped else hint), flipped


class _Front:
    """The front half of :func:`process_recording`: ``(frame, PreparedFrame or per-frame error)`` in recording order
    (:meth:`frames`), and with two tracking passes the backward one (:meth:`backward`).

    With ``prefetch`` > 0 (and ``fork`` available) a worker process reads, decodes and segments up to that many
    frames ahead while the caller tracks: the two halves run on two cores.  Results are identical to the inline
    path: the front half's state (projector, segmenter and its seeded RNG) is forked once and only the worker
    advances it, and :meth:`FrameProcessor.track` takes the calibration from each prepared frame.  With two passes
    (``two_way``) the worker keeps every frame the forward pass will track in a :class:`FrameStore` file and sends
    only where it lies, so it runs ahead without a bound; after the last frame it tracks them backwards
    (:meth:`FrameProcessor.backward`) while the caller still tracks forwards, and :meth:`backward` collects that.
    It refuses a frame whose stamp is not after the previous one's itself (``StampOrderError``, as ``track`` would),
    so that both passes cover the same frames.  The recording's warnings are re-issued in the caller in order; an
    error reading the recording is raised there.  Inline, :meth:`backward` returns None: the caller's
    ``FrameProcessor`` keeps the frames and tracks them backwards in :meth:`FrameProcessor.finish`.
    """

    def __init__(self, recording: Any, proc: FrameProcessor, *, prefetch: int, two_way: bool) -> None:
        self.recording = recording
        self.proc = proc
        self.forked = prefetch > 0 and _can_fork()
        self.two_way = two_way
        self._prefetch = prefetch
        self._worker: Any = None
        self._q: Any = None
        self._dir: str | None = None
        self._reader: FrameStore | None = None
        self._store_path: Path | None = None
        self._stored: list[tuple[int, int]] = []  # where the worker stored each frame the caller tracked, in order

    def __enter__(self) -> _Front:
        if self.forked:
            import multiprocessing as mp
            import tempfile

            ctx = mp.get_context("fork")
            if self.two_way:
                self._dir = tempfile.mkdtemp(prefix="walker-gait-frames-")
                self._store_path = Path(self._dir) / "frames.bin"
                self._reader = FrameStore.reader(self._store_path)
                self.proc.keep_frames = False  # the worker keeps them
            self._q = ctx.Queue(maxsize=0 if self.two_way else self._prefetch)
            self._worker = ctx.Process(target=_front_worker,
                                       args=(self._q, self.recording, self.proc, self._store_path),
                                       name="walker-gait-prepare", daemon=True)
            with _fork_safely():
                self._worker.start()
        return self

    def __exit__(self, *exc: object) -> None:
        import shutil

        if self._worker is not None:
            if self._worker.is_alive():
                self._worker.terminate()
            self._worker.join(timeout=5.0)
            self._q.close()
            self._q.cancel_join_thread()
        if self._reader is not None:
            self._reader.close()
        if self._dir is not None:
            shutil.rmtree(self._dir, ignore_errors=True)

    def _get(self) -> tuple[str, Any]:
        import queue as queue_mod

        while True:
            try:
                kind, payload, caught = self._q.get(timeout=1.0)
            except queue_mod.Empty:
                if not self._worker.is_alive():
                    raise RuntimeError(f"the frame-preparing worker process died (exit code {self._worker.exitcode})")
                continue
            for category, text in caught:
                warnings.warn(text, category, stacklevel=3)
            if kind == "error":
                raise payload
            return kind, payload

    def frames(self) -> Iterator[tuple[Any, Any]]:
        if not self.forked:
            for frame in self.recording.iter_frames():
                yield frame, _prepare_one(self.proc, frame)
            return
        while True:
            kind, payload = self._get()
            if kind == "done":
                return
            frame, prepared = payload
            if isinstance(prepared, tuple):  # ("stored", offset, length) in the worker's FrameStore file
                assert self._reader is not None
                self._stored.append((prepared[1], prepared[2]))
                prepared = self._reader.at(prepared[1], prepared[2])
            yield frame, prepared

    def backward(self, progress: Any = None) -> list[PassTrack] | None:
        """The worker's backward passes, one per run of ``tracker_runs`` (None inline); ``progress``: a tqdm-like bar
        it advances, or None.

        The worker sends the backward tracker's state after each frame and this process, idle once its forward pass
        is done, scores it (:meth:`FrameProcessor._score`, on the frame read back from the worker's store) and takes
        the feet's measures of its pose (the worker's trackers leave them out: ``LegTracker(defer_feet=True)``,
        :meth:`~walker_gait.core.tracker.FeetReport.complete`): the worker's pass, the end of the run's critical
        path, is spared both, and the poses are those of the inline pass bit for bit."""
        if not (self.forked and self.two_way):
            return None
        assert self._reader is not None
        n = len(self._stored)
        runs = self.proc._runs
        scores = np.full((runs, n), np.nan)
        scoring_ms = np.zeros((runs, n))
        # each run's, each frame's measured (points, shoe rise, shoe turn)
        feet: list[list[tuple[Any, Any, Any] | None]] = [[None] * n for _ in range(runs)]
        feet_ms = np.zeros((runs, n))  # their time, the tracker's work done here
        last: list[tuple[Any, Any, Any] | None] = [None] * runs  # of each run's last pose estimated, which a held pose repeats
        reports: dict[Any, Any] = {}
        done: list[PassTrack | None] = [None] * runs
        while True:
            kind, payload = self._get()
            if kind == "bprog":
                if progress is not None:
                    progress.update(payload)
                continue
            if kind == "bstate":
                run, i, state, pending = payload
                t0 = time.perf_counter()
                frame = self._reader.at(*self._stored[i])
                scores[run, i] = self.proc._score(frame, state, i)
                t1 = time.perf_counter()
                if pending is not None:
                    if frame.intrinsics not in reports:
                        reports[frame.intrinsics] = self.proc.backward_feet(frame.intrinsics)
                    last[run] = reports[frame.intrinsics].measured(pending, points=frame.points, floor=frame.floor,
                                                                   no_depth=frame.no_depth)
                feet[run][i] = last[run]
                scoring_ms[run, i] = (t1 - t0) * 1e3
                feet_ms[run, i] = (time.perf_counter() - t1) * 1e3
                continue
            if kind == "backward":
                run, track = payload
                if len(track.poses) != n or np.isnan(scores[run]).any():
                    raise RuntimeError(f"the frame-preparing worker's backward pass {run} covers {len(track.poses)} "
                                       f"frames, {int(np.isnan(scores[run]).sum())} of them unscored, of {n}")
                poses = [p if m is None or not np.all(np.isfinite(p.points)) else
                         dataclasses.replace(p, points=m[0], shoe_rise=m[1], shoe_turn=m[2])
                         for p, m in zip(track.poses, feet[run], strict=True)]
                done[run] = dataclasses.replace(track, poses=poses, scores=scores[run], scoring_ms=scoring_ms[run],
                                                tracker_ms=track.tracker_ms + feet_ms[run])
                if all(d is not None for d in done):
                    return [d for d in done if d is not None]
                continue
            raise RuntimeError(f"unexpected message {kind!r} from the frame-preparing worker")


def _front_worker(q: Any, recording: Any, proc: FrameProcessor, store_path: Path | None) -> None:
    """Worker process of :class:`_Front` (forked: the recording and processor are copies)."""
    import signal

    from walker_gait.core.gait import StampOrderError

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's; it stops this process
    frames = recording.iter_frames()
    store = FrameStore(path=store_path) if store_path is not None else None
    last = -math.inf
    while True:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                frame = next(frames, None)
                if frame is None:
                    item: tuple[str, Any] = ("done", None)
                else:
                    prepared: Any = _prepare_one(proc, frame)
                    if store is not None and not isinstance(prepared, Exception):
                        if not prepared.stamp > last:  # as FrameProcessor.track refuses it
                            prepared = StampOrderError(f"stamp {prepared.stamp:.6f} s is not after the previous "
                                                       f"frame's ({last:.6f} s)")
                        else:
                            last = prepared.stamp
                            prepared = ("stored", *store.append(prepared))
                    item = ("frame", (dataclasses.replace(frame, data=b""), prepared))
            except Exception as exc:  # noqa: BLE001 - raised in the parent
                item = ("error", exc)
        q.put((*item, [(w.category, str(w.message)) for w in caught]))
        if item[0] != "frame":
            break
    if item[0] != "done" or store is None:
        return
    try:
        def counted(order: Iterable[int]) -> Iterator[int]:
            done = 0
            for i in order:
                yield i
                done += 1
                if done % 15 == 0:
                    q.put(("bprog", 15, []))
            q.put(("bprog", done % 15, []))

        for run in range(proc._runs):  # each run's pass sent as it ends, its states scored meanwhile by the parent
            def send(i: int, frame: Any, state: Any, feet: Any, run: int = run) -> float:
                q.put(("bstate", (run, i, state, feet), []))  # scored and completed by the parent
                return math.nan

            q.put(("backward", (run, proc.backward(store, progress=counted, score=send, defer_feet=True, run=run)),
                   []))
    except Exception as exc:  # noqa: BLE001 - raised in the parent
        q.put(("error", exc, []))
    finally:
        store.close()


def _load_kernels_beside() -> threading.Thread:
    """Load the tracker's compiled kernels (:func:`walker_gait.core.kernels.compiled`: numba's import and its cached
    kernels, ~0.4 s; their compilation once after an install) in a thread started now; join it before forking."""
    from walker_gait.core import kernels

    thread = threading.Thread(target=kernels.compiled, name="walker-gait-kernels", daemon=True)
    thread.start()
    return thread


def _in_background(fn: Any, *args: Any, **kwargs: Any) -> Any:
    """Start ``fn(*args, **kwargs)`` in a forked process; returns a callable that waits and re-raises.

    Runs inline where ``fork`` is unavailable or this is already a daemon (``batch`` worker) process.
    """
    import multiprocessing as mp

    if not _can_fork():
        fn(*args, **kwargs)
        return lambda: None
    pool = ProcessPoolExecutor(max_workers=1, mp_context=mp.get_context("fork"))
    with _fork_safely():  # submit forks the worker
        future = pool.submit(fn, *args, **kwargs)

    def wait() -> None:
        try:
            future.result()
        finally:
            pool.shutdown(wait=True)

    return wait


def process_recording(path: Path, out_dir: Path, *, options: PipelineOptions | None = None,
                      progress: bool = True, ground_truth: Mapping[str, Any] | None = None) -> ProcessResult:
    """Process one recording; write steps/events/joints CSV, summary.json, tracked.mcap, report.html."""
    from walker_gait.io.bags import open_recording
    from walker_gait.io.outputs import write_events_csv, write_joints_csv, write_steps_csv, write_summary_json

    options = options or PipelineOptions()
    t_start = time.perf_counter()
    recording = open_recording(path, depth_topic=options.depth_topic, info_topic=options.info_topic,
                               camera_info_file=options.camera_info_file)
    out_dir.mkdir(parents=True, exist_ok=True)
    proc = FrameProcessor(options)
    poses: list[LegPose] = []
    floors: list[FloorPlane] = []
    events: list[GaitEvent] = []
    steps: list[Step] = []
    skipped: Counter[str] = Counter()
    timing_sum: Counter[str] = Counter()
    n_frames = 0
    tracked: list[tuple[int, str, FrameResult]] = []  # (stamp_ns, frame_id, result) for tracked.mcap
    kept: list[tuple[int, str]] = []  # (stamp_ns, frame_id) of the frames whose results come from proc.finish()
    from walker_gait.core.depth import CameraInfoError, DepthDecodeError
    from walker_gait.core.gait import StampOrderError

    def take(stamp_ns: int, frame_id: str, res: FrameResult) -> None:
        poses.append(res.pose)
        floors.append(res.floor)
        events.extend(res.events)
        steps.extend(res.steps)
        timing_sum.update(res.timings_ms)
        if options.write_mcap:
            tracked.append((stamp_ns, frame_id, res))

    two_way = options.passes == "both"
    # the tracker's compiled kernels loaded (or compiled, once after an install) before the frame worker is forked, so
    # that its backward pass, the end of the critical path, inherits them; beside learn_structure in a thread
    kernels_loaded = _load_kernels_beside() if two_way and options.prefetch > 0 and _can_fork() else None
    try:
        if two_way:  # offline, the recording at hand: the walker's own structure learned from it first
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # the tracking pass reads the same frames and reports their problems
                proc.learn_structure(recording.iter_frames(), progress=lambda it: _progress(
                    it, total=recording.frame_count, enabled=progress, desc=f"{path.name} (walker structure)"))
    finally:
        if kernels_loaded is not None:
            kernels_loaded.join()  # no thread may be running when the worker is forked
    with _Front(recording, proc, prefetch=options.prefetch, two_way=two_way) as front:
        for frame, prepared in _progress(front.frames(), total=recording.frame_count, enabled=progress,
                                         desc=f"{path.name} (forward)" if two_way else path.name):
            n_frames += 1
            try:
                if isinstance(prepared, Exception):
                    raise prepared
                res = proc.track(prepared)
            except (DepthDecodeError, CameraInfoError, MissingCalibration, StampOrderError) as exc:
                kind = getattr(exc, "kind", None) or type(exc).__name__
                if not skipped[kind]:
                    print(f"walker-gait: warning: {path}: frame at {frame.stamp:.3f} s skipped: {exc} "
                          "(further frames skipped for this reason are only counted)", file=sys.stderr)
                skipped[kind] += 1
                continue
            if res is None:
                kept.append((frame.stamp_ns, frame.frame_id))
            else:
                take(frame.stamp_ns, frame.frame_id, res)
        backward = None
        if front.forked and two_way:
            if options.write_report:  # imported (matplotlib, ~0.4 s) while the worker still tracks backwards
                import walker_gait.report  # noqa: F401
            bar = _progress_bar(total=len(kept) * (options.tracker_runs or 1), enabled=progress, desc=f"{path.name} (backward)")
            try:
                backward = front.backward(bar)
            finally:
                if bar is not None:
                    bar.close()

    def backward_bar(order: Any) -> Any:
        return _progress(order, total=len(kept), enabled=progress, desc=f"{path.name} (backward)")

    finished = proc.finish(backward=backward, progress=backward_bar)
    for (stamp_ns, frame_id), res in zip(kept, finished.results, strict=True):
        take(stamp_ns, frame_id, res)
    events.extend(finished.events)
    steps.extend(finished.steps)
    processed = len(poses)
    if processed == 0:  # nothing to write: fail before any output exists
        from walker_gait.io.bags import RecordingError

        hint = ""
        if set(skipped) & {"no_camera_info", "CameraInfoError"}:
            hint = "; give the depth camera's calibration with --camera-info FILE.yaml"
        raise RecordingError(f"{path}: no frame could be processed ({dict(skipped) or 'no depth frames'}){hint}")
    summary = _summary_dict(proc.analyzer.summary(window_s=None, steps=steps, checked=two_way))  # as checked (two passes)
    no_floor = sum(1 for f in floors if not f.valid)
    up_hint, flipped = _floor_up_hint(options.segmenter.floor.up_hint, floors)
    if flipped:
        print(f"walker-gait: note: {path}: the floor was found with the camera upside down (floor.up_hint "
              f"{list(up_hint)} instead of {list(options.segmenter.floor.up_hint)}; floor.auto_flip)", file=sys.stderr)
    if no_floor > processed // 2:
        print(f"walker-gait: warning: {path}: no floor plane found in {no_floor} of {processed} frames, so the legs "
              "could not be tracked there; if the camera is mounted rolled, set the floor's up direction in the "
              "camera frame, e.g. --param floor_segmentation.floor.up_hint=[1.0,0.0,0.0] (default [0.0,-1.0,0.0], "
              "image rows pointing down; floor.auto_flip also tries [0.0,1.0,0.0], a camera upside down)", file=sys.stderr)
    wall_s = time.perf_counter() - t_start
    timings = {k: v / max(processed, 1) for k, v in timing_sum.items()}
    metadata = {
        "input": str(path),
        "preset": options.preset,
        "seed": options.seed,
        "passes": options.passes,
        "tracker_runs": options.tracker_runs if two_way else None,
        "frames_from_backward_pass": (round(finished.backward_share * processed) if two_way and processed else None),
        "steps_unconfirmed": finished.unconfirmed_steps if two_way else None,
        "frames_legs_exchanged_back": finished.exchanged_frames if two_way else None,
        "bridge_hidden_s": options.bridge_hidden_s if two_way else None,
        "report_lowpass_hz": options.report_lowpass_hz if two_way else None,
        "report_pelvis_window_s": options.report_pelvis_window_s,
        "leg_length_m": (options.leg_length_m or None) if options.report_pelvis_window_s > 0 else None,
        "reported_segment_lengths_m": _reported_lengths(poses, placed=options.report_pelvis_window_s > 0),
        "frames_total": n_frames,
        "frames_processed": processed,
        "frames_skipped": dict(skipped),
        "frames_without_floor": no_floor,
        "floor_up_hint": list(up_hint),
        "walker_gait_version": __version__,
        "processing_time_s": round(wall_s, 3),
        "depth_topic": recording.depth_topic,
        "info_topic": recording.info_topic,
        "mean_stage_ms": {k: round(v, 3) for k, v in timings.items()},
    }
    files = []
    report = None
    if options.write_report:
        from walker_gait.report import write_report

        # the figures take ~1 s: drawn in a second process while this one writes the other files, half of them in a
        # third (this one is idle once its files are written)
        files.append(out_dir / "report.html")
        report = _in_background(write_report, files[-1], steps=steps, events=events, poses=poses, summary=summary,
                                metadata=metadata, ground_truth=dict(ground_truth) if ground_truth else None,
                                floor=next((f for f in reversed(floors) if f.valid), None),
                                processes=2 if _can_fork() else 1)
    files.append(out_dir / "steps.csv")
    write_steps_csv(files[-1], steps)
    files.append(out_dir / "events.csv")
    write_events_csv(files[-1], events)
    files.append(out_dir / "joints.csv")
    write_joints_csv(files[-1], poses)
    files.append(out_dir / "summary.json")
    write_summary_json(files[-1], summary, metadata=metadata)
    if options.write_mcap:
        files.append(out_dir / "tracked.mcap")
        bridged = None
        if options.passes == "forward" and options.bridge_hidden_s > 0:  # the live leg_tracker's leg_track_bridged
            from walker_gait.core.smoothing import live_bridged

            bridged = live_bridged([r.pose for _, _, r in tracked], [r.floor for _, _, r in tracked],
                                   hide_below=options.tracker.hide_below, max_gap_s=options.bridge_hidden_s)[0]
        write_tracked_mcap(files[-1], frames=tracked, events=events, steps=steps, summary=summary,
                           particle_count=int(getattr(options.tracker, "n_particles", 0)), bridged=bridged)
    if report is not None:
        report()
    return ProcessResult(input=path, out_dir=out_dir, frames=processed, skipped=dict(skipped), steps=steps,
                         events=events, poses=poses, summary=summary, wall_s=time.perf_counter() - t_start,
                         timings_ms=timings, files=files, passes=options.passes,
                         tracker_runs=metadata["tracker_runs"],
                         frames_from_backward_pass=metadata["frames_from_backward_pass"],
                         steps_unconfirmed=metadata["steps_unconfirmed"],
                         frames_legs_exchanged_back=metadata["frames_legs_exchanged_back"])


def write_tracked_mcap(path: Path, *, frames: list[tuple[int, str, FrameResult]], events: list[GaitEvent],
                       steps: list[Step], summary: Mapping[str, Any], particle_count: int,
                       bridged: Sequence[LegPose] | None = None) -> None:
    """The messages the live nodes would publish, as a rosbag2/MCAP (atomic; Foxglove-readable).

    ``frames`` are ``(stamp_ns, frame_id, result)``; ``summary`` uses GaitSummary's field names; ``bridged`` (one pose
    per frame, a one-pass run's: :func:`walker_gait.core.smoothing.live_bridged`) adds ``/leg_track_bridged``.
    """
    from walker_gait import messages as M
    from walker_gait.io.bagwriter import BagWriter

    topics = {
        "/joint_states": M.JOINT_STATE, "/leg_track": M.LEG_TRACK, "/leg_markers": M.MARKER_ARRAY,
        "/floor_plane": M.FLOOR_PLANE, "/gait_events": M.GAIT_EVENT, "/steps": M.STEP,
        "/gait_summary": M.GAIT_SUMMARY,
    }
    if bridged is not None:
        if len(bridged) != len(frames):
            raise ValueError(f"{len(bridged)} bridged poses for {len(frames)} frames")
        topics["/leg_track_bridged"] = M.LEG_TRACK
    with BagWriter(path, fmt="mcap", typestore=M.typestore(), overwrite=True) as bag:
        for topic, typename in topics.items():
            bag.add_topic(topic, typename)
        stream: list[tuple[int, str, Any]] = []
        for k, (stamp_ns, frame_id, res) in enumerate(frames):
            header = M.make_header(M.make_time(stamp_ns, ns=True), frame_id)
            if bridged is not None:
                stream.append((stamp_ns, "/leg_track_bridged",
                               M.make_leg_track(bridged[k], header, particle_count=particle_count)))
            stream.append((stamp_ns, "/joint_states", M.make_joint_state(res.pose, header)))
            stream.append((stamp_ns, "/leg_track", M.make_leg_track(res.pose, header, particle_count=particle_count)))
            stream.append((stamp_ns, "/leg_markers", M.make_markers(res.pose, header)))
            stream.append((stamp_ns, "/floor_plane", M.make_floor_plane(res.floor, header)))
        frame_id = frames[0][1] if frames else ""
        for ev in events:
            stream.append((round(ev.stamp * 1e9), "/gait_events", M.make_gait_event(ev, frame_id)))
        for st in steps:
            stream.append((round(st.stamp * 1e9), "/steps", M.make_step(st, frame_id)))
        if frames:
            last_ns = frames[-1][0]
            stream.append((last_ns, "/gait_summary", M.make_gait_summary(
                dict(summary), M.make_header(M.make_time(last_ns, ns=True), frame_id))))
        stream.sort(key=lambda item: item[0])
        for stamp_ns, topic, msg in stream:
            bag.write(topic, max(stamp_ns, 0), msg)


# ------------------------------------------------------------------------------------------ batch


def _batch_one(args: tuple[str, str, PipelineOptions]) -> dict[str, Any]:
    path, out, options = args
    try:
        res = process_recording(Path(path), Path(out), options=options, progress=False)
    except Exception as exc:  # noqa: BLE001 - one bad recording must not stop the batch
        return {"input": path, "status": "error", "error": f"{type(exc).__name__}: {exc}"}
    row = {"input": path, "status": "ok", "frames": res.frames, "steps": len(res.steps)}
    row.update({k: v for k, v in res.summary.items() if not isinstance(v, (list, tuple, dict))})
    return row


def process_batch(folder: Path, out_dir: Path, *, options: PipelineOptions, workers: int = 2,
                  progress: bool = True) -> Path:
    """Process every recording in ``folder`` (``workers`` processes); write ``summaries.csv`` + ``.json``."""
    import csv

    from walker_gait.io.bags import find_recordings
    from walker_gait.io.outputs import atomic_write

    recordings = find_recordings(folder)
    out_dir.mkdir(parents=True, exist_ok=True)
    jobs = [(str(p), str(out_dir / p.stem), options) for p in recordings]
    rows: list[dict[str, Any]] = []
    with ProcessPoolExecutor(max_workers=max(1, workers)) as pool:
        futures = [pool.submit(_batch_one, job) for job in jobs]
        for fut in _progress(as_completed(futures), total=len(futures), enabled=progress, desc="batch"):
            rows.append(fut.result())
    rows.sort(key=lambda r: r["input"])
    columns: list[str] = []
    for r in rows:
        columns.extend(k for k in r if k not in columns)
    table = out_dir / "summaries.csv"
    with atomic_write(table) as fh:
        writer = csv.DictWriter(fh, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)
    with atomic_write(out_dir / "summaries.json") as fh:
        json.dump(rows, fh, indent=2, default=str)
    failed = [r for r in rows if r["status"] != "ok"]
    if failed:
        for r in failed:
            print(f"walker-gait: error: {r['input']}: {r['error']}", file=sys.stderr)
    return table
