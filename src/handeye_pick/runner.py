"""The request protocol of ``handeye-pick run``: one JSON request in, one JSON reply out.

``Runner.handle(line)`` parses and validates a whole request before it calls the cell, so a
request that is malformed in any part moves nothing; it never raises for a bad request or a
refused or failed operation: every ending becomes a reply. Only Ctrl-C/SIGTERM
(``KeyboardInterrupt``, after the cell stopped the arm) and defects propagate, and
``Runner.interrupted_reply`` answers the request in flight for them.

Requests (camera frame in mm for detections, robot poses as UR vectors in m and rad)::

    {"id": "1", "op": "capture", "pose": "capture"}          pose optional
    {"id": "2", "op": "pick", "capture_id": "c1", "candidates": [DETECTION, ...],
     "place": true, "dry_run": false}                        place, dry_run optional
    {"id": "3", "op": "place"}    {"id": "4", "op": "move", "pose": "home"}
    {"id": "5", "op": "status"}   {"id": "6", "op": "resume"}   {"id": "7", "op": "quit"}
    {"id": "8", "op": "stop"}     {"id": "9", "op": "cycle-stop"}   {"id": "10", "op": "release"}

``capture`` and ``pick`` may name the vision program's point cloud of the capture,
``"cloud": {"file": "PATH.npy"}`` (camera frame, mm), for a recording (``run --record``).

Every reply carries ``id`` and ``ok``; failed ones ``status`` and ``error``. A request may carry
``token`` (required when the runner was given one, see ``cli/run.py``).

While a request runs, ``Runner.answer_now`` answers ``stop`` (it brakes the arm and halts the
cell), ``status`` (``busy``, with the request and the step in progress) and malformed lines at
once, from the thread that reads requests; the others wait their turn. A motion request with
``"events": true`` also gets event lines, carrying its ``id`` and no ``ok``:
``{"id": "4", "event": "step", "step": "retreat"}`` as each step starts, and
``{"id": "4", "event": "view-clear"}`` once the arm has passed ``capture.view_clear_at`` (a
fixed camera may capture again).

``cycle-stop`` (hold after the running request) and ``release`` are answered at once too; while
the cell is held, motion requests are answered ``held`` and never run (the line state,
``handeye_pick.line``, is given as ``Runner.line``).
"""

from __future__ import annotations

import hmac
import json
import logging
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from handeye_pick.cell.ahead import AheadRequest
from handeye_pick.cell.captures import Capture
from handeye_pick.cell.pick import PickResult
from handeye_pick.cell.plan import NoFeasibleCandidate
from handeye_pick.cell.session import Cell
from handeye_pick.detection import Detection, detection_from_data
from handeye_pick.errors import (
    InputError,
    RobotError,
    SafetyRefusal,
    Status,
    Terminated,
    ending,
)
from handeye_pick.geometry import ur_pose_list
from handeye_pick.safety import PreflightRefusal

log = logging.getLogger(__name__)

MAX_LINE_BYTES = 1_000_000
"""Longest request line read; a longer one is answered with an error, never held in memory."""
MISSED_MESSAGE = "it was opened and the arm retreated; the cell is ready"
"""Follows why the gripper sensed no part, in a missed pick's reply."""
MAX_CANDIDATES = 100
"""Most candidate detections one pick request may carry."""

_KEYS: dict[str, tuple[str, ...]] = {  # "events": true asks for the request's event lines
    "capture": ("pose", "events", "cloud"),
    "pick": ("capture_id", "candidates", "place", "dry_run", "events", "cloud"),
    "place": ("events",),
    "move": ("pose", "events"),
    "status": (),
    "resume": (),
    "quit": (),
    "stop": (),
    "cycle-stop": (),
    "release": (),
}
_MOTION_OPS = frozenset({"capture", "pick", "place", "move", "resume"})
_HELD_OPS = frozenset({"capture", "pick", "place", "move"})  # not run while the cell is held
_LINE_OPS = frozenset({"cycle-stop", "release"})
_COMMON_KEYS = ("id", "op", "token")


class LineDoor(Protocol):
    """The line state as the runner sees it (``handeye_pick.line.state.Line``)."""

    def held(self) -> str | None:
        """Who gave the cycle stop in force, or None."""

    def command(self, name: str, by: str) -> dict[str, object]:
        """``cycle-stop`` or ``release`` given by ``by``: the reply's fields."""

    def noted_stop(self, by: str) -> None:
        """A ``stop`` request was given to the cell: audit who gave it."""

    def status_fields(self) -> dict[str, object]:
        """What a ``status`` reply adds (``held``, ``held_by``, ``line_state``)."""

    def run_pending(self) -> None:
        """Run, on the calling thread (the cell's), what other doors handed over."""


class BadRequest(InputError):
    """The request line is not a complete, valid request; nothing was done."""


@dataclass(frozen=True)
class Request:
    """A parsed and fully validated request."""

    id: str | int | None
    op: str
    pose: str | None = None
    capture_id: str | None = None
    candidates: tuple[Detection, ...] = ()
    place: bool = True
    dry_run: bool = False
    events: bool = False  # write event lines while it runs
    cloud: Path | None = None  # the vision program's cloud of the capture, for a recording


class Runner:
    """Answers requests with ``cell``; ``token`` (when set) must come with every request."""

    def __init__(self, cell: Cell, token: str | None = None) -> None:
        self.cell = cell
        self._token = token
        self.quit = False
        self.events: Callable[[dict[str, object]], None] | None = None  # where event lines go
        self._busy: dict[str, object] | None = None  # the request running: id, op, step
        self._events = False  # the running request asked for its event lines
        self._view_clear_sent = False
        self.line: LineDoor | None = None  # the line state (run), or None
        self._peek: Callable[[], bytes | str | None] | None = None
        self._not_a_pick: bytes | str | None = None  # the waiting line last found no pick
        self.check_ahead = True  # run checks a waiting pick while the place moves (watch_queue)
        cell.watch_steps(self._on_step)

    def watch_queue(self, peek: Callable[[], bytes | str | None]) -> None:
        """``peek`` gives the request line first in line behind the running one (None: none
        waits); a pick waiting behind a running place is checked while the place moves
        (``Cell.look_ahead``). Called from the cell's thread."""
        self._peek = peek
        self.cell.look_ahead(self._waiting_pick)

    def _waiting_pick(self) -> AheadRequest | None:
        """The pick request first in line, as the cell would run it; None when none waits, or
        it would not run as a pick now (malformed, a dry run, held, an unknown capture)."""
        line = self._peek() if self._peek is not None else None
        if line is None or line is self._not_a_pick:  # asked at every look: parse it once
            return None
        self._not_a_pick = line
        try:
            request = self._parse(line)
            if request.op != "pick" or request.dry_run or self._held_reply(request) is not None:
                return None
            capture = self.cell.request_capture(request.capture_id)
        except InputError:
            return None
        self._not_a_pick = None
        rid = None if request.id is None else str(request.id)
        return AheadRequest(_key(line), request.candidates, capture, request.place, rid)

    @property
    def running(self) -> dict[str, object] | None:
        """A copy of the request running (id, op, step), or None; safe from any thread."""
        busy = self._busy
        return dict(busy) if busy is not None else None

    def idle(self) -> None:
        """The cell's thread between requests: run what the line's other doors handed over
        (a resume from the OPC UA server or a wired input)."""
        if self.line is not None:
            self.line.run_pending()

    def handle(self, line: bytes | str) -> dict[str, object]:
        """The reply to one request line (without its newline)."""
        try:
            request = self._parse(line)
        except BadRequest as exc:
            return bad_request_reply(line, exc)
        held = self._held_reply(request)
        if held is not None:
            self.cell.drop_ahead(_key(line), Status.HELD, str(held["error"]))
            return held
        if request.op in _MOTION_OPS:
            self._busy = {"id": request.id, "op": request.op}
            self._events, self._view_clear_sent = request.events, False
        try:
            return {"id": request.id, **self._dispatch(request, _key(line))}
        except (KeyboardInterrupt, SystemExit):
            raise
        except (InputError, SafetyRefusal, RobotError) as exc:
            return {"id": request.id, "ok": False, **failure_fields(exc)}
        finally:
            view_clear_at = self._view_clear_at()
            if (
                self._busy is not None
                and view_clear_at is not None
                and (self._busy.get("step") == view_clear_at)
            ):
                self._view_clear()  # the sequence ended on the view-clear point itself
            self._busy = None

    def answer_now(self, line: bytes | str, waiting: bool) -> dict[str, object] | None:
        """The reply to a request that must not wait behind the one running (or behind those
        ``waiting`` in line), or None when it takes its turn: ``stop`` (brakes the arm at once
        and halts the cell), ``status`` while the cell is busy, and a malformed request.
        Reads no controller: safe beside a running request."""
        try:
            request = self._parse(line)
        except BadRequest as exc:
            return bad_request_reply(line, exc)
        busy = self.running
        if request.op == "stop":
            running = f" while request {busy['id']} ran {busy['op']}" if busy else ""
            self.cell.request_stop(f"stopped by request {request.id}{running}")
            if self.line is not None:
                self.line.noted_stop(f"request {request.id}")
            return {"id": request.id, "ok": True, "status": Status.STOPPED, "request": busy}
        if request.op in _LINE_OPS:
            return {"id": request.id, **self._line_command(request)}
        if request.op == "status" and (busy is not None or waiting):
            return {
                "id": request.id,
                "ok": True,
                "status": Status.BUSY,
                "request": busy,
                "halted": self.cell.halted is not None,
                "halted_reason": self.cell.halted,
                **self._line_fields(),
            }
        return None

    def _held_reply(self, request: Request) -> dict[str, object] | None:
        """The reply to a motion request while a cycle stop holds the cell: not run."""
        by = self.line.held() if self.line is not None and request.op in _HELD_OPS else None
        if by is None:
            return None
        return {
            "id": request.id,
            "ok": False,
            "status": Status.HELD,
            "held_by": by,
            "error": f"the cell is held (cycle stop by {by}): {request.op} was not run; "
            "it runs again after a release",
        }

    def _line_command(self, request: Request) -> dict[str, object]:
        if self.line is None:
            error = f"{request.op}: this session has no line state"
            return {"ok": False, "status": Status.BAD_REQUEST, "error": error}
        return self.line.command(request.op, f"request {request.id}")

    def _line_fields(self) -> dict[str, object]:
        """The line's fields of a ``status`` reply (none without a line state)."""
        return self.line.status_fields() if self.line is not None else {}

    def _parse(self, line: bytes | str) -> Request:
        data = _parse_json(line)
        request_id = _request_id(data)
        self._check_token(data)
        return _validate(data, request_id)

    def _view_clear_at(self) -> str | None:
        return self.cell.config.capture.view_clear_at

    def _on_step(self, step: str) -> None:
        """A step of the running request started: say so; once the arm has passed the
        view-clear point (the step after it started), say that too."""
        busy = self._busy
        if busy is None:
            return
        passed, busy["step"] = busy.get("step"), step
        self._emit({"id": busy["id"], "event": "step", "step": step})
        if passed is not None and passed == self._view_clear_at():
            self._view_clear()

    def _view_clear(self) -> None:
        if self._busy is not None and not self._view_clear_sent:
            self._view_clear_sent = True
            self._emit({"id": self._busy["id"], "event": "view-clear"})

    def _emit(self, event: dict[str, object]) -> None:
        if self.events is not None and self._events:
            self.events(event)

    @staticmethod
    def interrupted_reply(request_line: bytes | str, exc: KeyboardInterrupt) -> dict[str, object]:
        """The reply for the request in flight when Ctrl-C or SIGTERM ended the session."""
        try:
            request_id = _request_id(_parse_json(request_line))
        except BadRequest:
            request_id = None
        signal_name = "SIGTERM" if isinstance(exc, Terminated) else "SIGINT"
        return {
            "id": request_id,
            "ok": False,
            "status": ending(exc).reply,
            "error": f"{signal_name}: the arm was stopped and the outcome written; exiting",
        }

    def _check_token(self, data: Mapping[str, Any]) -> None:
        if self._token is None:
            return
        given = data.get("token")
        if not isinstance(given, str) or not hmac.compare_digest(given, self._token):
            raise BadRequest("missing or wrong token: every request must carry the shared token")

    def _dispatch(self, request: Request, key: str) -> dict[str, object]:
        cell = self.cell
        rid = None if request.id is None else str(request.id)
        if request.op == "capture":
            capture = cell.capture(request.pose, request_id=rid)
            if request.cloud is not None:
                cell.note_cloud(request.cloud, capture)
            return _capture_reply(capture)
        if request.op == "pick":
            named = cell.request_capture(request.capture_id)
            if request.cloud is not None:
                cell.note_cloud(request.cloud, named)
            result = cell.pick(
                request.candidates,
                named,
                place=request.place,
                dry_run=request.dry_run,
                request_id=rid,
                ahead_key=key,
            )
            return pick_reply(result)
        if request.op == "place":
            T_place = cell.place(request_id=rid)
            return {"ok": True, "status": Status.PLACED, "place_pose": ur_pose_list(T_place)}
        if request.op == "move" and request.pose is not None:  # _validate requires the pose
            reached = cell.move_to(request.pose, request_id=rid)
            return {
                "ok": True,
                "status": Status.MOVED,
                "pose": request.pose,
                "tcp_pose": ur_pose_list(reached),
            }
        if request.op == "status":
            return {**status_reply(cell), **self._line_fields()}
        if request.op == "resume":
            cell.resume(request_id=rid)
            return {"ok": True, "status": Status.READY}
        if request.op == "quit":
            self.quit = True
            return {"ok": True, "status": Status.BYE}
        if request.op == "stop":  # nothing was running: the cell halts until resume
            self.cell.request_stop(f"stopped by request {request.id}")
            if self.line is not None:
                self.line.noted_stop(f"request {request.id}")
            return {"ok": True, "status": Status.STOPPED, "request": None}
        if request.op in _LINE_OPS:
            return self._line_command(request)
        raise BadRequest(f"{request.op}: incomplete request")


def _key(line: bytes | str) -> str:
    """What a request line is known by when a pick is checked ahead: the line itself."""
    return line.decode(errors="replace") if isinstance(line, bytes) else line


def bad_request_reply(line: bytes | str, exc: BadRequest) -> dict[str, object]:
    """The reply to a line that is no valid request: its id when one can be read."""
    try:
        request_id = _request_id(_parse_json(line))
    except BadRequest:
        request_id = None
    return {"id": request_id, "ok": False, "status": Status.BAD_REQUEST, "error": str(exc)}


def queue_full_error(waiting: int) -> BadRequest:
    """Why a request was answered without being run: too many wait already."""
    return BadRequest(f"{waiting} requests are waiting already: this one was not queued, not run")


def failure_fields(exc: BaseException) -> dict[str, object]:
    """``status`` (``errors.ending``) and ``error`` of a reply for a refused or failed request."""
    fields: dict[str, object] = {
        "error": str(exc),
        "error_type": type(exc).__name__,
        "status": ending(exc).reply,
    }
    if isinstance(exc, NoFeasibleCandidate):
        fields["refused"] = [{"candidate": r.candidate, "reasons": r.reasons} for r in exc.refusals]
    elif isinstance(exc, PreflightRefusal):
        failed = [r.line for r in exc.results if not r.passed]
        fields["refused"] = [{"candidate": 0, "reasons": failed}]
    return fields


def pick_reply(result: PickResult) -> dict[str, object]:
    reply: dict[str, object] = {
        "ok": result.status is not Status.MISSED,
        "status": result.status,
        "candidate": result.candidate,
        "capture_id": result.capture.capture_id,
        "cycle": result.cycle,
        "pick_id": result.pick_id,
        "cycle_s": round(result.cycle_s, 4),
        "targets": result.plan.targets_ur(),
        "reached": {name: ur_pose_list(T) for name, T in result.reached.items()},
        "errors_mm": {name: round(e.position_mm, 4) for name, e in result.errors.items()},
        "refused": [{"candidate": r.candidate, "reasons": r.reasons} for r in result.refused],
    }
    if result.T_base_tcp_place is not None:
        reply["place"] = {
            "index": result.place_index,
            "pose": ur_pose_list(result.T_base_tcp_place),
        }
    if result.alternative is not None:
        reply["alternative"] = result.alternative
    if result.status is Status.MISSED:
        reply["error"] = f"grasp missed: {result.missed or 'no part sensed'}: {MISSED_MESSAGE}"
    return reply


def status_reply(cell: Cell) -> dict[str, object]:
    state = cell.status()
    reply: dict[str, object] = {
        "ok": True,
        "status": Status.READY if state.ready else Status.NOT_READY,
        "ready": state.ready,
        "halted": state.halted is not None,
        "halted_reason": state.halted,
        "problems": state.problems,
    }
    if state.T_base_flange is not None:
        reply["flange_pose_ur"] = ur_pose_list(state.T_base_flange)
    if state.T_base_tcp is not None:
        reply["tcp_pose_ur"] = ur_pose_list(state.T_base_tcp)
    return reply


def _capture_reply(capture: Capture) -> dict[str, object]:
    return {
        "ok": True,
        "status": Status.CAPTURED,
        "capture_id": capture.capture_id,
        "cycle": capture.cycle,
        "flange_pose_ur": (
            ur_pose_list(capture.T_base_flange) if capture.T_base_flange is not None else None
        ),
        "timestamp": capture.timestamp.isoformat(timespec="microseconds"),
    }


# --- parsing ------------------------------------------------------------------------------------


def _reject_constant(name: str) -> float:
    raise BadRequest(f"{name} is not a number JSON allows")


def _parse_json(line: bytes | str) -> dict[str, Any]:
    if len(line) > MAX_LINE_BYTES:
        raise BadRequest(f"request longer than {MAX_LINE_BYTES} bytes")
    try:
        data = json.loads(line, parse_constant=_reject_constant)
    except (ValueError, RecursionError) as exc:
        raise BadRequest(f"not valid JSON: {exc}") from None
    if not isinstance(data, dict):
        raise BadRequest(f"a request is a JSON object, got {type(data).__name__}")
    return data


def _request_id(data: Mapping[str, Any]) -> str | int | None:
    request_id = data.get("id")
    if request_id is None or isinstance(request_id, str):
        return request_id
    if isinstance(request_id, int) and not isinstance(request_id, bool):
        return request_id
    raise BadRequest(f"id must be a string or an integer, got {request_id!r}")


def _validate(data: Mapping[str, Any], request_id: str | int | None) -> Request:
    op = data.get("op")
    if not isinstance(op, str) or op not in _KEYS:
        raise BadRequest(f"op must be one of {', '.join(_KEYS)}, got {op!r}")
    unknown = sorted(set(data) - set(_COMMON_KEYS) - set(_KEYS[op]))
    if unknown:
        raise BadRequest(f"{op}: unknown keys {unknown} (allowed: {', '.join(_KEYS[op])})")
    pose = _optional(data, "pose", str)
    if op == "move" and pose is None:
        raise BadRequest("move: give the name of a pose under poses in the config")
    candidates: tuple[Detection, ...] = ()
    if op == "pick":
        listed = data.get("candidates")
        if not isinstance(listed, list) or not 1 <= len(listed) <= MAX_CANDIDATES:
            raise BadRequest(f"pick: candidates must be a list of 1 to {MAX_CANDIDATES} detections")
        candidates = tuple(_candidate(item, request_id, i) for i, item in enumerate(listed))
    place = _optional(data, "place", bool)
    dry_run = _optional(data, "dry_run", bool)
    return Request(
        id=request_id,
        op=op,
        pose=pose,
        capture_id=_optional(data, "capture_id", str),
        candidates=candidates,
        place=True if place is None else place,
        dry_run=bool(dry_run),
        events=bool(_optional(data, "events", bool)),
        cloud=_cloud(data),
    )


def _cloud(data: Mapping[str, Any]) -> Path | None:
    """``"cloud": {"file": PATH}``: the capture's point cloud (.npy or .ply, camera frame, mm)
    for a recording; read only by the recording, never by the cell."""
    cloud = data.get("cloud")
    if cloud is None:
        return None
    if not isinstance(cloud, dict) or set(cloud) != {"file"} or not isinstance(cloud["file"], str):
        raise BadRequest('cloud must be {"file": PATH} (a .npy or .ply cloud, camera frame, mm)')
    return Path(cloud["file"])


def _candidate(item: object, request_id: str | int | None, index: int) -> Detection:
    source = f"request {request_id} candidate {index}"
    _reject_non_finite(item, source)
    try:
        return detection_from_data(item, source)
    except InputError as exc:
        raise BadRequest(str(exc)) from None


def _reject_non_finite(value: object, source: str) -> None:
    """Huge JSON numbers (1e400) parse as inf: refuse them here with the source named."""
    if isinstance(value, float) and not math.isfinite(value):
        raise BadRequest(f"{source}: numbers must be finite")
    if isinstance(value, dict):
        for inner in value.values():
            _reject_non_finite(inner, source)
    elif isinstance(value, list):
        for inner in value:
            _reject_non_finite(inner, source)


def _optional(data: Mapping[str, Any], key: str, kind: type) -> Any:
    value = data.get(key)
    if value is None:
        return None
    if not isinstance(value, kind):
        raise BadRequest(f"{key} must be a {kind.__name__}, got {value!r}")
    return value
