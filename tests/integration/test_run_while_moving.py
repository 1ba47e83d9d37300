"""``handeye-pick run`` while the arm moves, through the real ur_rtde against the simulated
controller: a blended pick (the radii sent, the TCP's deviation at each corner, the straight
end of the descent), ``status`` and ``stop`` answered mid-path, requests queued behind a stop
and behind a fault, ``resume`` after a stop, and an eye-to-hand client that takes its image on
``view-clear`` and queues its next pick while the arm places."""

from __future__ import annotations

import itertools
import json
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from handeye_pick.geometry import ur_pose_to_matrix
from mocks.ur_controller import SimulatedController
from tests.integration.test_pick_cli import TCP_OFFSET, audit_records
from tests.integration.test_run_loop import (
    OBJECT_BASE_M,
    Loop,
    SimFactory,
    detection_for,
    loop,
    loop_config,
)

BLEND_MM = 20.0
STRAIGHT_MM = 20.0  # grasp.straight_mm's default for a gripper without fingers
BLENDED = {
    "motion": "  speed_mps: 0.25\n  accel_mps2: 1.2\n  grasp_speed_mps: 0.1\n"
    f"  blend_mm: {BLEND_MM}\n  blend_always: true\n",  # paths whatever a start costs
    # The place retreat ends short of the place approach: the arm stands there, not at a corner.
    "place": "  poses: [[-0.3, 0.35, 0.15, 3.14159265, 0, 0]]\n  approach_mm: 80\n"
    "  retreat_mm: 50\n",
}


def lines_until_reply(
    run: Loop, request_id: str | None
) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """Read ``run``'s lines up to the reply to ``request_id``: (the reply, every line before
    it: events and other replies, in order)."""
    before: list[dict[str, Any]] = []
    while True:
        line = run.reply()
        if line.get("id") == request_id and "ok" in line:
            return line, before
        before.append(line)


def next_event(run: Loop, event: str, step: str | None = None) -> dict[str, Any]:
    """Skip lines up to the event line ``event`` (with ``step`` when given)."""
    while True:
        line = run.reply()
        assert "ok" not in line, f"a reply came before the {event} {step} event: {line}"
        if line.get("event") == event and (step is None or line.get("step") == step):
            return line


def capture_at_home(run: Loop) -> dict[str, Any]:
    """Move home and capture there; the capture's reply."""
    assert run.ask({"id": "m", "op": "move", "pose": "home"})["ok"]
    captured = run.ask({"id": "c", "op": "capture"})
    assert captured["ok"], captured
    return captured


def pick_request(request_id: str, captured: dict[str, Any]) -> str:
    """A pick of the object at OBJECT_BASE_M as seen in ``captured``, asking for its events."""
    detection = detection_for(ur_pose_to_matrix(captured["flange_pose_ur"]), OBJECT_BASE_M)
    request = {
        "id": request_id,
        "op": "pick",
        "capture_id": captured["capture_id"],
        "candidates": [detection],
    }
    return json.dumps({**request, "events": True})


class Trace:
    """The simulated TCP position (base frame, m) polled every 10 ms while it runs."""

    def __init__(self, ctl: SimulatedController) -> None:
        self.points: list[np.ndarray] = []
        self._ctl = ctl
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._poll, daemon=True)

    def _poll(self) -> None:
        while not self._done.wait(0.01):
            self.points.append(np.array(self._ctl.snapshot().tcp_pose[:3]))

    @contextmanager
    def running(self) -> Iterator[Trace]:
        self._thread.start()
        try:
            yield self
        finally:
            self._done.set()
            self._thread.join()


def distance_to_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    ab = b - a
    t = float(np.clip(np.dot(p - a, ab) / np.dot(ab, ab), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + t * ab)))


def test_a_blended_pick_rounds_each_corner_within_its_radius_and_descends_straight(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET)
    with loop(loop_config(tmp_path, ctl.host, **BLENDED)) as run:
        captured = capture_at_home(run)
        start_m = np.array(ctl.snapshot().tcp_pose[:3])
        with Trace(ctl).running() as trace:
            run.send(pick_request("p", captured))
            reply, events = lines_until_reply(run, "p")
    assert reply["status"] == "placed", reply
    steps = [e["step"] for e in events if e.get("event") == "step"]
    assert steps == [
        "approach",
        "grasp",
        "gripper close",
        "retreat",
        "place-approach",
        "place",
        "gripper open",
        "place-retreat",
    ], steps
    plan = next(r for r in audit_records(tmp_path) if r.get("request_id") == "p")
    blends_mm = plan["blends_mm"]
    assert blends_mm == {"approach": BLEND_MM, "retreat": BLEND_MM, "place-approach": BLEND_MM}

    paths = [c for c in ctl.commands if c["kind"] == "movePath"]
    assert [c["radii"] for c in paths] == [[0.02, 0.0], [0.02, 0.02, 0.0]], paths
    assert all(c["skipped_blends"] == [] for c in paths)  # no blend the controller refused

    targets = {name: np.array(pose[:3]) for name, pose in plan["targets"].items()}
    waypoints = [start_m, targets["approach"], targets["grasp"]]
    waypoints += [targets["retreat"], targets["place-approach"], targets["place"]]
    waypoints += [targets["place-retreat"]]
    blended_at = [targets[name] for name in blends_mm]
    for p in trace.points:
        off_line_mm = 1000.0 * min(
            distance_to_segment(p, a, b) for a, b in itertools.pairwise(waypoints)
        )
        in_corner = [1000.0 * float(np.linalg.norm(p - c)) for c in blended_at]
        # Off the straight lines only inside a corner's ball (0.6 mm: rounding of the record).
        assert off_line_mm < 0.6 or min(in_corner) <= BLEND_MM + 0.6, (p, off_line_mm)
    for corner in blended_at:  # the arm went round each corner: it never stood at it
        closest_mm = min(1000.0 * float(np.linalg.norm(p - corner)) for p in trace.points)
        assert 1.0 < closest_mm < BLEND_MM, closest_mm

    # The last straight_mm above the grasp lies on its tool axis (here vertical).
    grasp = targets["grasp"]
    near = [p for p in trace.points if 0.0 < p[2] - grasp[2] < STRAIGHT_MM / 1000.0]
    assert near
    lateral_mm = max(1000.0 * float(np.linalg.norm(p[:2] - grasp[:2])) for p in near)
    assert lateral_mm < 0.05, lateral_mm


def test_status_and_stop_are_answered_mid_path_and_a_queued_pick_is_refused_halted(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET)
    with loop(loop_config(tmp_path, ctl.host, **BLENDED)) as run:
        captured = capture_at_home(run)
        run.send(pick_request("p1", captured))
        run.send(pick_request("p2", captured))  # queued behind p1
        next_event(run, "step", "retreat")  # the transfer path is under way
        run.send(json.dumps({"id": "s?", "op": "status"}))
        status, _ = lines_until_reply(run, "s?")
        assert status["status"] == "busy", status
        assert status["request"]["id"] == "p1", status
        assert status["request"]["step"] in ("retreat", "place-approach"), status
        run.send(json.dumps({"id": "stop", "op": "stop"}))
        stopped_reply, before = lines_until_reply(run, "stop")  # at once, before p1 ends
        assert stopped_reply["status"] == "stopped", stopped_reply
        assert not [line for line in before if "ok" in line]
        assert stopped_reply["request"]["id"] == "p1"
        first, before = lines_until_reply(run, "p1")
        assert (first["ok"], first["status"]) == (False, "stopped"), first
        assert not [line for line in before if "ok" in line]
        second, _ = lines_until_reply(run, "p2")
        assert (second["ok"], second["status"]) == (False, "halted"), second
        assert "stopped by request stop while request p1 ran pick" in second["error"]
        assert not ctl.snapshot().moving
        assert ctl.commands[-1]["kind"] == "stopL"
        commands_when_halted = len(ctl.commands)
        assert run.ask({"id": "m", "op": "move", "pose": "home"})["status"] == "halted"
        assert len(ctl.commands) == commands_when_halted  # nothing sent while halted
        resumed = run.ask({"id": "r", "op": "resume"})
        assert (resumed["ok"], resumed["status"]) == (True, "ready"), resumed
        captured = capture_at_home(run)
        run.send(pick_request("p3", captured))
        again, _ = lines_until_reply(run, "p3")
        assert again["status"] == "placed", again
    outcome = next(
        r
        for r in audit_records(tmp_path)
        if r.get("request_id") == "p1" and r["event"] == "outcome"
    )
    assert outcome["status"] == "stopped"
    assert outcome["step"] in ("retreat", "place-approach", "place"), outcome


def test_a_fault_mid_path_ends_the_pick_and_the_queued_one_is_answered_halted(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    # Motion 1 is the move home; 2 is the path down to the grasp; 3 the transfer path.
    ctl = sim_controller(
        tcp_offset=TCP_OFFSET, speed_factor=4.0, inject=("protective-stop@move:3:0.5",)
    )
    with loop(loop_config(tmp_path, ctl.host, **BLENDED)) as run:
        captured = capture_at_home(run)
        run.send(pick_request("p1", captured))
        run.send(pick_request("p2", captured))
        first, _ = lines_until_reply(run, "p1")
        assert (first["ok"], first["status"]) == (False, "fault"), first
        second, _ = lines_until_reply(run, "p2")
        assert (second["ok"], second["status"]) == (False, "halted"), second
        assert "protective stop" in second["error"]
    paths = [c for c in ctl.commands if c["kind"] == "movePath"]
    assert len(paths) == 2  # nothing after the faulted path
    outcome = next(
        r
        for r in audit_records(tmp_path)
        if r.get("request_id") == "p1" and r["event"] == "outcome"
    )
    assert outcome["status"] == "fault"
    assert outcome["step"] in ("retreat", "place-approach", "place"), outcome


ETH_CAMERA = "[[0, 1, 0, -450], [1, 0, 0, -100], [0, 0, -1, 1200], [0, 0, 0, 1]]\n"
ETH_DETECTION_MM = [-100.0, -70.0, 1140.0]  # a point on the table 1140 mm below the camera


def test_an_eye_to_hand_client_images_on_view_clear_and_queues_its_next_pick(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, speed_factor=2.0)
    (tmp_path / "eth.yaml").write_text(ETH_CAMERA)
    hand_eye = f"  mode: eye-to-hand\n  file: {tmp_path / 'eth.yaml'}\n  units: mm\n"
    hand_eye += "  camera_position_mm: [-440, -110, 1190]\n"
    capture = "  pose: aside\n  view_clear_at: retreat\n"
    config = loop_config(tmp_path, ctl.host, hand_eye=hand_eye, capture=capture, **BLENDED)
    with loop(config) as run:
        assert run.ask({"id": "c", "op": "capture"})["ok"]
        pick = {"op": "pick", "candidates": [{"position_mm": ETH_DETECTION_MM}], "events": True}
        run.send(json.dumps({"id": "p1", **pick}))
        next_event(run, "view-clear")
        # What the client's camera sees now: the arm past the retreat, still moving to place.
        snapshot = ctl.snapshot()
        assert snapshot.moving
        grasp_m = np.array([-0.52, -0.20, 0.06])
        assert snapshot.tcp_pose[2] > grasp_m[2] + 0.099 - BLEND_MM / 1000.0
        run.send(json.dumps({"id": "p2", **pick}))  # detected while the arm places
        first, before = lines_until_reply(run, "p1")
        assert first["status"] == "placed", first
        assert not [line for line in before if "ok" in line]
        second, events = lines_until_reply(run, "p2")
        assert second["status"] == "placed", second
        assert [e["event"] for e in events].count("view-clear") == 1
    moves = [c for c in ctl.commands if c["kind"] in ("moveL", "movePath", "moveJ")]
    # p2 started as soon as p1 ended: no capture move between them (the camera is fixed).
    assert len(moves) == 1 + 2 * 3, [c["kind"] for c in moves]


def test_a_request_line_sent_mid_move_is_read_at_once_even_when_malformed(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET)
    with loop(loop_config(tmp_path, ctl.host, **BLENDED)) as run:
        captured = capture_at_home(run)
        run.send(pick_request("p", captured))
        next_event(run, "step", "grasp")
        run.send(b"{not json\n")
        bad, _ = lines_until_reply(run, None)  # the next reply: before the pick's
        assert (bad["ok"], bad["status"]) == (False, "bad-request"), bad
        reply, _ = lines_until_reply(run, "p")
        assert reply["status"] == "placed", reply
