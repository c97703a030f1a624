"""``make bench`` / ``python -m walker_gait.bench``: measure speed and accuracy, write BENCHMARKS.md.

Sections: the machine; depth + segmentation stage; end-to-end accuracy per scenario with cues 3d / 2d /
combined side by side (step length and width errors as in the seed paper's Tables 2-3, joint errors,
step detection); presets ``paper`` vs ``default``; the gait analyzer on ground-truth poses; ``process``
wall time on a 10 s 640x480 recording (I/O included); the live graph fed by ``replay`` at 30 Hz.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as dt
import math
import os
import platform
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

SCENARIOS = ("normal", "slow_elderly", "baggy_trousers", "occlusion", "asymmetric", "stop_and_go", "absent_start",
             "different_camera", "walker_lag")
CUES = ("3d", "2d", "combined")


def log(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def machine() -> str:
    cpu = "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = ""
    try:
        kb = int(next(l for l in Path("/proc/meminfo").read_text().splitlines() if l.startswith("MemTotal")).split()[1])
        mem = f", {kb / 1024 / 1024:.0f} GiB RAM"
    except (OSError, StopIteration, ValueError):
        pass
    return (f"{cpu}, {os.cpu_count()} cores{mem}; {platform.system()} {platform.release()}; Python "
            f"{platform.python_version()}, numpy {np.__version__}; OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'unset')}")


def f(v: float, digits: int = 1) -> str:
    if v is None or np.isnan(v):
        return "n/a"
    return "never" if np.isinf(v) else f"{v:.{digits}f}"


def pm(pair: tuple[float, float]) -> str:
    return f"{f(pair[0], 2)} ± {f(pair[1], 2)}"


def section_segmentation(seed: int) -> list[str]:
    from walker_gait.bench.segmentation import run_segmentation_bench

    log("[bench] depth + segmentation")
    r = run_segmentation_bench(rng=np.random.default_rng(seed))
    keys = {k: v for k, v in r.items() if isinstance(v, (int, float))}
    # the walker rocking on its wheels (1 deg RMS pitch and roll): does the floor follow it frame by frame?
    rock = run_segmentation_bench(rng=np.random.default_rng(seed), rocking_deg=1.0)
    keys.update({f"{k}_rocking_1deg": v for k, v in rock.items() if k.startswith("floor_") and isinstance(v, (int, float))})
    # the camera mounted upside down with the default floor.up_hint: floor.auto_flip's search (frames without a
    # floor at the start) and the floor and legs once found
    flip = run_segmentation_bench(rng=np.random.default_rng(seed), roll_deg=180.0)
    keys.update({f"{k}_upside_down": v for k, v in flip.items()
                 if (k.startswith("floor_") or k == "leg_kept_final_pct") and isinstance(v, (int, float))})
    lines = ["## Depth decoding + back-projection + floor + ROI (640x480, one core)", "",
             "| measure | value |", "|---|---|"]
    lines += [f"| {k} | {f(float(v), 3)} |" for k, v in keys.items()]
    return lines + [""]


def section_endtoend(scenarios: tuple[str, ...], duration: float, seed: int) -> tuple[list[str], list[Any]]:
    from walker_gait.bench.endtoend import evaluate, render, run_pipeline, true_leg_length
    from walker_gait.synth import SessionSpec, generate_session

    scores = []
    for k, name in enumerate(scenarios):
        dur = max(duration, 14.0) if name == "absent_start" else duration
        session = generate_session(SessionSpec.preset(name, duration=dur), rng=np.random.default_rng(seed + k))
        rendered = render(session)
        log(f"[bench] {name}: {len(rendered.frames)} frames rendered in {rendered.seconds:.0f} s")
        runs = [(c, "both", 0.0, "default", None) for c in CUES] + [
            ("combined", "forward", 0.0, "default", None), ("combined", "both", 0.0, "default", 2),
            ("combined", "both", true_leg_length(session), "default", None), ("combined", "both", 0.0, "accurate", None)]
        for cue, passes, leg, preset, tracker_runs in runs:
            t0 = time.perf_counter()
            run = run_pipeline(session, rendered, preset=preset, cue=cue, seed=seed, passes=passes, leg_length_m=leg,
                               tracker_runs=tracker_runs)
            sc = evaluate(session, preset=preset, cue=cue, seed=seed, rendered=rendered, passes=passes,
                          leg_length_m=leg, run=run)
            if passes == "forward":
                sc = dataclasses.replace(sc, cue=f"{cue}, one pass")
                # the same run as the live leg_tracker's leg_track_bridged has it
                scores.append(sc)
                sc = dataclasses.replace(evaluate(session, preset=preset, cue=cue, seed=seed, rendered=rendered,
                                                  passes=passes, run=run, bridged=True),
                                         cue=f"{cue}, one pass, bridged live")
            if leg:
                sc = dataclasses.replace(sc, cue=f"{cue}, leg length given")
            if tracker_runs is not None:
                sc = dataclasses.replace(sc, cue=f"{cue}, two runs")
            if preset != "default":
                sc = dataclasses.replace(sc, cue=f"{cue}, preset {preset}")
            log(f"[bench]   {preset}/{sc.cue}: {time.perf_counter() - t0:.0f} s, "
                f"tracker {f(sc.ms_per_frame['tracker'])} "
                f"ms/frame, step length err {pm(sc.step_length_err_cm)} cm")
            scores.append(sc)
    lines = ["## End-to-end accuracy per scenario (preset `default`; `accurate` in its own row), cues side by side", "",
             "`walker-gait process` as it runs by default: the recording tracked forwards and backwards in time and "
             "the two passes merged frame by frame (`--passes both`); the `combined, one pass` row is the forward "
             "pass alone (`--passes forward`), what the live graph computes; the `combined, two runs` row tracks "
             "each direction twice (`--tracker-runs 2`: four passes merged); the `combined, one pass, bridged live` row "
             "is the same run as the live `leg_tracker` publishes it on `leg_track_bridged` (each stretch in which a "
             "foot was hidden bridged once it is seen again, its frames held until then: `bridge_hidden_s`; the steps "
             "are the one-pass row's, the live analyzer reads `leg_track`; how long frames were held is listed below "
             "the table); the `combined, leg length given` row is "
             "`--passes both` told the user's leg length (`--leg-length-m`, the synthetic user's true one: thigh + "
             "shank + ankle height), which sets the reported thighs and calves (the hips' height) and nothing "
             "else; the `combined, preset accurate` row is `--preset accurate` (288 particles instead of 192, each direction "
             "tracked twice, for offline use). "
             "`tracker ms/frame` is the forward pass "
             "(the live tracker's work per frame); `pipeline frames/s` counts every offline stage, the further runs, "
             "the backward passes and the scoring of every pass included.",
             "",
             "Step length / width error: mean ± SD of |detected − true| over matched steps, cm (the seed paper's",
             "Tables 2-3 report the combined cue at 2.73-3.87 cm length and 1.75-3.04 cm width on real subjects).",
             "Joint error: mean 3D distance over frames where both legs are in view, cm.",
             "Frames > 10 cm: the share of those frames whose mean error over the ten points exceeds 10 cm (a frame "
             "without a pose counts), of the frames with both ankles in the walker's region of interest (where the "
             "walker measures; the segmentation keeps nothing outside it) / of all of them (absent_start: the user "
             "walks in from the side, in the image but outside that region, where the tracker, by design, does not "
             "follow).",
             "Recall (in view): over the true steps whose heel strike follows at least 1 s with the user in view and at "
             "the walker (both ankles in its region of interest; a leg hidden behind the other still counts; "
             "absent_start: the user walks in from out of view and from the side) and comes at least 0.1 s before the "
             "recording ends, matched/true.",
             "Recovery (sessions that start without the user): seconds from the user's arrival (both legs in the image and "
             "both ankles in the walker's region of interest, as for recall; after it, from the first frame with both "
             "legs anywhere in the image) until the mean error of the ten points stays under 10 cm for 5 frames; "
             "n/a where the user is in view throughout.",
             "Cadence error: the session summary's cadence (what `summary.json` reports: the walkway's 60 / mean step "
             "time over the steps the summary pools) against the same figure of the true steps taken at the walker (in view "
             "with both ankles in its region of interest, as the recall in view: a user walking up from the side takes "
             "steps the walker does not measure), signed %.",
             "",
             "| scenario | cue | step length err cm | step width err cm | steps det/true (matched) | precision | "
             "recall (in view) | HS timing (median, frames) | cadence err % | hip | knee | ankle | heel | toe | "
             "frames > 10 cm % (at walker / in image) | "
             "L/R swaps (frames) | recovery s (at walker / in image) | tracker ms/frame | pipeline frames/s |",
             "|" + "---|" * 20]
    for sc in scores:
        j = sc.joint_err_cm
        lines.append(
            f"| {sc.scenario} | {sc.cue} | {pm(sc.step_length_err_cm)} | {pm(sc.step_width_err_cm)} | "
            f"{sc.detected_steps}/{sc.gt_steps} ({sc.matched_steps}) | {f(sc.precision, 2)} | {f(sc.recall, 2)} "
            f"({f(sc.recall_in_view, 2)}, {sc.matched_in_view}/{sc.gt_steps_in_view}) | "
            f"{f(sc.hs_timing_median_frames, 2)} | {f(sc.cadence_err_pct)} | "
            + " | ".join(f(j.get(p, float('nan'))) for p in ("hip", "knee", "ankle", "heel", "toe"))
            + f" | {f(sc.frames_over_10cm_at_walker_pct)} / {f(sc.frames_over_10cm_pct)} | {sc.swap_frames} | {f(sc.recovery_s, 2)} / {f(sc.recovery_in_image_s, 2)} | "
            f"{f(sc.ms_per_frame['tracker'])} | {f(sc.fps)} |")
    lines += ["", "`leg_track_bridged` (the `bridged live` rows): the share of frames held back (a foot hidden, or "
              "behind such a frame) and their delay, median / largest, from each frame's stamp to that of the frame "
              "that released it (0: published with `leg_track`):", ""]
    lines += [f"* {sc.scenario}: {f(sc.held_pct)} % held, {f(sc.held_s[0], 2)} / {f(sc.held_s[1], 2)} s"
              for sc in scores if math.isfinite(sc.held_pct)]
    lines += ["", "How often each true joint is inside the camera image at all (frames %; a point outside it is "
              "only constrained by the model's lengths and the parts below it):", ""]
    seen: set[str] = set()
    for sc in scores:
        if sc.scenario not in seen:
            seen.add(sc.scenario)
            lines.append(f"* {sc.scenario}: " + ", ".join(f"{p} {f(v, 0)} %" for p, v in sc.in_image_pct.items()))
    from walker_gait.bench.endtoend import JOINT_KINDS

    lines += ["", "`JointState` angles against the synthetic truth (the same frames as the joint errors, both legs pooled): "
              "mean |error| (mean signed error: + = the reported angle is larger), degrees. The synthetic feet never "
              "roll, so the true ankle inversion is 0 throughout.", "",
              "| scenario | cue | " + " | ".join(k.replace("_", " ") for k in JOINT_KINDS) + " |",
              "|" + "---|" * (2 + len(JOINT_KINDS))]
    for sc in scores:
        if sc.cue.startswith("combined"):
            lines.append(f"| {sc.scenario} | {sc.cue} | " + " | ".join(
                f"{f(sc.angle_err_deg.get(k, math.nan))} ({sc.angle_bias_deg.get(k, math.nan):+.1f})" for k in JOINT_KINDS)
                + " |")
    return lines + [""], scores


def section_presets(seed: int, frames: int, *, run_paper: bool = True) -> list[str]:
    from walker_gait.bench.endtoend import evaluate, render
    from walker_gait.core.tracker import preset as tracker_preset
    from walker_gait.synth import SessionSpec, generate_session

    frames = max(frames, 2)
    session = generate_session(SessionSpec.preset("normal", duration=frames / 30.0 + 0.05),
                               rng=np.random.default_rng(seed))
    rendered = render(session, frames)
    n = len(rendered.frames)
    lines = [f"## Presets side by side (`normal`, the same first {n} frames for both, combined cue)", "",
             "Both presets start with their initial search on frame 1, which costs several tracking frames; "
             "`first frame s` is that search, `tracker ms/frame` the mean over the frames after it. The `paper` "
             "preset is the seed's configuration (5000 particles, plain SIR, full-resolution 2D cue), so it can "
             "only be scored on a few frames here; `make bench ARGS=\"--paper-frames N\"` scores more.", "",
             "| preset | particles | first frame s | tracker ms/frame | hip | knee | ankle | heel | toe | "
             "frames > 10 cm % |", "|---|---|---|---|---|---|---|---|---|---|"]
    for name in ("default", "paper"):
        if name == "paper" and not run_paper:
            lines.append("| paper | 5000 | not run (`--paper-frames 0`) | | | | | | | |")
            continue
        log(f"[bench] preset {name} ({n} frames)")
        sc = evaluate(session, preset=name, seed=seed, rendered=rendered)
        j = sc.joint_err_cm
        track_ms = sc.tracker_ms_after_first
        lines.append(f"| {name} | {tracker_preset(name).n_particles} | {f(sc.tracker_first_ms / 1000, 1)} | "
                     f"{f(track_ms)} | "
                     + " | ".join(f(j.get(p, float('nan'))) for p in ("hip", "knee", "ankle", "heel", "toe"))
                     + f" | {f(sc.frames_over_10cm_pct)} |")
    return lines + [""]


def section_gait_on_truth(seed: int) -> list[str]:
    from walker_gait.bench.gait import run_gait_bench

    log("[bench] gait analyzer on ground-truth poses")
    rows = run_gait_bench(scenarios=("normal", "slow_elderly", "asymmetric", "stop_and_go"), seed=seed,
                          noise_m=0.0, source="synth")
    rows += run_gait_bench(scenarios=("normal", "slow_elderly", "asymmetric", "stop_and_go"), seed=seed,
                           noise_m=0.01, source="synth")
    keys = ("scenario", "noise_m", "precision", "recall", "step_length_mae", "step_width_mae",
            "hs_timing_median_abs_frames", "cadence_error_pct")
    lines = ["## Gait analyzer alone, on ground-truth leg points (+ i.i.d. noise)", "",
             "| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for r in rows:
        cells = []
        for k in keys:
            v = r.get(k, "")
            cells.append(f(v * 100, 2) + " cm" if k.endswith("_mae") and isinstance(v, float) else
                         (f(v, 3) if isinstance(v, float) else str(v)))
        lines.append("| " + " | ".join(cells) + " |")
    return lines + [""]


def section_process_and_live(seed: int, live: bool) -> list[str]:
    from walker_gait.pipeline import PipelineOptions, process_recording
    from walker_gait.synth import SessionSpec, generate_session, write_session

    lines = ["## `walker-gait process` and the live graph (10 s, 30 Hz, 640x480 `normal` session, preset `default`)",
             ""]
    with tempfile.TemporaryDirectory() as tmp:
        bag = Path(tmp) / "session.mcap"
        session = generate_session(SessionSpec.preset("normal", duration=10.0), rng=np.random.default_rng(seed))
        write_session(session, bag, fmt="mcap", encoding="16UC1")
        log("[bench] process")
        t0 = time.perf_counter()
        res = process_recording(bag, Path(tmp) / "out", options=PipelineOptions(seed=seed), progress=False)
        wall = time.perf_counter() - t0
        lines += [f"* `process`: {res.frames} frames in **{wall:.1f} s wall** (target ≤ 10 s), I/O and report "
                  f"included; mean stage times ms/frame: "
                  + ", ".join(f"{k} {v:.1f}" for k, v in res.timings_ms.items())]
        log("[bench] process --tracker-runs 2")
        t0 = time.perf_counter()
        twice = process_recording(bag, Path(tmp) / "out_twice", options=PipelineOptions(seed=seed, tracker_runs=2),
                                  progress=False)
        lines += [f"* `process --tracker-runs 2` (each direction tracked twice): {twice.frames} frames in "
                  f"{time.perf_counter() - t0:.1f} s wall; tracker {twice.timings_ms['tracker']:.1f} ms/frame forwards "
                  f"and {twice.timings_ms['tracker_more_runs']:.1f} for the second run, "
                  f"{twice.timings_ms['tracker_backward']:.1f} backwards (both runs)"]
        log("[bench] process --preset accurate")
        t0 = time.perf_counter()
        acc = process_recording(bag, Path(tmp) / "out_accurate", options=PipelineOptions(seed=seed, preset="accurate"),
                                progress=False)
        lines += [f"* `process --preset accurate` (offline: 288 particles, each direction tracked twice): {acc.frames} "
                  f"frames in {time.perf_counter() - t0:.1f} s wall; tracker {acc.timings_ms['tracker']:.1f} ms/frame "
                  f"forwards and {acc.timings_ms['tracker_more_runs']:.1f} for the second run, "
                  f"{acc.timings_ms['tracker_backward']:.1f} backwards (both runs)"]
        if live:
            from walker_gait.bench.live import run_live

            log("[bench] live graph")
            lr = run_live(bag, rate=1.0, timeout_s=120)
            lines += [f"* live graph fed by `replay` at 30 Hz: {lr.images} images in, {lr.joint_states} JointState out; "
                      f"latency image→JointState median **{lr.median_latency_ms:.0f} ms**, p95 {lr.p95_latency_ms:.0f} ms "
                      f"(target median ≤ 100 ms), of which image→floor_plane (decoding and segmentation) "
                      f"{lr.floor_median_latency_ms:.0f} ms; latency trend {f(lr.latency_trend_ms_per_s())} ms per s "
                      f"(> 0 = growing backlog); frames reported skipped: {lr.skipped or 'none'}, "
                      f"processed with a stand-in part: {lr.stood_in or 'none'}, "
                      f"without a part the sender dropped: {lr.absent or 'none'}, "
                      f"between the frames a node worked on, by their stamps, those it did not: {lr.missed or 'none'}; "
                      f"{len(lr.steps)} steps (process: {len(res.steps)})"]
            bl = lr.bridged_latencies_ms
            lines += [f"* `leg_track_bridged` in the same run: {len(lr.bridged_stamps_ns)} LegTrack out (frames still "
                      f"held when the replay ended come out once the input has paused for `bridge_hidden_s`); latency "
                      f"image→LegTrack median "
                      f"{f(float(np.median(bl)) if bl else math.nan, 0)} ms, p95 "
                      f"{f(float(np.percentile(bl, 95)) if bl else math.nan, 0)} ms, largest "
                      f"{f(max(bl) if bl else math.nan, 0)} ms (a hidden foot's frames wait for it to be seen again)"]
            lines += [f"  * `{line}`" for line in lr.skip_log]
    return lines + [""]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m walker_gait.bench", description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="3 scenarios, 5 s sessions, paper preset on 4 frames")
    parser.add_argument("--scenarios", nargs="*", default=None)
    parser.add_argument("--duration", type=float, default=None, help="seconds per scenario session")
    parser.add_argument("--paper-frames", type=int, default=None,
                        help="frames the paper preset is scored on (~30 s each here; 0 = skip)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-live", action="store_true")
    parser.add_argument("--out", default="BENCHMARKS.md")
    args = parser.parse_args(argv)
    scenarios = tuple(args.scenarios) if args.scenarios else (("normal", "occlusion", "baggy_trousers")
                                                              if args.quick else SCENARIOS)
    duration = args.duration or (5.0 if args.quick else 8.0)
    paper_frames = args.paper_frames if args.paper_frames is not None else (4 if args.quick else 12)
    started = time.perf_counter()
    lines = ["# walker_gait benchmarks", "",
             f"Measured {dt.datetime.now(dt.timezone.utc):%Y-%m-%d %H:%M} UTC by `make bench` "
             f"(`python -m walker_gait.bench{' ' + ' '.join(argv or sys.argv[1:]) if (argv or sys.argv[1:]) else ''}`) on: "
             f"{machine()}.", "",
             "All data are synthetic sessions from `walker_gait.synth` (exact ground truth; leg surfaces, trousers "
             "and sensor are not the tracker's model). Seeds are fixed, so a rerun on the same machine reproduces "
             "the accuracy figures; timings vary with machine load.", ""]
    lines += section_segmentation(args.seed)
    e2e, _ = section_endtoend(scenarios, duration, args.seed)
    lines += e2e
    lines += section_presets(args.seed, paper_frames, run_paper=paper_frames > 0)
    lines += section_gait_on_truth(args.seed)
    lines += section_process_and_live(args.seed, live=not args.no_live)
    lines += [f"Total benchmark time: {time.perf_counter() - started:.0f} s.", ""]
    text = "\n".join(lines)
    from walker_gait.io.outputs import atomic_write

    with atomic_write(Path(args.out)) as fh:
        fh.write(text)
    print(text)
    log(f"[bench] wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
