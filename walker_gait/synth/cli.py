"""Command line of the synthetic session generator (``main(argv) -> int``)."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from walker_gait.io.bagwriter import BAG_FORMATS, BagWriteError
from walker_gait.synth.export import ENCODINGS, gt_path_for, write_session
from walker_gait.synth.session import SCENARIOS, SessionSpec, generate_session


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m walker_gait.synth",
        description="Generate a synthetic walker depth-camera session with exact ground truth.",
    )
    p.add_argument("--scenario", choices=SCENARIOS, default="normal")
    p.add_argument("--duration", type=float, default=10.0, help="seconds (default 10)")
    p.add_argument("--fps", type=float, default=30.0)
    p.add_argument("--scale", type=float, default=1.0, help="image resolution factor (e.g. 0.25)")
    p.add_argument("--out", required=True, type=Path, help="output recording (.mcap file, rosbag2 dir, .db3 or .bag)")
    p.add_argument("--format", dest="fmt", choices=BAG_FORMATS, default=None, help="default: from the suffix, else mcap")
    p.add_argument("--encoding", choices=ENCODINGS, default="16UC1")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--no-rgb", action="store_true", help="omit the extra rgb8 topic")
    p.add_argument("--no-noise", action="store_true", help="ideal depth (no sensor noise/dropouts)")
    p.add_argument("--vibration", type=float, default=0.0, metavar="DEG",
                   help="RMS pitch and roll (deg) of the walker rocking on its wheels while it rolls (default 0: rigid)")
    p.add_argument("--contact-sheet", type=Path, default=None, help="also write a PNG contact sheet")
    p.add_argument("--overwrite", action="store_true")
    p.add_argument("--quiet", action="store_true")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    fmt = args.fmt
    if fmt is None:
        fmt = {".bag": "ros1", ".db3": "sqlite3"}.get(args.out.suffix, "mcap")
    try:
        overrides: dict[str, object] = {"duration": args.duration, "fps": args.fps, "scale": args.scale}
        if args.no_noise:
            overrides["sensor_noise"] = False
        if args.no_rgb:
            overrides["rgb_topic"] = False
        if args.vibration < 0:
            raise ValueError(f"--vibration must be >= 0, got {args.vibration}")
        if args.vibration > 0:
            overrides["vibration_deg"] = (args.vibration, args.vibration)
        spec = SessionSpec.preset(args.scenario, **overrides)
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    session = generate_session(spec, rng=np.random.default_rng(args.seed))
    n = len(session)

    def progress(i: int, total: int) -> None:
        if not args.quiet and (i == total or i % 30 == 0):
            print(f"\r{i}/{total} frames", end="" if i < total else "\n", file=sys.stderr, flush=True)

    try:
        out = write_session(session, args.out, fmt=fmt, encoding=args.encoding, overwrite=args.overwrite, progress=progress)
    except (BagWriteError, ValueError, OSError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 1
    dt = time.perf_counter() - t0
    if args.contact_sheet is not None:
        from walker_gait.synth.contact_sheet import write_contact_sheet

        write_contact_sheet(session, args.contact_sheet)
    if not args.quiet:
        k = session.intrinsics
        print(
            f"wrote {out} ({fmt}, {args.encoding}, {n} frames {k.width}x{k.height}, "
            f"{len(session.steps)} steps, {len(session.events)} events) + {gt_path_for(out).name} in {dt:.1f} s",
            file=sys.stderr,
        )
    return 0
