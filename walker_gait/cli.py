"""``walker-gait``: run the live node graph, replay recordings, process them offline, demo, generate.

User errors (missing file, unknown format, bad parameter...) print ``walker-gait: error: ...`` naming
the file and the problem and exit with status 2, without a traceback.
"""

from __future__ import annotations

from walker_gait import limit_blas_threads

limit_blas_threads()  # before numpy is imported (by any walker_gait module); inherited by the node processes

import argparse  # noqa: E402
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path
from typing import Any

NODE_NAMES = ("depth_to_cloud", "floor_segmentation", "leg_tracker", "gait_analyzer", "bag_replay")
EXIT_USER_ERROR = 2


class UserError(Exception):
    """A problem with the user's input; printed without a traceback."""


def _user_error_types() -> tuple[type[BaseException], ...]:
    from walker_gait.config import ParameterError

    types: list[type[BaseException]] = [UserError, ParameterError, FileNotFoundError, IsADirectoryError,
                                        PermissionError]
    try:
        from walker_gait.io.bags import RecordingError

        types.append(RecordingError)
    except ImportError:  # pragma: no cover - reader not installed
        pass
    return tuple(types)


# ------------------------------------------------------------------------------------------- run


def _pdeathsig() -> None:  # pragma: no cover - runs in the child between fork and exec
    """Children die with their parent even if it is SIGKILLed (Linux), so no orphans are left."""
    try:
        import ctypes

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except OSError:
        pass


def node_command(name: str, *, params_file: Path | None, remaps: list[str], params: list[str]) -> list[str]:
    cmd = [sys.executable, "-m", "walker_gait.ros", name, "--ros-args"]
    if params_file is not None:
        cmd += ["--params-file", str(params_file)]
    for r in remaps:
        cmd += ["-r", r]
    for p in params:
        cmd += ["-p", p]
    return cmd


def cmd_run(args: argparse.Namespace) -> int:
    """Start the live graph: one OS process per node; Ctrl-C / SIGTERM stops them all."""
    from walker_gait.config import default_params_file
    from walker_gait.paramspec import CAMERA_PARAMS

    params_file = Path(args.params_file) if args.params_file else default_params_file()
    if not params_file.is_file():
        raise UserError(f"{params_file}: parameters file not found")
    remaps: list[str] = []
    if args.depth_topic:
        remaps.append(f"depth/image_raw:={args.depth_topic}")
    if args.info_topic:
        remaps.append(f"depth/camera_info:={args.info_topic}")
    node_params: dict[str, list[str]] = {}
    for item in args.param or []:
        key, sep, value = item.partition("=")
        node, _, name = key.partition(".")
        if not sep or node not in NODE_NAMES or not name:
            raise UserError(f"--param expects NODE.PARAM=VALUE with NODE one of {', '.join(NODE_NAMES)}, got {item!r}")
        node_params.setdefault(node, []).append(f"{name}:={value}")
        if node == "depth_to_cloud" and name in CAMERA_PARAMS:  # the other stages decode the same camera
            for other in CAMERA_PARAMS[name]:
                node_params.setdefault(other, []).append(f"{name}:={value}")
    nodes = args.nodes.split(",") if args.nodes else list(NODE_NAMES)
    for n in nodes:
        if n not in NODE_NAMES:
            raise UserError(f"unknown node {n!r}; nodes: {', '.join(NODE_NAMES)}")
    procs: dict[str, subprocess.Popen[bytes]] = {}
    stopping = False

    def request_stop(signum: int, frame: Any) -> None:
        nonlocal stopping
        stopping = True

    old_int = signal.signal(signal.SIGINT, request_stop)
    old_term = signal.signal(signal.SIGTERM, request_stop)
    try:
        for name in nodes:
            extra: list[str] = []
            if name == "bag_replay" and args.replay:
                if not Path(args.replay).exists():
                    raise UserError(f"{args.replay}: no such file or folder")
                extra = [f"input:={Path(args.replay).resolve()}", f"rate:={args.rate}", f"loop:={str(args.loop).lower()}"]
            cmd = node_command(name, params_file=params_file, remaps=remaps, params=extra + node_params.get(name, []))
            # own session: a terminal Ctrl-C reaches only us, and we forward exactly one SIGINT
            procs[name] = subprocess.Popen(cmd, start_new_session=True, preexec_fn=_pdeathsig)  # noqa: S603
        print(f"walker-gait run: started {', '.join(f'{n} (pid {p.pid})' for n, p in procs.items())}; "
              "Ctrl-C to stop", flush=True)
        failed: list[str] = []
        while not stopping:
            for name, proc in procs.items():
                code = proc.poll()
                if code is not None and name not in failed:
                    failed.append(name)
                    print(f"walker-gait run: node {name} exited with status {code}", file=sys.stderr, flush=True)
            if failed and len(failed) == len(procs):
                break
            time.sleep(0.1)
    finally:
        signal.signal(signal.SIGINT, old_int)
        signal.signal(signal.SIGTERM, old_term)
        codes = _stop_all(procs)
    bad = {n: c for n, c in codes.items() if c not in (0, -signal.SIGINT)}
    if bad:
        print(f"walker-gait run: nodes stopped with errors: {bad}", file=sys.stderr)
        return 1
    return 0


def _stop_all(procs: dict[str, subprocess.Popen[bytes]], *, grace_s: float = 10.0) -> dict[str, int]:
    for proc in procs.values():
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
    deadline = time.monotonic() + grace_s
    for proc in procs.values():
        try:
            proc.wait(timeout=max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            proc.terminate()
            try:
                proc.wait(timeout=3)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
    return {name: int(proc.returncode) for name, proc in procs.items()}


# ---------------------------------------------------------------------------------------- replay


def cmd_replay(args: argparse.Namespace) -> int:
    path = Path(args.input)
    if not path.exists():
        raise UserError(f"{path}: no such file or folder")
    if args.rate <= 0:
        raise UserError(f"--rate must be > 0, got {args.rate}")
    from walker_gait.io.bags import open_recording

    recording = open_recording(path, depth_topic=args.depth_topic, info_topic=args.info_topic)
    print(recording.describe(), flush=True)
    del recording

    import rclpy

    from walker_gait.ros.base import WalkerNode
    from walker_gait.ros.replay import Replayer

    rclpy.init(args=[sys.argv[0]])
    node = WalkerNode("bag_replay")
    replayer = Replayer(node, str(path), rate=args.rate, loop=args.loop, publish_clock=not args.no_clock,
                        start_delay=args.start_delay, depth_topic=args.depth_topic, info_topic=args.info_topic,
                        wait_subscribers=args.wait_subscribers, wait_info_subscribers=args.wait_info_subscribers)
    replayer.start()
    try:
        while rclpy.ok() and not replayer.finished.is_set():
            rclpy.spin_once(node, timeout_sec=0.1)
        # give late subscribers' reliable queues a moment to drain
        end = time.monotonic() + args.linger
        while rclpy.ok() and time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.1)
    except KeyboardInterrupt:
        pass
    finally:
        replayer.stop()
        node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    print(f"replayed {replayer.published} messages from {path}")
    return 0 if not node.problems else 1


# --------------------------------------------------------------------------------------- process


def _pipeline_params(args: argparse.Namespace) -> Any:
    from walker_gait.config import default_params_file, load_params_file, parse_overrides

    params_file = Path(args.params_file) if args.params_file else default_params_file()
    file_params = load_params_file(params_file) if params_file.is_file() else {}
    return file_params, parse_overrides(args.param or [])


def _report_options(args: argparse.Namespace) -> dict[str, float]:
    """The reported poses' ``PipelineOptions`` given on the command line (the others keep the options' defaults)."""
    return {name: value for name in ("bridge_hidden_s", "report_lowpass_hz", "report_pelvis_window_s", "leg_length_m")
            if (value := getattr(args, name, None)) is not None}


def cmd_process(args: argparse.Namespace) -> int:
    from walker_gait.pipeline import PipelineOptions, process_recording

    path = Path(args.input)
    if not path.exists():
        raise UserError(f"{path}: no such file or folder")
    file_params, overrides = _pipeline_params(args)
    options = PipelineOptions.from_params(file_params, overrides, preset=args.preset, seed=args.seed,
                                          depth_topic=args.depth_topic, info_topic=args.info_topic,
                                          camera_info_file=args.camera_info, passes=args.passes,
                                          tracker_runs=args.tracker_runs, tracker_threads=args.tracker_threads,
                                          **_report_options(args))
    result = process_recording(path, Path(args.out), options=options, progress=not args.quiet)
    if not args.quiet:
        print(result.describe())
    return 0


def cmd_batch(args: argparse.Namespace) -> int:
    from walker_gait.pipeline import PipelineOptions, process_batch

    file_params, overrides = _pipeline_params(args)
    options = PipelineOptions.from_params(file_params, overrides, preset=args.preset, seed=args.seed,
                                          passes=args.passes, tracker_runs=args.tracker_runs, **_report_options(args))
    table = process_batch(Path(args.folder), Path(args.out), options=options, workers=args.workers,
                          progress=not args.quiet)
    print(f"summary table: {table}")
    return 0


# ------------------------------------------------------------------------------------------ demo


def cmd_demo(args: argparse.Namespace) -> int:
    from walker_gait.demo import run_demo

    return run_demo(out=Path(args.out), live=args.live, seed=args.seed, quiet=args.quiet)


def cmd_generate(args: argparse.Namespace, rest: list[str]) -> int:
    from walker_gait.synth.__main__ import main as synth_main

    return int(synth_main(rest))


# ------------------------------------------------------------------------------------------ main


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="walker-gait", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("run", help="start the live node graph (one process per node); Ctrl-C stops it")
    p.add_argument("--params-file", help="ROS 2 parameters YAML (default: config/walker_gait.yaml)")
    p.add_argument("--depth-topic", help="remap the depth image input (default /depth/image_raw)")
    p.add_argument("--info-topic", help="remap the CameraInfo input (default /depth/camera_info)")
    p.add_argument("--nodes", help=f"comma-separated subset of {','.join(NODE_NAMES)}")
    p.add_argument("--param", action="append", metavar="NODE.PARAM=VALUE",
                   help="override one node parameter (repeatable), e.g. leg_tracker.preset=paper")
    p.add_argument("--replay", metavar="INPUT", help="let bag_replay play this recording into the graph")
    p.add_argument("--rate", type=float, default=1.0, help="replay rate (with --replay)")
    p.add_argument("--loop", action="store_true", help="loop the replay (with --replay)")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("replay", help="publish a recording's topics (and /clock) into the ROS graph")
    p.add_argument("input", help=".mcap, rosbag2 folder, .db3 or ROS 1 .bag")
    p.add_argument("--rate", type=float, default=1.0)
    p.add_argument("--loop", action="store_true")
    p.add_argument("--no-clock", action="store_true", help="do not publish /clock")
    p.add_argument("--depth-topic")
    p.add_argument("--info-topic")
    p.add_argument("--start-delay", type=float, default=1.0, help="seconds to wait for subscribers first")
    p.add_argument("--linger", type=float, default=1.0, help="seconds to keep publishing queues alive at the end")
    p.add_argument("--wait-subscribers", type=int, default=0, metavar="N",
                   help="first wait (up to 30 s) until N subscribers listen to the depth and CameraInfo topics")
    p.add_argument("--wait-info-subscribers", type=int, default=None, metavar="M",
                   help="with --wait-subscribers: wait for M (instead of N) on the CameraInfo topic")
    p.set_defaults(func=cmd_replay)

    for name, helptext in (("process", "run the whole pipeline offline on a recording, write results"),
                           ("batch", "process every recording in a folder in parallel")):
        p = sub.add_parser(name, help=helptext)
        if name == "process":
            p.add_argument("input", help=".mcap, rosbag2 folder, .db3, ROS 1 .bag, or a folder of them")
            p.add_argument("--depth-topic")
            p.add_argument("--info-topic")
            p.add_argument("--camera-info", metavar="FILE.yaml", help="calibration when the recording has none")
            p.add_argument("--tracker-threads", type=int, default=1, metavar="N",
                           help="with --passes forward: the tracker's compiled likelihood kernels spread the particles "
                           "over N threads (the same results; less tracking time only where a core is otherwise idle; "
                           "with --passes both the two directions already take two cores; default 1)")
            p.set_defaults(func=cmd_process)
        else:
            p.add_argument("folder")
            p.add_argument("--workers", type=int, default=max(1, (os.cpu_count() or 2) - 0))
            p.set_defaults(func=cmd_batch)
        p.add_argument("--out", required=True, help="output folder")
        p.add_argument("--param", action="append", metavar="KEY=VALUE", help="override a parameter (repeatable), "
                       "e.g. leg_tracker.n_particles=300")
        p.add_argument("--params-file", help="ROS 2 parameters YAML (default: config/walker_gait.yaml)")
        p.add_argument("--preset", default=None, help="tracker preset: default (real time), accurate (offline: 288 "
                       "particles and each direction tracked twice, --tracker-runs 2: about twice the default's time, "
                       "heels about 15 %% nearer the truth on a synthetic sweep) or paper (the seed's)")
        p.add_argument("--seed", type=int, default=0)
        p.add_argument("--passes", choices=("both", "forward"), default="both",
                       help="both (default): track the recording forwards and backwards in time and keep, frame by "
                       "frame, the estimate the depth data support better (about twice the tracking time); "
                       "forward: one pass, as the live graph tracks")
        p.add_argument("--tracker-runs", type=int, default=None, metavar="N",
                       help="with --passes both: track each direction N times, each run with a particle filter of its "
                       "own random stream, and merge every run (1 to 8; default 1, 2 with --preset accurate: two runs "
                       "put the heels and ankles about 10 %% nearer the truth on the synthetic sweeps, for twice the "
                       "tracking time)")
        p.add_argument("--bridge-hidden-s", type=float, default=None, metavar="S",
                       help="with --passes both: where a foot was hidden behind the other leg for up to S seconds, "
                       "report its knee, ankle, heel and toe on a curve between where it was last seen and where it "
                       "is seen again instead of the tracker's held pose (default 1.0; 0 = off; the gait analysis "
                       "reads the tracked poses either way)")
        p.add_argument("--report-lowpass-hz", type=float, default=None, metavar="HZ",
                       help="with --passes both: low-pass the reported leg points and joint angles at HZ (zero-phase "
                       "Butterworth, as gait labs filter marker trajectories; default 6; 0 = off; the gait analysis "
                       "reads the tracked poses either way)")
        p.add_argument("--report-pelvis-window-s", type=float, default=None, metavar="S",
                       help="report the hips and knees, which the camera does not see, with the pelvis over the "
                       "ankles (their midpoint averaged over S seconds, a few cm ahead of it: more while the feet "
                       "swing, walking, than standing; facing the feet's heading) and the legs' joint angles solved "
                       "again so that the tracked knees, ankles, heels and toes stay (with --passes both a window centred "
                       "on the frame, with forward the last S seconds, as the live graph), with one length of "
                       "each segment per track, the tracked ones' median (the knees moved along the tracked calves "
                       "to it, and the heels along the tracked feet from the toes at the pitch and heading their "
                       "shoes show, with forward only where the track has shown the shoe cleanly, and the feet put "
                       "on the floor, a foot whose heel and toe are within 2 cm of it flat on it; default 1.0; 0 = "
                       "the hips, knees, heels and toes as tracked; the steps and events are the same either way)")
        p.add_argument("--leg-length-m", type=float, default=None, metavar="M",
                       help="the user's measured leg length in metres (the hip joint centre's height above the floor "
                       "standing; floor to greater trochanter; with only the stature at hand, about 0.53 of it): the "
                       "reported hips and knees with thighs and calves "
                       "of that length, which the camera cannot measure (with the pelvis placed, "
                       "--report-pelvis-window-s > 0; batch: every recording is taken to be this user's; default: not "
                       "measured, the tracker's lengths)")
        p.add_argument("--quiet", action="store_true", help="no progress bar")

    p = sub.add_parser("demo", help="generate a sample walking session, process it, compare with ground truth")
    p.add_argument("--out", default="out/demo")
    p.add_argument("--live", action="store_true", help="go through the live node graph instead of in-process")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--quiet", action="store_true")
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("generate", help="generate a synthetic session (see walker-gait generate --help)",
                       add_help=False)
    p.set_defaults(func=None)
    return parser


def _show_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                  file: Any = None, line: str | None = None) -> None:
    """Warnings about the user's input (``RecordingWarning``) read like the CLI's own, without source lines."""
    from walker_gait.io.bags import RecordingWarning

    out = sys.stderr if file is None else file
    if issubclass(category, RecordingWarning):
        out.write(f"walker-gait: warning: {message}\n")
    else:
        out.write(warnings.formatwarning(message, category, filename, lineno, line))


def main(argv: list[str] | None = None) -> int:
    previous = warnings.showwarning
    warnings.showwarning = _show_warning
    try:
        return _main(list(sys.argv[1:] if argv is None else argv))
    finally:
        warnings.showwarning = previous


def _main(argv: list[str]) -> int:
    parser = build_parser()
    if argv and argv[0] == "generate":
        try:
            return cmd_generate(argparse.Namespace(), argv[1:])
        except _user_error_types() as exc:
            print(f"walker-gait: error: {exc}", file=sys.stderr)
            return EXIT_USER_ERROR
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except KeyboardInterrupt:
        print("walker-gait: interrupted", file=sys.stderr)
        return 130
    except _user_error_types() as exc:
        print(f"walker-gait: error: {exc}", file=sys.stderr)
        return EXIT_USER_ERROR


if __name__ == "__main__":
    sys.exit(main())
