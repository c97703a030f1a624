"""``walker-gait demo``: a sample walking session, processed, next to its ground truth.

The sample is a synthetic session (``walker_gait.synth``, scenario ``normal``, Kinect v1 640x480 at 30 Hz)
generated on first use into the output folder and reused afterwards. ``--live`` sends it through the live
node graph (``walker-gait run`` fed by ``bag_replay``) instead of the in-process pipeline.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from walker_gait.core.types import LEG_POINTS, Side, Step

SAMPLE_SCENARIO = "normal"
SAMPLE_DURATION_S = 10.0


def ensure_sample(out: Path, *, seed: int, quiet: bool) -> tuple[Path, Path]:
    """The sample recording and its ground truth in ``out`` (generated once, then reused)."""
    bag = out / f"sample_{SAMPLE_SCENARIO}_seed{seed}.mcap"
    gt = bag.with_suffix(".gt.json")
    if bag.is_file() and gt.is_file():
        return bag, gt
    from walker_gait.synth import SessionSpec, generate_session, write_session

    out.mkdir(parents=True, exist_ok=True)
    if not quiet:
        print(f"generating the sample session ({SAMPLE_DURATION_S:.0f} s, scenario {SAMPLE_SCENARIO!r}) -> {bag}",
              flush=True)
    t0 = time.perf_counter()
    session = generate_session(SessionSpec.preset(SAMPLE_SCENARIO, duration=SAMPLE_DURATION_S),
                               rng=np.random.default_rng(seed))
    write_session(session, bag, fmt="mcap", encoding="16UC1")
    if not quiet:
        print(f"  generated {len(session)} frames in {time.perf_counter() - t0:.1f} s", flush=True)
    return bag, gt


def gt_steps(gt: dict[str, Any]) -> list[Step]:
    nan = float("nan")

    def f(v: Any) -> float:
        return nan if v is None else float(v)

    return [Step(stamp=float(s["stamp"]), side=Side.LEFT if s["side"] == "left" else Side.RIGHT,
                 index=int(s["index"]), step_length=f(s["step_length"]), step_width=f(s["step_width"]),
                 step_time=f(s["step_time"]), stride_length=f(s["stride_length"]), stride_time=f(s["stride_time"]),
                 stance_time=f(s["stance_time"]), swing_time=f(s["swing_time"]),
                 single_support_time=f(s["single_support_time"]),
                 double_support_time=f(s["double_support_time"])) for s in gt["steps"]]


def comparison(steps: list[Step], truth: list[Step]) -> tuple[dict[str, float], dict[int, Step]]:
    """Scores of ``steps`` against ``truth`` and, per detected step index, its matched true step."""
    from walker_gait.bench.gait import match_steps

    pairs, missed, extra = match_steps(truth, steps)
    matched = [(truth[ti], steps[di]) for ti, di in pairs]
    le = [abs(d.step_length - t.step_length) for t, d in matched if np.isfinite(t.step_length)]
    we = [abs(d.step_width - t.step_width) for t, d in matched if np.isfinite(t.step_width)]
    scores = {"matched": len(pairs), "missed": len(missed), "extra": len(extra),
              "step_length_mae_cm": float(np.mean(le) * 100) if le else float("nan"),
              "step_width_mae_cm": float(np.mean(we) * 100) if we else float("nan")}
    return scores, {di: truth[ti] for ti, di in pairs}


def joint_errors_cm(poses: list[Any], gt: dict[str, Any]) -> dict[str, float]:
    stamps = np.asarray(gt["frames"]["stamp"], dtype=float)
    truth = np.asarray(gt["frames"]["leg_points"], dtype=float)
    errs: list[np.ndarray] = []
    for pose in poses:
        i = int(np.argmin(np.abs(stamps - pose.stamp)))
        if abs(stamps[i] - pose.stamp) < 1e-3:
            errs.append(np.linalg.norm(np.asarray(pose.points) - truth[i], axis=-1))
    if not errs:
        return {}
    e = np.stack(errs)  # frames, side, point
    out = {name: float(np.nanmean(e[:, :, k]) * 100) for k, name in enumerate(LEG_POINTS)}
    out["frames_over_10cm_pct"] = float(np.mean(np.nanmean(e, axis=(1, 2)) > 0.10) * 100)
    return out


def too_slow_note(log_lines: list[str]) -> str | None:
    """What to tell the user of a live demo whose leg tracker said it could not keep up (its first such line of the
    graph's log ``log_lines``): the steps are then those of the frames it got to, not what the software does with
    every frame; ``None`` if it kept up."""
    behind = [line for line in log_lines if "cannot keep up" in line]
    if not behind:
        return None
    return ("note: this machine is too slow for the live graph at the camera's rate; the leg tracker said:\n  "
            + behind[0] + "\n  (`make demo` tracks the same recording offline, every frame)")


def run_demo(*, out: Path, live: bool, seed: int, quiet: bool) -> int:
    from walker_gait.pipeline import format_steps_table, format_summary

    bag, gt_path = ensure_sample(out, seed=seed, quiet=quiet)
    gt = json.loads(gt_path.read_text(encoding="utf-8"))
    truth = gt_steps(gt)
    results = out / ("results_live" if live else "results")
    if live:
        from walker_gait.bench.live import run_live

        print("replaying the sample through the live node graph (walker-gait run --replay) ...", flush=True)
        live_res = run_live(bag, rate=1.0)
        steps = sorted(live_res.steps, key=lambda s: s.stamp)
        cmp, matches = comparison(steps, truth)
        print(format_steps_table(steps, truth=matches))
        print(f"frames in/out: {live_res.images}/{live_res.joint_states}; latency image -> JointState median "
              f"{live_res.median_latency_ms:.0f} ms, p95 {live_res.p95_latency_ms:.0f} ms; skipped: "
              f"{live_res.skipped or 'none'}; walker-gait run exit code {live_res.run_exit_code}")
        note = too_slow_note(live_res.skip_log)
        if note:
            print(note)
    else:
        from walker_gait.pipeline import PipelineOptions, process_recording

        res = process_recording(bag, results, options=PipelineOptions(seed=seed), progress=not quiet,
                                ground_truth={"steps": gt["steps"]})
        print(f"\n{bag.name}: {res.frames} frames processed in {res.wall_s:.1f} s "
              f"({res.frames / max(res.wall_s, 1e-9):.1f} frames/s); {res.tracking_note()}")
        cmp, matches = comparison(res.steps, truth)
        print("\nsteps (detected, with the ground truth alongside):")
        print(format_steps_table(res.steps, truth=matches))
        print("\nsummary:  " + format_summary(res.summary))
        errs = joint_errors_cm(res.poses, gt)
        if errs:
            print("tracking error vs ground truth (mean, cm): " + ", ".join(
                f"{k} {v:.1f}" for k, v in errs.items() if k != "frames_over_10cm_pct")
                + f"; frames with mean error > 10 cm: {errs['frames_over_10cm_pct']:.1f} %")
        print(f"\nreport: {(results / 'report.html').resolve()}")
    print(f"steps vs ground truth: {cmp['matched']} matched, {cmp['missed']} missed, {cmp['extra']} extra; "
          f"step length MAE {cmp['step_length_mae_cm']:.1f} cm, step width MAE {cmp['step_width_mae_cm']:.1f} cm")
    sys.stdout.flush()
    return 0
