"""Shared plumbing of the walker_gait rclpy nodes (the only package that imports rclpy).

* Messages travel as CDR bytes built/parsed by :mod:`walker_gait.messages` (``raw=True``
  subscriptions, publishers given ``bytes``), so nodes and the offline pipeline share one
  conversion layer.
* Parameters are declared from the core config dataclasses (:mod:`walker_gait.config`).
* Every callback is guarded: a bad frame is logged once per kind of problem, counted on
  ``/diagnostics`` and skipped; the node keeps running.
"""

from __future__ import annotations

import importlib
import math
import signal
import statistics
import sys
import threading
import time
from collections import Counter, deque
from collections.abc import Callable
from typing import Any

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from walker_gait import messages as M
from walker_gait.config import ParameterError, build, flatten

# ---------------------------------------------------------------------------------------------- QoS
#: Camera input: best effort, keep last 5 — matches both best-effort drivers and reliable bag players.
SENSOR_IN = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=5, reliability=ReliabilityPolicy.BEST_EFFORT,
                       durability=DurabilityPolicy.VOLATILE)
#: Per-frame streams between our nodes and to visualisers: reliable, keep last 5.
STREAM = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=5, reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.VOLATILE)


def stream_in(depth: int) -> QoSProfile:
    """Per-frame stream subscription between our nodes: reliable, keep last ``depth``, volatile."""
    if depth < 1:
        raise ParameterError(f"input_depth must be >= 1, got {depth}")
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)


#: Per-frame stream subscriptions between our nodes: reliable keep-last-5 — large fragmented messages are
#: not lost to a dropped fragment, and a slow node still only ever sees the newest 5 (no growing backlog).
#: (``leg_tracker`` uses :func:`stream_in` with its ``input_depth``.)
STREAM_IN = stream_in(5)


def input_qos(reliability: str) -> QoSProfile:
    """Camera-input QoS: ``best_effort`` (default; matches every driver) or ``reliable`` (reliable sources,
    same profile as :data:`STREAM_IN`)."""
    if reliability == "best_effort":
        return SENSOR_IN
    if reliability == "reliable":
        return STREAM_IN
    raise ParameterError(f"input_reliability must be 'best_effort' or 'reliable', got {reliability!r}")


#: Discrete gait events and steps: reliable, keep last 100 — none lost to a briefly slow subscriber.
EVENTS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.VOLATILE)
#: Gait summaries: reliable, transient local, keep last 1 — late-joining dashboards get the latest.
LATCHED = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: /diagnostics.
DIAGNOSTICS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)


def rclpy_type(typename: str) -> Any:
    """rclpy message class for ``pkg/msg/Name``."""
    pkg, _, name = typename.split("/")
    return getattr(importlib.import_module(f"{pkg}.msg"), name)


_MIN_PERIOD_S = 1e-4
"""Stamp intervals shorter than this (s) are no camera's period (10 kHz): two messages of one frame stamped a hair
apart, not frames; :class:`BusyMonitor` neither reads its period from them nor counts them."""


class BusyMonitor:
    """How much of its input's time a node spends working on it: the work summed over the last ``window`` frames
    against the span of their stamps (1.0: busy all the time).  Above ``limit`` the node cannot keep up with the
    camera: frames wait in its input queue (latency grows to the queue's depth) and are then dropped; it counts as
    keeping up again below ``limit`` x ``relief``.  A stamp that does not advance (a replay that loops) starts
    afresh.

    It also counts the frames it did not work on (:attr:`missed`): where consecutive frames it worked on lie ``k``
    camera periods apart, ``k - 1`` frames came between them that it skipped (counted by kind as well) or never got
    (lost whole in its input queue, or never sent).  The period (:attr:`period_s`) is the median of the recent stamp
    intervals within 1.5 times the shortest of them (the consecutive frames', whatever the stamps' jitter): a node
    that never sees two consecutive frames reads a multiple of it and counts too few, never too many; a gap of
    ``max_gap_s`` or more is the input pausing (a camera restarted, a replay between recordings), not frames missed."""

    def __init__(self, *, window: int = 60, limit: float = 0.95, relief: float = 0.85, min_frames: int = 15,
                 max_gap_s: float = 1.0) -> None:
        if not (window >= min_frames >= 2 and 0.0 < relief < 1.0 and limit > 0.0 and max_gap_s > 0.0):
            raise ValueError(f"window >= min_frames >= 2, 0 < relief < 1, limit > 0 and max_gap_s > 0, got {window}, "
                             f"{min_frames}, {relief}, {limit}, {max_gap_s}")
        self.max_gap_s = max_gap_s
        self._intervals: deque[float] = deque(maxlen=4 * window)  # stamp intervals between frames worked on
        self.period_s = math.nan  # the camera's period (s) read from them; NaN before the first interval
        self.missed = 0  # frames between those worked on that the node did not work on
        self.limit = limit
        self.relief = relief
        self.min_frames = min_frames
        self._frames: deque[tuple[float, float]] = deque(maxlen=window)
        self.overloaded = False
        self.episodes = 0  # times it started falling behind

    def add(self, stamp_s: float, work_s: float) -> bool:
        """Record one frame (its stamp, s, and the wall time, s, spent on it); True when this frame makes a node
        that was keeping up fall behind (to be said once per episode)."""
        if self._frames and stamp_s <= self._frames[-1][0]:
            self._frames.clear()
            self.overloaded = False
        if self._frames:
            gap = stamp_s - self._frames[-1][0]
            if _MIN_PERIOD_S <= gap < self.max_gap_s:
                self._intervals.append(gap)
                shortest = min(self._intervals)
                self.period_s = statistics.median(g for g in self._intervals if g <= 1.5 * shortest)
                self.missed += max(0, round(gap / self.period_s) - 1)
        self._frames.append((stamp_s, work_s))
        busy = self.busy
        if not math.isfinite(busy):
            return False
        if not self.overloaded and busy > self.limit:
            self.overloaded = True
            self.episodes += 1
            return True
        if self.overloaded and busy < self.limit * self.relief:
            self.overloaded = False
        return False

    @property
    def busy(self) -> float:
        """Work over stamp span of the frames in the window (the first frame's work left out: it opens the span);
        NaN before ``min_frames`` frames."""
        if len(self._frames) < self.min_frames:
            return math.nan
        span = self._frames[-1][0] - self._frames[0][0]
        return sum(w for _, w in list(self._frames)[1:]) / span if span > 0 else math.nan

    @property
    def work_ms(self) -> float:
        """Mean wall time a frame (ms) over the window; NaN without frames."""
        return 1e3 * sum(w for _, w in self._frames) / len(self._frames) if self._frames else math.nan

    @property
    def interval_ms(self) -> float:
        """Mean stamp interval (ms) between the frames worked on in the window; NaN with fewer than two."""
        if len(self._frames) < 2:
            return math.nan
        return 1e3 * (self._frames[-1][0] - self._frames[0][0]) / (len(self._frames) - 1)


class WalkerNode(Node):
    """Base class: guarded raw pub/sub, config-declared parameters, diagnostics."""

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self._problems: Counter[str] = Counter()
        self._stand_ins: Counter[str] = Counter()
        self._absent: Counter[str] = Counter()
        self.frames_ok = 0
        self.busy_monitor: BusyMonitor | None = None  # made by the first :meth:`frame_timed`
        self._diag_pub = self.create_publisher(rclpy_type(M.DIAGNOSTIC_ARRAY), "/diagnostics", DIAGNOSTICS)
        self._diag_timer = self.create_timer(1.0, self._publish_diagnostics)

    # -- parameters --------------------------------------------------------------------------------
    def declare_config(self, cls: type, *, prefix: str = "", base: Any | None = None) -> Any:
        """Declare every field of config dataclass ``cls`` as a parameter and build it from their values."""
        defaults = flatten(base if base is not None else cls())
        values: dict[str, Any] = {}
        for key, default in defaults.items():
            name = prefix + key
            if default is None:
                param = self.declare_parameter(name, Parameter.Type.STRING)
                value = param.value
                values[key] = None if value in (None, "", "none", "None") else value
            else:
                if isinstance(default, list) and not default:
                    default = [""]  # rclpy cannot infer the type of an empty list
                values[key] = self.declare_parameter(name, default).value
        try:
            return build(cls, values, base=base)
        except ParameterError as exc:
            self.get_logger().fatal(str(exc))
            raise

    # -- pub/sub -----------------------------------------------------------------------------------
    def raw_publisher(self, typename: str, topic: str, qos: QoSProfile, *,
                      event_callbacks: Any = None) -> Callable[[Any], None]:
        pub = self.create_publisher(rclpy_type(typename), topic, qos, event_callbacks=event_callbacks)

        def publish(msg: Any) -> None:
            pub.publish(M.serialize(msg))

        publish.publisher = pub  # type: ignore[attr-defined]
        return publish

    def raw_subscription(self, typename: str, topic: str, callback: Callable[[Any], None], qos: QoSProfile) -> Any:
        def on_bytes(data: bytes) -> None:
            self.dispatch(topic, typename, callback, data)

        return self.create_subscription(rclpy_type(typename), topic, on_bytes, qos, raw=True)

    def dispatch(self, topic: str, typename: str, callback: Callable[[Any], None], data: bytes) -> None:
        """Deserialize and handle one message; any error skips it (logged once per kind, counted)."""
        with self.guard(topic):
            try:
                msg = M.deserialize(data, typename)
            except Exception as exc:  # noqa: BLE001 - undecodable bytes are one more kind of bad input
                raise UndecodableMessage(f"cannot decode a {typename} message: {exc}") from exc
            callback(msg)

    # -- errors and diagnostics --------------------------------------------------------------------
    def guard(self, where: str) -> _Guard:
        return _Guard(self, where)

    def report_problem(self, kind: str, detail: str) -> None:
        """Count a skipped frame; log the first occurrence of each kind (then once per 1000)."""
        n = _tally(self._problems, kind)
        if n is not None:
            self.get_logger().error(f"{detail} (frame skipped; {kind} seen {n}x; counted on /diagnostics)")

    def report_stand_in(self, kind: str, detail: str) -> None:
        """Count a frame processed with a stand-in for a part that never arrived; log the first of each kind
        (then once per 1000) as a warning."""
        n = _tally(self._stand_ins, kind)
        if n is not None:
            self.get_logger().warning(f"{detail} ({kind} stood in {n}x; counted on /diagnostics)")

    def report_absent(self, kind: str, detail: str) -> None:
        """Count a frame that never came whole for a reason the node upstream reports itself (a leg track the
        tracker dropped while it could not keep up, which its own /diagnostics show): on /diagnostics as
        ``absent.KIND``, not a problem of this node; the first of each kind (then once per 1000) logged as
        information."""
        n = _tally(self._absent, kind)
        if n is not None:
            self.get_logger().info(f"{detail} ({kind} absent {n}x; counted on /diagnostics)")

    def diagnostic_values(self) -> dict[str, Any]:
        """A node's own key-values for /diagnostics (none by default)."""
        return {}

    def _publish_diagnostics(self) -> None:
        level = 0 if not self._problems else 1
        message = "ok" if not self._problems else f"{sum(self._problems.values())} frame(s) skipped"
        values: dict[str, Any] = {"frames_ok": self.frames_ok}
        values.update({f"skipped.{k}": v for k, v in sorted(self._problems.items())})
        values.update({f"stood_in.{k}": v for k, v in sorted(self._stand_ins.items())})
        values.update({f"absent.{k}": v for k, v in sorted(self._absent.items())})
        values.update(self.diagnostic_values())
        busy = self.busy_monitor
        if busy is not None and math.isfinite(busy.work_ms):  # frames timed
            values.update({"busy_pct": round(100 * busy.busy, 1) if math.isfinite(busy.busy) else "n/a",
                           "work_ms_mean": round(busy.work_ms, 1), "falling_behind_episodes": busy.episodes,
                           "frames_missed": busy.missed})
            if busy.overloaded:
                level = 1
                message = ("cannot keep up with its input" if message == "ok"
                           else f"{message}; cannot keep up with its input")
        now = self.get_clock().now().nanoseconds
        msg = M.make_diagnostics(M.make_header(M.make_time(now, ns=True), ""), name=f"walker_gait: {self.get_name()}",
                                 hardware_id=self.get_fully_qualified_name(), level=level, message=message,
                                 values=values)
        self._diag_pub.publish(M.serialize(msg))

    def frame_timed(self, stamp_s: float, work_s: float, *, advice: str) -> None:
        """Record the wall time ``work_s`` spent on the frame stamped ``stamp_s`` (:class:`BusyMonitor`); when the
        node starts falling behind its input, say so once (a warning with the figures and ``advice``); while it is
        behind, /diagnostics is at WARN."""
        if self.busy_monitor is None:
            self.busy_monitor = BusyMonitor()
        m = self.busy_monitor
        if m.add(stamp_s, work_s):
            self.get_logger().warning(
                f"cannot keep up with its input: {m.work_ms:.0f} ms of work on each frame it took, those frames "
                f"{m.interval_ms:.0f} ms apart by their stamps: busy {100 * m.busy:.0f} % of the time; frames wait in "
                f"the input queue and are dropped when it overflows; {advice} (falling behind {m.episodes}x; on "
                "/diagnostics)")

    @property
    def problems(self) -> dict[str, int]:
        return dict(self._problems)

    @property
    def stand_ins(self) -> dict[str, int]:
        return dict(self._stand_ins)

    @property
    def absent(self) -> dict[str, int]:
        return dict(self._absent)


def _tally(counter: Counter[str], kind: str) -> int | None:
    """Count one ``kind`` in ``counter``; its new count when that is worth a log line (the first, then every
    1000th), else None."""
    counter[kind] += 1
    n = counter[kind]
    return n if n == 1 or n % 1000 == 0 else None


class UndecodableMessage(ValueError):
    kind = "undecodable_message"


class _Guard:
    def __init__(self, node: WalkerNode, where: str) -> None:
        self.node = node
        self.where = where

    def __enter__(self) -> _Guard:
        return self

    def __exit__(self, exc_type: Any, exc: BaseException | None, tb: Any) -> bool:
        if exc is None or not isinstance(exc, Exception):
            return False  # KeyboardInterrupt / SystemExit / shutdown propagate
        kind = getattr(exc, "kind", None) or type(exc).__name__
        self.node.report_problem(str(kind), f"{self.where}: {type(exc).__name__}: {exc}")
        return True


def spin_node(factory: Callable[[], WalkerNode], args: list[str] | None = None) -> int:
    """Init rclpy, build the node, spin until Ctrl-C / SIGTERM, shut down cleanly; exit code 0.

    rclpy's own signal handlers are disabled: they would shut the context down before the node's
    ``close()`` could publish what it flushes at the end (e.g. gait_analyzer's last steps).
    """
    from rclpy.signals import SignalHandlerOptions

    argv = sys.argv if args is None else args
    rclpy.init(args=argv, signal_handler_options=SignalHandlerOptions.NO)
    stop = install_interrupt_handlers()
    node: WalkerNode | None = None
    code = 0
    try:
        node = factory()
        while rclpy.ok() and not stop.is_set():
            rclpy.spin_once(node, timeout_sec=0.1)
    except ExternalShutdownException:
        pass
    except ParameterError:
        code = 2
    finally:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C must not interrupt the cleanup
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        if node is not None:
            close = getattr(node, "close", None)
            if close is not None and rclpy.ok():
                try:
                    if close():
                        time.sleep(0.3)  # let reliable subscribers fetch what close() published
                except Exception as exc:  # noqa: BLE001 - a failing close must not hide the exit
                    print(f"{node.get_name()}: error while closing: {exc}", file=sys.stderr)
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return code


def install_interrupt_handlers() -> threading.Event:
    """SIGINT and SIGTERM set the returned event, which the spin loop checks between spins (every spin timeout).

    The handler raised KeyboardInterrupt before; raised wherever the main thread was, it could land inside rclpy's
    executor (its generator of ready callbacks, which holds the wait set's entities in use), and a node then hung in
    its shutdown until ``walker-gait run`` killed it (seen once in a full test run: ``bag_replay: -9``)."""
    stop = threading.Event()

    def handler(signum: int, frame: Any) -> None:
        stop.set()

    signal.signal(signal.SIGINT, handler)
    signal.signal(signal.SIGTERM, handler)
    return stop


__all__ = [
    "DIAGNOSTICS", "EVENTS", "LATCHED", "SENSOR_IN", "STREAM", "STREAM_IN", "BusyMonitor", "WalkerNode", "input_qos",
    "rclpy_type", "spin_node",
]
