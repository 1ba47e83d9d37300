"""``Publisher``: the session's observer (``cell.observer.CellObserver``) that logs every channel
to a Foxglove context, which writes MCAP files (``recorder.McapFiles``) and feeds the live view
(``live.start_live``).

Channels (docs/recording.md): ``/tf`` (``base -> flange`` from the RTDE samples the cell reads,
one per ``MOVING_PERIOD_S`` slot of controller time while the arm moves; ``flange -> tcp``;
the camera; ``capture_flange`` and ``capture_cam``), ``/cell/candidates``, ``/cell/plan``,
``/cell/reached``, ``/cell/scene``, ``/cell/status`` and ``/cell/audit`` (JSON), and
``/camera/points``. A timer thread, once a second, writes again what holds until it changes
(the fixed frames, the latched capture, the scene, the last flange pose when no sample came:
the arm is at rest and only the cell reads the controller) so a viewer that joins late, or a
new file of a folder, has them; and it flushes the file. A cloud is read and thinned on a thread
of its own, never in the cycle.
"""

from __future__ import annotations

import contextlib
import functools
import json
import logging
import math
import queue
import threading
import time
from collections.abc import Callable, Sequence
from datetime import datetime, timezone
from pathlib import Path
from types import TracebackType

import foxglove
import numpy as np
from foxglove.channels import FrameTransformsChannel, PointCloudChannel, SceneUpdateChannel
from foxglove.messages import FrameTransform

from handeye_pick.cell.captures import Capture
from handeye_pick.cell.plan import CandidateRefusal, PickPlan
from handeye_pick.cloud.files import open_cloud
from handeye_pick.config.schema import CellConfig
from handeye_pick.errors import HandEyePickError
from handeye_pick.geometry import Transform, invert, ur_pose_to_matrix
from handeye_pick.hand_eye.files import HandEyeCalibration, HandEyeMode
from handeye_pick.record import channels as ch
from handeye_pick.record.live import start_live
from handeye_pick.record.recorder import McapFiles
from handeye_pick.record.stamps import ControllerClock
from handeye_pick.steps import Step

log = logging.getLogger(__name__)

MOVING_PERIOD_S = 0.01
"""``base -> flange`` is logged once in each slot this long (controller time, s) while the arm
moves: 100 Hz, from the 250 looks a second the cell takes at a moving arm (a slot without a
look has no frame)."""
REST_PERIOD_S = 1.0
"""At rest (the pose unchanged, or no sample read) it is logged once a second."""
MOVED_M = 1e-6
"""A pose that changed by less than this (m, and about this in rad) counts as unchanged."""
DEFAULT_CLOUD_POINTS = 50_000
"""Most points of a recorded cloud (``--cloud-points``): thinned evenly beyond that."""
STATUS_SCHEMA = "handeye_pick.CellStatus"
"""The schema name of /cell/status: the session's state as JSON (any object)."""
AUDIT_SCHEMA = "handeye_pick.AuditRecord"
"""The schema name of /cell/audit: one audit record as JSON (any object)."""
WORK_QUEUE = 10_000
"""Messages waiting for the worker thread at most (a minute and a half of frames at 100 Hz)."""
CLOUD_QUEUE = 2
"""Clouds waiting to be read; one named while these wait is skipped, with a warning."""


class Publisher:
    """Logs a session to a recording (``record``: a file or a folder) and/or a live view
    (``live``: host and port); use as a context manager, outside the ``Cell``'s."""

    def __init__(
        self,
        config: CellConfig,
        calibration: HandEyeCalibration,
        *,
        record: Path | None = None,
        live: tuple[str, int] | None = None,
        cloud_points: int = DEFAULT_CLOUD_POINTS,
    ) -> None:
        # The SDK logs a line for every message it cannot write; the recorder's one warning
        # says it once (recorder.McapFiles).
        logging.getLogger("foxglove").setLevel(logging.ERROR)
        self._config = config
        self._calibration = calibration
        self._cloud_points = cloud_points
        self._T_tcp_flange = invert(config.robot.T_flange_tcp)
        self._clock = ControllerClock()
        self._lock = threading.Lock()
        # The last base -> flange logged: actual_TCP_pose (UR vector), controller s, wall ns.
        self._flange: tuple[list[float], float, int] | None = None
        self._capture_frames: list[tuple[str, str, Transform]] = []
        # Held for the session: once a context is dropped, its channels are closed.
        self._context = context = foxglove.Context()
        self._tf = FrameTransformsChannel("/tf", context=context)
        self._candidates = SceneUpdateChannel("/cell/candidates", context=context)
        self._plan = SceneUpdateChannel("/cell/plan", context=context)
        self._reached = SceneUpdateChannel("/cell/reached", context=context)
        self._scene = SceneUpdateChannel("/cell/scene", context=context)
        # A JSON channel needs a schema for the live view to advertise it; named, so a panel
        # and a reader of the file see what the messages are (docs/recording.md).
        self._status = foxglove.Channel(
            "/cell/status",
            schema=_json_schema(STATUS_SCHEMA),
            message_encoding="json",
            context=context,
        )
        self._audit = foxglove.Channel(
            "/cell/audit",
            schema=_json_schema(AUDIT_SCHEMA),
            message_encoding="json",
            context=context,
        )
        self._points = PointCloudChannel("/camera/points", context=context)
        self._server = start_live(context, *live) if live is not None else None
        self.files: McapFiles | None = None
        try:
            self.files = McapFiles(record, context, self._latched) if record is not None else None
        except BaseException:
            self._stop_server()
            raise
        self._closing = threading.Event()
        self._clouds: queue.Queue[tuple[Path, Capture | None] | None] = queue.Queue(CLOUD_QUEUE)
        self._work: queue.Queue[Callable[[], None] | None] = queue.Queue(WORK_QUEUE)
        self._behind = False
        self._threads = [
            threading.Thread(target=self._run_work, name="record-worker", daemon=True),
            threading.Thread(target=self._every_second, name="record-timer", daemon=True),
            threading.Thread(target=self._read_clouds, name="record-clouds", daemon=True),
        ]
        for thread in self._threads:
            thread.start()

    @property
    def live_port(self) -> int | None:
        """The port the live view listens on (None: no live view)."""
        return self._server.port if self._server is not None else None

    # --- the session's observer ----------------------------------------------------------------

    def on_sample(self, tcp_pose: Sequence[float], controller_time_s: float) -> None:
        last = self._flange
        if last is not None:
            since = controller_time_s - last[1]
            # One frame per slot of MOVING_PERIOD_S of controller time, not one per period
            # since the last frame: the cell looks every few ms, so "a period since the last"
            # waits for the look after the period and lost a slot in three (65-72 Hz).
            if since >= 0.0 and _slot(controller_time_s) == _slot(last[1]):
                return
            if since < REST_PERIOD_S and _same(last[0], tcp_pose):
                return
        wall_ns = self._clock.wall_ns(controller_time_s)
        pose = list(tcp_pose)
        self._flange = (pose, controller_time_s, wall_ns)
        self._submit(lambda: self._log_flange(pose, wall_ns))

    def _log_flange(self, tcp_pose: list[float], wall_ns: int) -> None:
        T_base_flange = ur_pose_to_matrix(tcp_pose) @ self._T_tcp_flange
        self._tf.log(ch.frames([ch.frame(ch.BASE, ch.FLANGE, T_base_flange, wall_ns)]))

    def on_capture(self, capture: Capture) -> None:
        if capture.T_base_flange is None:  # eye-to-hand: the camera's frame is fixed
            return
        frames = [
            (ch.BASE, ch.CAPTURE_FLANGE, capture.T_base_flange),
            (ch.CAPTURE_FLANGE, ch.CAPTURE_CAM, self._calibration.T_cal),
        ]
        with self._lock:
            self._capture_frames = frames
        now = _now_ns()
        self._submit(lambda: self._log_frames(frames, now))

    def on_cloud(self, path: Path, capture: Capture | None) -> None:
        try:
            self._clouds.put_nowait((path, capture))
        except queue.Full:
            log.warning("recording: cloud %s skipped: %d clouds wait to be read", path, CLOUD_QUEUE)

    def on_candidates(
        self,
        plans: Sequence[PickPlan],
        chosen: int | None,
        refused: Sequence[CandidateRefusal],
    ) -> None:
        now, kept = _now_ns(), (list(plans), list(refused))
        self._submit(
            lambda: self._candidates.log(ch.candidates_update(kept[0], chosen, kept[1], now))
        )

    def on_plan(
        self,
        steps: Sequence[Step],
        T_base_tcp_start: Transform | None,
        q_actual: Sequence[float] | None = None,
    ) -> None:
        now, kept = _now_ns(), list(steps)

        def log() -> None:  # on the recorder's thread: the arm's joints take milliseconds
            arm = (
                ch.arm_entities(self._config, kept, T_base_tcp_start, q_actual, now)
                if T_base_tcp_start is not None and q_actual is not None
                else []
            )
            self._plan.log(ch.plan_update(kept, T_base_tcp_start, now, arm))

        self._submit(log)

    def on_reached(self, name: str, T_target: Transform | None, T_reached: Transform) -> None:
        now = _now_ns()
        self._submit(lambda: self._reached.log(ch.reached_update(name, T_target, T_reached, now)))

    def on_status(self, status: dict[str, object]) -> None:
        stamped = {"time": datetime.now(timezone.utc).isoformat(timespec="microseconds")}
        line = json.dumps({**stamped, **status}, default=str).encode()
        self._submit(lambda: self._status.log(line))

    def on_audit(self, line: str) -> None:
        self._submit(lambda: self._logged_audit(line))

    def _logged_audit(self, line: str) -> None:
        self._audit.log(line.encode())
        if self.files is not None:
            self.files.flush()  # a chunk ends at every record: a killed process loses little

    # --- the worker ----------------------------------------------------------------------------

    def _submit(self, work: Callable[[], None]) -> None:
        """Hand ``work`` to the worker thread: the cycle never waits for a message to be built
        or written. A worker that has fallen ``WORK_QUEUE`` items behind drops what comes, and
        says so once."""
        try:
            self._work.put_nowait(work)
        except queue.Full:
            if not self._behind:
                self._behind = True
                log.warning("recording: %d messages wait: later ones are dropped", WORK_QUEUE)

    def _run_work(self) -> None:
        """The worker thread: build and log, in order; a failure ends only the recording."""
        while True:
            work = self._work.get()
            if work is None:
                return
            try:
                work()
                self._check()
            except Exception as exc:  # the cell goes on without its recording
                log.warning("recording stopped (the cell goes on): %s: %s", type(exc).__name__, exc)
                self._close_sinks()
                return

    # --- the rest ------------------------------------------------------------------------------

    def _check(self) -> None:
        if self.files is not None:
            self.files.check()

    def _latched(self) -> None:
        """Log what holds until it changes: the fixed frames, the latched capture, the scene."""
        now = _now_ns()
        if self._calibration.mode is HandEyeMode.EYE_IN_HAND:
            camera = (ch.FLANGE, ch.CAM, self._calibration.T_cal)
        else:
            camera = (ch.BASE, ch.CAM, self._calibration.T_cal)
        with self._lock:
            fixed = [(ch.FLANGE, ch.TCP, self._config.robot.T_flange_tcp), camera]
            fixed += self._capture_frames
        self._log_frames(fixed, now)
        self._scene.log(ch.scene_update(self._config, now))

    def _log_frames(self, frames: Sequence[tuple[str, str, Transform]], now: int) -> None:
        transforms: list[FrameTransform] = [ch.frame(p, c, T, now) for p, c, T in frames]
        self._tf.log(ch.frames(transforms))
        self._check()

    def _every_second(self) -> None:
        """The timer thread (see the module's docstring); a failure ends only the recording."""
        try:
            while not self._closing.wait(REST_PERIOD_S):
                self._submit(self._latched)
                last = self._flange
                now = _now_ns()
                if last is not None and now - last[2] >= REST_PERIOD_S * 1e9:
                    self._submit(functools.partial(self._log_flange, last[0], now))
                if self.files is not None:
                    self._submit(self.files.flush)
        except Exception as exc:  # the cell goes on without its recording
            log.warning("recording stopped (the cell goes on): %s: %s", type(exc).__name__, exc)
            self._close_sinks()

    def _read_clouds(self) -> None:
        while True:
            item = self._clouds.get()
            if item is None:
                return
            path, capture = item
            try:
                points = thinned_cloud_mm(path, self._cloud_points)
            except (HandEyePickError, OSError) as exc:
                log.warning("recording: cloud %s not recorded: %s", path, exc)
                continue
            eye_in_hand = capture is not None and capture.T_base_flange is not None
            frame_id = ch.CAPTURE_CAM if eye_in_hand else ch.CAM
            try:
                self._points.log(ch.cloud_message(points, frame_id, _now_ns()))
                self._check()
            except Exception as exc:  # the cell goes on without its recording
                log.warning("recording: cloud %s not recorded: %s", path, exc)

    def close(self) -> None:
        """Stop the threads, write the file's index, stop the live view; safe to call twice."""
        self._closing.set()
        for thread in self._threads:
            if thread.name == "record-clouds":
                _put_end(self._clouds)
            if thread.name == "record-worker":
                self._work.put(None)  # after everything submitted before: nothing is lost
            if thread is not threading.current_thread():
                thread.join(timeout=10.0)
        self._close_sinks()

    def _close_sinks(self) -> None:
        if self.files is not None:
            self.files.close()
        self._stop_server()

    def _stop_server(self) -> None:
        server, self._server = self._server, None
        if server is not None:
            server.stop()

    def __enter__(self) -> Publisher:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def thinned_cloud_mm(path: Path, max_points: int) -> np.ndarray:
    """The finite points of a cloud file (organised H x W x 3 or N x 3, camera frame, mm),
    every k-th kept so that at most ``max_points`` remain; read in chunks (memory bounded)."""
    with open_cloud(path) as reader:
        total = reader.layout.points
        step = max(1, math.ceil(total / max_points))
        kept: list[np.ndarray] = []
        start = 0
        for xyz, _rgb in reader.chunks():
            first = (-start) % step  # the index of the first kept point within this chunk
            picked = np.asarray(xyz[first::step], dtype=np.float32)
            kept.append(picked[np.isfinite(picked).all(axis=1)])
            start += len(xyz)
    points = np.concatenate(kept) if kept else np.empty((0, 3), dtype=np.float32)
    return points[:max_points]


def _slot(controller_time_s: float) -> int:
    """The ``MOVING_PERIOD_S`` slot of controller time (s) a sample falls in."""
    return math.floor(controller_time_s / MOVING_PERIOD_S)


def _same(pose_a: Sequence[float], pose_b: Sequence[float]) -> bool:
    """Two UR pose vectors alike to ``MOVED_M`` (m, and rad for the rotation vector)."""
    return all(abs(a - b) < MOVED_M for a, b in zip(pose_a, pose_b, strict=True))


def _now_ns() -> int:
    return time.time_ns()


def _put_end(clouds: queue.Queue[tuple[Path, Capture | None] | None]) -> None:
    while True:
        try:
            clouds.put_nowait(None)
            return
        except queue.Full:
            with contextlib.suppress(queue.Empty):  # the reader emptied it meanwhile
                clouds.get_nowait()


def _json_schema(name: str) -> foxglove.Schema:
    """A JSON schema named ``name`` that admits any object."""
    data = json.dumps({"title": name, "type": "object"}).encode()
    return foxglove.Schema(name=name, encoding="jsonschema", data=data)
